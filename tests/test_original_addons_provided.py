"""Original add-ons that provide what is already built in (docs/original-benchbot.md, section 3): an unchanged
original add-on's spec that a first-party plugin re-implements is "already provided" and the rest of the add-on
installs; a robot no plugin here can run is listed as unavailable, never put in place of a working one; the
original's two BEAR ground-truth sets, isaac_develop and bear_develop, are both offered and every score says which
one it used.

The add-ons' code is never copied here: packs are hand-written in the original layout, and where a test needs "the
original's code" it registers its own stand-in files as such (``ORIGINAL_FILES``), so the mechanism is what is
tested; the table itself is checked against the byte-for-byte copies of the add-ons' YAML files
(tests/data/original_addons/).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from benchbot.packs import original_addons as oa
from benchbot.core.registry import Registry
from benchbot.core.specs import load_spec_file

ROOT = Path(__file__).resolve().parents[1]
ADDONS = ROOT / "tests" / "data" / "original_addons"


def install(*args: str):
    from benchbot.cli.main import app

    return CliRunner().invoke(app, ["install", *args], env={"COLUMNS": "400"})


def known_as(monkeypatch, addon: str, *files: Path) -> None:
    """Let ``files`` (hand-written stand-ins) count as the original add-on ``addon``'s own files."""
    table = dict(oa.ORIGINAL_FILES)
    for f in files:
        table[oa.git_blob_id(f)] = (addon, f.name)
    monkeypatch.setattr(oa, "ORIGINAL_FILES", table)


def test_the_table_knows_the_original_files_copied_here():
    """Every copied YAML of the add-ons whose specs a plugin re-implements is in ORIGINAL_FILES, under its add-on."""
    for addon, folder in (("formats_object_map", "formats"), ("eval_omq", "evaluation_methods"),
                          ("robots_isaac", "robots")):
        files = sorted((ADDONS / addon / folder).glob("*.yaml"))
        assert files
        for f in files:
            assert oa.ORIGINAL_FILES[oa.git_blob_id(f)] == (addon, f"{folder}/{f.name}"), f
    assert oa.git_blob_id(ADDONS / "tasks_ssu" / "LICENSE.txt") not in oa.ORIGINAL_FILES


def formats_pack(tmp_path: Path) -> Path:
    """formats_object_map as copied (its YAMLs) plus hand-written modules for the functions they name."""
    pack = tmp_path / "formats_object_map"
    shutil.copytree(ADDONS / "formats_object_map", pack)
    for spec in (pack / "formats").glob("*.yaml"):
        module, _, _ = load_spec_file(spec)["functions"]["create"].rpartition(".")
        attrs = {v.rpartition(".")[2] for v in load_spec_file(spec)["functions"].values()}
        (pack / "formats" / f"{module}.py").write_text("".join(f"def {a}(*args):\n    raise SystemExit('pack code "
                                                               f"ran')\n" for a in sorted(attrs)))
    return pack


def test_an_unchanged_formats_addon_is_already_provided_and_needs_no_code(data_dir, tmp_path, monkeypatch):
    pack = formats_pack(tmp_path)
    known_as(monkeypatch, "formats_object_map", *(pack / "formats").glob("*.py"))
    result = install(str(pack))  # no --allow-code: none of its code would ever run
    assert result.exit_code == 0, result.stderr
    assert result.stderr.count("is the original add-on formats_object_map's, unchanged; plugin 'task_semslam' "
                               "provides its re-implementation, which is used") == 3
    assert "(nothing new; already provided: formats: object_map, object_map_ground_truth, object_map_with_states)" \
        in result.stderr
    manifest = json.loads((data_dir / "packs" / "formats_object_map" / ".benchbot-pack.json").read_text())
    assert manifest["code"] == [] and sorted(manifest["built_in"]["formats"]) == [
        "object_map", "object_map_ground_truth", "object_map_with_states"]
    reg = Registry()
    assert {reg.entry("formats", n).plugin for n in manifest["built_in"]["formats"]} == {"task_semslam"}
    assert not reg.problems and not [k for k in reg.notes if k[0] == "formats"]
    reg.functions("formats", "object_map")["create"]()  # task_semslam's: the pack's would exit


def test_a_changed_copy_is_the_user_s_own_and_clashes(data_dir, tmp_path, monkeypatch):
    pack = formats_pack(tmp_path)
    known_as(monkeypatch, "formats_object_map", *(pack / "formats").glob("*.py"))
    module = pack / "formats" / "object_map.py"
    module.write_text(module.read_text() + "# changed\n")
    result = install(str(pack), "--allow-code")
    assert result.exit_code == 3 and "clashes with installed content" in result.stderr
    assert "format 'object_map' is already installed by plugin 'task_semslam'" in result.stderr


def test_an_examples_addon_installs_its_new_examples_beside_the_built_in_ones(data_dir, tmp_path, monkeypatch):
    """examples_base's layout: hello_active (the original's, unchanged) is provided by the built-in of that name;
    hello_benchbot is new and needs --allow-code (it runs from the pack); --override installs the add-on's own."""
    pack = tmp_path / "examples_base"
    for name in ("hello_active", "hello_benchbot"):
        (pack / "examples" / f".{name}").mkdir(parents=True)
        (pack / "examples" / f"{name}.yaml").write_text(
            f"name: {name}\ndescription: the original's {name}\nnative_command: python3 .{name}/{name}\n"
            f"container_directory: .{name}\n")
        (pack / "examples" / f".{name}" / name).write_text(f"print('{name}')\n")
    (pack / "examples" / ".hello_active" / "interactive_agent.py").write_text("AGENT = 'teleop'\n")
    known_as(monkeypatch, "examples_base", pack / "examples" / "hello_active.yaml",
             *(pack / "examples" / ".hello_active").iterdir())
    refused = install(str(pack))
    assert refused.exit_code == 3 and "contains code that BenchBot would run (1 place(s))" in refused.stderr
    assert "hello_benchbot.yaml: example runs 'python3 .hello_benchbot/hello_benchbot'" in refused.stderr
    result = install(str(pack), "--allow-code")
    assert result.exit_code == 0, result.stderr
    assert ("example 'hello_active' is the original add-on examples_base's, unchanged; plugin 'core_examples' "
            "provides its re-implementation, which is used (--override installs the add-on's own instead)") \
        in result.stderr
    assert "(examples: hello_benchbot; already provided: examples: hello_active)" in result.stderr
    reg = Registry()
    assert reg.entry("examples", "hello_active").plugin == "core_examples"
    assert reg.entry("examples", "hello_benchbot").plugin == "content_packs" and not reg.problems
    override = install(str(pack), "--allow-code", "--force", "--override")
    assert override.exit_code == 0 and "override: examples/hello_active.yaml" in override.stderr
    assert Registry().entry("examples", "hello_active").plugin == "content_packs"


# ------------------------------------------------------------------------------------------------ ground-truth sets
def test_both_ground_truth_sets_are_offered_bear_develop_as_the_original_published_it(registry):
    sets = registry.ground_truth_sets()
    assert set(sets) == {"isaac_develop", "bear_develop"}
    for name in ("isaac_develop", "bear_develop"):
        assert sorted(sets[name]) == sorted(f"{e}:{v}" for e in ("miniroom", "house") for v in range(1, 6))
    digest = oa.ground_truth_digest  # the content, "_file_path" (where the original's file was) left out
    original = json.loads((ADDONS / "ground_truths_bear_develop" / "ground_truths" / "miniroom_1.json").read_text())
    assert digest(registry.ground_truth("miniroom:1", "bear_develop")) == digest(original)
    assert digest(registry.ground_truth("miniroom:1", "ground_truths_bear_develop")) == digest(original)
    assert registry.ground_truth("miniroom:1") == registry.ground_truth("miniroom:1", "isaac_develop")
    assert digest(registry.ground_truth("miniroom:1")) != digest(original)
    assert registry.ground_truth_set("miniroom:1") == "isaac_develop"
    four = json.loads((ADDONS / "ground_truths_bear_develop" / "ground_truths" / "miniroom_4.json").read_text())
    assert digest(registry.ground_truth("miniroom:4", "bear_develop")) == digest(four)
    assert digest(four) == digest(registry.ground_truth("miniroom:4"))
    with pytest.raises(Exception, match="no set of ground truths named 'isaac'"):
        registry.ground_truth("miniroom:1", "isaac")


def test_installing_bear_develop_offers_its_files_beside_the_default(data_dir):
    result = install(str(ADDONS / "ground_truths_bear_develop"))
    assert result.exit_code == 0, result.stderr
    assert ("ground_truths/miniroom_1.json: ground truth 'miniroom:1' is offered as ground-truth set 'bear_develop' "
            "beside set 'isaac_develop' of plugin 'worlds', which stays the default (choose with --ground-truths "
            "bear_develop)") in result.stderr
    assert "ground truth 'miniroom:4' is already provided by plugin 'worlds'" in result.stderr
    reg = Registry()
    assert reg.entry("ground_truths", "miniroom:1").plugin == "worlds" and not reg.problems
    chosen = reg.ground_truth_sets()["bear_develop"]["miniroom:1"]
    assert chosen.plugin == "content_packs" and chosen.path.name == "miniroom_1.json"
    assert reg.ground_truth("miniroom:1", "bear_develop")["ground_truth"]["objects"][17]["centroid"] == \
        oa.BEAR_DEVELOP_SINK[1]


def test_each_score_says_which_set_it_used_and_bear_develop_moves_the_sink(registry, tmp_path):
    """The ground truth of miniroom:1 submitted as results: OMQ 1 against isaac_develop (the default), less against
    bear_develop (its sink is elsewhere); the per-result and combined scores, and `benchbot eval`, name the set."""
    from benchbot.core.evaluation import evaluate

    gt = registry.ground_truth("miniroom:1")
    names = gt["ground_truth"]["class_list"]
    objects = [{"label_probs": [float(c == o["class"]) for c in names], "centroid": o["centroid"],
                "extent": o["extent"]} for o in gt["ground_truth"]["objects"]]
    path = tmp_path / "miniroom_1.json"
    path.write_text(json.dumps({"task_details": registry.get("tasks", "semantic_slam:passive:ground_truth"),
                                "environment_details": [registry.get("environments", "miniroom:1")],
                                "results": {"objects": objects, "class_list": names}}))
    default = evaluate([path], "omq", registry)
    bear = evaluate([path], "omq", registry, ground_truth_set="bear_develop")
    assert default.combined["scores"]["OMQ"] == pytest.approx(1.0)
    assert 0.9 < bear.combined["scores"]["OMQ"] < 1.0
    assert default.per_result[0][1]["ground_truth_set"] == default.combined["ground_truth_set"] == "isaac_develop"
    assert bear.per_result[0][1]["ground_truth_set"] == bear.combined["ground_truth_set"] == "bear_develop"
    out = tmp_path / "scores.json"
    from benchbot.cli.main import app

    result = CliRunner().invoke(app, ["eval", str(path), "-o", str(out), "--ground-truths", "ground_truths_bear_develop"],
                                env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.stderr
    assert "ground truths: bear_develop" in result.stderr
    assert json.loads(out.read_text())["ground_truth_set"] == "bear_develop"
    wrong = CliRunner().invoke(app, ["eval", str(path), "--ground-truths", "isaac"], env={"COLUMNS": "200"})
    assert wrong.exit_code == 3 and "no set of ground truths named 'isaac'" in wrong.stderr


@pytest.mark.slow
def test_a_batch_scored_against_bear_develop_says_so_in_its_manifest_and_scores(tmp_path):
    """hello_eval_semantic_slam submits miniroom:1's default (isaac_develop) ground truth; scored against
    bear_develop (--ground-truths) it is not perfect (the sink moved), and the manifest, scores.json and
    episode_scores.json name the set."""
    import os
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--example", "hello_eval_semantic_slam",
                           "--no-sandbox", "--envs", "miniroom:1", "--camera-size", "64x48", "--ground-truths",
                           "bear_develop", "--no-tui", "--json", "--output-dir", str(tmp_path / "runs")],
                          capture_output=True, text=True, timeout=600, env=dict(os.environ, COLUMNS="200"))
    result = json.loads(proc.stdout)
    run_dir = Path(result["run_dir"])
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["ground_truth_set"] == "bear_develop" and manifest["ground_truth_sets"] == {"miniroom:1": "bear_develop"}
    scores = json.loads((run_dir / "scores.json").read_text())
    assert scores["ground_truth_set"] == "bear_develop" and 0.9 < scores["scores"]["OMQ"] < 1.0, scores["scores"]
    episode = json.loads((run_dir / "episode_scores.json").read_text())[0]
    assert episode["ground_truth_set"] == "bear_develop"
    wrong = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--example", "hello_passive", "--envs",
                            "miniroom:1", "--ground-truths", "isaac", "--no-tui", "--output-dir", str(tmp_path / "r2")],
                           capture_output=True, text=True, timeout=300, env=dict(os.environ, COLUMNS="200"))
    assert wrong.returncode == 3 and "no set of ground truths named 'isaac'" in wrong.stderr, wrong.stderr
