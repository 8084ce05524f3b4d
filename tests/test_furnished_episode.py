"""README's main job on the default scene style: ``benchbot batch --example semslam_geometric --envs miniroom:1``
runs on the furnished home (the test suite's conftest sets ``BENCHBOT_SIM_STYLE=primitives``; here it is unset),
and ``BENCHBOT_SIM_STYLE`` reaches the batch's episodes (the same batch in the primitives style scores otherwise)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def run_main_job(out: Path, style: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "BENCHBOT_SIM_STYLE"}
    if style is not None:
        env["BENCHBOT_SIM_STYLE"] = style
    proc = subprocess.run([*BENCHBOT, "batch", "--example", "semslam_geometric", "--envs", "miniroom:1",
                           "--output-dir", str(out)], capture_output=True, text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run_dir,) = [p for p in out.iterdir() if p.is_dir()]
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert [e["status"] for e in manifest["episodes"]] == ["ok"] and not manifest["episodes"][0]["collided"]
    return json.loads((run_dir / "scores.json").read_text())["scores"]


def test_main_job_runs_on_the_furnished_default_and_the_style_variable_reaches_episodes(tmp_path):
    furnished = run_main_job(tmp_path / "furnished", None)
    primitives = run_main_job(tmp_path / "primitives", "primitives")
    for scores in (furnished, primitives):  # the geometric example maps objects in either style
        assert 0.05 < scores["OMQ"] < 1.0 and scores["avg_pairwise"] > 0.1, scores
    # the example sees different images: its maps, hence its scores, differ (each style alone is deterministic)
    assert furnished["OMQ"] != primitives["OMQ"], (furnished, primitives)
