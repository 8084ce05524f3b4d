"""The splits' seeds and the test split's key: public seeds are fixed by (version, split, index); test seeds need
the host's key (HMAC-SHA256) and differ per key; a missing or malformed key is one line with the fix; a new key is
readable by its owner only and is never silently replaced."""

from __future__ import annotations

import hashlib
import hmac
import stat

import pytest

from benchbot.core.errors import SpecError, UsageError
from benchbot_worlds.procedural import splits


@pytest.fixture
def key_file(tmp_path, monkeypatch):
    path = tmp_path / "keys" / "test_split.key"
    monkeypatch.setenv("BENCHBOT_WORLDS_KEY_FILE", str(path))
    return path


def test_public_seeds_are_a_pure_function_of_version_split_and_index():
    seed = splits.home_seed("val", 42, 1)
    digest = hashlib.sha256(b"benchbot-worlds/procedural/v1/val/42").digest()
    assert seed == int.from_bytes(digest[:8], "big")
    assert len({splits.home_seed(s, i, 1) for s in ("train", "val") for i in range(500)}) == 1000
    assert splits.home_seed("val", 42, 2) != seed


def test_test_seeds_need_the_key_and_follow_it(key_file):
    with pytest.raises(SpecError, match="needs this host's key, and .*test_split.key does not exist") as info:
        splits.read_key()
    assert "benchbot worlds key" in info.value.hint
    splits.make_key()
    assert stat.S_IMODE(key_file.stat().st_mode) == 0o600
    key = splits.read_key()
    seed = splits.home_seed("test", 7, 1, key)
    assert seed == int.from_bytes(hmac.new(key, b"benchbot-worlds/procedural/v1/test/7", "sha256").digest()[:8], "big")
    with pytest.raises(UsageError, match="exists: this host's test homes are made with it"):
        splits.make_key()
    splits.make_key(force=True)
    assert splits.home_seed("test", 7, 1, splits.read_key()) != seed
    assert splits.key_id(key) != splits.key_id(splits.read_key()) and len(splits.key_id(key)) == 12


@pytest.mark.parametrize("text", ["", "zz" * 32, "ab" * 31, "ab" * 33])
def test_a_malformed_key_is_one_line(key_file, text):
    key_file.parent.mkdir(parents=True)
    key_file.write_text(text)
    with pytest.raises(SpecError, match="is not 64 hexadecimal characters"):
        splits.read_key()


@pytest.mark.parametrize("split, index, message", [("dev", 0, "no split 'dev'"), ("val", -1, "is negative")])
def test_bad_split_or_index(split, index, message):
    with pytest.raises(SpecError, match=message):
        splits.home_seed(split, index, 1)
