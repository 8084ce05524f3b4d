"""A home's variants declare the floor plan they share (environment field ``home_files``), installed through real
content packs: a lone copy of a BEAR variant gets a plan of its own, even with its siblings beside it; declaring the
sibling files gives the shared plan of the built-in home; a bad declaration is refused in one line at install (real
``benchbot install``), when the registry loads a pack edited since, and when the scene is built; the scene cache's
key follows the declared files and no others."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
import yaml

from benchbot.packs import content_packs as cp
from benchbot.core.errors import BackendError
from benchbot.core.registry import Registry
from benchbot.server.redaction import ground_truth_strings, redact
from benchbot_worlds.bear import DATA_DIR, home_files_of
from benchbot_worlds.homes.floorplan import home_files, plan_for_files
from benchbot_sim_taichi import scene_cache as cache
from benchbot_worlds.scene.build import build_scene

sys.path.insert(0, str(Path(__file__).parent))
from cli_in_process import benchbot  # noqa: E402

pytestmark = pytest.mark.usefixtures("data_dir")  # tests/conftest.py: installs go to a fresh data directory
SIBLINGS = [f"../maps/house_{v}.json" for v in range(1, 6)]


def _house_pack(root: Path, **fields) -> Path:
    """A pack holding copies of the five BEAR house variants in ``maps/`` and one environment ``myhouse:2`` whose
    map is the copy of house_2 (plus ``fields``)."""
    (root / "maps").mkdir(parents=True)
    for v in range(1, 6):
        (root / "maps" / f"house_{v}.json").write_text((DATA_DIR / f"house_{v}.json").read_text())
    own = json.loads((DATA_DIR / "house_2.json").read_text())["environment"]
    env = {"name": "myhouse", "variant": 2, "type": "sim_taichi", "map_path": "../maps/house_2.json",
           "start_pose": own["start_pose"], "trajectory_poses": own["trajectory_poses"], **fields}
    (root / "environments").mkdir()
    (root / "environments" / "house_2.yaml").write_text(yaml.safe_dump(env))
    return root


def _installed_env(pack: Path) -> dict:
    """Install ``pack`` as the pack ``p`` (replacing one installed before) and return its environment as the
    registry loads it."""
    cp.install_pack(pack, name="p", force=True, registry=Registry())
    return Registry().get("environments", "myhouse:2")


def _built_in_plan() -> dict:
    return plan_for_files(home_files({"name": "house", "variant": 2, "map_path": str(DATA_DIR / "house_2.json"),
                                      "home_files": home_files_of("house")})).to_dict()


def test_a_lone_copy_has_its_own_plan_and_declared_siblings_share_the_built_in_one(tmp_path):
    lone = _installed_env(_house_pack(tmp_path / "lone"))
    assert "home_files" not in lone and home_files(lone) == [Path(lone["map_path"])]  # its siblings sit beside it
    own = plan_for_files(home_files(lone)).to_dict()
    shared = _built_in_plan()
    assert (len(own["rooms"]), len(shared["rooms"])) == (7, 11)  # docs/simulator.md, A home's variants

    declared = _installed_env(_house_pack(tmp_path / "declared", home_files=SIBLINGS))
    installed_maps = Path(declared["map_path"]).parent
    assert declared["home_files"] == [str(installed_maps / f"house_{v}.json") for v in range(1, 6)]  # resolved
    assert plan_for_files(home_files(declared)).to_dict() == shared


def test_the_cache_key_follows_the_declared_files_only(tmp_path, monkeypatch):
    monkeypatch.setenv("BENCHBOT_SIM_STYLE", "furnished")
    pack = _house_pack(tmp_path / "p", home_files=SIBLINGS[1:3])  # house_2 (its own) and house_3
    env = _installed_env(pack)
    key = cache.scene_key(env)
    maps = Path(env["map_path"]).parent
    undeclared = maps / "house_5.json"
    undeclared.write_text(undeclared.read_text() + "\n")
    assert cache.scene_key(env) == key
    declared = maps / "house_3.json"
    declared.write_text(declared.read_text() + "\n")
    assert cache.scene_key(env) != key


@pytest.mark.parametrize("entry, expected", [
    ("../maps/house_9.json", "environments/house_2.yaml: $.home_files[1]: '../maps/house_9.json' does not exist"),
    ("../../outside.json", "environments/house_2.yaml: $.home_files[1]: '../../outside.json' leaves the pack"),
    ("/etc/hostname", "environments/house_2.yaml: $.home_files[1]: absolute path '/etc/hostname' is not allowed "
                      "in a pack"),
    ("../maps/notes.json", "environments/house_2.yaml: $.home_files[1]: maps/notes.json: not valid JSON (line 1"),
    ("../maps/plain.json", "environments/house_2.yaml: $.home_files[1]: 'maps/plain.json' is not a ground truth: it "
                           "has no ground_truth.objects"),
    ("../maps/a\0.json", "environments/house_2.yaml: $.home_files[1]: '../maps/a\\x00.json' holds a NUL "
                         "character"),
    ("a" * 5000, "environments/house_2.yaml: $.home_files[1]: '" + "a" * 5000 + "' does not exist"),
])
def test_a_bad_declaration_is_refused_by_benchbot_install_in_one_line(tmp_path, entry, expected):
    (tmp_path / "outside.json").write_text((DATA_DIR / "house_1.json").read_text())
    pack = _house_pack(tmp_path / "pack", home_files=[SIBLINGS[0], entry])
    (pack / "maps" / "notes.json").write_text("{not json")
    (pack / "maps" / "plain.json").write_text('{"ground_truth": {}}')
    proc = benchbot("install", str(pack), env={"BENCHBOT_ONLY_PLUGINS": "content_packs,sim_taichi"})
    assert proc.returncode == 3, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if "home_files" in line]
    assert len(lines) == 1 and expected in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr


def test_more_home_files_than_the_schema_allows_are_refused_by_benchbot_install_in_one_line(tmp_path):
    pack = _house_pack(tmp_path / "pack", home_files=[SIBLINGS[0]] * 33)
    proc = benchbot("install", str(pack), env={"BENCHBOT_ONLY_PLUGINS": "content_packs,sim_taichi"})
    assert proc.returncode == 3, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if "$.home_files" in line]
    assert lines == ["  environments/house_2.yaml: $.home_files: 33 items, more than the 32 allowed"], proc.stderr
    assert "Traceback" not in proc.stderr


def test_unusable_paths_and_symlink_loops_are_refused_in_one_line_at_scan(tmp_path):
    """A NUL character in map_path or home_files, and a symlink loop in the pack, are problems of the scan (which
    the registry also runs on every installed pack at load), not a traceback."""
    pack = _house_pack(tmp_path / "p", home_files=["../maps/house_1.json\0"])
    scan = cp.scan_pack(pack)
    assert any("$.home_files[0]: '../maps/house_1.json\\x00' holds a NUL character" in e for e in scan.errors), \
        scan.errors
    spec = yaml.safe_load((pack / "environments" / "house_2.yaml").read_text())
    spec.pop("home_files")
    (pack / "environments" / "house_2.yaml").write_text(yaml.safe_dump({**spec, "map_path": "../maps/x\0.json"}))
    (pack / "maps" / "loop_a").symlink_to("loop_b")
    (pack / "maps" / "loop_b").symlink_to("loop_a")
    scan = cp.scan_pack(pack)
    assert any("$.map_path: '../maps/x\\x00.json' holds a NUL character" in e for e in scan.errors), scan.errors
    assert any(e.startswith("maps/loop_a: symlink to loop_b cannot be resolved") for e in scan.errors), scan.errors


def test_a_pack_edited_after_install_is_refused_at_load_and_at_build(tmp_path, data_dir, monkeypatch):
    monkeypatch.setenv("BENCHBOT_SIM_STYLE", "furnished")
    env = _installed_env(_house_pack(tmp_path / "p", home_files=SIBLINGS[:2]))
    installed = data_dir / "packs" / "p" / "environments" / "house_2.yaml"
    spec = yaml.safe_load(installed.read_text())
    installed.write_text(yaml.safe_dump({**spec, "home_files": ["../../../elsewhere.json"]}))
    reg = Registry()
    assert "myhouse:2" not in reg.names("environments")
    assert any("$.home_files[0]: '../../../elsewhere.json' leaves the pack" in p for p in reg.problems.values()), \
        reg.problems
    Path(env["home_files"][0]).write_text("{not json")  # the registry's copy of the spec from before the edit
    with pytest.raises(BackendError) as exc:
        build_scene(env)
    assert exc.value.message.startswith("environment myhouse:2: home_files: cannot read the ground-truth file ")
    assert "\n" not in exc.value.message


@pytest.mark.parametrize("style", ["furnished", "primitives"])
@pytest.mark.parametrize("text, why", [
    ("[1, 2]", "no ground_truth.objects"),
    ('{"environment": {}, "ground_truth": {"class_list": ["chair"], "objects": [{"class": "chair"}]}}',
     "objects[0]"),
])
def test_a_declared_file_that_is_not_a_ground_truth_is_refused_at_build_in_one_line(tmp_path, style, text, why):
    """An environment that no pack install checked (a plugin's, a file's) declaring a JSON file that is no ground
    truth: a one-line BackendError naming the field, not a traceback from deep in the floor plan."""
    (tmp_path / "other.json").write_text(text)
    env = {"name": "x", "variant": 1, "map_path": str(DATA_DIR / "miniroom_1.json"), "home_files": ["other.json"],
           "style": style, "_file_path": str(tmp_path / "env.yaml")}
    with pytest.raises(BackendError) as exc:
        build_scene(env)
    assert exc.value.message.startswith("environment x:1: home_files: ") and why in exc.value.message
    assert "\n" not in exc.value.message


def test_a_relative_declared_file_is_redacted_where_an_error_names_it_resolved(tmp_path):
    """An environment file's relative home_files entry (``../maps/bad.json``) is opened, and named in errors, as an
    absolute path: the server's redaction and the sandbox's hidden folders take that path too."""
    (tmp_path / "maps").mkdir()
    (tmp_path / "maps" / "bad.json").write_text("{not json")
    env = {"name": "x", "variant": 1, "map_path": str(DATA_DIR / "miniroom_1.json"), "style": "furnished",
           "home_files": ["../maps/bad.json"], "_file_path": str(tmp_path / "envs" / "x.yaml")}
    assert str(tmp_path.resolve() / "maps" / "bad.json") in ground_truth_strings([env])
    with pytest.raises(BackendError) as exc:
        build_scene(env)
    assert "bad.json" in exc.value.message
    assert str(tmp_path.resolve() / "maps") not in redact(exc.value.message, ground_truth_strings([env]))


@pytest.mark.slow
def test_the_built_scene_of_a_declared_pack_home_is_the_built_in_home(tmp_path, monkeypatch):
    """The scene builder reads the declaration: the furnished scene of the pack's house_2 with its siblings declared
    has the built-in house:2's floor plan, walls and furniture, given the same name (a home is seeded by its name:
    benchbot.core.seeding.home_seed)."""
    monkeypatch.setenv("BENCHBOT_SIM_STYLE", "furnished")
    pack_scene = build_scene(_installed_env(_house_pack(tmp_path / "p", home_files=SIBLINGS)))
    built_in = build_scene({**Registry().get("environments", "house:2"), "name": "myhouse"})
    assert pack_scene.plan.to_dict() == built_in.plan.to_dict()
    assert pack_scene.obstacle_names == built_in.obstacle_names
    assert (pack_scene.obstacle_min == built_in.obstacle_min).all() and (pack_scene.tri_v == built_in.tri_v).all()
