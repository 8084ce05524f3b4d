"""The ``benchbot`` command, run as a user would (a real process; real simulator, server and OMQ)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def cli(*args: str, cwd: Path | None = None, timeout: float = 300, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, COLUMNS="200", **(env or {})))


def test_list_plugins_json_names_distributions_and_content():
    proc = cli("list", "plugins", "--json")
    assert proc.returncode == 0, proc.stderr
    plugins = {p["name"]: p for p in json.loads(proc.stdout)}
    assert plugins["sim_taichi"]["distribution"] == "benchbot-sim-taichi" and plugins["sim_taichi"]["version"]
    assert "miniroom:1" in plugins["worlds"]["registers"]["environments"]
    assert plugins["worlds"]["distribution"] == "benchbot-worlds"
    assert plugins["eval_omq"]["registers"]["evaluators"] == ["omq"]


@pytest.mark.slow
def test_show_and_unknown_names():
    proc = cli("show", "environments", "miniroom:1")
    assert proc.returncode == 0 and "start_pose" in proc.stdout
    proc = cli("show", "robots", "cartr")
    assert proc.returncode == 3
    assert proc.stderr.strip().splitlines()[0] == "error: no robot named 'cartr'"
    assert "carter" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_run_validates_the_combination():
    proc = cli("run", "--env", "miniroom:1:2")
    assert proc.returncode == 3 and "needs 1 scene(s)" in proc.stderr
    proc = cli("run", "--env", "miniroom:1", "--task", "scd:passive:ground_truth")
    assert proc.returncode == 3 and "needs 2 scene(s)" in proc.stderr


@pytest.mark.slow
def test_run_refuses_bad_tls_files_in_one_line(tmp_path):
    proc = cli("run", "--env", "miniroom:1", "--tls-cert", str(tmp_path / "missing.pem"))
    assert proc.returncode == 2 and proc.stderr.startswith("error: --tls-cert/--tls-key: no file") \
        and "Traceback" not in proc.stderr
    (tmp_path / "not.pem").write_text("not a certificate\n")
    proc = cli("run", "--env", "miniroom:1", "--tls-cert", str(tmp_path / "not.pem"))
    assert proc.returncode == 2 and "not a PEM certificate with its private key" in proc.stderr
    proc = cli("run", "--env", "miniroom:1", "--tls-key", str(tmp_path / "not.pem"))
    assert proc.returncode == 2 and "--tls-key needs --tls-cert" in proc.stderr
    proc = cli("submit", "--native", "true", "--address", "https://127.0.0.1:9/",
               env={"BENCHBOT_CA_FILE": str(tmp_path / "missing.pem")})
    assert proc.returncode == 2 and proc.stderr.startswith("error: BENCHBOT_CA_FILE=") and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_batch_scores_the_ground_truth_example_one(tmp_path):
    proc = cli("batch", "--example", "hello_eval_semantic_slam", "--no-sandbox", "--envs", "miniroom:1,house:1",
               "--camera-size", "64x48", "--output-dir", str(tmp_path), "--json")
    assert proc.returncode == 0, proc.stderr
    outcome = json.loads(proc.stdout)
    run_dir = Path(outcome["run_dir"])
    assert [e["status"] for e in outcome["episodes"]] == ["ok", "ok"]
    scores = json.loads((run_dir / "scores.json").read_text())
    assert scores["scores"]["OMQ"] == 1.0
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["versions"]["benchbot-sim-taichi"]
    assert [e["seed"] for e in manifest["episodes"]] == [0, 1]
    assert sorted(p.name for p in (run_dir / "results").glob("*.json")) == ["000_miniroom_1.json", "001_house_1.json"]


@pytest.mark.slow
def test_repeated_envs_and_robots_add_up(tmp_path):
    """``--envs A --envs B`` runs A and B (before, Typer kept only the last: B alone), and so does ``--robots``."""
    proc = cli("batch", "--example", "hello_passive", "--envs", "miniroom:1", "--envs", "miniroom:4,miniroom:2",
               "--robots", "carter", "--robots", "carter", "--camera-size", "32x24", "--no-evaluate",
               "--output-dir", str(tmp_path), "--json", "--no-tui")
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((Path(json.loads(proc.stdout)["run_dir"]) / "manifest.json").read_text())
    assert [(e["robot"], e["env"]) for e in manifest["episodes"]] == [
        (robot, env) for robot in ("carter", "carter") for env in ("miniroom:1", "miniroom:4", "miniroom:2")]


@pytest.mark.slow
def test_readme_main_job_with_the_baseline(tmp_path):
    """README command 1 (smaller camera so the test stays quick). A whole batch (5-7 s on a 2-core machine): slow,
    as conftest.py defines it; CI runs README command 1 itself just before the fast loop, and this test in -m slow."""
    proc = cli("batch", "--example", "semslam_geometric", "--envs", "miniroom:1", "--camera-size", "320x240",
               "--output-dir", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert "OMQ" in proc.stdout and "miniroom:1" in proc.stdout
    run_dir = next(tmp_path.iterdir())
    omq = json.loads((run_dir / "scores.json").read_text())["scores"]["OMQ"]
    assert 0.0 < omq < 1.0  # an honest baseline: it finds objects, and it is not the ground truth


@pytest.mark.slow
def test_readme_solution_runs_with_the_readmes_batch_native_line(tmp_path):
    """The README's agent, saved as my_solution.py, and its `batch --native` line fit together: every episode
    ends ok with results (before: the line ran it on an active task it cannot do, and it saved nothing)."""
    import shlex

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    (tmp_path / "my_solution.py").write_text(readme.split("```python\n", 1)[1].split("```", 1)[0])
    line = next(l for l in readme.splitlines() if l.startswith('uv run benchbot batch --native "python my_solution.py"'))
    words = shlex.split(line.split("#", 1)[0])[3:]  # after `uv run benchbot`
    proc = cli(*words, "--camera-size", "64x48", "--output-dir", str(tmp_path / "runs"), "--json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    episodes = json.loads(proc.stdout)["episodes"]
    assert len(episodes) == 2 and {e["status"] for e in episodes} == {"ok"}


@pytest.mark.slow
def test_eval_errors_are_one_line(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2")
    proc = cli("eval", str(bad), "-o", str(tmp_path / "s.json"))
    assert proc.returncode == 4
    assert proc.stderr.startswith(f"error: {bad}: not valid JSON")
    assert not (tmp_path / "s.json").exists()


def test_a_comma_list_broken_by_a_space_is_one_line_with_the_fix(tmp_path):
    """``--envs miniroom:1, house:1``: the shell splits the list; one usage line that says how to write it, not
    Typer's box about an extra argument, and nothing started (no run directory)."""
    from benchbot.cli.main import spaced_comma_list

    proc = cli("batch", "--example", "hello_passive", "--envs", "miniroom:1,", "house:1", "--output-dir",
               str(tmp_path / "runs"), timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines() == ["error: --envs 'miniroom:1,' is followed by 'house:1': a comma list is one "
                                        "word, with no spaces",
                                        "hint: write --envs miniroom:1,house:1 (or quote the whole list)"]
    assert not (tmp_path / "runs").exists()
    assert spaced_comma_list(["batch", "--envs", "miniroom:1,house:1", "--workers", "2"]) is None
    assert spaced_comma_list(["batch", "--envs", "miniroom:1,", "--workers", "2"]) is None  # Typer's own business
    assert spaced_comma_list(["batch", "--envs=miniroom:1,", "house:1"]) is None  # one word: Typer reports it
    assert spaced_comma_list(["submit", "--native", "python", "my.py", "--classes", "chair,", "table"]) is None


@pytest.mark.slow
def test_submit_needs_exactly_one_mode():
    proc = cli("submit")
    assert proc.returncode == 2 and "exactly one of --native" in proc.stderr
