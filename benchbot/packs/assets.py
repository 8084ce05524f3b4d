"""Asset packs: libraries of 3D models (GLB) that simulators draw ground-truth objects and furniture with.

A pack is a folder with ``manifest.json`` (schema ``schemas/asset_manifest.schema.json``), the ``*.glb`` files it
lists and an ``ATTRIBUTION.md``. Plugins offer packs through the hook ``benchbot_asset_packs`` (paths of
``manifest.json`` files); :func:`asset_library` merges every pack into one :class:`AssetLibrary`.

Model conventions (glTF 2.0): metres, +Y up, the model's front faces +Z, origin at the centre of the bottom face of
its bounds. A simulator converts glTF ``(x, y, z)`` to the map frame as ``(x, -z, y)``: there a model is z-up and
faces -y, and ``size_m`` is its bounds in map axes ``[width x, depth y, height z]``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchbot.core.errors import SpecError
from benchbot.core.limits import MAX_SPEC_BYTES
from benchbot.core.plugin_manager import call_each_plugin
from benchbot.core.safe_load import load_data_file

SCHEMA = "asset_manifest"
"""The schema (``schemas/asset_manifest.schema.json``) every manifest is validated against."""

HOOK = "benchbot_asset_packs"


@dataclass(frozen=True)
class AssetInfo:
    """One model of an asset pack (a manifest entry, plus where it lives).

    Attributes:
        id: unique id across all packs (e.g. ``chair_blendswap_cc0_12``).
        file: the GLB's file name inside its pack.
        cls: the ground-truth class it depicts (manifest ``class``; e.g. ``chair``), or ``None`` for furniture that
            is not an object of any class (distractors, structure).
        kind: what it is: the class for objects; for distractors e.g. ``cabinet``, ``rug``, ``floor_lamp``.
        role: ``object`` (depicts a class), ``distractor`` (furniture never of a class), ``structure`` (doors,
            windows: part of the building).
        size_m: bounds in map axes, metres: ``(width x, depth y, height z)``.
        triangles: triangle count.
        textures: ``({"width": w, "height": h}, ...)`` of its embedded textures.
        library: the library it comes from (e.g. ``BlendSwap-CC-0``).
        model: the model's name or id in that library.
        creator: the model's author.
        licence: SPDX-style licence id (``CC0-1.0``, ``CC-BY-3.0``).
        sha256: hex digest of the GLB file.
        path: absolute path of the GLB file.
        pack: the name of the pack (manifest ``name``).
        mount: where it goes: ``floor``, ``wall``, ``ceiling`` or ``surface`` (on a table/counter), or ``None``
            when the manifest does not say.
        licence_url: the licence's URL, or ``""``.
        tags: free words about the model (e.g. ``row`` for a row of books, ``closed`` for a shut laptop,
            ``upright`` for cutlery standing on its end).
    """

    id: str
    file: str
    cls: str | None
    kind: str
    role: str
    size_m: tuple[float, float, float]
    triangles: int
    textures: tuple[dict, ...]
    library: str
    model: str
    creator: str
    licence: str
    sha256: str
    path: Path
    pack: str
    mount: str | None = None
    licence_url: str = ""
    tags: tuple[str, ...] = ()

    @property
    def class_name(self) -> str | None:
        """The manifest's ``class`` (same as :attr:`cls`)."""
        return self.cls


class AssetLibrary:
    """Every asset of every pack, indexed by id, class and kind.

    Args:
        assets: the assets; ids must be unique.
        problems: one line per pack or asset that was left out (see :func:`asset_library`).

    Raises:
        ValueError: two assets share an id.
    """

    def __init__(self, assets: list[AssetInfo] | tuple[AssetInfo, ...] = (), problems: list[str] | None = None):
        self._by_id: dict[str, AssetInfo] = {}
        for asset in assets:
            if asset.id in self._by_id:
                raise ValueError(f"two assets have the id {asset.id!r}")
            self._by_id[asset.id] = asset
        self.problems: list[str] = list(problems or [])

    def all(self) -> list[AssetInfo]:
        """Every asset, in pack then manifest order."""
        return list(self._by_id.values())

    def get(self, asset_id: str) -> AssetInfo:
        """The asset with this id.

        Raises:
            KeyError: no asset has it.
        """
        return self._by_id[asset_id]

    def by_class(self, cls: str) -> list[AssetInfo]:
        """The assets depicting ground-truth class ``cls`` (role ``object``), in library order; ``[]`` if none."""
        return [a for a in self._by_id.values() if a.cls == cls]

    def by_kind(self, kind: str) -> list[AssetInfo]:
        """The assets of ``kind`` (a class name for objects, e.g. ``cabinet`` for distractors); ``[]`` if none."""
        return [a for a in self._by_id.values() if a.kind == kind]

    def classes(self) -> list[str]:
        """The ground-truth classes with at least one asset, sorted."""
        return sorted({a.cls for a in self._by_id.values() if a.cls is not None})

    def kinds(self) -> list[str]:
        """Every kind with at least one asset, sorted."""
        return sorted({a.kind for a in self._by_id.values()})

    def __len__(self) -> int:
        return len(self._by_id)


def load_asset_manifest(path: Path | str) -> list[AssetInfo]:
    """The assets of one pack, from its ``manifest.json``.

    Checks the schema, that ids are unique, that an object's ``kind`` is its ``class`` and that every listed file
    exists next to the manifest (files are plain names: nothing outside the pack folder can be named). The GLB
    contents (and ``sha256``) are not read here.

    Args:
        path: the manifest file (JSON, at most :data:`~benchbot.core.limits.MAX_SPEC_BYTES`).

    Returns:
        The pack's assets, in manifest order, with absolute ``path`` s.

    Raises:
        SpecError: one line ``"<manifest>: $.assets[3].size_m: <what is wrong>"`` naming the file and the field.
    """
    from benchbot.core.specs import validate

    path = Path(path).resolve()
    data = load_data_file(path, MAX_SPEC_BYTES, SpecError)
    validate(data, SCHEMA, str(path))
    out: list[AssetInfo] = []
    seen: set[str] = set()
    for i, entry in enumerate(data["assets"]):
        where = f"{path}: $.assets[{i}]"
        if entry["id"] in seen:
            raise SpecError(f"{where}.id: duplicate id {entry['id']!r}", "give every asset of a pack its own id")
        seen.add(entry["id"])
        if entry["role"] == "object" and entry["kind"] != entry["class"]:
            raise SpecError(f"{where}.kind: an object's kind must be its class {entry['class']!r}, "
                            f"not {entry['kind']!r}", "set kind to the class")
        glb = path.parent / entry["file"]
        if not glb.is_file():
            raise SpecError(f"{where}.file: {entry['file']} does not exist next to the manifest",
                            "put the GLB in the pack folder or fix the file name")
        out.append(_asset(entry, glb, data["name"]))
    return out


def _asset(entry: dict[str, Any], glb: Path, pack: str) -> AssetInfo:
    return AssetInfo(
        id=entry["id"], file=entry["file"], cls=entry["class"], kind=entry["kind"], role=entry["role"],
        size_m=tuple(float(v) for v in entry["size_m"]), triangles=int(entry["triangles"]),
        textures=tuple(dict(t) for t in entry["textures"]), library=entry["library"], model=entry["model"],
        creator=entry["creator"], licence=entry["licence"], sha256=entry["sha256"], path=glb, pack=pack,
        mount=entry.get("mount"), licence_url=entry.get("licence_url", ""), tags=tuple(entry.get("tags", ())),
    )


def asset_library(pm: Any = None, *, strict: bool = False) -> AssetLibrary:
    """Every asset pack offered by the plugins (hook ``benchbot_asset_packs``), merged into one library.

    Args:
        pm: the pluggy plugin manager; ``None``: the process-wide registry's (cached: built once per process).
        strict: raise on the first bad pack instead of leaving it out.

    Returns:
        An :class:`AssetLibrary`. A pack whose manifest is invalid, a hook that raises or returns something other
        than paths, and an asset whose id another pack already used are left out and described, one line each,
        in ``library.problems`` (the other packs still load).

    Raises:
        SpecError: only with ``strict=True``: the first problem, naming the manifest file and field.
    """
    if pm is None:
        return _default_library() if not strict else _build(_registry_pm(), strict=True)
    return _build(pm, strict=strict)


def _registry_pm() -> Any:
    from benchbot.core.registry import get_registry

    return get_registry().plugin_manager


@functools.lru_cache(maxsize=1)
def _default_library() -> AssetLibrary:
    return _build(_registry_pm(), strict=False)


def _build(pm: Any, *, strict: bool) -> AssetLibrary:
    assets: dict[str, AssetInfo] = {}
    problems: list[str] = []

    def problem(line: str, hint: str = "") -> None:
        if strict:
            raise SpecError(line, hint)
        problems.append(line)

    for plugin_name, returned, exc in call_each_plugin(pm, HOOK):
        if exc is None:
            try:
                paths = [Path(p) for p in returned or []]
            except TypeError as not_paths:
                exc = not_paths
        if exc is not None:  # a broken third-party pack must not break the others
            problem(f"plugin {plugin_name}: {HOOK}() raised {exc!r}".splitlines()[0],
                    "fix or disable that plugin (BENCHBOT_DISABLE_PLUGINS)")
            continue
        for manifest in paths:
            try:
                pack_assets = load_asset_manifest(manifest)
            except SpecError as exc:
                problem(f"plugin {plugin_name}: {exc.message}", exc.hint)
                continue
            for asset in pack_assets:
                if asset.id in assets:
                    other = assets[asset.id]
                    problem(f"plugin {plugin_name}: {manifest}: asset id {asset.id!r} is already used by pack "
                            f"{other.pack!r}; left out", "give the asset an id of its own")
                    continue
                assets[asset.id] = asset
    return AssetLibrary(list(assets.values()), problems)
