"""BenchBot hook implementation of ``benchbot_assets_sh3d``: offers the shipped asset pack (``pack/manifest.json``).
Imports nothing heavy."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl

PACK_DIR = Path(__file__).resolve().parent / "pack"
"""The shipped pack: ``manifest.json``, the ``*.glb`` models, ``ATTRIBUTION.md`` and ``LICENSES.md``."""

MANIFEST = PACK_DIR / "manifest.json"


@hookimpl
def benchbot_asset_packs() -> list[Path]:
    """The pack's manifest (see ``benchbot.packs.assets``)."""
    return [MANIFEST]
