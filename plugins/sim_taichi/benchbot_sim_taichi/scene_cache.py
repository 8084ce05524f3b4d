"""The cache of built scenes: what an environment costs to build before its first frame — the :class:`Scene`
(:func:`~benchbot_worlds.scene.build.build_scene`: floor plan, fitted textured models, their triangles and
textures), and what the renderer makes of it (:meth:`~benchbot_sim_taichi.render.renderer.Renderer.prepared_scene`:
the packed arrays with the BVH, the traced shadow maps, the light lists, the baked light) — kept on disk, so that a
second run of the same environment loads it in a fraction of a second instead of building it again.

Where: ``<cache dir>/sim_taichi-scenes/`` (:func:`benchbot.packs.pack_layout.cache_dir`: ``$BENCHBOT_CACHE_DIR``, else
``$XDG_CACHE_HOME/benchbot``, else ``~/.cache/benchbot``), made readable by its owner only; the solution sandbox hides
the cache directory, as it holds the layouts (the ground truth). Two files an environment: ``<key>.scene.npz`` (the
Scene) and ``<key>.prepared.npz`` (the renderer's arrays; its key adds the renderer's
:meth:`~benchbot_sim_taichi.render.renderer.Renderer.preparation_options`: arch, shadow samples, seed, Taichi's
version).

Keys are SHA-256 digests of everything that decides the content (:func:`scene_key`): the environment spec, the
style and seed, the bytes of its layout file (and of the files its ``home_files`` declares, from which the furnished
floor plan is derived: :func:`~benchbot_worlds.homes.floorplan.home_files`) and of its mesh files, the asset
packs' contents (every manifest entry as read, and the SHA-256 of each model file's bytes: :func:`assets_fingerprint`),
and the code: the bytes of every Python file of this package and of the core's modules that shape a scene
(:data:`CORE_MODULES`), its version, NumPy's, trimesh's and Pillow's versions, the image decoder that turns textures
into pixels (:func:`image_decoder`: Pillow's version and its JPEG and zlib libraries', or none) and
:data:`CACHE_FORMAT`. A change to any of them is a miss; nothing is ever invalidated by hand. (A scene is never
built without its textures: :class:`~benchbot_worlds.scene.meshes.TextureDecodeError`; the decoder is in the key
so that a scene decoded by one Pillow is not served to another.)

Files are NumPy ``.npz`` archives read with ``allow_pickle=False`` (loading one runs no code): arrays as they are,
strings and the floor plan as JSON in uint8 arrays. They are written to a temporary file beside their place, then
renamed (``os.replace``), so a reader never sees half a file, and parallel episodes building one scene at once
simply write it twice. An entry that cannot be read, whose recorded key, format or arrays do not match, or that
would take more than the cache's bound once read (a compressed archive too), is ignored with one log line (logger
``benchbot_sim_taichi.scene_cache``), removed, and built again; the cache never fails a run.

Its size is bounded by :data:`benchbot.core.limits.SCENE_CACHE_BYTES` (``BENCHBOT_SCENE_CACHE_BYTES``, 4 GiB; an entry
of the furnished miniroom:1 takes 82.6 MB in two files, house:1 362 MB, as ``scene_cache_bytes`` of
``BENCHBOT_SIM_STYLE=furnished uv run python benchmarks/first_run.py --smoke --env house:1 --warm 0`` says on
2026-11-24): after each write, the files used longest ago (by modification time, which every hit renews) are removed
until the rest fit. ``BENCHBOT_SCENE_CACHE_BYTES=0`` turns the cache off.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import json
import logging
import os
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

import benchbot_worlds

log = logging.getLogger(__name__)

#: Version of the files' layout: raise it when what an entry holds or how it is written changes.
CACHE_FORMAT = 1
#: The folder of the scene cache inside the cache directory.
FOLDER_NAME = "sim_taichi-scenes"
#: Temporary files (``.tmp-*``) older than this many seconds are a crashed writer's: removed when the cache is trimmed.
STALE_TMP_S = 3600.0

#: The packages whose code builds and prepares scenes: this simulator's and the worlds' (benchbot_worlds).
_PACKAGES = (Path(__file__).resolve().parent, Path(benchbot_worlds.__file__).resolve().parent)
#: Modules of the BenchBot core whose code decides what a scene holds (poses and start poses; the asset library the
#: furnished style chooses from): their bytes are part of :func:`code_fingerprint`.
CORE_MODULES = ("benchbot.core.geometry", "benchbot.packs.assets")
#: Distributions whose version decides what a scene holds besides NumPy: trimesh loads every mesh file, Pillow
#: decodes their textures (see also :func:`image_decoder`).
LIBRARIES = ("trimesh", "pillow")


# ------------------------------------------------------------------------------------------------------ where, when
def cache_folder() -> Path:
    """``<cache dir>/sim_taichi-scenes`` (not created; see the module docstring)."""
    from benchbot.packs.pack_layout import cache_dir

    return cache_dir().expanduser() / FOLDER_NAME


def max_bytes() -> int:
    """The cache's bound in bytes (:data:`benchbot.core.limits.SCENE_CACHE_BYTES`; 0: the cache is off).

    Raises:
        UsageError: ``BENCHBOT_SCENE_CACHE_BYTES`` is not a whole number of bytes ≥ 0.
    """
    from benchbot.core.limits import SCENE_CACHE_BYTES

    return int(SCENE_CACHE_BYTES.value())


# ------------------------------------------------------------------------------------------------------------- keys
def image_decoder() -> dict | None:
    """What decodes the models' textures (trimesh hands every image to Pillow): ``{"pillow": version, "jpeg":
    libjpeg's version, "libjpeg_turbo": its version or None, "zlib": zlib's version}`` (the libraries Pillow was
    built with: a JPEG texture's pixels may differ between libjpeg versions), or None when Pillow cannot be imported
    (then a furnished scene cannot be built: :class:`~benchbot_worlds.scene.meshes.TextureDecodeError`)."""
    try:
        import PIL
        from PIL import features
    except ImportError:
        return None

    def probe(get, name: str) -> str | None:
        try:
            return get(name)
        except Exception:  # noqa: BLE001 - an older Pillow without the probe, or without the feature
            return None

    return {"pillow": PIL.__version__, "jpeg": probe(features.version_codec, "jpg"),
            "libjpeg_turbo": probe(features.version_feature, "libjpeg_turbo"),
            "zlib": probe(features.version_codec, "zlib")}


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """SHA-256 (hex) of the code that builds and prepares scenes: the path and bytes of every ``.py`` file of
    ``benchbot_sim_taichi`` and ``benchbot_worlds``, of the core's :data:`CORE_MODULES`, the two distributions'
    versions, NumPy's and
    :data:`LIBRARIES`' versions, :func:`image_decoder` and :data:`CACHE_FORMAT` (computed once per process: a few
    milliseconds, and importing Pillow)."""
    import importlib.util
    from importlib import metadata

    def version(name: str) -> str:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return "unknown"

    h = hashlib.sha256()
    h.update(json.dumps([CACHE_FORMAT, version("benchbot-sim-taichi"), version("benchbot-worlds"), np.__version__,
                         [version(name) for name in LIBRARIES], image_decoder()]).encode())
    for package in _PACKAGES:
        for path in sorted(package.rglob("*.py")):
            h.update(str(path.relative_to(package.parent)).encode() + b"\0")
            h.update(path.read_bytes())
    for name in CORE_MODULES:
        h.update(name.encode() + b"\0")
        h.update(Path(importlib.util.find_spec(name).origin).read_bytes())
    return h.hexdigest()


def _file_digest(path: Path) -> str:
    """SHA-256 (hex) of the file at ``path``, read in blocks. Raises OSError: it cannot be read."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


@functools.lru_cache(maxsize=1024)
def _content_digest(path: str, size: int, mtime_ns: int) -> str:
    """SHA-256 (hex) of the file at ``path``, remembered per (path, size, modification time) within a process (the
    shipped pack's 187 models, 15 MB: about 30 ms once). Raises OSError: it cannot be read."""
    return _file_digest(Path(path))


def assets_fingerprint() -> list:
    """The installed asset packs' contents as the furnished style uses them: per model, every field of its manifest
    entry as read (:class:`benchbot.packs.assets.AssetInfo`: id, class, kind, role, size, mount, tags, the manifest's
    digest, …, its path) and the SHA-256 of the model file's bytes (so a file changed without its manifest is a
    miss too).

    Raises:
        OSError: a model file cannot be read.
    """
    from benchbot.packs.assets import asset_library

    rows = []
    for a in asset_library().all():
        st = os.stat(a.path)
        rows.append([dataclasses.asdict(a), _content_digest(str(a.path), st.st_size, st.st_mtime_ns)])
    return rows


def scene_key(environment: dict, seed: int = 0) -> str | None:
    """The key of the scene :func:`~benchbot_worlds.scene.build.build_scene` makes of ``environment`` with
    ``seed``: a 64-character SHA-256 hex digest of the spec, the style (the spec's, else
    :func:`~benchbot_worlds.scene.build.default_style`), the seed, the bytes of the layout file (``map_path``), of
    the ground-truth files its home's plan is derived from (furnished style:
    :func:`~benchbot_worlds.homes.floorplan.home_files`) and of the mesh files of ``objects``, the asset packs'
    contents (furnished style: :func:`assets_fingerprint`) and :func:`code_fingerprint`. ``None`` when a file it names cannot be read (then the
    scene is built, and the build says what is wrong).

    Raises:
        BackendError: the style variable names no style (as ``build_scene`` would).
    """
    from benchbot.core.errors import BackendError
    from benchbot_worlds.homes.floorplan import home_files
    from benchbot_worlds.scene.build import _env_dir, default_style

    style = environment.get("style") or default_style()
    files: list[Path] = []
    map_path = environment.get("map_path")
    if map_path:
        files.append(Path(map_path))
        if style == "furnished":
            try:
                files += home_files(environment, _env_dir(environment))
            except BackendError as e:
                log.info("scene cache: not used for %s:%s (%s)", environment.get("name"), environment.get("variant"),
                         e.message)
                return None
    for obj in environment.get("objects") or []:
        if isinstance(obj, dict) and isinstance(obj.get("mesh"), str):
            path = Path(obj["mesh"]).expanduser()
            files.append(path if path.is_absolute() else _env_dir(environment) / path)
    try:
        digests = [[str(p), _file_digest(p)] for p in files]
        assets = assets_fingerprint() if style == "furnished" else []
    except OSError as e:
        log.info("scene cache: not used for %s:%s (%s)", environment.get("name"), environment.get("variant"), e)
        return None
    what = {"format": CACHE_FORMAT, "code": code_fingerprint(), "environment": environment, "style": style,
            "seed": int(seed), "files": digests, "assets": assets}
    return hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()


def prepared_key(key: str, options: dict) -> str:
    """The key of the renderer's arrays of the scene ``key`` for a renderer whose
    :meth:`~benchbot_sim_taichi.render.renderer.Renderer.preparation_options` are ``options``."""
    return hashlib.sha256(json.dumps([key, options], sort_keys=True, default=str).encode()).hexdigest()


# ----------------------------------------------------------------------------------------- scenes as plain arrays
def _text(value: Any) -> np.ndarray:
    return np.frombuffer(json.dumps(value, allow_nan=True).encode(), np.uint8)


def _untext(a: np.ndarray) -> Any:
    return json.loads(bytes(np.asarray(a, np.uint8)).decode())


def _plan_classes() -> dict[str, type]:
    from benchbot_worlds.homes import floorplan

    return {c.__name__: c for c in (floorplan.FloorPlan, floorplan.Room, floorplan.Wall, floorplan.Opening,
                                     floorplan.WallSpan)}


def encode_plain(value: Any) -> Any:
    """``value`` — a floor plan (:class:`~benchbot_worlds.homes.floorplan.FloorPlan`) or anything made of its
    parts: its dataclasses, a ``Corridor``, NumPy arrays and scalars, tuples, lists, str/int/float/bool/None — as
    JSON-ready data that :func:`decode_plain` turns back into an equal value, every float bit for bit.

    Raises:
        TypeError: a part of another type.
    """
    from benchbot_worlds.homes.floorplan import Corridor

    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, np.ndarray):
        return {"nd": value.dtype.str, "shape": list(value.shape), "data": value.ravel().tolist()}
    if isinstance(value, np.generic):
        return {"np": value.dtype.str, "value": value.item()}
    if isinstance(value, tuple):
        return {"tuple": [encode_plain(v) for v in value]}
    if isinstance(value, list):
        return [encode_plain(v) for v in value]
    if isinstance(value, Corridor):
        return {"corridor": [encode_plain(value.p0), encode_plain(value.p1), value.radius]}
    if dataclasses.is_dataclass(value) and type(value).__name__ in _plan_classes():
        return {"dataclass": type(value).__name__,
                "fields": {f.name: encode_plain(getattr(value, f.name)) for f in dataclasses.fields(value)}}
    raise TypeError(f"scene cache: cannot store a {type(value).__name__}")


def decode_plain(data: Any) -> Any:
    """The value :func:`encode_plain` encoded.

    Raises:
        ValueError: ``data`` is not what :func:`encode_plain` writes (a class it does not know, a bad array).
    """
    from benchbot_worlds.homes.floorplan import Corridor

    if data is None or isinstance(data, (bool, int, float, str)):
        return data
    if isinstance(data, list):
        return [decode_plain(v) for v in data]
    if not isinstance(data, dict):
        raise ValueError(f"scene cache: unexpected {type(data).__name__} in a stored plan")
    if "nd" in data:
        dtype = np.dtype(data["nd"])
        if dtype.hasobject:
            raise ValueError("scene cache: object arrays are not stored")
        return np.array(data["data"], dtype=dtype).reshape(data["shape"])
    if "np" in data:
        return np.dtype(data["np"]).type(data["value"])
    if "tuple" in data:
        return tuple(decode_plain(v) for v in data["tuple"])
    if "corridor" in data:
        p0, p1, radius = data["corridor"]
        return Corridor(decode_plain(p0), decode_plain(p1), radius)
    cls = _plan_classes().get(data.get("dataclass"))
    if cls is None:
        raise ValueError(f"scene cache: unknown class {data.get('dataclass')!r} in a stored plan")
    return cls(**{k: decode_plain(v) for k, v in data["fields"].items()})


def scene_to_arrays(scene) -> dict[str, np.ndarray]:
    """A :class:`~benchbot_worlds.scene.model.Scene` as ``{name: array}`` for an ``.npz`` file: its array fields
    as they are (``scene.<field>``), the others (names, class list and ids, style, lighting, the floor plan) as JSON
    text in uint8 arrays (``scene.fields``, ``scene.plan``).

    Raises:
        TypeError: a field holds something :func:`encode_plain` cannot store.
    """
    out: dict[str, np.ndarray] = {}
    rest: dict[str, Any] = {}
    for f in dataclasses.fields(scene):
        value = getattr(scene, f.name)
        if isinstance(value, np.ndarray):
            if value.dtype.hasobject:
                raise TypeError(f"scene cache: Scene.{f.name} is an object array")
            out[f"scene.{f.name}"] = value
        elif f.name != "plan":
            if json.loads(json.dumps(value)) != value:
                raise TypeError(f"scene cache: Scene.{f.name} does not survive JSON")
            rest[f.name] = value
    out["scene.fields"] = _text(rest)
    out["scene.plan"] = _text(encode_plain(scene.plan))
    return out


def scene_from_arrays(arrays: dict) -> Any:
    """The :class:`~benchbot_worlds.scene.model.Scene` of :func:`scene_to_arrays`'s arrays.

    Raises:
        KeyError: an array is missing; ValueError, TypeError: the stored fields are not a Scene's.
    """
    from benchbot_worlds.scene.model import Scene

    values = dict(_untext(arrays["scene.fields"]))
    values["plan"] = decode_plain(_untext(arrays["scene.plan"]))
    for f in dataclasses.fields(Scene):
        if f.name not in values:
            values[f.name] = np.asarray(arrays[f"scene.{f.name}"])
    return Scene(**values)


# ------------------------------------------------------------------------------------------------------ the files
def _path(key: str, kind: str) -> Path:
    return cache_folder() / f"{key}.{kind}.npz"


def _read(key: str, kind: str, what: str) -> dict[str, np.ndarray] | None:
    """The arrays of entry ``key.kind`` (its ``entry`` record checked), or None when there is none or it is bad
    (logged once and removed): unreadable, not an ``.npz`` of plain arrays, a pickled object in it, or larger, as a
    file or once read, than the cache's bound (:func:`max_bytes`), so that a hostile file cannot exhaust memory."""
    limit = max_bytes()
    if limit == 0:
        return None
    path = _path(key, kind)
    if not path.is_file():
        return None
    try:
        size = path.stat().st_size
        if size > limit:
            raise ValueError(f"it takes {size} bytes, more than BENCHBOT_SCENE_CACHE_BYTES={limit}")
        with np.load(path, allow_pickle=False) as z:
            # what its arrays take once read (the archive's own sizes, which bound what zipfile gives out): a
            # compressed archive could hold far more than its file takes
            stored = sum(info.file_size for info in z.zip.infolist())
            if stored > limit:
                raise ValueError(f"its arrays take {stored} bytes, more than BENCHBOT_SCENE_CACHE_BYTES={limit}")
            arrays = {name: z[name] for name in z.files}
        entry = _untext(arrays.pop("entry"))
        if entry != {"format": CACHE_FORMAT, "key": key, "kind": kind}:
            raise ValueError(f"it records {entry!r}")
    except Exception as e:  # noqa: BLE001 - a bad entry is rebuilt, never a failure
        log.warning("scene cache: ignoring %s (%s: %s); building %s again", path, type(e).__name__, e, what)
        with contextlib.suppress(OSError):
            path.unlink()
        return None
    with contextlib.suppress(OSError):
        os.utime(path)  # used now: the last to be evicted
    return arrays


def _write(key: str, kind: str, arrays: dict[str, np.ndarray]) -> Path | None:
    """Write entry ``key.kind`` atomically, then trim the cache; None (and a log line) when it cannot be written
    or is larger than the bound alone."""
    limit = max_bytes()
    if limit == 0:
        return None
    size = sum(int(np.asarray(a).nbytes) for a in arrays.values())
    if size > limit:
        log.info("scene cache: an entry of %d bytes is larger than BENCHBOT_SCENE_CACHE_BYTES; not kept", size)
        return None
    folder = cache_folder()
    path = _path(key, kind)
    tmp = None
    try:
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=".npz")
        with os.fdopen(fd, "wb") as f:
            np.savez(f, entry=_text({"format": CACHE_FORMAT, "key": key, "kind": kind}), **arrays)
        os.replace(tmp, path)
        tmp = None
    except OSError as e:
        log.warning("scene cache: cannot write %s (%s)", path, e)
        return None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
    trim(limit)
    return path


def trim(limit: int | None = None) -> list[Path]:
    """Remove the cache's files used longest ago (oldest modification time first) until the rest take at most
    ``limit`` bytes (default :func:`max_bytes`), and temporary files of writers that died (older than
    :data:`STALE_TMP_S`). Returns the removed paths."""
    limit = max_bytes() if limit is None else int(limit)
    folder = cache_folder()
    if not folder.is_dir():
        return []
    removed, files = [], []
    now = time.time()
    for path in folder.iterdir():
        try:
            st = path.stat()
        except OSError:
            continue
        if path.name.startswith(".tmp-"):
            if now - st.st_mtime > STALE_TMP_S:
                with contextlib.suppress(OSError):
                    path.unlink()
                    removed.append(path)
            continue
        if path.suffix == ".npz":
            files.append((st.st_mtime, st.st_size, path))
    total = sum(size for _, size, _ in files)
    for _, size, path in sorted(files):
        if total <= limit:
            break
        with contextlib.suppress(OSError):
            path.unlink()
            removed.append(path)
            total -= size
    return removed


# --------------------------------------------------------------------------------------------------- what callers use
def load_scene(key: str) -> Any | None:
    """The :class:`~benchbot_worlds.scene.model.Scene` stored under ``key``, or None (none, off, or a bad entry:
    logged, removed)."""
    arrays = _read(key, "scene", "the scene")
    if arrays is None:
        return None
    try:
        return scene_from_arrays(arrays)
    except Exception as e:  # noqa: BLE001 - stored data of any shape (nested too deep: RecursionError) is rebuilt
        log.warning("scene cache: ignoring %s (%s: %s); building the scene again", _path(key, "scene"),
                    type(e).__name__, e)
        with contextlib.suppress(OSError):
            _path(key, "scene").unlink()
        return None


def store_scene(key: str, scene) -> Path | None:
    """Store ``scene`` under ``key``; the file written, or None (off, too large, not writable, or a scene field
    that cannot be stored: logged)."""
    try:
        arrays = scene_to_arrays(scene)
    except TypeError as e:
        log.warning("%s; the scene is not cached", e)
        return None
    return _write(key, "scene", arrays)


def scene_for(environment: dict, seed: int = 0, *, build: Callable | None = None,
              key: Any = ...) -> tuple[Any, str | None]:
    """``(scene, key)``: the scene of ``environment`` and ``seed`` from the cache, else built (``build``, default
    :func:`~benchbot_worlds.scene.build.build_scene`) and stored; ``key`` is :func:`scene_key` (None: the
    cache was not used). Pass ``key`` when it is known already (None: do not use the cache).

    Raises:
        BackendError: as ``build_scene`` (the environment is malformed or its files unreadable).
    """
    from benchbot.core import stages

    if build is None:
        from benchbot_worlds.scene.build import build_scene as build
    name = f"{environment.get('name')}:{environment.get('variant')}"
    if key is ...:
        key = scene_key(environment, seed) if max_bytes() else None
    if key is not None and _path(key, "scene").is_file():
        with stages.stage("loading the scene", detail=f"{name}, from the cache"):
            scene = load_scene(key)
        if scene is not None:
            return scene, key
    with stages.stage("building the scene", detail=name):
        scene = build(environment, seed=seed)
    if key is not None:
        store_scene(key, scene)
    return scene, key


def load_prepared(key: str, options: dict) -> dict[str, np.ndarray] | None:
    """The renderer's arrays of the scene ``key`` for a renderer with ``options`` (its
    :meth:`~benchbot_sim_taichi.render.renderer.Renderer.preparation_options`), or None."""
    return _read(prepared_key(key, options), "prepared", "the renderer's arrays")


def store_prepared(key: str, options: dict, arrays: dict[str, np.ndarray]) -> Path | None:
    """Store the renderer's arrays (:meth:`~benchbot_sim_taichi.render.renderer.Renderer.prepared_scene`) of the
    scene ``key`` for a renderer with ``options``; the file written, or None."""
    return _write(prepared_key(key, options), "prepared", arrays)


def set_scene(renderer, scene, key: str | None) -> bool:
    """``renderer.set_scene(scene)`` with the renderer's arrays from the cache when it has them (True), else
    prepared by the renderer and stored (False). ``key``: the scene's :func:`scene_key` (None: no cache)."""
    from benchbot.core import stages

    if key is None:
        renderer.set_scene(scene)
        return False
    options = renderer.preparation_options()
    prepared = None
    if _path(prepared_key(key, options), "prepared").is_file():
        with stages.stage("loading the BVH, shadow maps and baked light", detail="from the cache"):
            prepared = load_prepared(key, options)
    if prepared is not None:
        try:
            renderer.set_scene(scene, prepared=prepared)
            return True
        except (KeyError, ValueError, TypeError, IndexError) as e:
            log.warning("scene cache: the renderer's arrays do not fit (%s: %s); preparing the scene again",
                        type(e).__name__, e)
            with contextlib.suppress(OSError):
                _path(prepared_key(key, options), "prepared").unlink()
    renderer.set_scene(scene)
    store_prepared(key, options, renderer.prepared_scene())
    return False
