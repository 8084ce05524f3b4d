"""Batches: plans and seeds, parallel workers, failures and retries, kill-and-resume without redoing work."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from benchbot.batch.plan import plan_episodes
from benchbot.core.errors import UsageError

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
SMALL = ["--camera-size", "64x48"]


def cli(*args, timeout=300):
    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=timeout)


def manifest(run_dir: Path) -> dict:
    return json.loads((run_dir / "manifest.json").read_text())


def test_plan_gives_each_episode_a_recorded_seed():
    specs = plan_episodes(task="t", robots=["a", "b"], envs=["miniroom:1", "house:1"], repeat=2, seed=10,
                          argv=["x"], cwd=".", options={}, timeout_s=None)
    assert len(specs) == 8 and [s.seed for s in specs] == list(range(10, 18))
    assert (specs[3].robot, specs[3].env, specs[3].repeat) == ("a", "house:1", 1)
    assert len({s.results for s in specs}) == 8
    with pytest.raises(UsageError):
        plan_episodes(task="t", robots=["a"], envs=["e:1"], repeat=0, seed=0, argv=["x"], cwd=".", options={}, timeout_s=None)


@pytest.mark.slow
def test_repeats_on_two_workers(tmp_path):
    proc = cli("batch", "--example", "hello_eval_semantic_slam", "--no-sandbox", "--envs", "miniroom:1", "--repeat", "2",
               "--workers", "2", "--output-dir", str(tmp_path), "--json", "--zip", *SMALL)
    assert proc.returncode == 0, proc.stderr
    run_dir = Path(json.loads(proc.stdout)["run_dir"])
    records = manifest(run_dir)["episodes"]
    assert [(r["status"], r["repeat"], r["seed"]) for r in records] == [("ok", 0, 0), ("ok", 1, 1)]
    per_episode = json.loads((run_dir / "episode_scores.json").read_text())
    assert [e["scores"]["OMQ"] for e in per_episode] == [1.0, 1.0]
    assert (run_dir / "batch.zip").is_file()


@pytest.mark.slow
def test_failing_solution_is_reported_and_retried(tmp_path):
    proc = cli("batch", "--native", f"{sys.executable} -c 'import sys; sys.exit(3)'", "--envs", "miniroom:1",
               "--retries", "1", "--output-dir", str(tmp_path), *SMALL)
    assert proc.returncode == 1
    run_dir = next(tmp_path.iterdir())
    record = manifest(run_dir)["episodes"][0]
    assert (record["status"], record["returncode"], record["attempts"]) == ("failed", 3, 2)
    assert "miniroom:1: failed (exit status 3)" in proc.stderr


def _fake_executor(handed: list):
    """A ``run_local`` that runs nothing: it keeps what it is handed and fails every episode."""
    from benchbot.batch.plan import new_record

    def run_local(episodes, run_dir, *, workers, on_event, on_record, service=False):
        for spec, run in episodes:
            handed.append((spec, run))
            record = new_record(spec)
            record.status = "failed"
            on_record(record)

    return run_local


def test_each_combination_is_resolved_once_and_its_episodes_get_that_run_spec(tmp_path, monkeypatch):
    import pickle

    from benchbot.batch import runner
    from benchbot.core.registry import get_registry

    resolved, real = [], runner.resolve_run
    monkeypatch.setattr(runner, "resolve_run", lambda reg, *names: resolved.append(names) or real(reg, *names))
    handed: list = []
    monkeypatch.setattr(runner, "run_local", _fake_executor(handed))
    specs = plan_episodes(task="semantic_slam:passive:ground_truth", robots=["carter"], envs=["miniroom:1", "house:1"],
                          repeat=2, seed=0, argv=["x"], cwd=str(tmp_path), options={}, timeout_s=None)
    batch = runner.prepare_batch(get_registry(), run_dir=tmp_path, specs=specs, evaluate_with=None, prefix="batch",
                                 zip_results=False)
    outcome = runner.run_batch(get_registry(), batch)
    assert sorted(resolved) == [("semantic_slam:passive:ground_truth", "carter", env) for env in ("house:1", "miniroom:1")]
    assert [spec.index for spec, _ in handed] == [0, 1, 2, 3]
    assert all(run is batch.runs[(spec.robot, spec.env)] and run.env_string == spec.env for spec, run in handed)
    assert pickle.loads(pickle.dumps(handed[0][1])) == handed[0][1]  # it travels to worker processes and Ray as is
    assert [e.status for e in outcome.episodes] == ["failed"] * 4


def test_a_resumed_combination_that_no_longer_resolves_fails_only_its_episodes(tmp_path, monkeypatch):
    from benchbot.batch import runner
    from benchbot.core.errors import SpecError
    from benchbot.core.registry import get_registry

    specs = plan_episodes(task="semantic_slam:passive:ground_truth", robots=["carter"], envs=["miniroom:1", "house:1"],
                          repeat=1, seed=0, argv=["x"], cwd=str(tmp_path), options={}, timeout_s=None)
    runner.prepare_batch(get_registry(), run_dir=tmp_path, specs=specs, evaluate_with=None, prefix="batch",
                         zip_results=False)
    real = runner.resolve_run

    def resolve_run(reg, task, robot, env):
        if env == "house:1":
            raise SpecError("no environment named 'house:1'", "")
        return real(reg, task, robot, env)

    monkeypatch.setattr(runner, "resolve_run", resolve_run)
    handed: list = []
    monkeypatch.setattr(runner, "run_local", _fake_executor(handed))
    batch = runner.load_batch(get_registry(), tmp_path)
    assert list(batch.runs) == [("carter", "miniroom:1")] and list(batch.unresolved) == [("carter", "house:1")]
    outcome = runner.run_batch(get_registry(), batch, retries=1)
    assert [spec.env for spec, _ in handed] == ["miniroom:1", "miniroom:1"]
    house = outcome.episodes[1]
    assert (house.status, house.error, house.attempts) == ("error", "no environment named 'house:1'", 2)
    assert manifest(tmp_path)["episodes"][1]["status"] == "error"


@pytest.mark.slow
def test_killed_batch_resumes_without_redoing_finished_episodes(tmp_path):
    args = [*BENCHBOT, "batch", "--example", "hello_passive", "--envs", "miniroom:4,miniroom:1,house:1",
            "--output-dir", str(tmp_path), *SMALL]
    child = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + 240
    run_dir = None
    while time.monotonic() < deadline:  # wait until the first episode is recorded as done
        dirs = list(tmp_path.iterdir())
        if dirs and (dirs[0] / "manifest.json").is_file():
            run_dir = dirs[0]
            if manifest(run_dir)["episodes"][0]["status"] == "ok":
                break
        time.sleep(0.2)
    os.killpg(child.pid, signal.SIGKILL)
    child.wait()
    first = manifest(run_dir)["episodes"]
    assert first[0]["status"] == "ok" and first[2]["status"] != "ok"
    results_0 = (run_dir / first[0]["results"]).read_bytes()
    proc = cli("batch", "--resume", str(run_dir))
    assert proc.returncode == 0, proc.stderr
    after = manifest(run_dir)["episodes"]
    assert [e["status"] for e in after] == ["ok", "ok", "ok"]
    assert after[0]["attempts"] == 1  # not redone
    assert (run_dir / after[0]["results"]).read_bytes() == results_0
    assert json.loads((run_dir / "scores.json").read_text())["scores"]["OMQ"] == 0.0  # empty maps


def test_resume_needs_a_run_directory(tmp_path):
    proc = cli("batch", "--resume", str(tmp_path))
    assert proc.returncode == 2 and "is not a batch run directory" in proc.stderr


@pytest.mark.slow
def test_ray_executor_gives_the_same_results_as_local(tmp_path):
    outcomes = {}
    for executor in ("local", "ray"):
        out = tmp_path / executor
        proc = cli("batch", "--example", "hello_passive", "--envs", "miniroom:4,miniroom:1", "--executor", executor,
                   "--workers", "2", "--output-dir", str(out), "--json", *SMALL, timeout=600)
        assert proc.returncode == 0, proc.stderr
        run_dir = Path(json.loads(proc.stdout)["run_dir"])
        records = manifest(run_dir)["episodes"]
        outcomes[executor] = [(r["env"], r["seed"], r["status"], r["steps"], r["collided"]) for r in records]
        outcomes[executor + "_results"] = [(run_dir / r["results"]).read_text() for r in records]
    assert outcomes["local"] == outcomes["ray"]
    assert outcomes["local"][0][3] == 33  # the whole miniroom:4 trajectory
    assert outcomes["local_results"] == outcomes["ray_results"]


@pytest.mark.slow
def test_containerised_batch_needs_a_dockerfile_and_an_engine(tmp_path):
    proc = cli("batch", "--containerised", str(tmp_path), "--envs", "miniroom:1")
    assert proc.returncode == 2 and "no Dockerfile at" in proc.stderr
    (tmp_path / "Dockerfile").write_text("FROM python:3.11-slim\n")
    (tmp_path / "bin").mkdir()  # engines hidden from PATH
    proc = subprocess.run([*BENCHBOT, "batch", "--containerised", str(tmp_path), "--envs", "miniroom:1"],
                          capture_output=True, text=True, timeout=300, env=dict(os.environ, PATH=str(tmp_path / "bin")))
    assert proc.returncode == 2 and proc.stderr.startswith("error: ") and "neither is installed" in proc.stderr


@pytest.mark.slow
def test_containerised_batch_runs_a_container(tmp_path, container_engine_with_base_image):
    _, base_image = container_engine_with_base_image
    (tmp_path / "Dockerfile").write_text(
        f"FROM {base_image}\nCMD [\"python3\", \"-c\", \"open('/tmp/benchbot_result', 'w').write('{{}}')\"]\n")
    proc = cli("batch", "--containerised", str(tmp_path), "--envs", "miniroom:1", "--no-evaluate",
               "--output-dir", str(tmp_path / "runs"), *SMALL, timeout=900)
    assert proc.returncode == 0, proc.stderr


def test_parallel_workers_start_the_longest_episodes_first():
    from benchbot.batch.runner import longest_first
    from benchbot.core.registry import get_registry

    specs = plan_episodes(task="semantic_slam:passive:ground_truth", robots=["carter"],
                          envs=["miniroom:1", "house:1", "miniroom:3", "nowhere:1"], repeat=1, seed=0, argv=["x"],
                          cwd=".", options={}, timeout_s=None)
    order = [s.env for s in longest_first(specs, get_registry())]
    assert order == ["house:1", "miniroom:3", "miniroom:1", "nowhere:1"]  # 269, 56, 48 poses; unknown last


def test_expected_steps_are_the_trajectory_poses_of_a_passive_task():
    from benchbot.batch.plan import expected_steps, trajectory_length
    from benchbot.core.registry import get_registry

    registry = get_registry()
    passive, active = (registry.get("tasks", f"scd:{c}:ground_truth") for c in ("passive", "active"))
    pair = registry.scenes("miniroom:1:2")
    assert trajectory_length(pair) == sum(len(s["trajectory_poses"]) for s in pair) > 48
    assert expected_steps(passive, pair) == trajectory_length(pair) and expected_steps(active, pair) is None
    assert trajectory_length([{"name": "empty"}]) == 0


@pytest.mark.slow
def test_parallel_workers_share_the_cores(tmp_path):
    """Each of N workers caps its simulator threads and its solutions' BLAS/OpenMP threads at cores / N."""
    report = ("import os; print('threads', os.environ.get('BENCHBOT_TAICHI_THREADS'), "
              "os.environ.get('OMP_NUM_THREADS'), os.environ.get('OPENBLAS_NUM_THREADS'))")
    env = {k: v for k, v in os.environ.items() if k not in ("BENCHBOT_TAICHI_THREADS", "OMP_NUM_THREADS",
                                                           "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
    proc = subprocess.run([*BENCHBOT, "batch", "--native", f"{sys.executable} -c \"{report}\"", "--envs",
                           "miniroom:1,miniroom:2", "--workers", "2", "--output-dir", str(tmp_path), *SMALL],
                          capture_output=True, text=True, timeout=300, env=env)
    run_dir = next(tmp_path.iterdir())
    share = str(max(1, (os.cpu_count() or 1) // 2))
    for record in manifest(run_dir)["episodes"]:
        log = (run_dir / record["log"]).read_text()
        assert f"threads {share} {share} {share}" in log, (log, proc.stderr)


@pytest.mark.slow
def test_one_episode_at_a_time_leaves_the_solutions_threads_as_the_user_has_them(tmp_path):
    """Through the path a GPU batch takes with the service (episodes in threads of the batch process, here the
    ``batched`` executor's): one episode at a time, a solution's BLAS/OpenMP variables are left unset, so its own
    default applies (the example takes one BLAS thread); two at a time, each gets cores / 2."""
    report = ("import os; print('threads', os.environ.get('OMP_NUM_THREADS'), "
              "os.environ.get('OPENBLAS_NUM_THREADS'), os.environ.get('MKL_NUM_THREADS'))")
    env = {k: v for k, v in os.environ.items() if k not in ("BENCHBOT_TAICHI_THREADS", "OMP_NUM_THREADS",
                                                           "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
    share = str(max(1, (os.cpu_count() or 1) // 2))
    for workers, expected in (("1", "threads None None None"), ("2", f"threads {share} {share} {share}")):
        out = tmp_path / workers
        proc = subprocess.run([*BENCHBOT, "batch", "--native", f"{sys.executable} -c \"{report}\"", "--envs",
                               "miniroom:1,miniroom:2", "--executor", "batched", "--workers", workers,
                               "--output-dir", str(out), *SMALL], capture_output=True, text=True, timeout=300, env=env)
        run_dir = next(out.iterdir())
        for record in manifest(run_dir)["episodes"]:
            log = (run_dir / record["log"]).read_text()
            assert expected in log, (workers, log, proc.stderr)


@pytest.mark.slow
def test_noise_sweep_records_the_presets_and_the_noise_reaches_the_solution(tmp_path):
    """``--sweep noise=none,low`` runs both levels with the same seed, records the presets in the manifest and plan,
    and writes the robustness summary and plot; ``--noise low`` alone, with that seed, gives bit-identical results
    to the sweep's ``low`` episode, and different ones from ``none`` (the solution saw the noise)."""
    sweep = cli("batch", "--example", "semslam_geometric", "--envs", "miniroom:1", "--sweep", "noise=none,low",
                "--output-dir", str(tmp_path / "sweep"), "--json", *SMALL)
    assert sweep.returncode == 0, sweep.stderr
    out = json.loads(sweep.stdout)
    run_dir = Path(out["run_dir"])
    m = manifest(run_dir)
    assert [(p["noise"], p["seed"]) for p in m["plan"]] == [("none", 0), ("low", 0)]
    assert m["sweep"] == {"factor": "noise", "levels": ["none", "low"], "level_of": {"0": "none", "1": "low"}}
    assert set(m["noise"]) == {"none", "low"} and m["noise"]["low"]["laser"]["sigma_m"] == 0.005
    assert [e["noise"] for e in json.loads((run_dir / "episode_scores.json").read_text())] == ["none", "low"]
    robustness = json.loads((run_dir / "robustness.json").read_text())
    assert robustness == {**out["robustness"]}
    assert [lv["n"] for lv in robustness["levels"]] == [1, 1] and robustness["levels"][0]["low"] is None
    assert robustness["levels"][0]["reason"] == "n = 1 < 5: no confidence interval over environments"
    assert robustness["differences"][0]["reason"] == "n = 1 < 6: no paired test over environments"
    assert robustness["levels"][0]["episodes"]["reason"] == "n = 1 < 5: no confidence interval"
    assert robustness["score"] == "OMQ" and m["scores"]["scores"][0]["name"] == "OMQ"  # the declared primary
    assert m["episodes"][0]["backend"]["style"] == "primitives"
    assert " -m benchbot.cli batch --example semslam_geometric --envs miniroom:1 --sweep noise=none,low" in \
        m["provenance"]["command"]
    assert (run_dir / "trajectories" / (Path(m["plan"][0]["results"]).stem + ".json")).is_file()
    assert (run_dir / "robustness.png").is_file() and (run_dir / "robustness.svg").is_file()
    none, low = (json.loads((run_dir / p["results"]).read_text()) for p in m["plan"])
    assert none != low

    single = cli("batch", "--example", "semslam_geometric", "--envs", "miniroom:1", "--noise", "low",
                 "--output-dir", str(tmp_path / "single"), "--json", *SMALL)
    assert single.returncode == 0, single.stderr
    single_dir = Path(json.loads(single.stdout)["run_dir"])
    m1 = manifest(single_dir)
    assert m1["plan"][0]["noise"] == "low" and m1["sweep"] is None and list(m1["noise"]) == ["low"]
    assert not (single_dir / "robustness.json").exists()
    assert json.loads((single_dir / m1["plan"][0]["results"]).read_text()) == low


@pytest.mark.parametrize("args, message", [
    (["--noise", "loud"], "error: --noise 'loud' is not a noise preset"),
    (["--sweep", "noise"], "error: --sweep 'noise' is not FACTOR=LEVEL,LEVEL,..."),
    (["--sweep", "noise=low,loud"], "error: --sweep noise level 'loud' is not a noise preset"),
    (["--sweep", "noise=none,low", "--noise", "low"], "error: --noise and --sweep noise=... both set the noise"),
    (["--sweep", "robot=carter,carter"], "error: --sweep 'robot=carter,carter' gives level 'carter' twice"),
])
@pytest.mark.slow
def test_bad_noise_or_sweep_flags_are_one_line_usage_errors(tmp_path, args, message):
    proc = cli("batch", "--example", "hello_passive", "--envs", "miniroom:1", "--output-dir", str(tmp_path), *args)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.splitlines()[0] == message and proc.stderr.splitlines()[1].startswith("hint: ")
    assert not list(tmp_path.iterdir())


def test_a_ray_episode_sends_back_its_files_within_the_limit_and_only_its_log_past_it(tmp_path, monkeypatch):
    """What a Ray node sends back passes whole through memory: past BENCHBOT_RAY_EPISODE_BYTES only the log goes."""
    from benchbot.batch.executors import _collect

    (tmp_path / "logs").mkdir()
    (tmp_path / "logs" / "000.log").write_text("the log")
    (tmp_path / "outputs" / "000").mkdir(parents=True)
    (tmp_path / "outputs" / "000" / "big.bin").write_bytes(b"x" * 2048)
    files, problem = _collect(tmp_path, "logs/000.log")
    assert problem == "" and files["outputs/000/big.bin"] == b"x" * 2048 and "outputs/000/" in files
    monkeypatch.setenv("BENCHBOT_RAY_EPISODE_BYTES", "1K")
    files, problem = _collect(tmp_path, "logs/000.log")
    assert files == {"logs/000.log": b"the log"}
    assert "2055 bytes" in problem and "more than 1 KiB" in problem and "BENCHBOT_RAY_EPISODE_BYTES" in problem
