"""benchbot report: bootstrap confidence intervals, paired comparisons, the HTML page, clear errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot.batch.plan import new_record, plan_episodes, to_json
from benchbot.batch.report import bootstrap_ci, compare, load_run, render_html


def fake_run(root: Path, name: str, omq_by_env: dict[str, list[float]], robot: str = "carter") -> Path:
    """A run directory as `benchbot batch` writes it (manifest, config, episode_scores)."""
    run = root / name
    run.mkdir()
    rows, i = [], 0
    for env, values in omq_by_env.items():
        for r, v in enumerate(values):
            rows.append({"index": i, "env": env, "robot": robot, "repeat": r, "seed": i,
                         "scores": {"OMQ": v, "avg_pairwise": v, "avg_label": v, "avg_spatial": v, "avg_fp_quality": 1.0}})
            i += 1
    specs = plan_episodes(task="semantic_slam:passive:ground_truth", robots=[robot], envs=list(omq_by_env),
                          repeat=max(map(len, omq_by_env.values())), seed=0, argv=["true"], cwd=str(root),
                          options={}, timeout_s=None)
    records = [new_record(spec) for spec in specs]
    for record in records:
        record.status = "ok"
    (run / "manifest.json").write_text(json.dumps({"task": "semantic_slam:passive:ground_truth", "robots": [robot],
                                                   "environments": list(omq_by_env), "plan": to_json(specs),
                                                   "episodes": to_json(records), "wall_s": 1.0}))
    (run / "config.json").write_text(json.dumps({"environments": {e: [{"lighting": "night" if "2" in e else "base"}] for e in omq_by_env}}))
    (run / "episode_scores.json").write_text(json.dumps(rows))
    return run


def test_bootstrap_ci_brackets_the_mean_and_shrinks_with_data():
    rng = np.random.default_rng(1)
    small, large = rng.normal(0.5, 0.1, 10), rng.normal(0.5, 0.1, 1000)
    m, lo, hi = bootstrap_ci(small)
    assert lo < m < hi
    _, lo2, hi2 = bootstrap_ci(large)
    assert hi2 - lo2 < hi - lo
    assert bootstrap_ci(small) == (m, lo, hi)  # reproducible
    assert bootstrap_ci([0.3]) == (0.3, 0.3, 0.3)


def test_paired_comparison_on_shared_environments(tmp_path):
    a = load_run(fake_run(tmp_path, "a", {"miniroom:1": [0.2], "miniroom:2": [0.3], "house:1": [0.25], "house:9": [0.9]}))
    b = load_run(fake_run(tmp_path, "b", {"miniroom:1": [0.4], "miniroom:2": [0.45], "house:1": [0.5]}))
    c = compare(a, b)
    assert c["environments"] == ["miniroom:1", "miniroom:2", "house:1"]
    assert c["mean_difference"] == pytest.approx((0.2 + 0.15 + 0.25) / 3)
    assert 0 < c["ttest_p"] < 0.05


def test_html_report_and_cli(tmp_path):
    a = fake_run(tmp_path, "a", {"miniroom:1": [0.2, 0.3], "miniroom:2": [0.3, 0.35]})
    b = fake_run(tmp_path, "b", {"miniroom:1": [0.4, 0.5], "miniroom:2": [0.45, 0.5]})
    page = render_html([load_run(a), load_run(b)])
    assert page.count("data:image/png;base64,") == 4 and "Comparison" in page
    out = tmp_path / "report.html"
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "report", str(a), str(b), "-o", str(out), "--json"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    assert summary["runs"][0]["environments"]["miniroom:1"]["mean"] == pytest.approx(0.25)
    assert summary["comparison"]["mean_difference"] == pytest.approx(0.175)
    assert out.read_text().startswith("<!doctype html>")


def test_report_errors(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "report", str(tmp_path)], capture_output=True, text=True)
    assert proc.returncode == 2 and "is not a batch run directory" in proc.stderr
