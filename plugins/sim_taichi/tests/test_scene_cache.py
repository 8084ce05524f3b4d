"""The cache of built scenes (benchbot_sim_taichi.scene_cache) with the real simulator at a tiny resolution: a scene
and the renderer's arrays loaded from it equal the freshly built ones array for array and render the same images; a
changed layout file, package version or cache format is a miss; a corrupt or foreign entry is rebuilt with one log
line; the size bound removes the entries used longest ago."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import os

import numpy as np
import pytest

from benchbot.core import stages
from benchbot_sim_taichi import scene_cache as cache

ALL = ["image_rgb", "image_depth", "image_segment", "laser"]
LOGGER = "benchbot_sim_taichi.scene_cache"


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    """An empty cache directory of this test's own."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("BENCHBOT_CACHE_DIR", str(folder))
    monkeypatch.delenv("BENCHBOT_SCENE_CACHE_BYTES", raising=False)
    return folder / cache.FOLDER_NAME


def stages_of(work) -> list[str]:
    """The names of the stages started while ``work()`` runs."""
    heard: list[str] = []

    def listen(event):
        if event.kind == "start":
            heard.append(event.name)

    with stages.listening(listen):
        work()
    return heard


def warnings_of(caplog, work) -> tuple:
    """``(work(), [message of every record logged at WARNING or above while it ran])``, the cache's logger
    included (``caplog`` is cleared first)."""
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        result = work()
    return result, [r.getMessage() for r in caplog.records]


@contextlib.contextmanager
def changed(monkeypatch, target, name: str, value):
    """``target.<name>`` is ``value`` inside the block and :func:`cache.code_fingerprint` is computed afresh there;
    after it the real attribute is back and the fingerprint is computed afresh again."""
    real = getattr(target, name)
    monkeypatch.setattr(target, name, value)
    cache.code_fingerprint.cache_clear()
    try:
        yield
    finally:
        monkeypatch.setattr(target, name, real)
        cache.code_fingerprint.cache_clear()


def assert_same_scene(a, b) -> None:
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert isinstance(y, np.ndarray) and x.dtype == y.dtype and x.shape == y.shape, f.name
            assert x.tobytes() == y.tobytes(), f.name  # bit for bit
        elif f.name == "plan":
            assert json.dumps(cache.encode_plain(x)) == json.dumps(cache.encode_plain(y))
            assert type(x) is type(y)
        else:
            assert x == y and type(x) is type(y), f.name


def observations(backend) -> dict:
    obs = backend.observe(ALL)
    return {"rgb": obs["image_rgb"], "depth": obs["image_depth"],
            "class": obs["image_segment"]["class_segment_img"],
            "instance": obs["image_segment"]["instance_segment_img"], "scan": obs["laser"]["scans"]}


def test_a_cached_furnished_scene_equals_the_built_one_and_renders_the_same(bear_envs, make_backend, cache_dir):
    env = {**bear_envs["miniroom:1"], "style": "furnished"}
    built = make_backend(width=32, height=24)
    heard = stages_of(lambda: built.load_scene(env, seed=2))
    assert "building the scene" in heard and "building the BVH" in heard and "baking light" in heard, heard
    assert "loading the scene" not in heard
    files = sorted(p.name.split(".", 1)[1] for p in cache_dir.iterdir())
    assert files == ["prepared.npz", "scene.npz"]
    fresh_scene, fresh_prepared = built.scene, built._renderer.prepared_scene()
    assert fresh_scene.plan is not None and int(fresh_prepared["baked_points"]) > 0
    built.move_to(np.asarray(fresh_scene.trajectory_se2[3]))
    fresh_obs = observations(built)
    built.close()

    loaded = make_backend(width=32, height=24)
    heard = stages_of(lambda: loaded.load_scene(env, seed=2))
    assert "loading the scene" in heard and "building the scene" not in heard, heard
    assert "building the BVH" not in heard and "baking light" not in heard and "tracing shadow maps" not in heard
    assert_same_scene(fresh_scene, loaded.scene)
    prepared = loaded._renderer.prepared_scene()
    assert sorted(prepared) == sorted(fresh_prepared)
    for name, array in fresh_prepared.items():
        assert prepared[name].dtype == array.dtype and prepared[name].shape == array.shape, name
        assert prepared[name].tobytes() == array.tobytes(), name  # bit for bit (the BVH's rows hold int bits)
    loaded.move_to(np.asarray(fresh_scene.trajectory_se2[3]))
    for name, image in observations(loaded).items():
        assert np.array_equal(image, fresh_obs[name]), name

    # an episode's reset loads the same scene again: nothing is built or read
    heard = stages_of(lambda: loaded.load_scene(env, seed=2))
    assert not {"loading the scene", "building the scene", "building the BVH"} & set(heard), heard
    loaded.close()


def test_a_changed_layout_version_or_format_misses(synthetic_env, make_backend, cache_dir, monkeypatch):
    env = synthetic_env([("chair", (2.0, 0.5, 0.45), (0.5, 0.5, 0.9))])
    key = cache.scene_key(env, 0)
    assert key == cache.scene_key(dict(env), 0) and len(key) == 64
    assert cache.scene_key(env, 1) != key
    assert cache.scene_key({**env, "style": "furnished"}, 0) != key
    b = make_backend(width=16, height=12)
    assert "building the scene" in stages_of(lambda: b.load_scene(env))
    b.close()
    assert "building the scene" not in stages_of(lambda: make_backend(width=16, height=12).load_scene(env))

    data = json.loads(open(env["map_path"]).read())
    data["ground_truth"]["objects"][0]["centroid"][0] = 2.5  # the chair moved
    with open(env["map_path"], "w") as f:
        f.write(json.dumps(data))
    assert cache.scene_key(env, 0) != key
    b = make_backend(width=16, height=12)
    assert "building the scene" in stages_of(lambda: b.load_scene(env))
    assert float(b.scene.box_min[0, 0]) == pytest.approx(2.25)  # the new layout, not the cached one
    b.close()
    moved = cache.scene_key(env, 0)

    from importlib import metadata

    real_version = metadata.version
    with changed(monkeypatch, metadata, "version",
                 lambda name: "99.0" if name == "benchbot-sim-taichi" else real_version(name)):
        assert cache.scene_key(env, 0) != moved
    assert cache.scene_key(env, 0) == moved
    with changed(monkeypatch, cache, "CACHE_FORMAT", cache.CACHE_FORMAT + 1):
        assert cache.scene_key(env, 0) != moved


def test_a_corrupt_or_foreign_entry_is_rebuilt_with_one_log_line(synthetic_env, make_backend, cache_dir, caplog):
    env = synthetic_env([("table", (2.0, 0.0, 0.4), (1.0, 0.6, 0.8))])
    b = make_backend(width=16, height=12)
    b.load_scene(env)
    good = observations(b)
    b.close()
    key = cache.scene_key(env, 0)
    scene_file = cache_dir / f"{key}.scene.npz"
    prepared_file, = cache_dir.glob("*.prepared.npz")
    scene_file.write_bytes(b"PK\x03\x04 not a zip at all")
    np.savez(prepared_file, entry=np.array([object()], dtype=object))  # a pickled object: never loaded
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        b = make_backend(width=16, height=12)
        heard = stages_of(lambda: b.load_scene(env))
    assert "building the scene" in heard and "building the BVH" in heard, heard
    lines = [r.getMessage() for r in caplog.records if r.name == LOGGER]
    assert len(lines) == 2, lines
    assert str(scene_file) in lines[0] and "building the scene again" in lines[0]
    assert str(prepared_file) in lines[1] and "pickle" in lines[1].lower()
    for name, image in observations(b).items():
        assert np.array_equal(image, good[name]), name
    b.close()
    assert cache.load_scene(key) is not None  # written again, whole

    # an entry renamed to another key's name (its record names its own) is not taken for that key
    other = "0" * 64
    os.replace(scene_file, cache_dir / f"{other}.scene.npz")
    loaded, lines = warnings_of(caplog, lambda: cache.load_scene(other))
    assert loaded is None
    assert len(lines) == 1 and "records" in lines[0]
    assert not (cache_dir / f"{other}.scene.npz").exists()


def test_the_bound_removes_the_entries_used_longest_ago(cache_dir, monkeypatch):
    arrays = {"a": np.zeros(250_000, np.uint8)}  # about 250 kB a file
    paths = []
    for i in range(3):
        paths.append(cache._write(f"{i:064d}", "scene", arrays))
        os.utime(paths[-1], (1_000_000 + i, 1_000_000 + i))
    assert all(p.is_file() for p in paths)
    cache._read(f"{0:064d}", "scene", "it")  # used now: the newest
    monkeypatch.setenv("BENCHBOT_SCENE_CACHE_BYTES", "600000")
    newest = cache._write(f"{3:064d}", "scene", arrays)
    left = sorted(p.name[:64] for p in cache_dir.glob("*.npz"))
    assert left == [f"{0:064d}", f"{3:064d}"] and newest.is_file()
    assert sum(p.stat().st_size for p in cache_dir.glob("*.npz")) <= 600_000
    assert not list(cache_dir.glob(".tmp-*"))

    monkeypatch.setenv("BENCHBOT_SCENE_CACHE_BYTES", "0")  # off: nothing read, nothing written
    assert cache._read(f"{0:064d}", "scene", "it") is None
    assert cache._write(f"{4:064d}", "scene", arrays) is None


def test_an_entry_larger_than_the_bound_once_read_is_not_read(cache_dir, monkeypatch, caplog):
    """A compressed archive whose arrays would take more than BENCHBOT_SCENE_CACHE_BYTES once read (a zip bomb) is
    ignored and removed before any array is read; so is a file larger than the bound."""
    key = f"{7:064d}"
    cache_dir.mkdir(parents=True)
    bomb = cache_dir / f"{key}.scene.npz"
    np.savez_compressed(bomb, entry=cache._text({"format": cache.CACHE_FORMAT, "key": key, "kind": "scene"}),
                        a=np.zeros(2_000_000, np.uint8))  # 2 MB of zeros in a few kB
    assert bomb.stat().st_size < 100_000
    monkeypatch.setenv("BENCHBOT_SCENE_CACHE_BYTES", "1000000")
    read, lines = warnings_of(caplog, lambda: cache._read(key, "scene", "it"))
    assert read is None
    assert len(lines) == 1 and "more than BENCHBOT_SCENE_CACHE_BYTES" in lines[0]
    assert not bomb.exists()

    monkeypatch.delenv("BENCHBOT_SCENE_CACHE_BYTES")
    assert cache._write(key, "scene", {"a": np.zeros(300_000, np.uint8)}) is not None
    assert cache._read(key, "scene", "it") is not None
    monkeypatch.setenv("BENCHBOT_SCENE_CACHE_BYTES", "200000")  # the file alone is larger
    read, lines = warnings_of(caplog, lambda: cache._read(key, "scene", "it"))
    assert read is None
    assert len(lines) == 1 and "bytes, more than" in lines[0]


def test_a_stored_plan_of_any_shape_is_rebuilt_not_raised(cache_dir, caplog):
    """load_scene gives None (one log line, the entry removed) for stored fields that are no Scene's, nested too
    deep for the JSON decoder included."""
    key = f"{8:064d}"
    deep = np.frombuffer(("[" * 100_000 + "]" * 100_000).encode(), np.uint8)
    odd = cache._text({"dataclass": "Room", "fields": [1, 2]})
    for plan in (deep, odd):
        assert cache._write(key, "scene", {"scene.fields": cache._text({}), "scene.plan": plan}) is not None
        loaded, lines = warnings_of(caplog, lambda: cache.load_scene(key))
        assert loaded is None
        assert len(lines) == 1 and "building the scene again" in lines[0]
        assert not (cache_dir / f"{key}.scene.npz").exists()


def test_the_key_follows_the_core_code_and_trimesh_that_shape_a_scene(synthetic_env, monkeypatch):
    """A change to trimesh's version (it loads every mesh) or to the core's geometry module (poses) is a miss."""
    import importlib.util
    from importlib import metadata

    env = synthetic_env([("chair", (2.0, 0.5, 0.45), (0.5, 0.5, 0.9))])
    cache.code_fingerprint.cache_clear()
    key = cache.scene_key(env, 0)
    real_version = metadata.version
    with changed(monkeypatch, metadata, "version",
                 lambda name: "0.0.1" if name == "trimesh" else real_version(name)):
        assert cache.scene_key(env, 0) != key
    assert cache.scene_key(env, 0) == key

    assert "benchbot.core.geometry" in cache.CORE_MODULES
    real_bytes = cache.Path.read_bytes
    geometry = cache.Path(importlib.util.find_spec("benchbot.core.geometry").origin)
    with changed(monkeypatch, cache.Path, "read_bytes",
                 lambda self: real_bytes(self) + b"# changed" if self == geometry else real_bytes(self)):
        assert cache.scene_key(env, 0) != key


@pytest.fixture
def small_pack(tmp_path, monkeypatch):
    """A copy of two models of the shipped pack (one textured) with its manifest, as the only asset pack: the
    manifest's path."""
    import shutil

    from benchbot.packs import assets

    shipped = pytest.importorskip("benchbot_assets_sh3d.plugin").MANIFEST
    data = json.loads(shipped.read_text())
    keep = {"chair__sc_children_chair", "chair__ccby_green_stool"}
    data["assets"] = [a for a in data["assets"] if a["id"] in keep]
    folder = tmp_path / "pack"
    folder.mkdir()
    for a in data["assets"]:
        shutil.copy(shipped.parent / a["file"], folder / a["file"])
    manifest = folder / "manifest.json"
    manifest.write_text(json.dumps(data))
    monkeypatch.setattr(assets, "asset_library",
                        lambda *a, **k: assets.AssetLibrary(assets.load_asset_manifest(manifest)))
    return manifest


def _new_jpeg(decoder):
    return {**decoder, "jpeg": "0.1"}


def _edit_manifest(manifest):
    data = json.loads(manifest.read_text())
    data["assets"][0]["tags"] = [*data["assets"][0].get("tags", []), "changed"]
    manifest.write_text(json.dumps(data))


def _edit_model_in_place(manifest):
    """One byte of a model file changed, its size and modification time kept (only its content tells)."""
    data = json.loads(manifest.read_text())
    glb = manifest.parent / data["assets"][0]["file"]
    st = glb.stat()
    raw = bytearray(glb.read_bytes())
    raw[-1] ^= 0x01
    glb.write_bytes(bytes(raw))
    os.utime(glb, ns=(st.st_atime_ns, st.st_mtime_ns))
    cache._content_digest.cache_clear()  # digests are remembered per (path, size, time) within a process


@pytest.mark.parametrize("component", ["pillow version", "jpeg library", "no pillow", "trimesh version",
                                       "manifest entry", "model bytes"])
def test_the_key_follows_the_image_decoder_and_the_asset_packs(synthetic_env, small_pack, monkeypatch, component):
    """Everything that changes a furnished scene changes its key: Pillow's version, the JPEG library it decodes
    with, Pillow missing (then no scene is built at all: the key must not find one built elsewhere), trimesh's
    version, a field of an asset pack's manifest, and a model file's bytes (its size and time unchanged)."""
    import sys
    from importlib import metadata

    env = {**synthetic_env([("chair", (2.0, 0.5, 0.45), (0.5, 0.5, 0.9))]), "style": "furnished"}
    cache.code_fingerprint.cache_clear()
    key = cache.scene_key(env, 0)
    assert key == cache.scene_key(env, 0) and cache.image_decoder()["pillow"]
    assert {row[0]["id"] for row in cache.assets_fingerprint()} == {"chair__sc_children_chair",
                                                                    "chair__ccby_green_stool"}
    real_version = metadata.version
    if component in ("pillow version", "trimesh version"):
        name = component.split()[0]
        with changed(monkeypatch, metadata, "version",
                     lambda dist: "0.0.1" if dist == name else real_version(dist)):
            assert cache.scene_key(env, 0) != key
    elif component == "jpeg library":
        with changed(monkeypatch, cache, "image_decoder", lambda real=cache.image_decoder: _new_jpeg(real())):
            assert cache.scene_key(env, 0) != key
    elif component == "no pillow":
        with monkeypatch.context() as inside:
            inside.setitem(sys.modules, "PIL", None)  # as where Pillow is not installed: `import PIL` fails
            cache.code_fingerprint.cache_clear()
            assert cache.image_decoder() is None
            assert cache.scene_key(env, 0) != key
    elif component == "manifest entry":
        _edit_manifest(small_pack)
        assert cache.scene_key(env, 0) != key
    else:
        _edit_model_in_place(small_pack)
        assert cache.scene_key(env, 0) != key
    cache.code_fingerprint.cache_clear()
    if component not in ("manifest entry", "model bytes"):
        assert cache.scene_key(env, 0) == key  # the same again once the component is back
