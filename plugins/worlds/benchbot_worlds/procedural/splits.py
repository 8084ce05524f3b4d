"""The splits of procedural homes and their seeds: ``train`` and ``val`` are public (anyone can build home *i*),
``test`` is held out (its seeds come from a host's secret key, so only a host holding the key can build its homes
and their ground truth).

Seeds (64-bit, big-endian from the first 8 bytes of the digest) of home ``index`` of ``split`` under generator
version ``v``:

* public splits: SHA-256 of ``benchbot-worlds/procedural/v<v>/<split>/<index>`` (ASCII);
* ``test``: HMAC-SHA256 (RFC 2104, Python's :mod:`hmac`) of the same message under the host's 32-byte key.

The key is 64 hexadecimal characters in a file (``BENCHBOT_WORLDS_KEY_FILE``, else
``<data dir>/worlds/test_split.key``), made by :func:`make_key` (``benchbot worlds key``), readable by its owner only.
The sandbox hides the data and cache directories from solutions, so a solution cannot read the key or the test
homes' ground truth.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
from pathlib import Path

from benchbot.core import settings
from benchbot.core.errors import SpecError, UsageError
from benchbot.packs.pack_layout import data_dir
from benchbot_worlds.settings import WORLDS_KEY_FILE

SPLITS = ("train", "val", "test")
#: The held-out split: its seeds need the host's key.
HELD_OUT = "test"
KEY_BYTES = 32


def key_path() -> Path:
    """The host's key file: ``$BENCHBOT_WORLDS_KEY_FILE``, else ``<data dir>/worlds/test_split.key`` (may not exist)."""
    given = settings.get(WORLDS_KEY_FILE)
    return Path(given).expanduser() if given else data_dir() / "worlds" / "test_split.key"


def read_key() -> bytes:
    """The host's key (32 bytes).

    Raises:
        SpecError: there is no key file, or it is not 64 hexadecimal characters (one line with the fix).
    """
    path = key_path()
    try:
        text = path.read_text(encoding="ascii").strip()
    except FileNotFoundError:
        raise SpecError(f"the test split of procedural homes needs this host's key, and {path} does not exist",
                        "only a host holding the key builds test homes: make one with `benchbot worlds key` (or set "
                        "BENCHBOT_WORLDS_KEY_FILE); train and val need none") from None
    except (OSError, UnicodeDecodeError) as e:
        raise SpecError(f"the worlds key {path} cannot be read ({e.__class__.__name__})",
                        "make it readable, or make a new one with `benchbot worlds key --force`") from None
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) != KEY_BYTES:
        raise SpecError(f"the worlds key {path} is not {2 * KEY_BYTES} hexadecimal characters",
                        "restore the file, or make a new one with `benchbot worlds key --force` (new test homes)")
    return key


def make_key(*, force: bool = False) -> Path:
    """Write a new random key (:func:`secrets.token_bytes`) to :func:`key_path`, readable by its owner only
    (created with mode 0600, then moved into place).

    Raises:
        UsageError: a key exists and ``force`` is false (a new key means other test homes).
    """
    path = key_path()
    if path.exists() and not force:
        raise UsageError(f"{path} exists: this host's test homes are made with it",
                         "keep it; `benchbot worlds key --force` replaces it (every test home changes)")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="ascii") as f:
        f.write(secrets.token_bytes(KEY_BYTES).hex() + "\n")
    os.replace(tmp, path)
    return path


def key_id(key: bytes) -> str:
    """A short public name of a key (12 hex characters of SHA-256 of ``benchbot-worlds key id`` + key): which key
    made a test home, without revealing it."""
    return hashlib.sha256(b"benchbot-worlds key id" + key).hexdigest()[:12]


def home_seed(split: str, index: int, version: int, key: bytes | None = None) -> int:
    """The 64-bit seed of home ``index`` of ``split`` under generator ``version`` (module docstring).

    Raises:
        SpecError: an unknown split, a negative index, or the test split without ``key``.
    """
    if split not in SPLITS:
        raise SpecError(f"no split '{split}' of procedural homes", f"splits: {', '.join(SPLITS)}")
    if index < 0:
        raise SpecError(f"home index {index} of split '{split}' is negative", "indices start at 0")
    message = f"benchbot-worlds/procedural/v{version}/{split}/{index}".encode("ascii")
    if split == HELD_OUT:
        if key is None:
            raise SpecError("the test split's seeds need this host's key", "read it with read_key()")
        digest = hmac.new(key, message, hashlib.sha256).digest()
    else:
        digest = hashlib.sha256(message).digest()
    return int.from_bytes(digest[:8], "big")
