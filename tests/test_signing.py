"""Signed run directories (benchbot/batch/signing.py, `benchbot verify`): real Ed25519 keys and real files; sign →
verify ok, a flipped byte in any covered file fails naming it, a wrong key fails, bad input is one line."""

from __future__ import annotations

import json
import os
import stat
import sys
from pathlib import Path

import pytest

from benchbot.batch import signing
from benchbot.core.errors import UsageError

sys.path.insert(0, str(Path(__file__).parent))
from cli_in_process import benchbot as cli  # noqa: E402  (`benchbot verify`, run in this process)
from report_runs import make_run  # noqa: E402


@pytest.fixture(scope="module")
def signed(tmp_path_factory):
    """A scored run (two episodes: two results files), finished, and a host key pair; the run signed."""
    root = tmp_path_factory.mktemp("signed")
    run = make_run(root, "run", {"miniroom:1": [0.6, 0.7]})
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["finished"] = "2026-11-26T00:00:00+00:00"
    (run / "manifest.json").write_text(json.dumps(manifest))
    private, public = signing.write_key_pair(root / "host")
    signing.sign_run(run, private)
    return run, private, public


def copy_run(run: Path, to: Path) -> Path:
    import shutil

    shutil.copytree(run, to)
    return to


def test_key_pair_private_key_is_owner_only_and_never_replaced(signed, tmp_path):
    _, private, public = signed
    assert stat.S_IMODE(private.stat().st_mode) == 0o600
    assert public.read_text().startswith("-----BEGIN PUBLIC KEY-----")
    with pytest.raises(UsageError, match="exists"):
        signing.write_key_pair(private.parent)


def test_sign_then_verify_covers_every_results_file_the_scores_and_conditions(signed):
    run, _, public = signed
    doc = json.loads((run / "signature.json").read_text())
    s = doc["signed"]
    assert sorted(s["files"]) == ["config.json", "episode_scores.json", "manifest.json",
                                  "results/000_miniroom_1_r0.json", "results/001_miniroom_1_r1.json", "scores.json"]
    assert s["scores"]["OMQ"] == json.loads((run / "scores.json").read_text())["scores"]["OMQ"]
    assert s["conditions"]["task"] == "semantic_slam:passive:ground_truth" and s["conditions"]["episodes"] == 2
    assert s["conditions"]["worlds"] == signing.DEVELOPMENT and s["isolation"] == "bwrap"
    assert s["versions"]["benchbot"] == "0.1.0" and s["key"]["algorithm"] == "Ed25519"
    key = signing.load_public_key(public)
    assert s["key"]["fingerprint"] == signing.fingerprint(key)
    result = signing.check_run(run, [key])
    assert result.ok and result.fingerprint == signing.fingerprint(key), result.message
    proc = cli("verify", str(run), "--key", str(public))
    assert proc.returncode == 0 and proc.stdout.startswith("verified: ") and len(proc.stdout.splitlines()) == 1


def test_a_flipped_byte_in_any_covered_file_fails_naming_it(signed, tmp_path):
    run, _, public = signed
    key = signing.load_public_key(public)
    names = list(json.loads((run / "signature.json").read_text())["signed"]["files"])
    for k, name in enumerate(names):
        copy = copy_run(run, tmp_path / f"r{k}")
        data = bytearray((copy / name).read_bytes())
        data[len(data) // 2] ^= 0x01
        (copy / name).write_bytes(bytes(data))
        result = signing.check_run(copy, [key])
        assert result.status == "failed" and f"{copy / name}: changed since it was signed" in result.message, name
    proc = cli("verify", str(tmp_path / "r0"), "--key", str(public))
    assert proc.returncode == 1 and "verification failed" in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_a_flipped_byte_in_the_signature_file_fails(signed, tmp_path):
    run, _, public = signed
    key = signing.load_public_key(public)
    doc = json.loads((run / "signature.json").read_text())
    for field, change in (("scores", lambda s: s["scores"].update(OMQ=0.99)),
                          ("isolation", lambda s: s.update(isolation="container")),
                          ("files", lambda s: s["files"].update({"scores.json": "0" * 64}))):
        copy = copy_run(run, tmp_path / field)
        edited = json.loads(json.dumps(doc))
        change(edited["signed"])
        (copy / "signature.json").write_text(json.dumps(edited))
        result = signing.check_run(copy, [key])
        assert result.status == "failed" and "the signature is invalid" in result.message, field
    copy = copy_run(run, tmp_path / "garbled")
    (copy / "signature.json").write_bytes((run / "signature.json").read_bytes()[:-40])
    result = signing.check_run(copy, [key])
    assert result.status == "failed" and "garbled" in result.message and "signature.json" in result.message


def test_added_or_missing_results_file_fails(signed, tmp_path):
    run, _, public = signed
    copy = copy_run(run, tmp_path / "added")
    (copy / "results" / "002_extra.json").write_text("{}")
    result = signing.check_run(copy)
    assert result.status == "failed" and "002_extra.json: added after signing" in result.message
    copy = copy_run(run, tmp_path / "missing")
    (copy / "results" / "001_miniroom_1_r1.json").unlink()
    result = signing.check_run(copy)
    assert result.status == "failed" and "001_miniroom_1_r1.json: covered by the signature, but missing" in result.message


def test_a_wrong_key_fails_as_unknown(signed, tmp_path):
    run, _, _ = signed
    _, other = signing.write_key_pair(tmp_path / "other")
    result = signing.check_run(run, [signing.load_public_key(other)])
    assert result.status == "untrusted" and "signed by an unknown key SHA256:" in result.message
    proc = cli("verify", str(run), "--key", str(other))
    assert proc.returncode == 1 and "unknown key" in proc.stderr and "Traceback" not in proc.stderr


def test_bad_input_is_one_line_naming_the_file(signed, tmp_path):
    run, private, _ = signed
    (tmp_path / "junk.pem").write_text("not a key\n")
    for args, words in (((str(run), "--key", str(tmp_path / "junk.pem")), "junk.pem: not an Ed25519 public key"),
                        ((str(run), "--key", str(private)), "host_key.pem: not an Ed25519 public key"),
                        ((str(run), "--key", str(tmp_path / "none.pem")), "none.pem: no such public key file"),
                        ((str(tmp_path),), "is not a run directory (no manifest.json)"),
                        ((str(tmp_path / "nowhere"),), "no such folder")):
        proc = cli("verify", *args)
        assert proc.returncode == 2 and words in proc.stderr and "hint:" in proc.stderr, (args, proc.stderr)
        assert "Traceback" not in proc.stderr
    unsigned = copy_run(run, tmp_path / "unsigned")
    (unsigned / "signature.json").unlink()
    proc = cli("verify", str(unsigned))
    assert proc.returncode == 1 and "not signed (self-reported)" in proc.stderr
    with pytest.raises(UsageError, match="did not finish"):
        m = json.loads((unsigned / "manifest.json").read_text())
        del m["finished"]
        (unsigned / "manifest.json").write_text(json.dumps(m))
        signing.sign_run(unsigned, private)
    with pytest.raises(UsageError, match="not a readable Ed25519 private key"):
        signing.sign_run(run, tmp_path / "junk.pem")


def test_held_out_worlds():
    assert signing.worlds_standing(["procedural_test_0:1", "procedural_test_12:1:2"]) == signing.HELD_OUT
    for envs in (["miniroom:1"], ["procedural_val_3:1"], ["procedural_test_0:1", "house:1"], []):
        assert signing.worlds_standing(envs) == signing.DEVELOPMENT
    assert os.sep == "/"  # covered paths are /-separated
