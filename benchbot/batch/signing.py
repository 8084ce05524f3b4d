"""Signed run directories: results anyone can check (``benchbot challenge evaluate`` signs, ``benchbot verify``
checks; docs/challenge.md).

A host signs a finished run directory with its Ed25519 key (the ``cryptography`` library). The signature file,
``RUN/signature.json``, is ``{"signed": PAYLOAD, "signature": BASE64}``, where the signature is Ed25519 over the
payload's canonical JSON (:func:`canonical`: keys sorted, no spaces, ASCII) and the payload holds:

* ``format``: :data:`FORMAT`;
* ``files``: ``{path relative to RUN: SHA-256 hex}`` of every covered file (:func:`covered_files`): the manifest,
  ``config.json``, ``scores.json``, ``episode_scores.json``, ``conditions.json`` (a challenge's) and every file
  under ``results/``;
* ``scores``: the combined scores (``scores.json``'s ``scores``);
* ``conditions``: task, robots, environments, episodes, seeds, noise, limits, evaluation method, ground-truth sets
  and the worlds' standing (:func:`run_conditions`), and the challenge's conditions when it ran as one;
* ``versions``: the manifest's versions and lock-file hash; ``isolation``: the manifest's ``sandbox``;
* ``key``: the algorithm, the public key (raw 32 bytes, base64) and its fingerprint (:func:`fingerprint`);
* ``signed_at``: UTC time.

Verification (:func:`check_run`) checks, in order: the signature file parses; the signature is valid under the key
it names; that key is a trusted one (when any are given); every covered file's hash; no file under ``results/``
was added. Editing any byte of a covered file, or of the signature file, fails it.

Worlds are public (BEAR, procedural ``train``/``val``: anyone can build their ground truth, so a solution can carry
it) or held out (``<generator>_test_<n>``: only the host holding the split's key builds them). Only runs on held-out
worlds can be verified in the sense that matters: :func:`worlds_standing`.
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import re
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from benchbot.core.errors import UsageError

FORMAT = "benchbot-signed-run/1"
"""The payload's ``format``: a later format gets a new number."""

SIGNATURE_FILE = "signature.json"
"""The signature's file name in a run directory."""

COVERED = ("manifest.json", "config.json", "scores.json", "episode_scores.json", "conditions.json")
"""The top-level files a signature covers (those present), besides every file under :data:`RESULTS`."""

RESULTS = "results"
"""The folder of results files; every file under it is covered."""

PRIVATE_KEY_FILE = "host_key.pem"
"""The host's private key (PKCS #8 PEM, unencrypted, mode 0600) in a challenge folder."""

PUBLIC_KEY_FILE = "host_key.pub.pem"
"""The host's public key (SubjectPublicKeyInfo PEM): what a host publishes and ``--key`` takes."""

DEVELOPMENT = "development — ground truth public"
"""The standing of runs on public worlds: their ground truth is public, so a solution may carry it."""

HELD_OUT = "held-out"
"""The standing of runs whose every environment is a held-out world."""

_HELD_OUT_HOME = re.compile(r"^[a-z][a-z0-9]*_test_[0-9]+(:|$)")

KEY_HINT = f"give the host's public key file, {PUBLIC_KEY_FILE}, that `benchbot challenge init` wrote"


def canonical(payload: dict) -> bytes:
    """The bytes that are signed: ``payload`` as JSON with sorted keys, no spaces, ASCII only, no NaN."""
    return json.dumps(payload, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=False).encode("ascii")


def sha256_file(path: Path) -> str:
    """The SHA-256 (hex) of the file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def is_held_out(env: str) -> bool:
    """Whether environment ``env`` (``procedural_test_3:1``) is a world of a held-out split (``<generator>_test_<n>``)."""
    return bool(_HELD_OUT_HOME.match(str(env)))


def worlds_standing(environments) -> str:
    """:data:`HELD_OUT` when every environment is a held-out world, else :data:`DEVELOPMENT` (none given: development)."""
    envs = [str(e) for e in environments]
    return HELD_OUT if envs and all(is_held_out(e) for e in envs) else DEVELOPMENT


# --------------------------------------------------------------------------------------------------------------------
# Keys
# --------------------------------------------------------------------------------------------------------------------
def fingerprint(public_key) -> str:
    """``SHA256:<base64 of SHA-256 of the raw 32-byte key, no padding>`` (as OpenSSH names keys)."""
    from cryptography.hazmat.primitives import serialization

    raw = public_key.public_bytes(serialization.Encoding.Raw, serialization.PublicFormat.Raw)
    return "SHA256:" + base64.b64encode(hashlib.sha256(raw).digest()).decode("ascii").rstrip("=")


def write_key_pair(folder: Path) -> tuple[Path, Path]:
    """Make a new Ed25519 key pair in ``folder``: :data:`PRIVATE_KEY_FILE` (created with mode 0600) and
    :data:`PUBLIC_KEY_FILE`.

    Returns:
        (private key path, public key path).

    Raises:
        UsageError: a private key is already there (it signed this challenge's results: never replaced here).
    """
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    private, public = folder / PRIVATE_KEY_FILE, folder / PUBLIC_KEY_FILE
    if private.exists():
        raise UsageError(f"{private} exists: this challenge's results are signed with it",
                         "keep it; for a new challenge give another folder")
    folder.mkdir(parents=True, exist_ok=True)
    key = Ed25519PrivateKey.generate()
    pem = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                            serialization.NoEncryption())
    fd = os.open(private, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(pem)
    public.write_bytes(key.public_key().public_bytes(serialization.Encoding.PEM,
                                                     serialization.PublicFormat.SubjectPublicKeyInfo))
    return private, public


def load_private_key(path: Path):
    """The Ed25519 private key in ``path`` (PKCS #8 PEM).

    Raises:
        UsageError: missing, unreadable, or not an Ed25519 private key (naming the file).
    """
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    try:
        key = serialization.load_pem_private_key(Path(path).read_bytes(), password=None)
    except FileNotFoundError:
        raise UsageError(f"{path}: no such private key", "make the challenge with `benchbot challenge init DIR`") from None
    except (OSError, ValueError, TypeError) as exc:
        raise UsageError(f"{path}: not a readable Ed25519 private key in PEM ({exc.__class__.__name__})",
                         f"restore the {PRIVATE_KEY_FILE} that `benchbot challenge init` wrote") from None
    if not isinstance(key, Ed25519PrivateKey):
        raise UsageError(f"{path}: not an Ed25519 private key", f"use the {PRIVATE_KEY_FILE} of `benchbot challenge init`")
    return key


def load_public_key(path: Path):
    """The Ed25519 public key in ``path`` (SubjectPublicKeyInfo PEM, :data:`PUBLIC_KEY_FILE`).

    Raises:
        UsageError: missing, unreadable, or not an Ed25519 public key (naming the file and the fix).
    """
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

    try:
        key = serialization.load_pem_public_key(Path(path).read_bytes())
    except FileNotFoundError:
        raise UsageError(f"{path}: no such public key file", KEY_HINT) from None
    except (OSError, ValueError, TypeError) as exc:
        raise UsageError(f"{path}: not an Ed25519 public key in PEM ({exc.__class__.__name__})", KEY_HINT) from None
    if not isinstance(key, Ed25519PublicKey):
        raise UsageError(f"{path}: not an Ed25519 public key", KEY_HINT)
    return key


# --------------------------------------------------------------------------------------------------------------------
# What is signed
# --------------------------------------------------------------------------------------------------------------------
def _is_run_dir(run_dir: Path) -> None:
    if not run_dir.is_dir():
        raise UsageError(f"{run_dir}: no such folder", "give a run directory of `benchbot batch` (runs/batch-…)")
    if not (run_dir / "manifest.json").is_file():
        raise UsageError(f"{run_dir} is not a run directory (no manifest.json)",
                         "give a run directory of `benchbot batch` or `benchbot challenge evaluate`")


def covered_files(run_dir: Path) -> list[str]:
    """The paths (relative to ``run_dir``, ``/``-separated, sorted) a signature covers: those of :data:`COVERED`
    present and every file under ``results/``.

    Raises:
        UsageError: a covered path is a symbolic link or not a plain file (a signature covers bytes, not links).
    """
    names = [n for n in COVERED if (run_dir / n).exists() or (run_dir / n).is_symlink()]
    results = run_dir / RESULTS
    if results.is_dir():
        for root, dirs, files in os.walk(results):
            for name in dirs + files:
                if (Path(root) / name).is_symlink():
                    names.append(str((Path(root) / name).relative_to(run_dir)))
            names += [str((Path(root) / name).relative_to(run_dir)) for name in files
                      if not (Path(root) / name).is_symlink()]
    names = sorted(dict.fromkeys(n.replace(os.sep, "/") for n in names))
    for name in names:
        path = run_dir / name
        if path.is_symlink() or not path.is_file():
            raise UsageError(f"{path} is a link or not a plain file", "a signed run holds plain files only: remove it")
    return names


def run_conditions(manifest: dict) -> dict:
    """The conditions a run ran under, from its manifest: ``task``, ``robots``, ``environments``, ``worlds``
    (:func:`worlds_standing`), ``episodes``, ``seeds``, ``noise``, ``limits`` (``episode_timeout_s``: the distinct
    per-episode timeouts; ``solution``: the manifest's record of each solution's resource limits and how each was
    enforced, None for solutions not sandboxed), ``evaluate_with``, ``ground_truth_sets``, ``executor``."""
    plan = [p for p in manifest.get("plan") or [] if isinstance(p, dict)]
    envs = list(manifest.get("environments") or [])
    return {
        "task": manifest.get("task"), "robots": list(manifest.get("robots") or []), "environments": envs,
        "worlds": worlds_standing(envs), "episodes": len(plan), "seeds": sorted({p.get("seed") for p in plan
                                                                                if isinstance(p.get("seed"), int)}),
        "noise": sorted({str(p.get("noise", "none")) for p in plan}),
        "limits": {"episode_timeout_s": sorted({p.get("timeout_s") for p in plan
                                                if isinstance(p.get("timeout_s"), (int, float))}),
                   "solution": manifest.get("limits")},
        "evaluate_with": manifest.get("evaluate_with"), "ground_truth_sets": manifest.get("ground_truth_sets"),
        "executor": manifest.get("executor"),
    }


def _read_json(path: Path, what: str, hint: str):
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UsageError(f"{path}: missing ({what})", hint) from None
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path}: {what} is unreadable or not JSON ({exc.__class__.__name__})", hint) from None


def payload(run_dir: Path, public_key, challenge: dict | None = None) -> dict:
    """The payload :func:`sign_run` signs for ``run_dir`` (module docstring), ``challenge``'s conditions included.

    Raises:
        UsageError: not a finished, scored run directory (naming what is missing), or a covered path is a link.
    """
    run_dir = Path(run_dir)
    _is_run_dir(run_dir)
    hint = "sign a finished, scored run of `benchbot batch` (benchbot batch --resume RUN finishes one)"
    manifest = _read_json(run_dir / "manifest.json", "the manifest", hint)
    if not isinstance(manifest, dict) or not manifest.get("finished"):
        raise UsageError(f"{run_dir}: the batch did not finish (its manifest has no 'finished')", hint)
    scores = _read_json(run_dir / "scores.json", "the scores", hint)
    if not isinstance(scores, dict) or not isinstance(scores.get("scores"), dict):
        raise UsageError(f"{run_dir / 'scores.json'}: no 'scores' in it", hint)
    from cryptography.hazmat.primitives import serialization

    raw = public_key.public_bytes(serialization.Encoding.Raw, serialization.PublicFormat.Raw)
    conditions = run_conditions(manifest)
    if challenge is not None:
        conditions["challenge"] = challenge
    versions = dict(manifest.get("versions") or {})
    versions["lock_sha256"] = (((manifest.get("provenance") or {}).get("lock") or {}).get("sha256"))
    return {
        "format": FORMAT, "run": run_dir.name,
        "files": {name: sha256_file(run_dir / name) for name in covered_files(run_dir)},
        "scores": scores["scores"], "conditions": conditions, "versions": versions,
        "isolation": str(manifest.get("sandbox") or "none"),
        "key": {"algorithm": "Ed25519", "public_key": base64.b64encode(raw).decode("ascii"),
                "fingerprint": fingerprint(public_key)},
        "signed_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def sign_run(run_dir: Path, private_key_path: Path, challenge: dict | None = None) -> Path:
    """Sign the finished run directory ``run_dir`` with the Ed25519 key in ``private_key_path``: write
    ``RUN/signature.json`` (atomically; replacing an earlier one) over :func:`payload`.

    Returns:
        the signature file's path.

    Raises:
        UsageError: a bad key file, or ``run_dir`` is not a finished, scored run (:func:`payload`).
    """
    from benchbot.core import atomic

    key = load_private_key(private_key_path)
    signed = payload(Path(run_dir), key.public_key(), challenge)
    try:
        message = canonical(signed)
    except ValueError:  # NaN or infinity: JSON has no canonical form for it
        raise UsageError(f"{Path(run_dir) / 'scores.json'}: a score is NaN or infinite, which cannot be signed",
                         "re-evaluate the run; scores must be finite numbers") from None
    signature = base64.b64encode(key.sign(message)).decode("ascii")
    path = Path(run_dir) / SIGNATURE_FILE
    atomic.write_text(path, json.dumps({"signed": signed, "signature": signature}, indent=2, ensure_ascii=True) + "\n")
    return path


# --------------------------------------------------------------------------------------------------------------------
# Checking
# --------------------------------------------------------------------------------------------------------------------
@dataclass
class Verification:
    """What :func:`check_run` found.

    Attributes:
        status: ``verified`` (valid, by a trusted key when any were given, every file as signed), ``unsigned`` (no
            signature file), ``untrusted`` (valid, but by a key none of the trusted ones is) or ``failed``.
        message: one line: what was verified, or what fails (naming the file).
        fingerprint: the signing key's fingerprint ("" when unknown).
        signed: the signed payload (``{}`` when it could not be read).
        trusted_checked: whether trusted keys were given.
    """

    status: str
    message: str
    fingerprint: str = ""
    signed: dict = field(default_factory=dict)
    trusted_checked: bool = False

    @property
    def ok(self) -> bool:
        """Whether the run verified."""
        return self.status == "verified"


def check_run(run_dir: Path, trusted=None) -> Verification:
    """Check ``run_dir``'s signature (module docstring) against ``trusted`` (a list of Ed25519 public keys; None
    or empty: only the signature's own key, and the message says it was not checked against a trusted one).

    Returns:
        a :class:`Verification`; a bad signature file is a ``failed`` one, not an exception.

    Raises:
        UsageError: ``run_dir`` is not a run directory (no such folder, or no manifest.json).
    """
    from cryptography.exceptions import InvalidSignature
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

    run_dir = Path(run_dir)
    _is_run_dir(run_dir)
    path = run_dir / SIGNATURE_FILE
    checked = bool(trusted)
    if not path.exists():
        return Verification("unsigned", f"{path}: none, the run is not signed (self-reported)", trusted_checked=checked)
    try:
        doc = json.loads(path.read_bytes().decode("utf-8"))
        signed, signature = doc["signed"], base64.b64decode(doc["signature"], validate=True)
        raw = base64.b64decode(signed["key"]["public_key"], validate=True)
        public = Ed25519PublicKey.from_public_bytes(raw)
        files = signed["files"]
        if signed.get("format") != FORMAT or not isinstance(files, dict):
            raise ValueError("format")
    except (OSError, ValueError, KeyError, TypeError, AttributeError, UnicodeDecodeError) as exc:
        return Verification("failed", f"{path}: garbled, not a BenchBot signature ({exc.__class__.__name__}); "
                                      "the host signs runs with `benchbot challenge evaluate`", trusted_checked=checked)
    fp = fingerprint(public)
    try:
        public.verify(signature, canonical(signed))
    except (InvalidSignature, ValueError, TypeError):
        return Verification("failed", f"{path}: the signature is invalid (the file was edited, or was not made with "
                                      f"key {fp})", fp, trusted_checked=checked)
    if checked and fp not in {fingerprint(k) for k in trusted}:
        return Verification("untrusted", f"{path}: signed by an unknown key {fp}, not a trusted one", fp, signed,
                            checked)
    for name, digest in sorted(files.items()):
        target = run_dir / name
        if ".." in Path(name).parts or Path(name).is_absolute():
            return Verification("failed", f"{path}: names a file outside the run ({name})", fp, signed, checked)
        if target.is_symlink() or not target.is_file():
            return Verification("failed", f"{target}: covered by the signature, but missing (or not a plain file)",
                                fp, signed, checked)
        if sha256_file(target) != digest:
            return Verification("failed", f"{target}: changed since it was signed (SHA-256 differs)", fp, signed,
                                checked)
    try:
        now = covered_files(run_dir)
    except UsageError as exc:
        return Verification("failed", exc.message, fp, signed, checked)
    added = [n for n in now if n not in files]
    if added:
        return Verification("failed", f"{run_dir / added[0]}: added after signing (not covered by the signature)",
                            fp, signed, checked)
    conds = signed.get("conditions") or {}
    what = (f"{run_dir}: {len(files)} files as signed by key {fp}; {conds.get('task')}, "
            f"{len(conds.get('environments') or [])} environments ({conds.get('worlds')}), isolation "
            f"{signed.get('isolation')}")
    if not checked:
        what += "; the key was not checked against a trusted one (give --key HOST.pub.pem)"
    return Verification("verified", what, fp, signed, checked)
