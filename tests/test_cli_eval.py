"""``benchbot eval`` and ``benchbot gt`` run as a user would (a real process, the real registry and OMQ): scoring,
options, and every error path."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_evaluation import original_results_file, perfect_results, scd_results  # noqa: E402

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], cwd=cwd, capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, COLUMNS="200"))  # fmt: skip


def write(path: Path, data) -> str:
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return str(path)


@pytest.fixture
def files(registry, tmp_path):
    """good (miniroom:1, perfect), bad (house:1, objects[3].extent of 2 numbers), broken JSON, other task."""
    bad = perfect_results(registry, "house:1")
    bad["results"]["objects"][3]["extent"] = [1, 2]
    return {
        "good": write(tmp_path / "good.json", perfect_results(registry, "miniroom:1")),
        "bad": write(tmp_path / "bad.json", bad),
        "broken": write(tmp_path / "broken.json", '{"task_details": '),
        "other_task": write(tmp_path / "other.json",
                            perfect_results(registry, "miniroom:2", task="semantic_slam:active:ground_truth")),
    }  # fmt: skip


@pytest.mark.slow
def test_eval_original_file_table_json_and_scores_file(registry, tmp_path):
    orig = write(tmp_path / "orig.json", original_results_file(registry))
    proc = cli("eval", orig, "-o", str(tmp_path / "s.json"))
    assert proc.returncode == 0, proc.stderr
    assert "miniroom:1" in proc.stdout and "1.0000" in proc.stdout
    assert json.loads((tmp_path / "s.json").read_text())["scores"]["OMQ"] == 1.0
    proc = cli("eval", orig, "-o", str(tmp_path / "s2.json"), "--json", "--per-class", "--combine", "pooled",
               "--method", "omq", "--required-task", "semantic_slam:passive:ground_truth")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["combine"] == "pooled" and report["errors"] == [] and report["missing"] == []
    assert report["per_result"][0]["per_class"]["chair"]["scores"]["OMQ"] == 1.0
    scores = json.loads((tmp_path / "s2.json").read_text())
    assert scores["combine"] == "pooled" and scores["per_class"]["table"]["scores"]["OMQ"] == 1.0


@pytest.mark.slow
def test_eval_mixed_good_and_bad_files_scores_the_good_and_exits_4(files, tmp_path):
    out = tmp_path / "scores.json"
    proc = cli("eval", files["good"], files["bad"], "--required-envs", "miniroom:1,house:1", "-o", str(out))
    assert proc.returncode == 4
    assert f"error: {files['bad']}: results.objects[3].extent: expected 3 numbers, got 2" in proc.stderr.splitlines()
    assert "Traceback" not in proc.stderr
    assert "miniroom:1" in proc.stdout and "missing" in proc.stderr and "house:1" in proc.stderr
    scores = json.loads(out.read_text())
    assert scores["scores"]["OMQ"] == pytest.approx(0.5)  # bad counts as missing: 0
    assert "good.json" in proc.stdout or "miniroom:1" in proc.stdout


@pytest.mark.slow
def test_eval_error_paths(files, tmp_path):
    out = str(tmp_path / "s.json")
    cases = [
        (("eval", str(tmp_path / "nope.json"), "-o", out), 4, "no such results file"),
        (("eval", files["broken"], "-o", out), 4, f"error: {files['broken']}: not valid JSON"),
        (("eval", files["bad"], "-o", out), 4, "objects[3].extent: expected 3 numbers, got 2"),
        (("eval", files["good"], "-m", "mq", "-o", out), 3, "no evaluator named 'mq'"),
        (("eval", files["good"], "--required-task", "semantic_slam:flying", "-o", out), 3, "no task named"),
        (("eval", files["good"], "--required-envs-batch", "develop_99", "-o", out), 3, "no batch named 'develop_99'"),
        (("eval", files["good"], "--required-envs", "miniroom:1", "--required-envs-batch", "develop_1", "-o", out),
         2, "at most one of --required-envs and --required-envs-batch"),
        (("eval", files["good"], files["other_task"], "-o", out), 4, "results name several tasks"),
        (("eval", files["good"], "--combine", "median", "-o", out), 2, "--combine 'median'"),
    ]
    for args, code, text in cases:
        proc = cli(*args)
        assert proc.returncode == code, (args, proc.stderr)
        assert text in proc.stderr, (args, proc.stderr)
        assert proc.stderr.startswith("error: ") and "Traceback" not in proc.stderr, proc.stderr
    assert not Path(out).exists()  # nothing was scored


@pytest.mark.slow
def test_eval_validate_only_zip_and_batch(registry, files, tmp_path):
    archive = tmp_path / "batch.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.write(files["good"], "batch_0.json")
        z.writestr("batch_1.json", json.dumps(perfect_results(registry, "house:1")))
        z.writestr("submission.json", "{}")
    proc = cli("eval", "-V", str(archive))
    assert proc.returncode == 0, proc.stderr
    assert [line.split(":")[-1] for line in proc.stderr.splitlines() if line.startswith("valid ")] == [
        "batch_0.json", "batch_1.json"]
    proc = cli("eval", "--validate-only", files["good"], files["bad"])
    assert proc.returncode == 4 and "objects[3].extent" in proc.stderr
    assert f"valid {files['good']}" in proc.stderr.splitlines()
    out = tmp_path / "s.json"
    proc = cli("eval", str(archive), "--required-envs-batch", "develop_1", "-o", str(out), "--combine", "pooled")
    assert proc.returncode == 0, proc.stderr
    scores = json.loads(out.read_text())
    assert 0.0 < scores["scores"]["OMQ"] < 1.0 and scores["scores"]["FN"] > 0  # miniroom:3, house:3 missing
    assert sum(line.startswith("missing ") for line in proc.stderr.splitlines()) == 2


@pytest.mark.slow
def test_eval_scd_and_per_class_table(registry, tmp_path):
    path = write(tmp_path / "scd.json", scd_results(registry, "miniroom:1:2"))
    proc = cli("eval", path, "--per-class", "-o", str(tmp_path / "s.json"))
    assert proc.returncode == 0, proc.stderr
    assert "miniroom:1:2" in proc.stdout and "state" in proc.stdout and "per class" in proc.stdout
    assert json.loads((tmp_path / "s.json").read_text())["scores"]["avg_state_quality"] == pytest.approx(1.0)


@pytest.mark.slow
def test_gt_command(registry, tmp_path):
    proc = cli("gt", "miniroom:1")
    assert proc.returncode == 0, proc.stderr
    gt = json.loads(proc.stdout)
    assert gt == {k: registry.ground_truth("miniroom:1")["ground_truth"][k] for k in ("objects", "class_list", "synonyms")}
    out = tmp_path / "gt.json"
    proc = cli("gt", "house:1", "-o", str(out))
    assert proc.returncode == 0 and len(json.loads(out.read_text())["objects"]) == 56
    for env, text in (("miniroom:9", "no environment named"), ("miniroom:1:2", "one scene"), ("miniroom", "NAME:VARIANT")):
        proc = cli("gt", env)
        assert proc.returncode == 3 and text in proc.stderr, proc.stderr


@pytest.mark.slow
def test_gt_command_writes_the_original_layout(registry, tmp_path):
    """--layout original: the original's ground-truth file {environment, format, ground_truth}, valid as a ground
    truth spec (the layout of a content pack's ground_truths/ files)."""
    from benchbot.core.specs import validate

    out = tmp_path / "miniroom_1.json"
    proc = cli("gt", "miniroom:1", "--layout", "original", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    data = json.loads(out.read_text())
    registered = registry.ground_truth("miniroom:1")
    assert list(data) == ["environment", "format", "ground_truth"]
    assert data == {k: registered[k] for k in data}
    assert data["environment"]["name"] == "miniroom" and data["format"]["name"] == "object_map_ground_truth"
    assert len(data["ground_truth"]["objects"]) == 18 and validate(data, "ground_truth", str(out)) is None
    proc = cli("gt", "miniroom:1", "--layout", "full")
    assert proc.returncode == 2 and "--layout 'full'" in proc.stderr, proc.stderr
