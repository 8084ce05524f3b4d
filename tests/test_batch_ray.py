"""``benchbot batch --executor ray`` as a lab with a cluster runs it: a two-node Ray cluster addressed on loopback
(Ray itself listens on every interface, whatever ``--node-ip-address`` says: docs/cluster.md), started as
Ray's users start one (``ray start --head``, then ``ray start --address`` on a second node with its own CPU), with
token authentication on, in a Ray temporary folder of the test's own (``RAY_TMPDIR``: nothing here touches another
Ray on the machine). The second node runs in a mount namespace where the batch's run directories do not exist (no
shared file system) and no user namespace can be made (it cannot make the solution sandbox).

Covered: the live table in a pseudo-terminal; attaching as ``ray.init`` does (the cluster ``ray start`` began on
this machine, ``RAY_ADDRESS``, ``--ray-address``, ``ray://`` through Ray Client); one CPU per episode for its whole
life; results shipped back through Ray; sandboxing on a node, and a node that cannot sandbox failing its episode in
one line; a node whose raylet is killed losing only its episode, which runs again on the other node; Ray Client
session servers that die as they start, asked for again (and a session that never comes, in one line); wrong
addresses and Ctrl-C while attaching, in one line. About 3.5 min on a 2-core machine (``uv run pytest
tests/test_batch_ray.py -m slow``: 7 passed in 209 s, 2026-11-29).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from terminal import Terminal  # noqa: E402

pytest.importorskip("ray")

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
SMALL = ["--camera-size", "32x24", "--arch", "cpu"]
RAY = str(Path(sys.executable).with_name("ray"))

#: A native solution: says when it starts and ends and where it runs, whether it sees the paths it is given, and
#: waits ``argv[1]`` seconds on every step. Written into the folder it runs from.
SOLUTION = '''\
import json, os, socket, sys, time
from benchbot_api import ActionResult, Agent, BenchBot

STEP_S = float(sys.argv[1])
print("START", time.time(), "host", socket.gethostname(), flush=True)
for path in sys.argv[2:]:
    print("SEES", path, os.path.exists(path), flush=True)


class Slow(Agent):
    def is_done(self, action_result):
        return action_result != ActionResult.SUCCESS

    def pick_action(self, observations, action_list):
        time.sleep(STEP_S)
        return "move_next", {}

    def save_result(self, filename, empty_results, results_format_fns):
        with open(filename, "w") as f:
            json.dump(empty_results, f)


BenchBot(agent=Slow()).run()
print("END", time.time(), flush=True)
'''


def _listening(port: int) -> bool:
    """Whether a TCP socket listens on ``port`` (IPv4 or IPv6), from ``/proc/net/tcp*`` (state ``0A``)."""
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            rows = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        if any(r.split()[1].rsplit(":", 1)[1] == f"{port:04X}" and r.split()[3] == "0A" for r in rows):
            return True
    return False


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _descendants(pid: int) -> set[int]:
    """``pid``'s descendants now (from /proc)."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                ppid = int(Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(entry))
    out, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in out:
                out.add(child)
                todo.append(child)
    return out


def _raylet_pid(node_manager_port: int) -> int | None:
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                args = Path(f"/proc/{entry}/cmdline").read_bytes().split(b"\0")
            except OSError:
                continue
            if args and args[0].endswith(b"/raylet") and f"--node_manager_port={node_manager_port}".encode() in args:
                return int(entry)
    return None


def _stop(proc: subprocess.Popen) -> None:
    """Stop a ``ray start --block`` (and everything it started): SIGTERM, then SIGKILL to what is left."""
    if proc.poll() is not None:
        return
    family = _descendants(proc.pid)
    try:
        os.killpg(proc.pid, signal.SIGTERM)
    except ProcessLookupError:
        pass
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        pass
    for pid in family | _descendants(proc.pid) | {proc.pid}:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    proc.wait(10)


@dataclass
class Cluster:
    """The test cluster: ``env`` reaches it (``RAY_TMPDIR``, the token), ``runs`` is where batches write (the
    second node does not see it), ``gcs`` and ``client`` are the head's GCS and Ray Client ports."""

    base: Path
    env: dict
    gcs: int
    client: int
    node_b_port: int
    head: subprocess.Popen | None = None
    node_b: subprocess.Popen | None = None
    logs: list = field(default_factory=list)

    @property
    def runs(self) -> Path:
        return self.base / "runs"

    def _start(self, argv: list[str], name: str) -> subprocess.Popen:
        log = self.base / f"{name}.log"
        self.logs.append(log)
        with open(log, "w") as out:
            proc = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                    env=self.env, start_new_session=True)
        deadline = time.monotonic() + 120
        while "block forever" not in log.read_text():
            if proc.poll() is not None or time.monotonic() > deadline:
                _stop(proc)
                pytest.fail(f"ray start ({name}) did not come up:\n{log.read_text()[-3000:]}")
            time.sleep(0.3)
        return proc

    def start_head(self) -> None:
        """The head, and its Ray Client server listening: ``ray start`` says it is up before that server, which
        starts on its own, listens (a loaded machine once refused the first connection). Judged from the kernel's
        table of listening sockets: a probe connection would start a client session of its own."""
        self.head = self._start([RAY, "start", "--head", "--block", "--node-ip-address", "127.0.0.1",
                                 "--port", str(self.gcs), "--ray-client-server-port", str(self.client),
                                 "--dashboard-port", str(_free_port()), "--num-cpus", "1",
                                 "--include-dashboard", "false", "--disable-usage-stats"], "head")
        deadline = time.monotonic() + 60
        while not _listening(self.client):
            if time.monotonic() > deadline:
                pytest.fail(f"the head's Ray Client server never listened on {self.client}:\n{self.diagnostics()}")
            time.sleep(0.3)

    def start_node_b(self) -> None:
        """The second node: one CPU, in a mount namespace where ``runs`` is an empty folder and with user
        namespaces turned off (so bubblewrap cannot make a sandbox there)."""
        from benchbot.solutions.sandbox import bwrap_executable

        self.node_b = self._start([
            bwrap_executable(), "--bind", "/", "/", "--dev-bind", "/dev", "/dev", "--proc", "/proc", "--unshare-pid",
            "--unshare-user", "--disable-userns", "--die-with-parent", "--tmpfs", str(self.runs), "--",
            RAY, "start", "--block", "--address", f"127.0.0.1:{self.gcs}", "--node-ip-address", "127.0.0.1",
            "--num-cpus", "1", "--node-manager-port", str(self.node_b_port), "--disable-usage-stats"], "node_b")

    def ensure_node_b(self) -> None:
        if self.node_b is None or self.node_b.poll() is not None or _raylet_pid(self.node_b_port) is None:
            if self.node_b is not None:
                _stop(self.node_b)
            self.start_node_b()

    def node_b_id(self) -> str:
        """Node B's Ray node id (its raylet's ``--node_id``)."""
        args = Path(f"/proc/{_raylet_pid(self.node_b_port)}/cmdline").read_bytes().split(b"\0")
        return next(a.decode().split("=", 1)[1] for a in args if a.startswith(b"--node_id="))

    def node_b_runs_a_solution(self) -> bool:
        """Whether a solution process runs on node B now (under its raylet)."""
        raylet = _raylet_pid(self.node_b_port)
        for pid in _descendants(raylet) if raylet else ():
            try:
                if b"solution.py" in Path(f"/proc/{pid}/cmdline").read_bytes():
                    return True
            except OSError:
                pass
        return False

    def kill_node_b_raylet(self) -> None:
        pid = _raylet_pid(self.node_b_port)
        assert pid is not None, "node B has no raylet"
        os.kill(pid, signal.SIGKILL)

    def diagnostics(self) -> str:
        """The end of the Ray Client servers' logs on the head (for a failed assertion)."""
        logs = sorted((self.base / "r" / "ray" / "session_latest" / "logs").glob("ray_client_server*.*"))
        return "\n".join(f"--- {log.name}\n{log.read_text(errors='replace')[-1500:]}" for log in logs
                         if log.suffix in (".err", ".out"))

    def session_servers_that_died_starting(self) -> int:
        """How many of Ray Client's session servers died as they started (its proxy logs each one)."""
        log = self.base / "r" / "ray" / "session_latest" / "logs" / "ray_client_server.err"
        return log.read_text(errors="replace").count("SpecificServer startup failed") if log.is_file() else 0

    def stop(self) -> None:
        for proc in (self.node_b, self.head):
            if proc is not None:
                _stop(proc)


@pytest.fixture(scope="module")
def cluster():
    base = Path(tempfile.mkdtemp(prefix="bbray", dir="/tmp"))  # short: Ray's Unix sockets live under it
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    env.update(RAY_TMPDIR=str(base / "r"), RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(32),
               RAY_USAGE_STATS_ENABLED="0",
               RAY_CLIENT_SERVER_CHECK_CHANNEL_TIMEOUT_S="120")  # Ray Client's server starts slowly on a busy 2-core machine
    (base / "r").mkdir()
    (base / "runs").mkdir()
    c = Cluster(base, env, _free_port(), _free_port(), _free_port())
    try:
        c.start_head()
        c.start_node_b()
        yield c
    finally:
        c.stop()
        shutil.rmtree(base, ignore_errors=True)


@pytest.fixture
def solution(tmp_path) -> Path:
    folder = tmp_path / "solution"
    folder.mkdir()
    (folder / "solution.py").write_text(SOLUTION)
    return folder


def _batch(cluster: Cluster, *args: str) -> list[str]:
    return [*BENCHBOT, "batch", "--envs", "miniroom:4", *SMALL, "--no-evaluate", "--output-dir", str(cluster.runs),
            "--executor", "ray", *args]


def _through_ray_client(cluster: Cluster, argv: list[str], env: dict, cwd: Path) -> subprocess.CompletedProcess:
    """Run a batch through Ray Client; once more if no session came within the batch's 60 s (Ray's session server
    died as it started, and the proxy said so too late for the batch's own retries: see the tests of both below), and
    only then."""
    died_before = cluster.session_servers_that_died_starting()
    proc = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, timeout=300)
    if proc.returncode == 2 and "started no session" in proc.stderr \
            and cluster.session_servers_that_died_starting() > died_before:
        proc = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, timeout=300)
    return proc


#: A ``sitecustomize`` for a head whose Ray Client proxy starts, for its first connections, session servers that die
#: as they start, as Ray 2.60's sometimes do (it forks them from a multithreaded process). ``BENCHBOT_TEST_DEATHS``
#: lists how each dies, in order: ``exit`` exits at once (the proxy sees the exit and says the server did not start);
#: ``zombie`` exits while the proxy reads its command line (psutil raises ZombieProcess in the proxy). Each death
#: leaves a file in ``BENCHBOT_TEST_DIED`` (a folder); later connections get real session servers.
SESSIONS_DIE = '''\
import os, subprocess, sys
_ARGV = open("/proc/self/cmdline", "rb").read().split(b"\\0")
if b"ray.util.client.server" in _ARGV and b"--mode=proxy" in _ARGV:
    _popen_init, _popen_poll = subprocess.Popen.__init__, subprocess.Popen.poll

    def _sessions_die(self, args, *rest, **kwargs):
        died = os.environ["BENCHBOT_TEST_DIED"]
        deaths = os.environ["BENCHBOT_TEST_DEATHS"].split(",")
        if isinstance(args, list) and "--mode=specific-server" in args and len(os.listdir(died)) < len(deaths):
            how = deaths[len(os.listdir(died))]
            open(os.path.join(died, f"{len(os.listdir(died))}-{how}"), "w").close()
            args = [sys.executable, "-c", "raise SystemExit(1)"]
            self._benchbot_zombie = how == "zombie"
        _popen_init(self, args, *rest, **kwargs)

    def _poll(self, *args, **kwargs):
        if getattr(self, "_benchbot_zombie", False):  # the proxy's first look: alive; then it has exited, unreaped
            self._benchbot_zombie = False
            os.waitid(os.P_PID, self.pid, os.WEXITED | os.WNOWAIT)
            return None
        return _popen_poll(self, *args, **kwargs)

    subprocess.Popen.__init__, subprocess.Popen.poll = _sessions_die, _poll
'''


@contextlib.contextmanager
def _head_whose_sessions_die(deaths: str):
    """A one-node cluster whose first Ray Client session servers die as :data:`SESSIONS_DIE` says: yields the head
    (its ``env`` reaches it; ``base / "died"`` holds one file per death)."""
    base = Path(tempfile.mkdtemp(prefix="bbray", dir="/tmp"))
    for folder in ("site", "died", "r", "runs"):
        (base / folder).mkdir()
    (base / "site" / "sitecustomize.py").write_text(SESSIONS_DIE)
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    env.update(RAY_TMPDIR=str(base / "r"), RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(32),
               RAY_USAGE_STATS_ENABLED="0", PYTHONPATH=str(base / "site"), BENCHBOT_TEST_DIED=str(base / "died"),
               BENCHBOT_TEST_DEATHS=deaths)
    head = Cluster(base, env, _free_port(), _free_port(), _free_port())
    try:
        head.start_head()
        yield head
    finally:
        head.stop()
        shutil.rmtree(base, ignore_errors=True)


def _run_dir(text: str) -> Path:
    return Path(re.search(r"run directory: (\S+)", text)[1])


def _manifest(run_dir: Path) -> dict:
    return json.loads((run_dir / "manifest.json").read_text())


def _times(run_dir: Path, record: dict) -> tuple[float, float]:
    log = (run_dir / record["log"]).read_text()
    return float(re.search(r"^START (\S+)", log, re.M)[1]), float(re.search(r"^END (\S+)", log, re.M)[1])


@pytest.mark.slow
def test_live_table_one_episode_per_cpu_and_a_node_that_dies(cluster, solution):
    """In a terminal (the live table, the default), with neither --ray-address nor RAY_ADDRESS: the batch attaches
    to the cluster `ray start` began on this machine, as ray.init would. Four episodes on two 1-CPU nodes: both
    nodes work, one episode at a time each (the old blocking event queue lent an episode's CPU to the next one),
    and node B sends its results back although it cannot see the run directory. Once B has finished an episode,
    its raylet is killed in the middle of its next one: that episode is lost, run again on the head and recorded;
    no other episode is stopped, and the batch ends well."""
    cluster.ensure_node_b()
    node_b = cluster.node_b_id()
    before = set(cluster.runs.iterdir())
    argv = _batch(cluster, "--native", "python solution.py 0.15", "--no-sandbox", "--repeat", "4")
    with Terminal(argv, env=cluster.env, cwd=str(solution), columns=120, rows=30) as term:
        run_dir, deadline = None, time.monotonic() + 240
        while True:  # node B has sent back one finished episode and runs its next one
            if run_dir is None:
                found = [p for p in set(cluster.runs.iterdir()) - before if (p / "manifest.json").is_file()]
                run_dir = found[0] if found else None
            records = _manifest(run_dir)["episodes"] if run_dir is not None else []
            if any(r["status"] == "ok" and r["node"].get("id") == node_b for r in records) \
                    and cluster.node_b_runs_a_solution():
                break
            assert term.proc.poll() is None and time.monotonic() < deadline, term.text[-3000:]
            time.sleep(0.2)
        cluster.kill_node_b_raylet()
        assert term.wait(300) == 0, term.text[-3000:]
        text = term.text
    assert re.search(r"Ray: the Ray cluster at \S+ \(ray start on this machine\): 2 nodes, 2 CPUs", text), text[-3000:]
    assert "episodes done" in text and "4 episodes: 4 ok" in text and "Traceback" not in text
    manifest = _manifest(run_dir)
    executor = manifest["executor"]
    assert (executor["name"], executor["source"], executor["started_here"]) == ("ray", "ray start on this machine", False)
    assert node_b in {n["id"] for n in executor["nodes"]} and len(executor["nodes"]) == 2
    records = manifest["episodes"]
    assert {r["executor"] for r in records} == {"ray"} and all(r["status"] == "ok" for r in records)
    lost = [r for r in records if r["lost"]]
    assert len(lost) == 1, records
    assert lost[0]["attempts"] == 2 and lost[0]["lost"][0]["error"] == "its node died"
    assert lost[0]["lost"][0]["node"]["id"] == node_b != lost[0]["node"]["id"]  # run again on the head
    assert all(r["attempts"] == 1 for r in records if not r["lost"])  # no other episode was stopped
    on_b = [r for r in records if r["node"]["id"] == node_b]
    assert on_b, records
    by_node: dict[str, list[tuple[float, float]]] = {}
    for record in records:
        stem = Path(record["results"]).stem  # B's came back through Ray: B cannot see the run directory
        assert (run_dir / record["results"]).is_file() and (run_dir / "trajectories" / f"{stem}.json").is_file()
        by_node.setdefault(record["node"]["id"], []).append(_times(run_dir, record))
    for spans in by_node.values():  # one CPU per node: its episodes one after another
        spans.sort()
        assert all(end <= start for (_, end), (start, _) in zip(spans, spans[1:])), spans
    assert "Raylet is terminated" not in text and "marked dead" not in text  # Ray's messages: in logs/ray.log
    assert (run_dir / "logs" / "ray.log").is_file()


@pytest.mark.slow
def test_sandboxed_episodes_through_ray_client_and_a_node_that_cannot_sandbox(cluster, solution):
    """Sandboxed (the default) through Ray Client (RAY_ADDRESS=ray://...): the episode on the head runs in the
    sandbox (its host name, no ground truth, no run directories); the one on the node where no sandbox can be made
    fails in one line naming the node and the cause."""
    from benchbot.core.registry import get_registry
    from benchbot.solutions.sandbox import hidden_folders

    cluster.ensure_node_b()
    secret = next(str(p) for p in hidden_folders(get_registry()) if p.exists())
    env = {**cluster.env, "RAY_ADDRESS": f"ray://127.0.0.1:{cluster.client}"}
    argv = _batch(cluster, "--native", f"python solution.py 0 {secret} {cluster.runs}", "--repeat", "2")
    proc = _through_ray_client(cluster, argv, env, solution)
    assert proc.returncode == 1, proc.stderr[-3000:] + cluster.diagnostics()
    assert "(RAY_ADDRESS): 2 nodes" in proc.stderr and "Traceback" not in proc.stderr
    run_dir = _run_dir(proc.stderr)
    records = _manifest(run_dir)["episodes"]
    assert len({r["node"].get("id") for r in records}) == 2, [(r["status"], r["error"], r["node"]) for r in records]
    ok = [r for r in records if r["status"] == "ok"]
    failed = [r for r in records if r["status"] != "ok"]
    assert len(ok) == 1 and len(failed) == 1, records
    log = (run_dir / ok[0]["log"]).read_text()
    assert "host benchbot_submission" in log and f"SEES {secret} False" in log and f"SEES {cluster.runs} False" in log
    assert (run_dir / ok[0]["results"]).is_file() and (run_dir / "outputs" / Path(ok[0]["results"]).stem).is_dir()
    error = failed[0]["error"]
    assert failed[0]["status"] == "error" and "\n" not in error
    assert "address" not in failed[0]["node"]  # manifests name no host (BENCHBOT_MANIFEST_LOCAL=1 keeps it)
    assert error.startswith(f"on node {failed[0]['node']['id'][:8]}: "
                            "bubblewrap cannot make the solution sandbox on this machine"), error
    lines = [line for line in proc.stderr.splitlines() if "bubblewrap cannot make" in line]
    assert len(lines) == 2 and all(line.startswith(("[", "miniroom:4: error")) for line in lines), proc.stderr


@pytest.mark.slow
def test_wrong_ray_addresses_fail_at_once_in_one_line(tmp_path):
    port = _free_port()  # nothing listens there
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    base = [*BENCHBOT, "batch", "--example", "hello_passive", "--envs", "miniroom:4", "--output-dir", str(tmp_path),
            *SMALL]
    for argv, extra, where in (
        ([*base, "--executor", "ray", "--ray-address", f"127.0.0.1:{port}"], {}, "--ray-address"),
        ([*base, "--executor", "ray"], {"RAY_ADDRESS": f"127.0.0.1:{port}"}, "RAY_ADDRESS"),
    ):
        t0 = time.monotonic()
        proc = subprocess.run(argv, env={**env, **extra}, capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert lines[0] == f"error: no Ray cluster answers at 127.0.0.1:{port} ({where}): Connection refused", lines
        assert len(lines) == 2 and lines[1].startswith("hint: ") and time.monotonic() - t0 < 30
    proc = subprocess.run([*base, "--executor", "ray", "--ray-address", f"127.0.0.1:{port}"], capture_output=True,
                          env={**env, "RAY_ADDRESS": "127.0.0.1:1"}, text=True, timeout=60)
    assert f"at 127.0.0.1:{port} (--ray-address)" in proc.stderr  # the flag wins over RAY_ADDRESS, as in ray.init
    proc = subprocess.run([*base, "--ray-address", "10.0.0.1:6379"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and proc.stderr.startswith("error: --ray-address is for --executor ray")
    proc = subprocess.run([*base, "--executor", "ray", "--ray-address", "nonsense"], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2 and "is not HOST:PORT" in proc.stderr
    assert not any(tmp_path.iterdir())  # nothing ran: no run directory left behind


@pytest.mark.slow
def test_an_address_that_never_answers_times_out_and_ctrl_c_stops_the_wait(tmp_path):
    """A port that accepts connections but is no Ray cluster: ray.init would wait for minutes, deaf to Ctrl-C."""
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(16)  # the kernel completes handshakes; nothing ever answers
        address = f"127.0.0.1:{silent.getsockname()[1]}"
        code = ("from benchbot.batch.executors import connect_ray\nfrom benchbot.core.errors import UsageError\n"
                f"try:\n    connect_ray({address!r}, timeout_s=3)\nexcept UsageError as exc:\n    print(exc.message)\n")
        t0 = time.monotonic()
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
        assert proc.stdout.strip() == f"the Ray cluster at {address} (--ray-address) did not answer within 3 s"
        assert time.monotonic() - t0 < 30
        argv = [*BENCHBOT, "batch", "--example", "hello_passive", "--envs", "miniroom:4", "--executor", "ray",
                "--ray-address", address, "--output-dir", str(tmp_path), *SMALL]
        with Terminal(argv, columns=100, rows=30) as term:
            time.sleep(8)  # started, and waiting on the cluster
            assert term.proc.poll() is None, term.text
            term.press(b"\x03")
            t0 = time.monotonic()
            assert term.wait(20) == 130, term.text[-2000:]
            assert time.monotonic() - t0 < 10 and "interrupted" in term.text and "Traceback" not in term.text
    assert not any(tmp_path.iterdir())


def test_a_bad_limit_variable_stops_a_ray_batch_before_any_episode(monkeypatch):
    """A node reads BENCHBOT_RAY_EPISODE_BYTES only once its episode has run, and the simulator reads
    BENCHBOT_SCENE_CACHE_BYTES in every episode: run_batch reads both first, so a bad value is one UsageError
    before any episode (or cluster) is touched, not an error at the end of each episode."""
    from benchbot.batch.runner import run_batch
    from benchbot.core.errors import UsageError

    for variable in ("BENCHBOT_RAY_EPISODE_BYTES", "BENCHBOT_SCENE_CACHE_BYTES"):
        monkeypatch.setenv(variable, "lots")
        with pytest.raises(UsageError, match=f"{variable}='lots' is not a"):
            run_batch(None, None, executor="ray")  # stops before it looks at the registry or the batch
        monkeypatch.delenv(variable)


@pytest.mark.slow
def test_ray_client_sessions_that_die_as_they_start_are_asked_for_again(solution):
    """Ray Client's proxy on the head starts a session server per connection; when that server dies as it starts,
    the proxy answers ``ray.init`` with an error after its 30 s grace period. The batch asks for another session,
    up to three tries in all, logs each retry to its ``logs/ray.log``, and runs. Both deaths the proxy reports are
    made here: a server that exits at once, and one that exits while the proxy reads its command line (the zombie of
    a CI run, where the batch used to stop with ``psutil.ZombieProcess``)."""
    with _head_whose_sessions_die("zombie,exit") as head:
        target = f"ray://127.0.0.1:{head.client}"
        argv = _batch(head, "--native", "python solution.py 0", "--no-sandbox")
        proc = subprocess.run(argv, env={**head.env, "PYTHONPATH": "", "RAY_ADDRESS": target}, cwd=solution,
                              capture_output=True, text=True, timeout=400)
        assert proc.returncode == 0 and "1 episode: 1 ok" in proc.stderr, proc.stderr[-3000:] + head.diagnostics()
        assert sorted(p.name for p in (head.base / "died").iterdir()) == ["0-zombie", "1-exit"]
        retries = [line for line in (_run_dir(proc.stderr) / "logs" / "ray.log").read_text().splitlines()
                   if "session server died as it started" in line]
        assert len(retries) == 2, retries
        assert "ZombieProcess" in retries[0] and "(try 2 of 3)" in retries[0], retries
        assert "Starting Ray client server failed" in retries[1] and "(try 3 of 3)" in retries[1], retries


@pytest.mark.slow
def test_a_ray_client_session_that_never_comes_fails_in_one_line_and_the_next_batch_runs(solution):
    """When no session comes within the connection timeout (here 15 s: the proxy's answer for a server that died
    comes later), the batch stops in one line that says what happened and what to do, and the next batch gets a
    session and runs."""
    with _head_whose_sessions_die("exit") as head:
        target = f"ray://127.0.0.1:{head.client}"
        code = ("from benchbot.batch.executors import connect_ray\nfrom benchbot.core.errors import UsageError\n"
                f"try:\n    connect_ray({target!r}, timeout_s=15)\nexcept UsageError as exc:\n"
                "    print(exc.message)\n    print(exc.hint)\n")
        t0 = time.monotonic()
        proc = subprocess.run([sys.executable, "-c", code], env={**head.env, "PYTHONPATH": ""}, capture_output=True,
                              text=True, timeout=120)
        assert time.monotonic() - t0 < 60, proc.stdout + proc.stderr
        message, hint = proc.stdout.strip().splitlines()
        assert message == (f"the Ray Client server at {target} (--ray-address) accepted the connection but started "
                           "no session for this batch within 15 s"), proc.stdout + proc.stderr
        assert hint.startswith("run the batch again") and "ray_client_server*.err" in hint
        # The proxy logs the death only when its poll sees the exit before it reads the process's command line;
        # when the process exits between the two, psutil raises ZombieProcess and nothing is logged: 0 or 1.
        assert [p.name for p in (head.base / "died").iterdir()] == ["0-exit"], head.diagnostics()
        assert head.session_servers_that_died_starting() <= 1, head.diagnostics()
        argv = _batch(head, "--native", "python solution.py 0", "--no-sandbox")
        proc = subprocess.run(argv, env={**head.env, "PYTHONPATH": "", "RAY_ADDRESS": target}, cwd=solution,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0 and "1 episode: 1 ok" in proc.stderr, proc.stderr[-3000:] + head.diagnostics()


@pytest.mark.slow
def test_a_ray_started_for_the_batch_runs_its_episodes_at_normal_priority(tmp_path, monkeypatch):
    """Ray's workers run at nice 15 by default (starved on a busy node); the Ray a batch starts for itself runs them
    at nice 0, as the local executor, and each episode records the value and no host (docs/cluster.md)."""
    monkeypatch.delenv("RAY_worker_niceness", raising=False)
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    proc = subprocess.run([*BENCHBOT, "batch", "--example", "hello_passive", "--envs", "miniroom:1", "--executor",
                           "ray", "--ray-address", "local", "--output-dir", str(tmp_path), "--json", "--no-tui",
                           *SMALL], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    manifest = json.loads((Path(json.loads(proc.stdout)["run_dir"]) / "manifest.json").read_text())
    [episode] = manifest["episodes"]
    assert episode["node"]["niceness"] == 0 and "address" not in episode["node"], episode["node"]
    assert manifest["executor"]["address"] in (None, "local") and all("address" not in n for n in
                                                                       manifest["executor"]["nodes"])
