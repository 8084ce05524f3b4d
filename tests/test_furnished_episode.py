"""README's main job on the default scene style: ``benchbot batch --example semslam_geometric --envs miniroom:1``
runs on the furnished home (the test suite's conftest sets ``BENCHBOT_SIM_STYLE=primitives``; here it is unset),
and ``BENCHBOT_SIM_STYLE`` reaches the batch's episodes; both scores are README's figures (pinned here)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

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


#: README's figures for its command 1 (the table "Figures"): OMQ of ``semslam_geometric`` on miniroom:1.
README_OMQ = {"furnished": 0.0979, "primitives": 0.139}
#: Why a tolerance at all: the images are rendered in float32 by Taichi's CPU backend, whose vectorised code may
#: round differently on another CPU; a few depth pixels that differ move the baseline's boxes by millimetres, i.e.
#: OMQ by a few 1e-4 (runs on this project's machines agree to all four printed digits). Anything beyond 0.005 is
#: a change of the simulator or the baseline: update README's figure with it.
README_OMQ_TOLERANCE = 0.005


@pytest.mark.slow
def test_main_job_runs_on_the_furnished_default_and_the_style_variable_reaches_episodes(tmp_path):
    furnished = run_main_job(tmp_path / "furnished", None)
    primitives = run_main_job(tmp_path / "primitives", "primitives")
    for style, scores in (("furnished", furnished), ("primitives", primitives)):
        assert scores["avg_pairwise"] > 0.1, scores  # the geometric example maps objects in either style
        assert abs(scores["OMQ"] - README_OMQ[style]) < README_OMQ_TOLERANCE, (style, scores["OMQ"], README_OMQ)
