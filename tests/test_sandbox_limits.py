"""A sandboxed solution's resource limits (memory, processes, file size, CPU time), its environment allow-list, the
links it leaves in its outputs, and the clean-up of a killed batch's temporary folders, each with the real sandbox
(docs/security.md, "Resource limits")."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest

from benchbot.solutions.sandbox import run_sandboxed
from benchbot.solutions.sandbox_limits import SandboxLimits, cgroup_root

SMALL = SandboxLimits(memory_bytes=512 << 20, processes=48, file_bytes=1 << 20, cpu_s=1, tmp_bytes=16 << 20,
                      outputs_bytes=8 << 20)


@pytest.fixture
def sandbox(tmp_path, registry):
    """``sandbox(code, limits=SMALL, env=None)`` → (SandboxedRun, log text, outputs folder, seconds): ``code`` run
    as ``python solution.py`` in the real sandbox (a Unix socket that nothing serves stands for the backend)."""
    backend = socket.socket(socket.AF_UNIX)
    backend.bind(str(tmp_path / "backend.sock"))
    runs = iter(range(100))

    def run(code: str, limits: SandboxLimits = SMALL, env: dict | None = None):
        n = next(runs)
        folder = tmp_path / f"solution{n}"
        folder.mkdir()
        (folder / "solution.py").write_text(textwrap.dedent(code))
        outputs = tmp_path / f"outputs{n}"
        outputs.mkdir()
        log = tmp_path / f"log{n}.txt"
        t0 = time.monotonic()
        with open(log, "w") as out:
            result = run_sandboxed([sys.executable, "solution.py"], folder, registry=registry,
                                   backend_socket=tmp_path / "backend.sock", address="http://127.0.0.1:10000/",
                                   outputs=outputs, result_name="results.json", log=out, timeout_s=120,
                                   limits=limits, env=env)
        return result, log.read_text(), outputs, time.monotonic() - t0

    yield run
    backend.close()


def test_a_solution_past_its_memory_limit_is_stopped_with_the_reason(sandbox):
    run, log, _, _ = sandbox("""
        import numpy as np
        small = np.ones(10_000_000)  # 80 MB: NumPy works under the limit
        print("small ok", small.sum(), flush=True)
        big = np.ones(200_000_000)  # 1.6 GB
    """)
    assert "small ok" in log and run.outcome.returncode != 0
    assert run.limit == ("the solution exceeded its memory limit of 512 MiB (BENCHBOT_SANDBOX_MEMORY_BYTES)"), log


@pytest.mark.skipif(cgroup_root("memory") is None, reason="no memory cgroup this process may make (cgroup v1 memory "
                    "or a delegated v2): memory is capped per process only here")
def test_memory_spread_over_processes_is_capped_for_the_sandbox_as_a_whole(sandbox):
    """Four processes of 200 MB each stay under the per-process RLIMIT_DATA of 512 MiB, but together pass the
    sandbox's memory cgroup (512 MiB): the OOM killer ends one, and the episode says which limit. (The solution
    ends as soon as one of them has ended, or after 20 s: it waited the 20 s for the others before.) Each process
    may use 30 CPU seconds, not SMALL's one: at the cgroup's limit the kernel reclaims pages in the processes' time,
    and on a loaded machine one of them once reached SIGXCPU at 1 s before the OOM killer came."""
    assert SandboxLimits.current().record()["mechanism"]["memory_bytes"].startswith("cgroup memory limit")
    run, log, _, _ = sandbox("""
        import multiprocessing as mp, sys, time
        import numpy as np

        def hold():
            block = np.ones(25_000_000)  # 200 MB, touched
            time.sleep(20)

        procs = [mp.Process(target=hold) for _ in range(4)]
        for p in procs:
            p.start()
        while all(p.exitcode is None for p in procs):  # until one has ended: the OOM killer's, or all after 20 s
            time.sleep(0.05)
        codes = [p.exitcode for p in procs]
        print("exit codes", codes, flush=True)
        for p in procs:
            p.kill()
        sys.exit(1 if any(codes) else 0)
    """, limits=dataclasses.replace(SMALL, cpu_s=30))
    assert run.outcome.returncode != 0, log
    assert run.limit == "the solution exceeded its memory limit of 512 MiB (BENCHBOT_SANDBOX_MEMORY_BYTES)", log


def test_a_fork_bomb_is_stopped_at_its_process_limit_fast(sandbox):
    """RLIMIT_NPROC is set inside the sandbox's user namespace: it counts the sandbox's tasks only. This machine's
    user has more processes than the limit outside, and the solution still gets a few of its own."""
    host_tasks = sum(len(os.listdir(f"/proc/{p}/task")) for p in os.listdir("/proc") if p.isdigit()
                     and os.stat(f"/proc/{p}").st_uid == os.getuid())
    run, log, _, seconds = sandbox("""
        import os, time
        n = 0
        while True:
            if os.fork() == 0:
                time.sleep(60)
                os._exit(0)
            n += 1
            if n == 5:
                print("forked 5", flush=True)
    """, limits=dataclasses.replace(SMALL, cpu_s=60))
    assert "forked 5" in log  # its first children run
    assert run.limit == ("the solution exceeded its limit on processes and threads of 48 tasks "
                         "(BENCHBOT_SANDBOX_PROCESSES)"), log
    assert seconds < 15, seconds  # the whole sandbox (the sleeping children too) ends with it
    print(f"fork bomb stopped in {seconds:.2f} s (this user has {host_tasks} tasks outside the sandbox)")
    assert host_tasks > SMALL.processes or os.getuid() != 0


def test_writing_past_the_file_size_limit_is_stopped(sandbox):
    run, log, outputs, _ = sandbox("""
        with open("/benchbot/results/big.bin", "wb") as f:
            for _ in range(4):
                f.write(b"x" * 600_000)
    """)
    assert (outputs / "big.bin").stat().st_size == 1 << 20  # cut at the limit
    assert run.limit == "the solution exceeded its file size limit of 1 MiB (BENCHBOT_SANDBOX_FILE_BYTES)", log
    # a program that does not ignore SIGXFSZ, as Python does, is ended by it
    run, log, outputs, _ = sandbox("""
        import subprocess
        subprocess.run(["sh", "-c", "head -c 3000000 /dev/zero > /benchbot/results/dd.bin"])
        raise SystemExit(1)
    """)
    assert run.limit.startswith("the solution exceeded its file size limit"), log


def test_filling_the_outputs_folder_with_many_small_files_is_stopped(sandbox):
    """Each file stays under the file size limit (1 MiB); together they pass the outputs limit (8 MiB): the sandbox is
    stopped within a measurement period and the episode says which limit."""
    from benchbot.solutions.sandbox_limits import disk_bytes

    run, log, outputs, seconds = sandbox("""
        import os, time
        for n in range(100_000):
            with open(os.path.join(os.environ["BENCHBOT_RESULT_LOCATION"] + f".{n}"), "wb") as f:
                f.write(os.urandom(512 << 10))
            time.sleep(0.005)
    """)
    assert run.limit == ("the solution exceeded its limit on its outputs folder of 8 MiB "
                         "(BENCHBOT_SANDBOX_OUTPUTS_BYTES)"), log
    assert 8 << 20 < disk_bytes(outputs) < 64 << 20 and seconds < 60


def test_spinning_past_the_cpu_limit_is_stopped(sandbox):
    run, log, _, seconds = sandbox("""
        while True:
            pass
    """)
    assert run.outcome.returncode == 128 + signal.SIGXCPU
    assert run.limit == "the solution exceeded its CPU time limit of 1 second (BENCHBOT_SANDBOX_CPU_S)", log
    assert seconds < 15


def test_a_solution_within_its_limits_is_not_flagged_and_gets_only_allowed_variables(sandbox):
    env = dict(os.environ, AWS_SECRET_ACCESS_KEY="hunter2", LANG="C.UTF-8", LC_ALL="C.UTF-8", TZ="UTC",
               BENCHBOT_CLIENT_ID="client_1")
    run, log, outputs, _ = sandbox("""
        import json, os, threading
        threads = [threading.Thread(target=lambda: None) for _ in range(8)]
        [t.start() for t in threads]; [t.join() for t in threads]
        json.dump(dict(os.environ), open(os.environ["BENCHBOT_RESULT_LOCATION"], "w"))
    """, env=env)
    assert run.outcome.returncode == 0 and run.limit == "", log
    seen = json.loads((outputs / "results.json").read_text())
    assert "AWS_SECRET_ACCESS_KEY" not in seen and "hunter2" not in json.dumps(seen)
    assert (seen["LANG"], seen["LC_ALL"], seen["TZ"], seen["BENCHBOT_CLIENT_ID"]) == ("C.UTF-8", "C.UTF-8", "UTC",
                                                                                       "client_1")
    assert seen["HOME"] == "/tmp/home" and seen["PATH"] == os.environ["PATH"]
    allowed = {"PATH", "LANG", "LC_ALL", "TZ", "HOME", "PYTHONUNBUFFERED", "BENCHBOT_CLIENT_ID", "MPLBACKEND",
               "BENCHBOT_SUPERVISOR_ADDRESS", "BENCHBOT_RESULT_LOCATION", "BENCHBOT_SHARED_MEMORY", "TERM",
               "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "PYTHONPATH", "COLUMNS", "LINES",
               "PYTHONHASHSEED", "PYTHONDONTWRITEBYTECODE", "LC_CTYPE", "LANGUAGE", "DISPLAY", "XAUTHORITY"}
    assert set(seen) - {"PWD", "SHLVL", "_"} <= allowed, sorted(set(seen) - allowed)


def test_links_left_in_the_outputs_folder_are_dropped_with_a_line(sandbox, tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("ground truth")
    run, log, outputs, _ = sandbox(f"""
        import os
        os.makedirs("/benchbot/results/pictures")
        os.symlink({str(secret)!r}, "/benchbot/results/pictures/gt.json")
        os.symlink("/etc", "/benchbot/results/etc")
        open("/benchbot/results/pictures/real.png", "w").write("png")
    """)
    assert run.outcome.returncode == 0, log
    assert sorted(run.dropped_links) == ["etc", "pictures/gt.json"]
    assert not (outputs / "etc").is_symlink() and not (outputs / "pictures" / "gt.json").is_symlink()
    assert (outputs / "pictures" / "real.png").read_text() == "png" and secret.read_text() == "ground truth"
    assert ("[benchbot] the solution left a symbolic link in its outputs folder, /benchbot/results/pictures/gt.json: "
            "dropped") in log


OWNER = """
import sys, time
from benchbot.solutions.leftovers import owned_tempdir
with owned_tempdir(sys.argv[1]) as folder:
    print(folder, flush=True)
    time.sleep(600)
"""


def test_a_killed_owners_temporary_folders_are_cleaned_and_a_live_ones_kept(tmp_path):
    from benchbot.solutions.leftovers import clean_leftovers

    env = dict(os.environ, TMPDIR=str(tmp_path))
    owners = {prefix: subprocess.Popen([sys.executable, "-c", OWNER, prefix], env=env, stdout=subprocess.PIPE,
                                       text=True) for prefix in ("benchbot-episode-", "benchbot-sandbox-")}
    folders = {prefix: Path(p.stdout.readline().strip()) for prefix, p in owners.items()}
    (tmp_path / "benchbot-episode-old").mkdir()  # no owner file: never judged
    try:
        assert clean_leftovers(tmp_path, shm=None) == []  # both owners live
        owners["benchbot-episode-"].send_signal(signal.SIGKILL)
        owners["benchbot-episode-"].wait()
        assert clean_leftovers(tmp_path, shm=None) == [folders["benchbot-episode-"]]
        assert not folders["benchbot-episode-"].exists() and folders["benchbot-sandbox-"].is_dir()
        assert (tmp_path / "benchbot-episode-old").is_dir()
    finally:
        for p in owners.values():
            p.kill()
            p.wait()


@pytest.mark.skipif(cgroup_root("pids") is None and cgroup_root("memory") is None,
                    reason="no cgroup this process may make: sandboxes here leave none behind")
def test_a_killed_owners_cgroups_are_removed_and_a_live_ones_kept():
    """Each sandbox's cgroups (pids, memory) name their owner's PID: those of a dead owner are removed at the next
    batch start, a live owner's are kept."""
    from benchbot.solutions.leftovers import clean_leftovers
    from benchbot.solutions.sandbox_limits import SandboxCgroups

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    live = SandboxCgroups(SMALL)
    made = list(live.folders.values())
    try:
        assert made
        roots = {folder.parent for folder in made}
        orphans = [root / f"benchbot-sandbox-{dead.pid}-1-000000" for root in roots]
        for folder in orphans:
            folder.mkdir()
        removed = clean_leftovers(Path(tempfile.mkdtemp()), shm=None)
        assert sorted(removed) == sorted(orphans) and not any(f.exists() for f in orphans)
        assert all(folder.is_dir() for folder in made)
    finally:
        live.close()
    assert not any(folder.exists() for folder in made)


@pytest.mark.slow
def test_a_batch_records_its_limits_and_goes_on_past_an_episode_over_one(tmp_path):
    """A real batch: each episode's solution allocates past a small memory limit and ends ``resource_limit`` with
    its reason; the batch runs the next one and records the limits in force and how each is enforced."""
    folder = tmp_path / "solution"
    folder.mkdir()
    (folder / "hog.py").write_text("import numpy as np\nx = np.ones(100_000_000)\n")
    env = dict(os.environ, BENCHBOT_SANDBOX_MEMORY_BYTES="256M", COLUMNS="200")
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--native", "python hog.py", "--envs",
                           "miniroom:1", "--repeat", "2", "--camera-size", "64x48", "--output-dir",
                           str(tmp_path / "runs"), "--json", "--no-tui"], cwd=folder, capture_output=True, text=True,
                          timeout=600, env=env)
    assert proc.stdout, proc.stderr
    result = json.loads(proc.stdout)
    manifest = json.loads((Path(result["run_dir"]) / "manifest.json").read_text())
    reason = "the solution exceeded its memory limit of 256 MiB (BENCHBOT_SANDBOX_MEMORY_BYTES)"
    assert [(e["status"], e["error"]) for e in manifest["episodes"]] == [("resource_limit", reason)] * 2
    limits = manifest["limits"]
    assert (limits["memory_bytes"], limits["processes"], limits["file_bytes"]) == (256 << 20, 512, 1 << 30)
    assert limits["mechanism"]["memory_bytes"].startswith(("cgroup memory limit over the whole sandbox",
                                                           "RLIMIT_DATA, each process"))
    assert limits["mechanism"]["processes"].startswith(("cgroup pids.max", "RLIMIT_NPROC"))
    assert "cgroup_v2" in limits["mechanism"]
    # no host name and no absolute path of this machine anywhere in the manifest; --resume finds the solution again
    text = (Path(result["run_dir"]) / "manifest.json").read_text()
    assert '"hostname"' not in text and str(tmp_path) not in text and os.path.expanduser("~") + "/" not in text
    assert manifest["plan"][0]["cwd"].startswith(("~/", "$RUN_DIR/")), manifest["plan"][0]
    assert manifest["command"][:2] == ["benchbot", "batch"]
    assert manifest["plan"][0]["cwd"] == "$RUN_DIR/../../solution" or manifest["plan"][0]["cwd"].startswith("~/")
    resumed = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--resume", result["run_dir"], "--json",
                              "--no-tui"], cwd=tmp_path, capture_output=True, text=True, timeout=600, env=env)
    manifest = json.loads((Path(result["run_dir"]) / "manifest.json").read_text())
    assert [(e["status"], e["attempts"]) for e in manifest["episodes"]] == [("resource_limit", 2)] * 2, \
        resumed.stderr[-2000:]
