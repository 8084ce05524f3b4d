"""What researchers already have carries over: the original add-ons, as they are on disk, through `benchbot install`.

The add-ons are unmodified copies of the original repositories' files (tests/data/original_addons/, see its
ATTRIBUTION.md; the first test checks every file against its git blob id). Each is installed with and without
``--dry-run`` through the real CLI (Typer's runner in this process; two cases in a real process), and both must
exit with the same code and say the same thing:

* tasks_ssu, batches_isaac and ground_truths_isaac_develop are identical in meaning to what the first-party
  plugins ship: "already provided", installed, exit 0;
* robots_isaac's ``carter`` (Isaac Sim, Unreal) cannot run here: sim_taichi's stays, ``--override`` or not, and
  ``carter_remote`` installs listed as unavailable, with the reason;
* envs_isaac_develop and envs_isaac_challenge are a ``.remote`` link: explained (the URL, that nothing is
  downloaded, which installed environments correspond), exit 3, never handed to pip;
* formats_object_map and eval_omq name their own Python functions: refused without their modules, and a clash
  with the first-party formats/evaluator ("differs only in functions") once they have some that are not the
  original's code (with the original's, unchanged, they are already provided: tests/test_original_addons_provided.py).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from benchbot.packs import content_packs as cp
from benchbot.core.registry import Registry
from benchbot.core.specs import load_spec_file, singular
from benchbot.core.spec_meaning import differences, same_meaning

ROOT = Path(__file__).resolve().parents[1]
ADDONS = ROOT / "tests" / "data" / "original_addons"
BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


@pytest.fixture(scope="module")
def app():
    from benchbot.cli.main import app

    return app


def install(app, *args: str):
    """``benchbot install ARGS`` in this process; ``.exit_code``, ``.stderr``."""
    return CliRunner().invoke(app, ["install", *args], env={"COLUMNS": "400"})


def installed(data_dir: Path) -> list[str]:
    packs = data_dir / "packs"
    return sorted(p.name for p in packs.iterdir()) if packs.is_dir() else []


def dry_then_real(app, data_dir: Path, *args: str):
    """Install with ``--dry-run`` (which must change nothing), then for real; both exit with the same code."""
    before = installed(data_dir)
    dry = install(app, *args, "--dry-run")
    assert installed(data_dir) == before, "--dry-run changed the data directory"
    real = install(app, *args)
    assert dry.exit_code == real.exit_code, (dry.stderr, real.stderr)
    for result in (dry, real):
        assert "Traceback" not in result.stderr and "batche " not in result.stderr
        errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
        assert len(errors) == (0 if result.exit_code == 0 else 1), result.stderr
    return dry, real


def blob_id(data: bytes) -> str:
    """Git's id of a file's content (``git hash-object``)."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def test_copies_are_the_original_files_unmodified():
    manifest = json.loads((ADDONS / "MANIFEST.json").read_text())
    listed = set()
    for addon, source in manifest.items():
        assert source["repository"] == f"https://github.com/benchbot-addons/{addon}" and len(source["commit"]) == 40
        for rel, blob in source["files"].items():
            listed.add(f"{addon}/{rel}")
            assert blob_id((ADDONS / addon / rel).read_bytes()) == blob, f"{addon}/{rel} differs from the original"
    on_disk = {p.relative_to(ADDONS).as_posix() for p in ADDONS.rglob("*") if p.is_file()}
    assert on_disk - listed == {"MANIFEST.json", "ATTRIBUTION.md"}
    attribution = (ADDONS / "ATTRIBUTION.md").read_text()
    assert all(f"benchbot-addons/{addon}" in attribution and manifest[addon]["commit"] in attribution for addon in manifest)
    assert "BSD 3-Clause" in attribution and "Queensland University of Technology" in attribution


@pytest.mark.slow
def test_tasks_ssu_is_already_provided_by_task_semslam(app, data_dir):
    dry, real = dry_then_real(app, data_dir, str(ADDONS / "tasks_ssu"))
    assert real.exit_code == 0 and installed(data_dir) == ["tasks_ssu"]
    for result in (dry, real):
        assert result.stderr.count("is already provided by plugin 'task_semslam' (identical in meaning") == 6
        assert "tasks/sslam_pgt.yaml: task 'semantic_slam:passive:ground_truth' is already provided" in result.stderr
        assert ".dependencies lists benchbot-addons/formats_object_map" in result.stderr
    assert "would install content pack 'tasks_ssu'" in dry.stderr and "nothing changed" in dry.stderr
    assert "installed content pack 'tasks_ssu'" in real.stderr
    reg = Registry()
    assert {reg.entries["tasks"][n].plugin for n in reg.names("tasks")} == {"task_semslam"}
    assert not [k for k in reg.problems if k[0] == "tasks"]
    assert len([k for k in reg.notes if k[0] == "tasks"]) == 6
    shown = subprocess.run([sys.executable, "-m", "benchbot.cli", "plugins"], capture_output=True, text=True,
                           env={**os.environ, "BENCHBOT_DATA_DIR": str(data_dir), "COLUMNS": "400"}, timeout=120)
    assert shown.returncode == 0 and shown.stdout.count("note: task '") == 6, shown.stdout[-2000:]
    assert "'semantic_slam:passive:ground_truth' of plugin 'content_packs'" in shown.stdout


def test_batches_isaac_develop_batches_are_the_same_scenes(app, data_dir):
    dry, real = dry_then_real(app, data_dir, str(ADDONS / "batches_isaac"))
    assert real.exit_code == 0
    for result in (dry, real):
        for i in range(1, 7):
            assert f"batches/develop_{i}.yaml: batch 'develop_{i}' is already provided by plugin 'worlds'" in result.stderr
        assert ("batches/challenge_4.yaml: batch 'challenge_4' names environments that are not installed: "
                "office:1..3, apartment:1..3, company:1..3") in result.stderr
    reg = Registry()
    assert reg.entry("batches", "develop_3").plugin == "worlds"
    assert reg.get("batches", "develop_3")["environments"] == ["miniroom:4", "miniroom:5", "house:4", "house:5"]
    assert reg.entry("batches", "challenge_1").plugin == "content_packs"
    assert not [k for k in reg.problems if k[0] == "batches"]


def test_ground_truths_isaac_develop_are_the_shipped_ones(app, data_dir):
    dry, real = dry_then_real(app, data_dir, str(ADDONS / "ground_truths_isaac_develop"))
    assert real.exit_code == 0
    assert "ground_truths/miniroom_1.json: ground truth 'miniroom:1' is already provided by plugin 'worlds'" in dry.stderr
    assert Registry().entry("ground_truths", "miniroom:1").plugin == "worlds"


@pytest.mark.slow
def test_robots_isaac_installs_what_can_run_and_lists_the_rest_as_unavailable(app, data_dir):
    """``carter`` (type sim_unreal) cannot run here: sim_taichi's stays, even with --override; ``carter_remote``
    installs and is listed as unavailable, with the reason."""
    for extra in ([], ["--force", "--override"]):
        dry, real = dry_then_real(app, data_dir, str(ADDONS / "robots_isaac"), *extra)
        assert real.exit_code == 0 and installed(data_dir) == ["robots_isaac"]
        for result in (dry, real):
            assert ("robots/carter.yaml: robot 'carter' cannot run here: its type 'sim_unreal' needs a robot backend "
                    "that no installed plugin provides (types here: ros2, sim_taichi); the one of plugin 'sim_taichi' "
                    "is kept") in result.stderr
            assert "robot 'carter_remote' is unavailable here (benchbot list robots says so)" in result.stderr
            assert "override:" not in result.stderr
        assert "(robots: carter_remote; already provided: robots: carter)" in real.stderr
        reg = Registry()
        assert reg.entry("robots", "carter").plugin == "sim_taichi" and not reg.unavailable_reason("robots", "carter")
        assert reg.entry("robots", "carter_remote").plugin == "content_packs"
        assert "type 'sim_unreal' needs a robot backend" in reg.unavailable_reason("robots", "carter_remote")
        assert not [k for k in reg.problems if k[0] == "robots"] and ("robots", "carter") not in reg.notes
    listed = subprocess.run([*BENCHBOT, "list", "robots", "--json"], capture_output=True, text=True, timeout=120,
                            env={**os.environ, "BENCHBOT_DATA_DIR": str(data_dir)})
    rows = {row["name"]: row for row in json.loads(listed.stdout)}
    assert rows["carter"]["unavailable"] is None and rows["carter"]["plugin"] == "sim_taichi"
    assert rows["carter_remote"]["unavailable"].startswith("type 'sim_unreal' needs a robot backend")
    cp.uninstall_pack("robots_isaac")
    assert "carter_remote" not in Registry().entries["robots"]


def test_envs_isaac_develop_remote_is_explained_never_sent_to_pip(app, data_dir):
    dry, real = dry_then_real(app, data_dir, str(ADDONS / "envs_isaac_develop"))
    assert real.exit_code == 3 and installed(data_dir) == []
    for result in (dry, real):
        assert ("error: add-on 'envs_isaac_develop' keeps its environments in a download (.remote: "
                "https://cloudstor.aarnet.edu.au/plus/s/ZqgsznfVNyxnbxV/download); BenchBot downloads nothing") in result.stderr
        assert "unzip it into environments/ (the 10 BEAR development scenes" in result.stderr
        assert "corresponding here: environments miniroom:1..5, house:1..5 (plugin 'worlds')" in result.stderr
        assert "hint: use the installed environments miniroom:1..5, house:1..5 instead" in result.stderr
        assert "pip" not in result.stderr and "would run" not in result.stderr


def test_envs_isaac_challenge_has_no_counterpart_here(app, data_dir):
    dry, real = dry_then_real(app, data_dir, str(ADDONS / "envs_isaac_challenge"))
    assert real.exit_code == 3
    assert "not available here: environments apartment:1..5, company:1..5, office:1..5" in real.stderr
    assert "hint: no installed environments correspond" in real.stderr


@pytest.mark.slow
def test_the_cli_process_exits_as_in_process(data_dir):
    env = dict(os.environ, COLUMNS="400", BENCHBOT_INSTALLER="pip")
    for addon, code in (("envs_isaac_develop", 3), ("robots_isaac", 0)):
        for extra in (["--dry-run"], []):
            proc = subprocess.run([*BENCHBOT, "install", str(ADDONS / addon), *extra], capture_output=True, text=True,
                                  env=env, timeout=120)
            assert proc.returncode == code, proc.stderr
            assert "Traceback" not in proc.stderr and " -m pip " not in proc.stderr
    assert installed(data_dir) == ["robots_isaac"]


def copy_with_placeholder_modules(addon: str, tmp: Path) -> Path:
    """The add-on's copied files plus a placeholder module (written here, not the original code) for every
    function its specs name."""
    dest = tmp / addon
    shutil.copytree(ADDONS / addon, dest)
    for spec in dest.glob("*/*.yaml"):
        modules: dict[str, set[str]] = {}
        for value in load_spec_file(spec)["functions"].values():
            module, _, attr = value.rpartition(".")
            modules.setdefault(module, set()).add(attr)
        for module, attrs in modules.items():
            (spec.parent / f"{module}.py").write_text("".join(f"def {a}(*args):\n    return {{}}\n" for a in sorted(attrs)))
    return dest


@pytest.mark.slow
def test_formats_and_evaluation_methods_name_their_own_code(app, data_dir, tmp_path):
    for addon, plugin in (("formats_object_map", "task_semslam"), ("eval_omq", "eval_omq")):
        dry, real = dry_then_real(app, data_dir, str(ADDONS / addon))  # as copied: YAML only, no modules
        assert real.exit_code == 3
        assert ("formats/object_map.yaml: $.functions.create: 'object_map.create_empty': no module object_map.py in "
                "formats/ of the pack" if addon == "formats_object_map" else
                "'omq.combine': no module omq.py in evaluation_methods/ of the pack") in real.stderr
        pack = copy_with_placeholder_modules(addon, tmp_path)
        dry, real = dry_then_real(app, data_dir, str(pack))
        assert real.exit_code == 3 and "contains code that BenchBot would run" in real.stderr
        dry, real = dry_then_real(app, data_dir, str(pack), "--allow-code")
        assert real.exit_code == 3
        name = "object_map" if addon == "formats_object_map" else "omq"
        assert f"'{name}' is already installed by plugin '{plugin}'" in real.stderr
        assert ("differs only in functions (the pack's own code, not that of plugin" in real.stderr
                or "differs in functions" in real.stderr), real.stderr  # (an evaluator may also declare scores)
    assert installed(data_dir) == []


def test_dry_run_of_several_packs_checks_each_against_the_ones_before(app, data_dir, tmp_path):
    for name, envs in (("first", "[miniroom:1]"), ("second", "[miniroom:2]")):
        (tmp_path / name / "batches").mkdir(parents=True)
        (tmp_path / name / "batches" / "b.yaml").write_text(f"name: my_batch\nenvironments: {envs}\n")
    dry, real = dry_then_real(app, data_dir, str(tmp_path / "first"), str(tmp_path / "second"))
    assert real.exit_code == 3 and installed(data_dir) == ["first"]
    for result in (dry, real):
        assert "batches/b.yaml: batch 'my_batch' is already installed by pack 'first'" in result.stderr
        assert "differs in environments" in result.stderr


@pytest.mark.slow
def test_a_pack_cannot_override_another_packs_override(app, data_dir, tmp_path):
    """A runnable carter that differs (a slower one) overrides sim_taichi's; an identical copy is then provided by
    that pack; a third carter cannot override the override."""
    carter = load_spec_file(Registry().entry("robots", "carter").path)
    carter.pop("_file_path", None)
    for name, speed in (("slow_robots", 0.5), ("same_robots", 0.5), ("other_robots", 0.25)):
        (tmp_path / name / "robots").mkdir(parents=True)
        (tmp_path / name / "robots" / "carter.yaml").write_text(json.dumps({**carter, "speed_factor": speed}))
    assert install(app, str(tmp_path / "slow_robots"), "--override").exit_code == 0
    dry, real = dry_then_real(app, data_dir, str(tmp_path / "same_robots"), "--override")  # nothing to override
    assert real.exit_code == 0 and "robot 'carter' is already provided by pack 'slow_robots'" in real.stderr
    dry, real = dry_then_real(app, data_dir, str(tmp_path / "other_robots"), "--override")
    assert real.exit_code == 3 and installed(data_dir) == ["same_robots", "slow_robots"]
    assert ("error: pack 'other_robots' would override an override: robots/carter.yaml: robot 'carter' of pack "
            "'slow_robots'") in real.stderr and "is itself an override" in real.stderr


def test_remote_part_missing_from_a_pack_with_specs_is_a_note(app, data_dir, tmp_path):
    pack = tmp_path / "mixed"
    shutil.copytree(ADDONS / "batches_isaac", pack)
    shutil.copy(ADDONS / "envs_isaac_develop" / ".remote", pack / ".remote")
    dry, real = dry_then_real(app, data_dir, str(pack))
    assert real.exit_code == 0
    assert "note: .remote: https://cloudstor.aarnet.edu.au/plus/s/ZqgsznfVNyxnbxV/download would be unzipped into " \
           "environments/; BenchBot downloads nothing" in real.stderr


@pytest.mark.parametrize("text, message", [
    ("", None),
    ("environments\n", "line 1 is 'environments', not 'URL FOLDER'"),
    ("https://example.org/x.zip ../outside\n", "the folder '../outside' is not inside the add-on"),
])
def test_malformed_remote_is_one_line_naming_the_file(app, data_dir, tmp_path, text, message):
    pack = tmp_path / "odd"
    pack.mkdir()
    (pack / ".remote").write_text(text)
    result = install(app, str(pack))
    assert result.exit_code == 3 and "Traceback" not in result.stderr
    if message is None:  # an empty .remote and nothing else: no spec files
        assert "no spec files found" in result.stderr
    else:
        assert f"error: {pack / '.remote'}: {message}" in result.stderr


def test_brackets_in_names_are_printed_not_read_as_markup(app, data_dir, tmp_path):
    pack = tmp_path / "brackets"
    (pack / "tasks").mkdir(parents=True)
    (pack / "tasks" / "[red]t.yaml").write_text("name: t\nactions: 3\nobservations: []\n")
    result = install(app, str(pack))
    assert result.exit_code == 3 and "Traceback" not in result.stderr and "tasks/[red]t.yaml: $.actions" in result.stderr
    odd = tmp_path / "[red]odd"
    odd.mkdir()
    (odd / ".remote").write_text("not-a-url environments\n")
    result = install(app, str(odd))
    assert result.exit_code == 3 and "Traceback" not in result.stderr
    assert f"error: {odd / '.remote'}: line 1 is 'not-a-url environments'" in result.stderr


def test_registry_keeps_one_of_two_identical_specs_and_notes_the_other():
    from benchbot.core.hookspecs import hookimpl

    class Copycat:
        @staticmethod
        @hookimpl
        def benchbot_tasks():
            original = load_spec_file(ADDONS / "tasks_ssu" / "tasks" / "sslam_pgt.yaml")
            changed = {**load_spec_file(ADDONS / "tasks_ssu" / "tasks" / "sslam_agt.yaml"), "scene_count": 2}
            return [original, changed]

    reg = Registry(extra_plugins={"copycat": Copycat})
    assert reg.entry("tasks", "semantic_slam:passive:ground_truth").plugin == "task_semslam"
    assert "identical in meaning" in reg.notes[("tasks", "semantic_slam:passive:ground_truth")]
    assert ("tasks", "semantic_slam:passive:ground_truth") not in reg.problems
    assert "defined twice" in reg.problems[("tasks", "semantic_slam:active:ground_truth")]


def test_identical_in_meaning():
    task = {"name": "t", "actions": ["move_angle", "move_distance"], "observations": ["poses", "laser"],
            "description": "one", "type": "sim_unreal"}
    same = {"observations": ["laser", "poses"], "type": "semantic_slam", "name": "t", "scene_count": 1.0,
            "actions": ["move_distance", "move_angle"], "localisation": "ground_truth", "_file_path": "/x"}
    assert same_meaning("tasks", task, same) and differences("tasks", task, same) == []
    assert differences("tasks", task, {**same, "scene_count": 2, "localisation": "noisy"}) == ["localisation", "scene_count"]
    batch = {"name": "b", "environments": ["house:1", "miniroom:1"]}
    assert differences("batches", batch, {**batch, "environments": ["miniroom:1", "house:1"]}) == ["environments"]
    env = {"name": "e", "variant": 1, "type": "sim_taichi", "map_path": "m", "start_pose": [1, 0, 0, 0, 0, 0, 0.3],
           "robots": ["carter"]}
    assert same_meaning("environments", env, {**env, "variant": "1", "start_pose": [1.0, 0.0, 0, 0, 0, 0, 0.3], "robots": []})
    assert not same_meaning("environments", {**env, "flag": True}, {**env, "flag": 1})
    gt = {"environment": {**env, "_file_path": "/home/x.yaml"}, "format": {"name": "f", "description": "a"},
          "ground_truth": {"objects": []}}
    assert same_meaning("ground_truths", gt, {**gt, "environment": env, "format": {"name": "f"}})


def test_kind_names_are_spelt_right(tmp_path):
    assert [singular(k) for k in ("batches", "tasks", "ground_truths")] == ["batch", "task", "ground truth"]
    pack = tmp_path / "twice"
    (pack / "batches").mkdir(parents=True)
    for name in ("a", "b"):
        (pack / "batches" / f"{name}.yaml").write_text("name: same\nenvironments: [miniroom:1]\n")
    assert cp.scan_pack(pack).errors == ["batches/b.yaml: batch 'same' is also defined by batches/a.yaml"]
    from benchbot.plugins.testing import check_content_plugin

    class Twice:
        @staticmethod
        def benchbot_batches():
            return [{"name": "same", "environments": ["miniroom:1"]}] * 2

    from benchbot.core.hookspecs import hookimpl

    Twice.benchbot_batches = hookimpl(Twice.benchbot_batches)
    with pytest.raises(AssertionError, match="batch 'same' is returned twice"):
        check_content_plugin(Twice, light_import=False)


def test_a_mistyped_path_is_a_usage_error_not_sent_to_pip(app, data_dir, tmp_path):
    missing = str(tmp_path / "tasks_ssuu")
    for target in (missing, "./tasks_ssuu"):
        dry, real = dry_then_real(app, data_dir, target)
        for result in (dry, real):
            assert result.exit_code == 2 and f"error: no such file or folder: {target}" in result.stderr
            assert "would run" not in result.stderr and "running:" not in result.stderr
    dry = install(app, "benchbot-sim-example", "--dry-run")  # a requirement still goes to the installer
    assert dry.exit_code == 0 and "would run:" in dry.stderr and "benchbot-sim-example" in dry.stderr
