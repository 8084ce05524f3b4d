"""Batches against hostile or broken solutions and run directories: results files that do not parse, solutions that
fork, hang, flood their output or outlive a killed batch, and hand-edited manifests on --resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
SMALL = ["--camera-size", "64x48"]


def batch(*args, env=None, timeout=120):
    return subprocess.run([*BENCHBOT, "batch", *args], capture_output=True, text=True, timeout=timeout,
                          env=None if env is None else {**os.environ, **env})


def manifest(run_dir: Path) -> dict:
    return json.loads((run_dir / "manifest.json").read_text())


def only_run_dir(output: Path) -> Path:
    (run_dir,) = list(output.iterdir())
    return run_dir


def running(pid: int) -> bool:
    """The process exists and is not a zombie (orphans may stay zombies where init does not reap them)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except (FileNotFoundError, ProcessLookupError):
        return False


def wait_gone(pids: list[int], within_s: float) -> list[int]:
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline and any(map(running, pids)):
        time.sleep(0.1)
    return [p for p in pids if running(p)]


def solution(tmp_path: Path, body: str) -> str:
    """A native solution: ``body`` after a preamble that forks a child sleeping 120 s. It runs sandboxed (the
    default), so it tells nothing through files: :func:`pids` finds it and its child in this machine's ``/proc``."""
    script = tmp_path / "solution.py"
    script.write_text(
        "import os, sys, time\n"
        "child = os.fork()\n"
        "if child == 0:\n"
        "    time.sleep(120)\n"
        "    os._exit(0)\n"
        "print('forked a child', flush=True)\n" + body
    )
    return f"{sys.executable} {script}"


def running_solutions(tmp_path: Path) -> list[int]:
    """The pids (as this machine numbers them, sandboxed or not) of the live processes running ``python
    tmp_path/solution.py``: solutions and their forked children."""
    script = str(tmp_path / "solution.py")
    found = []
    for entry in os.listdir("/proc"):
        try:
            argv = Path(f"/proc/{entry}/cmdline").read_bytes().split(b"\0")
        except (OSError, ValueError):
            continue
        if entry.isdigit() and len(argv) > 1 and argv[1].decode(errors="replace") == script and running(int(entry)):
            found.append(int(entry))
    return found


def pids(tmp_path: Path, count: int = 1, within_s: float = 90) -> list[int]:
    """The pids of ``count`` running solutions and their forked children (waiting for them to start and fork)."""
    deadline = time.monotonic() + within_s
    while len(found := running_solutions(tmp_path)) < 2 * count:
        assert time.monotonic() < deadline, "the solutions never started"
        time.sleep(0.1)
    return found


def none_left_within(tmp_path: Path, within_s: float) -> list[int]:
    """The solutions' processes still running after ``within_s`` seconds (none, if their groups were ended)."""
    deadline = time.monotonic() + within_s
    while (left := running_solutions(tmp_path)) and time.monotonic() < deadline:
        time.sleep(0.1)
    return left


def descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (children of all its threads, recursively)."""
    out = []
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except FileNotFoundError:
        return out
    for task in tasks:
        try:
            children = Path(f"/proc/{pid}/task/{task}/children").read_text().split()
        except FileNotFoundError:
            continue
        for child in map(int, children):
            out += [child, *descendants(child)]
    return out


# ------------------------------------------------------------------------------------------------ processes
@pytest.mark.slow
def test_a_forked_child_ends_with_its_episode_and_episodes_get_a_default_timeout(tmp_path):
    proc = batch("--native", solution(tmp_path, "sys.exit(0)\n"), "--envs", "miniroom:1", "--no-evaluate",
                 "--output-dir", str(tmp_path / "runs"), *SMALL)
    assert proc.returncode == 1, proc.stderr  # no results
    assert none_left_within(tmp_path, 2) == []  # before: the child slept on after the batch
    m = manifest(only_run_dir(tmp_path / "runs"))
    assert "forked a child" in (only_run_dir(tmp_path / "runs") / m["episodes"][0]["log"]).read_text()
    assert m["episodes"][0]["status"] == "no_results"
    assert m["plan"][0]["timeout_s"] == 300 + 10 * 48  # startup + 10 s × 48 trajectory poses of miniroom:1
    assert m["episode_timeout"]["source"] == "default"


@pytest.mark.slow
def test_episode_timeout_stops_the_whole_group(tmp_path):
    t0 = time.monotonic()
    proc = batch("--native", solution(tmp_path, "time.sleep(120)\n"), "--envs", "miniroom:1", "--no-evaluate",
                 "--episode-timeout", "2", "--output-dir", str(tmp_path / "runs"), *SMALL)
    assert time.monotonic() - t0 < 60
    assert proc.returncode == 1
    assert none_left_within(tmp_path, 2) == []
    m = manifest(only_run_dir(tmp_path / "runs"))
    record = m["episodes"][0]
    assert "forked a child" in (only_run_dir(tmp_path / "runs") / record["log"]).read_text()
    assert record["status"] == "timeout" and "timeout of 2 s" in record["error"], record
    assert m["plan"][0]["timeout_s"] == 2 and m["episode_timeout"] == {"source": "--episode-timeout", "seconds": 2}
    assert "timeout" in proc.stderr


@pytest.mark.slow
def test_a_sandboxed_process_that_leaves_its_group_ends_with_the_sandbox(tmp_path):
    """setsid() takes a process out of the solution's process group, so the group's clean-up misses it; in the
    sandbox it still ends with its episode (the sandbox's PID namespace ends)."""
    body = "if os.fork() == 0:\n    os.setsid()\n    time.sleep(120)\n    os._exit(0)\nprint('escaped', flush=True)\n"
    proc = batch("--native", solution(tmp_path, body), "--envs", "miniroom:1", "--no-evaluate",
                 "--output-dir", str(tmp_path / "runs"), *SMALL)
    assert proc.returncode == 1, proc.stderr  # no results
    run_dir = only_run_dir(tmp_path / "runs")
    assert "escaped" in (run_dir / manifest(run_dir)["episodes"][0]["log"]).read_text()
    assert none_left_within(tmp_path, 2) == []


@pytest.mark.parametrize("workers", [1, 2])
@pytest.mark.slow
def test_kill_9_of_the_batch_ends_its_solutions(tmp_path, workers):
    envs = "miniroom:1" if workers == 1 else "miniroom:1,miniroom:2"
    batch_proc = subprocess.Popen(
        [*BENCHBOT, "batch", "--native", solution(tmp_path, "time.sleep(120)\n"), "--envs", envs, "--no-evaluate",
         "--workers", str(workers), "--output-dir", str(tmp_path / "runs"), "--no-tui", *SMALL],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        solution_pids = pids(tmp_path, workers)
        below = descendants(batch_proc.pid)
        assert set(solution_pids) <= set(below)
        os.kill(batch_proc.pid, signal.SIGKILL)  # the batch alone: its solutions are in their own sessions
        batch_proc.wait(10)
        assert wait_gone(solution_pids, 10) == []  # before: they ran on (up to 63 s, or forever for the fork)
        assert wait_gone(below, 20) == []  # worker processes, watchdogs, the manager
    finally:
        if batch_proc.poll() is None:
            os.killpg(batch_proc.pid, signal.SIGKILL)
            batch_proc.wait()


@pytest.mark.slow
def test_a_flood_of_output_is_capped_without_blocking_or_losing_the_exit_status(tmp_path):
    script = tmp_path / "flood.py"
    script.write_text("import sys\nblock = b'x' * (1 << 20)\nfor _ in range(64):\n    sys.stdout.buffer.write(block)\n"
                      "sys.stdout.flush()\nsys.exit(5)\n")
    t0 = time.monotonic()
    proc = batch("--native", f"{sys.executable} {script}", "--envs", "miniroom:1", "--no-evaluate",
                 "--episode-timeout", "60", "--output-dir", str(tmp_path / "runs"), *SMALL,
                 env={"BENCHBOT_MAX_LOG_BYTES": "100000"})
    assert time.monotonic() - t0 < 60
    run_dir = only_run_dir(tmp_path / "runs")
    record = manifest(run_dir)["episodes"][0]
    assert (record["status"], record["returncode"]) == ("failed", 5), proc.stderr
    log = (run_dir / record["log"]).read_bytes()
    first, _, rest = log.partition(b"\n")  # the sandbox's line saying where /benchbot/results is, then the solution
    assert first.startswith(b"[benchbot] the solution's /benchbot/results is"), first[:200]
    assert rest.startswith(b"x" * 100000) and len(rest) < 100000 + 200
    assert b"[log truncated at 100000 bytes (67108864 written): raise with BENCHBOT_MAX_LOG_BYTES]" in log


@pytest.mark.slow
def test_a_bad_log_cap_is_a_one_line_error(tmp_path):
    proc = batch("--native", "true", "--envs", "miniroom:1", "--output-dir", str(tmp_path), *SMALL,
                 env={"BENCHBOT_MAX_LOG_BYTES": "lots"})
    assert proc.returncode == 2 and "BENCHBOT_MAX_LOG_BYTES='lots' is not a whole number" in proc.stderr
    assert "Traceback" not in proc.stderr


# ------------------------------------------------------------------------------------------------ bad results
RESULTS_SOLUTION = """
import json, os, sys, urllib.request
config = json.loads(urllib.request.urlopen(os.environ["BENCHBOT_SUPERVISOR_ADDRESS"] + "config/", timeout=10).read())
scene = config["environments"][0]
env = f"{scene['name']}:{scene['variant']}"
corrupt = json.loads(open(sys.argv[1]).read())
with open(os.environ["BENCHBOT_RESULT_LOCATION"], "w") as f:
    if env in corrupt:
        f.write(corrupt[env])
    else:
        json.dump({"task_details": config["task"], "environment_details": config["environments"],
                   "results": {"objects": [], "class_list": ["bottle", "cup"]}}, f)
"""


@pytest.mark.slow
def test_a_corrupt_results_file_fails_only_its_episode_also_on_resume(tmp_path):
    script, corrupt = tmp_path / "solution.py", tmp_path / "corrupt.json"
    script.write_text(RESULTS_SOLUTION)
    corrupt.write_text(json.dumps({"miniroom:1": "{not json", "miniroom:3": json.dumps({"task_details": {}})}))
    proc = batch("--native", f"{sys.executable} {script} {corrupt}", "--envs", "miniroom:1,miniroom:2,miniroom:3",
                 "--output-dir", str(tmp_path / "runs"), *SMALL)
    assert proc.returncode == 1
    run_dir = only_run_dir(tmp_path / "runs")
    episodes = manifest(run_dir)["episodes"]
    assert [e["status"] for e in episodes] == ["bad_results", "ok", "bad_results"], proc.stderr
    assert "not valid JSON" in episodes[0]["error"] and "\n" not in episodes[0]["error"]  # found by the episode
    assert "environment_details" in episodes[2]["error"]  # found by the evaluation
    scores = json.loads((run_dir / "scores.json").read_text())  # before: no scores at all
    assert [e["index"] for e in scores["excluded_episodes"]] == [0, 2]
    assert [e["env"] for e in json.loads((run_dir / "episode_scores.json").read_text())] == ["miniroom:2"]
    assert [e["status"] for e in manifest(run_dir)["excluded"]] == ["bad_results", "bad_results"]
    assert "bad_results" in proc.stderr and "not valid JSON" in proc.stderr

    # on resume the bad ones run again, and so does a finished one whose results were damaged since
    corrupt.write_text("{}")
    (run_dir / episodes[1]["results"]).write_text("[truncated")
    proc = batch("--resume", str(run_dir))
    assert proc.returncode == 0, proc.stderr
    episodes = manifest(run_dir)["episodes"]
    assert [(e["status"], e["attempts"]) for e in episodes] == [("ok", 2), ("ok", 2), ("ok", 2)]
    scores = json.loads((run_dir / "scores.json").read_text())
    assert "excluded_episodes" not in scores and len(json.loads((run_dir / "episode_scores.json").read_text())) == 3


# ------------------------------------------------------------------------------------------------ manifests
@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    """A finished 3-episode batch (no evaluation) whose manifest the tests below edit (each on a copy)."""
    out = tmp_path_factory.mktemp("finished")
    script = out / "ok.py"
    script.write_text("import os\nopen(os.environ['BENCHBOT_RESULT_LOCATION'], 'w').write('{}')\n")
    proc = batch("--native", f"{sys.executable} {script}", "--envs", "miniroom:1,miniroom:2,miniroom:3",
                 "--no-evaluate", "--output-dir", str(out / "runs"), *SMALL)
    assert proc.returncode == 0, proc.stderr
    return only_run_dir(out / "runs")


def edited(finished_run: Path, tmp_path: Path, edit) -> Path:
    import shutil

    run_dir = tmp_path / "run"
    shutil.copytree(finished_run, run_dir)
    m = manifest(run_dir)
    for record in m["episodes"]:
        record["status"] = "pending"
    edit(m)
    (run_dir / "manifest.json").write_text(json.dumps(m))
    return run_dir


def _set(path: str, value):
    def edit(m):
        node, keys = m, path.split(".")
        for key in keys[:-1]:
            node = node[int(key)] if key.isdigit() else node[key]
        node[int(keys[-1]) if keys[-1].isdigit() else keys[-1]] = value
    return edit


@pytest.mark.parametrize("edit, message", [
    (_set("plan", {}), "$.plan: {} is not of type 'array'"),
    (lambda m: m["episodes"].pop(), "$.episodes: 2 records for 3 planned episodes"),
    (_set("episodes.1.attempts", "2"), "$.episodes[1].attempts: '2' is not of type 'integer'"),
    (_set("plan.0.seed", 1.5), "$.plan[0].seed: 1.5 is not of type 'integer'"),
    (_set("plan.2.results", "results/../../escaped.json"), "$.plan[2].results: 'results/../../escaped.json' does not match"),
    (_set("plan.2.log", "/tmp/escaped.log"), "$.plan[2].log: '/tmp/escaped.log' does not match"),
    (_set("plan.1.index", 2), "$.plan[1].index: 2, expected 1"),
    (_set("episodes.1.env", "house:1"), "$.episodes[1].env: 'house:1' differs from $.plan[1].env 'miniroom:2'"),
    (lambda m: [_set(f"{key}.1.results", "results/000_miniroom_1.json")(m) for key in ("plan", "episodes")],
     "$.plan[1].results: results/000_miniroom_1.json is also $.plan[0].results"),
    (_set("plan.0.timeout_s", -1), "$.plan[0].timeout_s: -1 is less than or equal to the minimum of 0"),
])
@pytest.mark.slow
def test_resume_refuses_a_bad_manifest_naming_the_field(finished_run, tmp_path, edit, message):
    run_dir = edited(finished_run, tmp_path, edit)
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    proc = batch("--resume", str(run_dir))
    assert proc.returncode == 2, proc.stderr
    first = proc.stderr.splitlines()[0]
    assert first.startswith(f"error: {run_dir / 'manifest.json'}: ") and message in first, proc.stderr
    assert "Traceback" not in proc.stderr and "already done" not in proc.stderr
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before  # nothing ran, nothing written


@pytest.mark.slow
def test_resume_refuses_a_results_folder_linked_outside_the_run_directory(finished_run, tmp_path):
    run_dir = edited(finished_run, tmp_path, lambda m: None)
    outside = tmp_path / "outside"
    outside.mkdir()
    import shutil

    shutil.rmtree(run_dir / "results")
    (run_dir / "results").symlink_to(outside)
    proc = batch("--resume", str(run_dir))
    assert proc.returncode == 2 and "outside the run directory" in proc.stderr, proc.stderr
    assert list(outside.iterdir()) == []


# ------------------------------------------------------------------------------------------------ timeouts
def test_default_episode_timeouts_follow_the_task_and_the_flag_replaces_them():
    from benchbot.batch.plan import plan_episodes
    from benchbot.batch.runner import apply_timeouts, default_timeout_s
    from benchbot.core.errors import UsageError
    from benchbot.core.registry import get_registry

    registry = get_registry()
    poses = [len(scene["trajectory_poses"]) for scene in registry.scenes("miniroom:1:2")]
    assert default_timeout_s(registry, "semantic_slam:passive:ground_truth", "miniroom:1") == 300 + 10 * 48
    assert default_timeout_s(registry, "scd:passive:ground_truth", "miniroom:1:2") == 300 + 10 * sum(poses)
    assert default_timeout_s(registry, "semantic_slam:active:ground_truth", "miniroom:1") == 3600
    assert default_timeout_s(registry, "scd:active:ground_truth", "miniroom:1:2") == 7200

    def plan(timeout_s):
        return plan_episodes(task="semantic_slam:active:ground_truth", robots=["carter"], envs=["miniroom:1"],
                             repeat=1, seed=0, argv=["x"], cwd=".", options={}, timeout_s=timeout_s)

    specs = plan(None)
    assert apply_timeouts(registry, specs)["source"] == "default" and specs[0].timeout_s == 3600
    specs = plan(0)
    assert apply_timeouts(registry, specs) == {"source": "--episode-timeout", "seconds": None}
    assert specs[0].timeout_s is None  # 0: no timeout
    for bad in (-1, float("nan"), float("inf")):
        with pytest.raises(UsageError, match="--episode-timeout must be a number of seconds ≥ 0"):
            plan(bad)


# ------------------------------------------------------------------------------------------------ hostile results
PLANTED_SOLUTION = """
import json, os, urllib.request
PLANTED = json.loads({planted!r})
config = json.loads(urllib.request.urlopen(os.environ["BENCHBOT_SUPERVISOR_ADDRESS"] + "config/", timeout=10).read())
scene = config["environments"][0]
with open(os.environ["BENCHBOT_RESULT_LOCATION"], "w") as f:
    f.write(PLANTED[f"{{scene['name']}}:{{scene['variant']}}"])
"""


@pytest.mark.slow
def test_a_huge_number_or_another_environment_fails_only_its_episode_also_on_resume(tmp_path):
    """miniroom:1 writes a 400-digit integer into a centroid (valid JSON, under the 4,300-digit cap); house:1
    writes miniroom:1's perfect results, claiming miniroom:1; miniroom:2 writes its own perfect results. Before:
    the first crashed scoring (OverflowError: no scores for any episode) and the second was scored against
    miniroom:1. Now each is ``bad_results`` with a one-line reason and miniroom:2 is scored and written."""
    from benchbot.core.registry import get_registry

    sys.path.insert(0, str(Path(__file__).parent))
    from test_evaluation import perfect_results

    registry = get_registry()
    huge = perfect_results(registry, "miniroom:1")
    planted = {"miniroom:1": json.dumps(huge).replace(json.dumps(huge["results"]["objects"][2]["centroid"]),
                                                      f"[1.0, {10 ** 400}, 0.5]", 1),
               "house:1": json.dumps(perfect_results(registry, "miniroom:1")),
               "miniroom:2": json.dumps(perfect_results(registry, "miniroom:2"))}
    assert str(10 ** 400) in planted["miniroom:1"]
    folder = tmp_path / "solution"  # a sandboxed solution sees its own folder: the batch's working directory
    folder.mkdir()
    (folder / "planted.py").write_text(PLANTED_SOLUTION.format(planted=json.dumps(planted)))
    proc = subprocess.run([*BENCHBOT, "batch", "--native", "python planted.py", "--envs",
                           "miniroom:1,miniroom:2,house:1", "--output-dir", str(tmp_path / "runs"), *SMALL],
                          cwd=folder, capture_output=True, text=True, timeout=300)
    assert "Traceback" not in proc.stderr and proc.returncode == 1, proc.stderr
    run_dir = only_run_dir(tmp_path / "runs")
    results = [str(run_dir / e["results"]) for e in manifest(run_dir)["plan"]]

    def check(stderr: str) -> None:
        episodes = manifest(run_dir)["episodes"]
        assert [e["status"] for e in episodes] == ["bad_results", "ok", "bad_results"], stderr
        assert episodes[0]["error"] == (f"{results[0]}: results.objects[2].centroid[1]: expected a finite number, "
                                        "got an integer of 401 digits (beyond a float's range, ±1.8e+308)")
        assert episodes[2]["error"] == (f"{results[2]}: environment_details name miniroom:1, but these are the "
                                        "results of an episode on house:1")
        assert episodes[0]["error"] in stderr and episodes[2]["error"] in stderr and "Traceback" not in stderr
        scores = json.loads((run_dir / "scores.json").read_text())
        assert [e["index"] for e in scores["excluded_episodes"]] == [0, 2]
        per_episode = json.loads((run_dir / "episode_scores.json").read_text())
        assert [(e["env"], e["scores"]["OMQ"]) for e in per_episode] == [("miniroom:2", 1.0)]
        assert scores["scores"]["OMQ"] == pytest.approx(1 / 3)  # the excluded ones count as empty (0)

    check(proc.stderr)
    proc = batch("--resume", str(run_dir))  # the bad ones run again, and are refused again, one line each
    assert proc.returncode == 1, proc.stderr
    check(proc.stderr)
    assert [e["attempts"] for e in manifest(run_dir)["episodes"]] == [2, 1, 2]

    # a FIFO where a finished episode's results were is found without opening it (never waited on): the episode
    # runs again; a folder where a results file goes is one line, never deleted
    Path(results[1]).unlink()
    os.mkfifo(results[1])
    Path(results[2]).unlink()
    Path(results[2]).mkdir()
    proc = batch("--resume", str(run_dir))
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr
    episodes = manifest(run_dir)["episodes"]
    assert [(e["status"], e["attempts"]) for e in episodes] == [("bad_results", 3), ("ok", 2), ("error", 3)]
    assert episodes[2]["error"] == f"{results[2]}: a folder, where the episode's results file goes"
    assert Path(results[1]).is_file() and Path(results[2]).is_dir()


def test_an_absurd_repeat_is_one_usage_line_at_once(tmp_path):
    """``--repeat 99999999999999999999`` was accepted: the plan grew ~110 MB/s until the batch was killed."""
    measure = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:]); "
               "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(p.returncode)")
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-c", measure, *BENCHBOT, "batch", "--example", "hello_passive", "--envs",
                           "miniroom:1", "--repeat", "99999999999999999999", "--output-dir", str(tmp_path / "runs")],
                          capture_output=True, text=True, timeout=120)
    seconds = time.monotonic() - t0
    *lines, peak_kib = proc.stderr.rstrip("\n").splitlines()
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert lines[0] == ("error: --repeat 99999999999999999999 is more than the maximum of 1000 repetitions "
                        "(set BENCHBOT_MAX_REPEAT to raise it)")
    assert seconds < 30 and int(peak_kib) < 400 * 1024, (seconds, peak_kib)
    assert not (tmp_path / "runs").exists()
    # within --repeat's bound, the batch's size is bounded too, before its plan is made
    proc = batch("--example", "hello_passive", "--envs", "miniroom:1,miniroom:2", "--repeat", "3", "--output-dir",
                 str(tmp_path / "runs"), env={"BENCHBOT_MAX_BATCH_EPISODES": "5"})
    assert proc.returncode == 2 and proc.stderr.splitlines()[0] == (
        "error: a batch of 1 robot(s) × 2 environment(s) × 3 repetition(s) is more than the limit of 5 episodes "
        "(set BENCHBOT_MAX_BATCH_EPISODES to raise it)"), proc.stderr
    assert not (tmp_path / "runs").exists()
