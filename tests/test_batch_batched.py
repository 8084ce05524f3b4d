"""The ``batched`` executor of ``benchbot batch``: episodes run together in one process on one simulator (episodes of
one environment sharing its loaded scene), each with its own solution process and API endpoint, and give the results
they give run one by one; Ctrl-C stops every running solution at once."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from benchbot.batch.plan import read_manifest

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
SMALL = ["--camera-size", "64x48"]


def run(*args, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.slow
def test_batched_episodes_give_the_results_of_running_them_one_by_one(tmp_path):
    """semslam_geometric maps what it observes, so equal results files mean equal observations, step by step."""
    outcome = {}
    for name, flags in (("one_by_one", []), ("batched", ["--executor", "batched", "--workers", "3"])):
        proc = run("batch", "--example", "semslam_geometric", "--envs", "miniroom:4,miniroom:1", "--repeat", "2",
                   "--output-dir", str(tmp_path / name), "--json", *SMALL, *flags)
        assert proc.returncode == 0, proc.stderr
        run_dir = Path(json.loads(proc.stdout)["run_dir"])
        manifest = read_manifest(run_dir)  # checked against schemas/batch_manifest.schema.json
        records = manifest["episodes"]
        outcome[name] = {
            "records": [(r["env"], r["repeat"], r["seed"], r["status"], r["steps"], r["collided"]) for r in records],
            "results": [(run_dir / r["results"]).read_bytes() for r in records],
            "trajectories": [(run_dir / "trajectories" / (Path(r["results"]).stem + ".json")).read_bytes()
                             for r in records],
            "scores": json.loads((run_dir / "episode_scores.json").read_text()),
            "executor": (manifest["executor"]["name"], {r["executor"] for r in records}),
        }
    one, batched = outcome["one_by_one"], outcome["batched"]
    assert batched["executor"] == ("batched", {"batched"}) and one["executor"] == ("local", {"local"})
    assert [r[3] for r in one["records"]] == ["ok"] * 4 and [r[4] for r in one["records"]] == [33, 33, 48, 48]
    assert batched["records"] == one["records"]
    assert batched["results"] == one["results"]
    assert batched["trajectories"] == one["trajectories"]
    assert batched["scores"] == one["scores"]
    assert any(json.loads(r)["results"]["objects"] for r in one["results"])  # maps with objects: the comparison means something


@pytest.mark.slow
def test_ctrl_c_stops_every_running_solution_of_a_batched_batch(tmp_path):
    pids = tmp_path / "pids"
    pids.mkdir()
    solution = (f"{sys.executable} -c \"import os, time; open(os.path.join({str(pids)!r}, str(os.getpid())), 'w')"
                ".close(); time.sleep(600)\"")
    batch = subprocess.Popen([*BENCHBOT, "batch", "--native", solution, "--no-sandbox", "--envs", "miniroom:4",
                              "--repeat", "3", "--executor", "batched", "--workers", "3", "--no-tui",
                              "--output-dir", str(tmp_path / "runs"), *SMALL],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 240
    while len(list(pids.iterdir())) < 3 and time.monotonic() < deadline and batch.poll() is None:
        time.sleep(0.2)
    started = sorted(int(p.name) for p in pids.iterdir())
    assert len(started) == 3, batch.stderr.read() if batch.poll() is not None else "the solutions did not start"
    t0 = time.monotonic()
    os.killpg(batch.pid, signal.SIGINT)  # what Ctrl-C in a terminal does to the foreground group
    _, stderr = batch.communicate(timeout=60)
    assert batch.returncode == 130, stderr
    assert time.monotonic() - t0 < 30, "stopping took too long"
    assert "Traceback" not in stderr, stderr
    for pid in started:  # every solution was stopped (each runs in a process group of its own)
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_recording_with_concurrent_batched_episodes_is_a_usage_error():
    """Each episode's MCAP recorder is a plugin of the process's one plugin manager: batched episodes running
    together would each record the others' steps, and the first to end would finish the others' files. run_batch
    refuses the combination before any episode runs."""
    from types import SimpleNamespace

    from benchbot.batch.runner import run_batch
    from benchbot.core.errors import UsageError

    batch = SimpleNamespace(specs=[SimpleNamespace(record=False), SimpleNamespace(record=True)])
    with pytest.raises(UsageError, match="--record cannot be used with --executor batched"):
        run_batch(None, batch, executor="batched", workers=2)


def test_run_batched_runs_episodes_of_one_world_together_and_takes_its_thread_variables_back(monkeypatch):
    """With a stand-in for run_episode: episodes of one world start next to each other, up to ``workers`` at once,
    every record says ``batched``, and the thread-count variables it set for the solutions are gone afterwards."""
    import threading

    from benchbot.batch import executors
    from benchbot.batch.plan import new_record, plan_episodes

    specs = plan_episodes(task="t", robots=["carter"], envs=["house:1", "miniroom:1"], repeat=3, seed=0,
                          argv=["x"], cwd=".", options={}, timeout_s=None)
    order = [0, 3, 1, 4, 2, 5]  # interleaved worlds, as longest-first can hand them over
    started, running, most = [], [0], [0]
    lock = threading.Lock()
    for name in executors.THREAD_VARIABLES[1:]:
        monkeypatch.delenv(name, raising=False)
    seen_env = []

    def fake_run_episode(spec, run, run_dir, events):
        with lock:
            started.append(spec.env)
            running[0] += 1
            most[0] = max(most[0], running[0])
            seen_env.append(os.environ.get("OMP_NUM_THREADS"))
        time.sleep(0.05)
        with lock:
            running[0] -= 1
        record = new_record(spec)
        record.status = "ok"
        return record

    monkeypatch.setattr(executors, "run_episode", fake_run_episode)
    records = []
    executors.run_batched([(specs[i], None) for i in order], "/nonexistent", workers=2,
                          on_event=lambda *a: None, on_record=records.append)
    grouped = executors.world_order([(specs[i], None) for i in order])
    assert [spec.env for spec, _ in grouped] == ["house:1"] * 3 + ["miniroom:1"] * 3
    assert [spec.repeat for spec, _ in grouped] == [0, 1, 2, 0, 1, 2]
    assert sorted(started) == ["house:1"] * 3 + ["miniroom:1"] * 3
    assert most[0] == 2 and len(records) == 6 and {r.executor for r in records} == {"batched"}
    assert set(seen_env) == {str(max(1, (os.cpu_count() or 1) // 2))}
    assert all(name not in os.environ for name in executors.THREAD_VARIABLES[1:])
