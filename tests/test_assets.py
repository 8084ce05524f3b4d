"""Asset packs (benchbot.packs.assets): manifests validated with one-line errors naming file and field; packs of
several plugins merged into one library indexed by class and kind; a bad pack left out and reported."""

from __future__ import annotations

import json
import types
from pathlib import Path

import pluggy
import pytest

from benchbot.core import hookspecs
from benchbot.packs.assets import AssetInfo, AssetLibrary, asset_library, load_asset_manifest
from benchbot.core.errors import SpecError
from benchbot.core.hookspecs import hookimpl


def entry(asset_id: str, cls: str | None = "chair", kind: str | None = None, role: str = "object") -> dict:
    return {
        "id": asset_id, "file": f"{asset_id}.glb", "class": cls, "kind": kind or cls, "role": role,
        "size_m": [0.5, 0.5, 0.9], "triangles": 12, "textures": [{"width": 64, "height": 64}],
        "library": "test-lib", "model": asset_id, "creator": "someone", "licence": "CC0-1.0",
        "sha256": "0" * 64,
    }


def write_pack(folder: Path, name: str, assets: list[dict]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for a in assets:
        (folder / a["file"]).write_bytes(b"glTF")
    manifest = folder / "manifest.json"
    manifest.write_text(json.dumps({"format": "benchbot_asset_pack", "version": 1, "name": name, "assets": assets}))
    return manifest


def manager(*plugins) -> pluggy.PluginManager:
    pm = pluggy.PluginManager(hookspecs.PROJECT_NAME)
    for cls in hookspecs.HOOK_CLASSES:
        pm.add_hookspecs(cls)
    for i, plugin in enumerate(plugins):
        pm.register(plugin, name=f"pack_plugin_{i}")
    return pm


def plugin_offering(*manifests) -> types.ModuleType:
    mod = types.ModuleType("asset_plugin")
    mod.benchbot_asset_packs = hookimpl(lambda: list(manifests))
    return mod


def test_a_valid_manifest_loads_with_absolute_paths(tmp_path):
    manifest = write_pack(tmp_path / "p", "pack_a", [entry("chair_1"), entry("rug_1", None, "rug", "distractor")])
    assets = load_asset_manifest(manifest)
    assert [a.id for a in assets] == ["chair_1", "rug_1"]
    chair = assets[0]
    assert chair.cls == chair.class_name == "chair" and chair.size_m == (0.5, 0.5, 0.9) and chair.pack == "pack_a"
    assert chair.path == (tmp_path / "p" / "chair_1.glb").resolve() and chair.path.is_file()
    assert assets[1].cls is None and assets[1].kind == "rug"


@pytest.mark.parametrize("mutate, field, words", [
    (lambda a: a.update(size_m=[0.5, -1, 0.9]), "$.assets[1].size_m[1]", "less than or equal to the minimum"),
    (lambda a: a.pop("creator"), "$.assets[1]", "'creator' is a required property"),
    (lambda a: a.update(licence=""), "$.assets[1].licence", "should be non-empty"),
    (lambda a: a.update(file="../outside.glb"), "$.assets[1].file", "does not match"),
    (lambda a: a.update(role="distractor", kind="cabinet"), "$.assets[1].class", "is not of type 'null'"),
    (lambda a: a.update(kind="stool"), "$.assets[1].kind", "an object's kind must be its class"),
    (lambda a: a.update(id="chair_1"), "$.assets[1].id", "duplicate id"),
])
def test_a_bad_manifest_is_one_line_naming_file_and_field(tmp_path, mutate, field, words):
    bad = entry("chair_2")
    mutate(bad)
    bad.setdefault("file", "x.glb")
    manifest = write_pack(tmp_path / "p", "pack_a", [entry("chair_1")] + [bad])
    if "outside" in bad["file"]:
        (tmp_path / "outside.glb").write_bytes(b"glTF")
    with pytest.raises(SpecError) as info:
        load_asset_manifest(manifest)
    message = info.value.message
    assert "\n" not in message and message.startswith(f"{manifest.resolve()}: {field}") and words in message


def test_a_missing_glb_is_named(tmp_path):
    manifest = write_pack(tmp_path / "p", "pack_a", [entry("chair_1")])
    (tmp_path / "p" / "chair_1.glb").unlink()
    with pytest.raises(SpecError, match=r"manifest.json: \$\.assets\[0\]\.file: chair_1.glb does not exist"):
        load_asset_manifest(manifest)


def test_a_manifest_that_is_not_json_is_one_line(tmp_path):
    manifest = tmp_path / "manifest.json"
    manifest.write_text("{not json")
    with pytest.raises(SpecError) as info:
        load_asset_manifest(manifest)
    assert str(manifest) in info.value.message and "\n" not in info.value.message


def test_library_merges_packs_of_several_plugins_by_class_and_kind(tmp_path):
    a = write_pack(tmp_path / "a", "pack_a", [entry("chair_1"), entry("table_1", "table"),
                                              entry("rug_1", None, "rug", "distractor")])
    b = write_pack(tmp_path / "b", "pack_b", [entry("chair_2"), entry("door_1", None, "door", "structure")])
    lib = asset_library(manager(plugin_offering(a), plugin_offering(str(b))))
    assert lib.problems == [] and len(lib) == 5
    assert sorted(x.id for x in lib.by_class("chair")) == ["chair_1", "chair_2"]
    assert {x.pack for x in lib.by_class("chair")} == {"pack_a", "pack_b"}
    assert [x.id for x in lib.by_kind("rug")] == ["rug_1"] and lib.by_kind("rug")[0].cls is None
    assert lib.by_class("rug") == [] and lib.by_class("toaster") == []
    assert lib.get("door_1").role == "structure" and lib.classes() == ["chair", "table"]
    assert lib.kinds() == ["chair", "door", "rug", "table"]
    with pytest.raises(KeyError):
        lib.get("nope")


def test_a_bad_pack_or_a_broken_plugin_is_left_out_and_reported_the_others_load(tmp_path):
    good = write_pack(tmp_path / "good", "good", [entry("chair_1")])
    bad = write_pack(tmp_path / "bad", "bad", [dict(entry("chair_9"), triangles=0)])
    clash = write_pack(tmp_path / "clash", "clash", [entry("chair_1", "table"), entry("bed_1", "bed")])
    broken = types.ModuleType("broken")
    broken.benchbot_asset_packs = hookimpl(lambda: 1 / 0)
    pm = manager(plugin_offering(good), plugin_offering(bad), plugin_offering(clash), broken)
    lib = asset_library(pm)
    assert sorted(a.id for a in lib.all()) == ["bed_1", "chair_1"] and lib.get("chair_1").pack == "good"
    text = "\n".join(lib.problems)
    assert len(lib.problems) == 3, text
    assert "$.assets[0].triangles: 0 is less than the minimum of 1" in text and str(bad.resolve()) in text
    assert "asset id 'chair_1' is already used by pack 'good'" in text
    assert "benchbot_asset_packs() raised ZeroDivisionError" in text
    with pytest.raises(SpecError):
        asset_library(pm, strict=True)


def test_library_refuses_duplicate_ids():
    lib = AssetLibrary()
    assert lib.all() == [] and len(lib) == 0
    a = AssetInfo("x", "x.glb", None, "rug", "distractor", (1, 1, 0.01), 2, (), "l", "m", "c", "CC0-1.0",
                  "0" * 64, Path("/x.glb"), "p")
    with pytest.raises(ValueError, match="two assets have the id 'x'"):
        AssetLibrary([a, a])


def test_the_default_library_comes_from_the_installed_plugins():
    # whatever plugins are enabled in tests, the default library is built from the registry's plugin manager
    lib = asset_library()
    assert isinstance(lib, AssetLibrary) and lib.problems == []
    assert asset_library() is lib  # cached per process
