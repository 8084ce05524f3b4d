"""Commands as a person runs them: in a real pseudo-terminal (the live views), pressing q and Ctrl-C, and with
stderr going to a log. Each test bounds its wait on the process itself, which the process cannot swallow."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from terminal import Terminal  # noqa: E402

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
SMALL = ["--camera-size", "64x48", "--arch", "cpu"]


def _batch(tmp_path: Path, *envs: str) -> list[str]:
    return [*BENCHBOT, "batch", "--example", "hello_passive", "--envs", ",".join(envs), *SMALL,
            "--output-dir", str(tmp_path)]


@pytest.mark.slow
def test_batch_view_closes_itself_and_prints_the_scores(tmp_path):
    with Terminal(_batch(tmp_path, "miniroom:4"), columns=160, rows=48) as term:
        assert term.wait(300) == 0, term.text[-2000:]
        assert "omq scores" in term.text and "results and scores in" in term.text
        assert "1 episode: 1 ok" in term.text
        assert "[Taichi]" not in term.text  # Taichi's banner is kept out of every command's output


@pytest.mark.slow
@pytest.mark.alone  # its bound holds on a machine not busy with other tests
def test_ctrl_c_stops_a_batch_in_its_live_view_at_once(tmp_path):
    """The bound is the design's (benchbot/batch/stopping.py), not this machine's speed: the waits before Ctrl-C
    are on what the screen shows, with room for a loaded machine; after it, the command must be gone within
    STOP_BOUND_S (plus the second the pseudo-terminal and process exit may take when every core is busy)."""
    from benchbot.batch.stopping import STOP_BOUND_S

    with Terminal(_batch(tmp_path, "miniroom:4", "miniroom:1"), columns=80, rows=24) as term:
        assert term.wait_for(r"episodes done", 300), term.text[-2000:]
        term.press(b"\x03")
        t0 = time.monotonic()
        assert term.wait(STOP_BOUND_S + 30) == 130, term.text[-2000:]
        took = time.monotonic() - t0
        assert took < STOP_BOUND_S + 1.5, (took, term.text[-2000:])
        assert term.wait_for(r"--resume", 10), term.text[-2000:]
        text = " ".join(term.text.split())
        assert f"at most {STOP_BOUND_S:.0f} s" in text and "Do you want to quit" not in text
    (run_dir,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    assert f"interrupted; finish the batch with: benchbot batch --resume {run_dir}" in text
    states = {e["state"] for e in json.loads((run_dir / "progress.json").read_text())["episodes"].values()}
    assert "running" not in states and "interrupted" in states, states


@pytest.mark.slow
@pytest.mark.alone  # its bound holds on a machine not busy with other tests
def test_ctrl_c_is_bounded_even_when_the_solution_ignores_sigterm(tmp_path):
    """The worst case the bound is for: a solution that ignores SIGTERM with a 60 s grace before SIGKILL. The
    command is still gone within STOP_BOUND_S of Ctrl-C, and so is the solution (its group was SIGKILLed)."""
    from benchbot.batch.stopping import STOP_BOUND_S

    pid_file = tmp_path / "solution.pid"
    (tmp_path / "stubborn.py").write_text(
        "import os, signal, time\n"
        "signal.signal(signal.SIGTERM, signal.SIG_IGN)\n"
        f"open({str(pid_file)!r}, 'w').write(str(os.getpid()))\n"
        "time.sleep(600)\n")
    argv = [*BENCHBOT, "batch", "--native", f"{sys.executable} stubborn.py", "--no-sandbox", "--envs", "miniroom:1",
            *SMALL, "--output-dir", str(tmp_path / "runs")]
    with Terminal(argv, columns=80, rows=24, cwd=str(tmp_path),
                  env={**os.environ, "BENCHBOT_STOP_GRACE_S": "60"}) as term:
        deadline = time.monotonic() + 300
        while not pid_file.is_file() or not pid_file.read_text():
            assert time.monotonic() < deadline and term.proc.poll() is None, term.text[-2000:]
            time.sleep(0.1)
        solution = int(pid_file.read_text())
        term.press(b"\x03")
        t0 = time.monotonic()
        assert term.wait(STOP_BOUND_S + 30) == 130, term.text[-2000:]
        took = time.monotonic() - t0
        assert took < STOP_BOUND_S + 1.5, (took, term.text[-2000:])
    assert _ends(solution, within_s=30), f"the solution {solution} still runs"  # SIGKILLed: gone, or a zombie
    assert "finish the batch with: benchbot batch --resume" in " ".join(term.text.split())


def _ends(pid: int, within_s: float) -> bool:
    """True once ``pid`` is gone or a zombie (killed, not yet reaped by its new parent) within ``within_s``."""
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError):
            return True
        if state in ("Z", "X"):
            return True
        time.sleep(0.05)
    return False


def test_mark_interrupted_rewrites_only_the_running_episodes(tmp_path):
    from benchbot.batch.progress import PROGRESS, mark_interrupted

    assert mark_interrupted(tmp_path) == 0 and not (tmp_path / PROGRESS).exists()
    (tmp_path / PROGRESS).write_text(json.dumps({"episodes": {
        "0": {"state": "ended", "step": 48, "started": 1.0, "stage": ""},
        "1": {"state": "running", "step": 7, "started": 2.0, "stage": "building the BVH"}}}))
    assert mark_interrupted(tmp_path) == 1
    episodes = json.loads((tmp_path / PROGRESS).read_text())["episodes"]
    assert episodes["0"]["state"] == "ended" and episodes["1"] == {"state": "interrupted", "step": 7, "started": 2.0,
                                                                   "stage": ""}


def test_an_episode_still_running_after_ctrl_c_cannot_undo_the_interrupted_mark(tmp_path):
    """After Ctrl-C the batch's thread can still be busy in its episode (a kernel compile no exception interrupts)
    and send its next stage or step: that must not write ``running`` over the mark."""
    from benchbot.batch.progress import PROGRESS, ProgressFile, mark_interrupted

    progress = ProgressFile(tmp_path)
    progress.event("start", 0, None)
    progress.event("start", 1, None)
    progress.event("end", 0, None)
    assert mark_interrupted(tmp_path) == 1
    progress.event("stage", 1, {"stage": "compiling kernels"})
    progress.event("step", 1, {"step": 3})
    progress.event("start", 2, None)
    episodes = json.loads((tmp_path / PROGRESS).read_text())["episodes"]
    assert {k: e["state"] for k, e in episodes.items()} == {"0": "ended", "1": "interrupted"}


@pytest.mark.slow
def test_q_closes_the_batch_view_and_the_batch_goes_on(tmp_path):
    with Terminal(_batch(tmp_path, "miniroom:4"), columns=100, rows=30) as term:
        assert term.wait_for(r"episodes done", 120), term.text[-2000:]
        term.press(b"q")
        assert term.wait(300) == 0, term.text[-2000:]
        assert "the table was closed; the batch goes on" in term.text
        assert "[1/1] miniroom:4  ok  33 steps" in term.text  # the line printed when the view is gone
        after_q = term.text.split("the table was closed; the batch goes on")[1].split("[1/1] miniroom:4  ok")[0]
        assert "[1/1] miniroom:4  " in after_q, after_q  # what the episode is doing, not a silence


@pytest.mark.slow
def test_ctrl_c_stops_benchbot_run_in_its_live_view(tmp_path):
    """Ctrl-C in the live view of an episode served in the command's process ends it (130), and the view's
    live-state folder goes with it (a temporary folder of its own, which used to stay behind)."""
    (tmp_path / "tmp").mkdir()
    with Terminal([*BENCHBOT, "run", "--env", "miniroom:1", "--port", "0", *SMALL], columns=100, rows=30,
                  env=dict(os.environ, TMPDIR=str(tmp_path / "tmp"))) as term:
        assert term.wait_for(r"backend +http://127\.0\.0\.1:\d+/", 120), term.text[-2000:]  # the view shows it
        assert any(p.name.startswith("benchbot-live-") for p in (tmp_path / "tmp").iterdir())
        term.press(b"\x03")
        assert term.wait(15) == 130, term.text[-2000:]
    assert not any(p.name.startswith("benchbot-live-") for p in (tmp_path / "tmp").iterdir())


@pytest.mark.slow
def test_batch_without_a_terminal_prints_each_episode_as_it_finishes(tmp_path):
    proc = subprocess.Popen(_batch(tmp_path, "miniroom:4", "miniroom:1"), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        lines = []
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            line = proc.stderr.readline()
            if not line:
                break
            lines.append(line)
            if line.startswith("[1/2] miniroom:4  ok"):
                assert proc.poll() is None  # printed while the batch still runs, not at the end
                break
        assert any(l.startswith("[1/2] miniroom:4  ok  33 steps") for l in lines), lines
        said = "".join(lines).split("[1/2] miniroom:4  ok")[0]  # what the first episode did, before it ended
        assert "[1/2] miniroom:4  starting …" in said and "[1/2] miniroom:4  the backend is ready" in said, said
        assert "building the scene" in said or "loading the scene" in said, said
        assert "\x1b[" not in said  # plain lines in a log
        rest, _ = proc.communicate(timeout=300)[1], None
        assert proc.returncode == 0, rest
        assert "[2/2] miniroom:1  ok  48 steps" in rest and "2 episodes: 2 ok in " in rest
        assert "━" not in "".join(lines) + rest  # no progress bars in a log
    finally:
        proc.kill()
        proc.wait()


@pytest.mark.parametrize("flags, code, message", [
    (["--evaluate-with", "nope"], 3, "no evaluator named 'nope'"),
    (["--prefix", "../escape"], 2, "--prefix '../escape' is not a name"),
])
@pytest.mark.slow
def test_a_batch_that_cannot_start_leaves_no_run_directory(tmp_path, flags, code, message):
    proc = subprocess.run([*_batch(tmp_path, "miniroom:4"), *flags], capture_output=True, text=True, timeout=120)
    assert proc.returncode == code and message in proc.stderr, proc.stderr
    assert list(tmp_path.iterdir()) == [] and not (tmp_path.parent / "escape").exists()


@pytest.mark.slow
def test_a_batch_that_scored_nothing_says_so(tmp_path):
    proc = subprocess.run([*BENCHBOT, "batch", "--native", "false", "--envs", "miniroom:4", *SMALL, "--output-dir",
                           str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0
    assert "nothing was scored (no episode produced results)" in proc.stderr
    assert "results and scores in" not in proc.stderr


def test_a_batch_whose_script_is_missing_says_so_before_starting_anything(tmp_path):
    proc = subprocess.run([*BENCHBOT, "batch", "--native", "python -u my_solution.py --fast", "--envs", "miniroom:1",
                           *SMALL, "--output-dir", str(tmp_path / "runs")], capture_output=True, text=True,
                          timeout=60, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert f"{tmp_path / 'my_solution.py'} does not exist" in proc.stderr and "hint: run benchbot from the folder" in proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "runs").exists()  # no run directory, no backend


def test_only_a_python_scripts_path_is_checked(tmp_path):
    from benchbot.core.errors import UsageError
    from benchbot.solutions.submission import check_native_files

    (tmp_path / "ok.py").write_text("")
    for fine in ("python ok.py", "python3 -u -W ignore ok.py --x", "python -m mypkg", "python -c 'print(1)'",
                 "./run.sh", "false", "python"):
        check_native_files(fine, tmp_path)
    for missing in ("python my.py", "python3.11 -u sub/my.py", "/usr/bin/python3 gone.py"):
        with pytest.raises(UsageError, match="does not exist"):
            check_native_files(missing, tmp_path)


def test_a_native_command_with_unbalanced_quotes_is_one_line(tmp_path):
    from benchbot.core.errors import UsageError
    from benchbot.solutions.submission import check_native_files

    with pytest.raises(UsageError, match="No closing quotation") as info:
        check_native_files('python "my solution.py', tmp_path)
    assert "\n" not in info.value.message and "balance its quotes" in info.value.hint


def test_a_quiet_episode_is_described_every_few_seconds():
    from benchbot.batch.narration import Narrator

    lines: list[str] = []
    with Narrator(lines.append, {0: "[1/1] miniroom:1"}, {0: 48}, quiet_s=0.5) as narrator:
        narrator.event("start", 0, None)
        narrator.event("stage", 0, {"stage": "baking light (12/29)"})
        narrator.event("stage", 0, {"stage": "baking light (13/29)"})  # the same stage: no new line
        deadline = time.monotonic() + 30
        while not any("baking light (13/29) …, " in l for l in lines) and time.monotonic() < deadline:
            time.sleep(0.05)
        narrator.event("stage", 0, {"stage": ""})
        narrator.event("step", 0, {"step": 1})
        narrator.event("step", 0, {"step": 7})
        while not any("step 7 of 48 (the solution runs)" in l for l in lines) and time.monotonic() < deadline:
            time.sleep(0.05)
        narrator.event("end", 0, None)
    assert lines[:2] == ["[1/1] miniroom:1  starting …", "[1/1] miniroom:1  baking light (12/29) …"], lines
    assert lines[2].startswith("[1/1] miniroom:1  baking light (13/29) …, 0:0"), lines  # said again when quiet
    assert "[1/1] miniroom:1  the backend is ready; the solution runs …" in lines
    assert any(l.startswith("[1/1] miniroom:1  step 7 of 48 (the solution runs), 0:0") for l in lines), lines


def test_a_closed_view_says_what_the_running_episodes_wait_for():
    from benchbot.batch.narration import Narrator

    lines: list[str] = []
    narrator = Narrator(lines.append, {0: "[1/2] miniroom:4", 1: "[2/2] miniroom:1"}, {0: 33}, speaking=False)
    narrator.event("start", 0, None)
    narrator.event("step", 0, {"step": 5})
    assert lines == []  # the view shows it
    narrator.speak()
    assert len(lines) == 1 and lines[0].startswith("[1/2] miniroom:4  step 5 of 33 (the solution runs), 0:00"), lines
    stopping = Narrator(lines.append, {0: "[1/1] miniroom:1"}, muted=lambda: True)  # Ctrl-C: the backend may
    stopping.event("start", 0, None)                                                 # still talk; not printed
    stopping.event("stage", 0, {"stage": "baking light"})
    assert len(lines) == 1, lines


def test_an_episode_log_names_the_run_directorys_folder_for_the_sandboxs(tmp_path):
    """A sandboxed solution prints /benchbot/results/...; its episode log says which folder of the run directory
    that is (before: only the sandbox's path, which does not exist outside it)."""
    from benchbot.core.registry import get_registry
    from benchbot.solutions.sandbox import run_sandboxed

    outputs = tmp_path / "run" / "outputs" / "000_miniroom_1"
    outputs.mkdir(parents=True)
    (tmp_path / "socket").touch()  # no backend: the solution only prints
    with open(tmp_path / "000.log", "w") as log:
        run = run_sandboxed([sys.executable, "-c", "print('images in /benchbot/results/x_images')"], tmp_path,
                            registry=get_registry(), backend_socket=tmp_path / "socket",
                            address="http://127.0.0.1:10000/", outputs=outputs, result_name="r.json", log=log,
                            timeout_s=60)
    text = (tmp_path / "000.log").read_text()
    assert run.outcome.returncode == 0, text
    assert f"the solution's /benchbot/results is {outputs.resolve()}" in text, text
    assert text.strip().splitlines()[-1] == "images in /benchbot/results/x_images"


@pytest.mark.parametrize("argv", [["--help"], ["plugin", "new", "--help"]])
def test_help_reads_well_at_80_columns(argv):
    proc = subprocess.run([*BENCHBOT, *argv], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "COLUMNS": "80", "TERM": "dumb"})
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert all(len(line) <= 80 for line in lines), [l for l in lines if len(l) > 80]
    text = " ".join(proc.stdout.split())
    assert "; )" not in text and "[tool.uv.sources]" in text if argv[0] == "plugin" else True
    if argv == ["--help"]:  # each example command whole on its line, what it does under it
        assert any(l.strip() == "benchbot batch --example semslam_geometric --envs miniroom:1" for l in lines)
        assert any(l.strip() == "benchbot submit --native python my_solution.py" for l in lines)
        assert "A short flag means the same in every command: -e environment(s)," in text
        assert not any(l.strip() == "score, print a table)" for l in lines), lines  # a line broken by hand
