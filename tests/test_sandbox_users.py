"""What the original BenchBot's users need inside the solution sandbox (docs/security.md, "Isolation levels"): an
installed content pack's example runs from its own folder (shown read-only, nothing else of the pack, refused when it
holds a ground truth or a link out of it), the sources of editable installs (``pip install -e``) of the solution's
Python are shown, and the user's display (X11 with its cookie, Wayland) is passed through, or the solution draws off
screen with one line saying why. Everything runs for real: bubblewrap, ``benchbot install``, a real venv with pip's
editable installs, a real Xvfb."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from benchbot.solutions import sandbox_extras as extras
from benchbot.core.registry import Registry

ROOT = Path(__file__).resolve().parents[1]
ISAAC_MINIROOM_1 = ROOT / "tests" / "data" / "original_addons" / "ground_truths_isaac_develop" / "ground_truths" \
    / "miniroom_1.json"
ACTIVE = "semantic_slam:active:ground_truth"

#: The line every sandboxed episode log starts with (where /benchbot/results is on the host): not a note these
#: tests count.
RESULTS_NOTE = "the solution's /benchbot/results is"


def install(*args: str):
    from benchbot.cli.main import app

    return CliRunner().invoke(app, ["install", *args], env={"COLUMNS": "400"})


def sandboxed(argv: list[str], folder: Path, tmp_path: Path, registry, env: dict | None = None):
    """Run ``argv`` in ``folder`` sandboxed against a backend socket that answers nothing; (run, its log's text)."""
    from benchbot.solutions.sandbox import run_sandboxed

    outputs = tmp_path / "outputs"
    outputs.mkdir(exist_ok=True)
    log_path = tmp_path / "sandboxed.log"
    with socket.socket(socket.AF_UNIX) as backend, open(log_path, "w") as log:
        backend.bind(str(tmp_path / "backend.sock"))
        backend.listen()
        try:
            run = run_sandboxed(argv, folder, registry=registry, backend_socket=tmp_path / "backend.sock",
                                address="http://127.0.0.1:10000/", outputs=outputs, result_name="r.json", env=env,
                                log=log, timeout_s=120)
        finally:
            (tmp_path / "backend.sock").unlink()
    return run, log_path.read_text()


# ------------------------------------------------------------------------------------------------ pack examples
PROBE_EXAMPLE = r'''#!/usr/bin/env python3
# An example of a content pack: it looks for the pack's ground truth and the rest of the pack, then submits an empty
# object map through the original API.
import json
import os
from pathlib import Path

from benchbot_api import Agent, BenchBot

here = Path(os.path.abspath(__file__)).parent
pack = here.parents[1]
tries = {"own folder": lambda: sorted(os.listdir(here)),
         "pack ground truth": lambda: open(pack / "ground_truths" / "room_1.json").read()[:20],
         "pack root": lambda: sorted(os.listdir(pack)),
         "examples folder": lambda: sorted(os.listdir(here.parent)),
         "sibling example": lambda: open(here.parent / ".other" / "notes.txt").read(),
         "data directory": lambda: sorted(os.listdir(pack.parents[1])),
         "approvals": lambda: open(pack.parents[1] / "code-approvals.json").read()[:20]}
for what, attempt in tries.items():
    try:
        print("SAW", what, json.dumps(attempt()))
    except OSError as exc:
        print("NOT", what, type(exc).__name__)


class Done(Agent):
    def is_done(self, result):
        return True

    def pick_action(self, observations, actions):
        return None, {}

    def save_result(self, filename, empty_results, fns):
        with open(filename, "w") as f:
            json.dump(empty_results, f)


BenchBot(agent=Done()).run()
'''


def example_pack(tmp_path: Path, name: str, script: str, extra: dict[str, bytes | str] | None = None) -> Path:
    """A content pack in the original add-on layout with the example ``name`` (``python3 .name/name``, as the
    original examples run), its ground truth, a sibling example's folder, and ``extra`` files of the example's
    folder."""
    pack = tmp_path / f"{name}_pack"
    own = pack / "examples" / f".{name}"
    own.mkdir(parents=True)
    (pack / "examples" / f"{name}.yaml").write_text(
        f"name: {name}\ndescription: a test example\nnative_command: python3 .{name}/{name}\n"
        f"container_directory: .{name}\n")
    (own / name).write_text(script)
    for rel, content in (extra or {}).items():
        (own / rel).write_bytes(content if isinstance(content, bytes) else content.encode())
    (pack / "examples" / ".other").mkdir()
    (pack / "examples" / ".other" / "notes.txt").write_text("a sibling example's file")
    (pack / "ground_truths").mkdir()
    shutil.copy(ISAAC_MINIROOM_1, pack / "ground_truths" / "room_1.json")
    return pack


@pytest.mark.slow
def test_an_installed_packs_example_runs_sandboxed_scores_and_sees_nothing_else_of_the_pack(tmp_path, data_dir):
    """``benchbot install`` a pack with an example into a fresh data directory, then ``benchbot batch --example``
    it sandboxed (the default): it runs from its own folder, is scored, and finds neither the pack's ground truth nor
    its other files, the sibling example or anything else of the data directory."""
    pack = example_pack(tmp_path, "probe_example", PROBE_EXAMPLE)
    assert install(str(pack), "--allow-code").exit_code == 0
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--example", "probe_example", "--envs",
                           "miniroom:1", "--task", ACTIVE, "--camera-size", "64x48", "--json", "--no-tui",
                           "--output-dir", str(tmp_path / "runs")], capture_output=True, text=True, timeout=600,
                          cwd=tmp_path, env=dict(os.environ, COLUMNS="200"))
    assert proc.stdout, proc.stderr
    result = json.loads(proc.stdout)
    run_dir = Path(result["run_dir"])
    log = (run_dir / result["episodes"][0]["log"]).read_text()
    assert proc.returncode == 0, (proc.stderr, log)
    assert json.loads((run_dir / "manifest.json").read_text())["sandbox"] == "bwrap"
    assert result["episodes"][0]["status"] == "ok" and result["scores"]["scores"]["OMQ"] == 0.0, log
    assert 'SAW own folder ["probe_example"]' in log, log
    for what in ("pack ground truth", "sibling example", "approvals"):
        assert f"NOT {what} FileNotFoundError" in log, log
    # of the pack and the data directory only the folders leading to the example's own folder exist inside
    assert 'SAW pack root ["examples"]' in log and 'SAW examples folder [".probe_example"]' in log, log
    assert 'SAW data directory ["packs"]' in log, log


def test_a_packs_example_whose_folder_holds_a_ground_truth_runs_only_unsandboxed(tmp_path, data_dir):
    """The original hello_eval_scd keeps copies of ground truths beside its script: its folder, which the sandbox
    would show it, holds a ground truth, so it is refused before anything runs, in one line naming the file and the
    fix; a link out of an example's folder (edited in after the install) is refused the same way."""
    from benchbot.core.errors import UsageError
    from benchbot.solutions.sandbox import check_sandboxable
    from benchbot.solutions.submission import example_submission

    pack = example_pack(tmp_path, "eval_copy", "print('reads its ground truth')\n",
                        {"ground_truth_miniroom_1.json": ISAAC_MINIROOM_1.read_bytes()})
    assert install(str(pack), "--allow-code").exit_code == 0
    reg = Registry()
    submission = example_submission(reg, "eval_copy")
    with pytest.raises(UsageError) as refused:
        check_sandboxable(submission, reg)
    own = data_dir / "packs" / "eval_copy_pack" / "examples" / ".eval_copy"
    assert refused.value.message == (f"the example's folder {own.resolve()} is shown to it in the sandbox, but "
                                     "ground_truth_miniroom_1.json is a ground-truth or layout file of the registry "
                                     "(miniroom_1.json)")  # the BEAR file, byte for byte
    assert "--no-sandbox" in refused.value.hint and "\n" not in refused.value.message
    check_sandboxable(example_submission(reg, "eval_copy"))  # without the registry: the spec alone says nothing

    clean = example_pack(tmp_path / "clean", "linked", "print('hello')\n")
    assert install(str(clean), "--allow-code").exit_code == 0
    installed = data_dir / "packs" / "linked_pack" / "examples" / ".linked"
    (installed / "answers.json").symlink_to(installed.parents[1] / "ground_truths" / "room_1.json")
    reg = Registry()
    assert "linked" not in reg.names("examples")  # the pack changed since its code was allowed: not run at all
    with pytest.raises(UsageError) as linked:  # nor, run by hand from there, shown
        extras.check_pack_example([sys.executable, ".linked/linked"], installed.parent, reg)
    assert "answers.json is a symbolic link leading out of it" in linked.value.message


def test_a_revealed_folder_inside_a_hidden_folder_under_a_shown_one_is_all_that_shows(tmp_path):
    """The data directory inside a shown folder (emptied by a tmpfs): the example's folder is bound into that tmpfs
    before it is made read-only, the example's working folder is made there, and nothing else of the data
    directory shows; neither can be written."""
    from benchbot.solutions.sandbox import SandboxLayout, check_available

    shown = tmp_path / "shown"
    hidden = shown / "data"
    own = hidden / "packs" / "p" / "examples" / ".ex"
    own.mkdir(parents=True)
    (own / "ex.py").write_text("print(1)\n")
    (hidden / "secret.json").write_text("{}")
    (own.parent / "other.yaml").write_text("name: other\n")
    (shown / "visible.txt").write_text("v")
    (tmp_path / "hosts").write_text("127.0.0.1 localhost\n")
    (tmp_path / "out").mkdir()
    (tmp_path / "sock").write_text("")
    layout = SandboxLayout(shown=[shown], hidden=[hidden], outputs=tmp_path / "out", backend_socket=tmp_path / "sock",
                           hosts_file=tmp_path / "hosts", cwd=own.parent, revealed=[own])
    args = layout.bwrap_args()
    at = args.index("--tmpfs", args.index(str(shown)))
    assert args[at:at + 9] == ["--tmpfs", str(hidden), "--ro-bind", str(own), str(own), "--dir", str(own.parent),
                               "--remount-ro", str(hidden)]
    script = (f"ls -A {shown} {hidden} {own.parent} {own}; cat {hidden}/secret.json; touch {hidden}/x {own}/y; "
              "pwd")
    done = subprocess.run([check_available(), *args, "sh", "-c", script], capture_output=True, text=True, timeout=60)
    assert done.stdout.split() == [f"{shown}:", "data", "visible.txt", f"{hidden}:", "packs", f"{own.parent}:", ".ex",
                                   f"{own}:", "ex.py", str(own.parent)], done
    assert "secret.json: No such file" in done.stderr and done.stderr.count("Read-only file system") == 2, done


def test_what_counts_as_ground_truth_in_a_folder_shown_to_a_solution(tmp_path, registry):
    """A file the registry names (a copy of its bytes too), a JSON file of the ground-truth layout in any
    formatting, a link leading out of the folder: each is named; code, a results file and links inside the folder
    are not."""
    known = extras.GroundTruthFiles.of(registry)
    env = registry.get("environments", "miniroom:1")
    bundled = Path(env["map_path"])

    def problem(**files) -> str:
        folder = tmp_path / f"f{len(list(tmp_path.iterdir()))}"
        folder.mkdir()
        (folder / "agent.py").write_text("print('hello')\n")
        for name, make in files.items():
            make(folder / name.replace("__", "."))
        return extras.ground_truth_problem(folder, known)

    results = {"objects": [{"label_probs": [1.0], "centroid": [0, 0, 0], "extent": [1, 1, 1]}], "class_list": ["a"]}
    assert problem(results__json=lambda p: p.write_text(json.dumps(results))) == ""
    assert problem(inner__py=lambda p: p.symlink_to(p.parent / "agent.py")) == ""
    assert problem(copy__bin=lambda p: shutil.copy(bundled, p)) == \
        f"copy.bin is a ground-truth or layout file of the registry ({bundled.name})"
    reformatted = json.dumps(json.loads(bundled.read_text()), indent=1)
    assert problem(gt__txt=lambda p: p.write_text("\n  " + reformatted)) == \
        "gt.txt is a ground truth (a JSON file with ground-truth objects)"
    bare = json.loads(bundled.read_text())["ground_truth"]
    assert "is a ground truth" in problem(bare__json=lambda p: p.write_text(json.dumps(bare)))
    outside = tmp_path / "outside.txt"
    outside.write_text("x")
    assert problem(out__txt=lambda p: p.symlink_to(outside)) == \
        f"out.txt is a symbolic link leading out of it (to {outside})"
    layout = tmp_path / "layout.bin"  # a registry's file in any form, reached by a hard link
    layout.write_bytes(b"\x00binary layout")
    known.inodes[(layout.stat().st_dev, layout.stat().st_ino)] = layout
    assert problem(linked__dat=lambda p: os.link(layout, p)) == \
        "linked.dat is a ground-truth or layout file of the registry (layout.bin)"


# ------------------------------------------------------------------------------------------------ editable installs
def _package(root: Path, name: str, layout: str) -> Path:
    """A project ``root`` with the package ``name`` in the ``src`` or ``flat`` layout, and a file beside it."""
    package = root / ("src" if layout == "src" else "") / name
    package.mkdir(parents=True)
    (package / "__init__.py").write_text(f"WHERE = {layout!r}\n")
    (root / "notes.txt").write_text("a file of the project, not of the package")
    packages = "" if layout == "src" else f'[tool.setuptools]\npackages = ["{name}"]\n'
    (root / "pyproject.toml").write_text('[build-system]\nrequires = ["setuptools>=64"]\n'
                                         'build-backend = "setuptools.build_meta"\n'
                                         f'[project]\nname = "{name}"\nversion = "0.1"\n{packages}')
    return root


@pytest.mark.slow
def test_editable_installs_of_the_solutions_python_are_shown(tmp_path, data_dir, registry):
    """A real venv with pip's editable installs, as the original's installer made of benchbot_api: a src-layout
    project (a ``.pth`` path) and a flat one (a setuptools ``__editable__`` finder) import inside the sandbox, the
    rest of their projects stays out of sight; one whose source lies in BenchBot's data directory is not shown, and
    the log says why in one line."""
    venv = tmp_path / "venv"
    made = subprocess.run([sys.executable, "-m", "venv", str(venv)], capture_output=True, text=True, timeout=300)
    if made.returncode != 0:
        pytest.skip(f"cannot make a venv with pip here: {made.stderr.strip().splitlines()[-1:]}")
    projects = [_package(tmp_path / "srcproj", "bb_editable_src", "src"),
                _package(tmp_path / "flatproj", "bb_editable_flat", "flat"),
                _package(data_dir / "src" / "hiddenproj", "bb_editable_hidden", "src")]
    pip = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "--disable-pip-version-check",
                          *[a for p in projects for a in ("-e", str(p))]], capture_output=True, text=True, timeout=600)
    if pip.returncode != 0:
        pytest.skip(f"pip cannot build the editable installs here (no package index for setuptools?): "
                    f"{pip.stderr.strip().splitlines()[-1:]}")
    site = next(venv.glob("lib/python*/site-packages"))
    kinds = {s.whole for s in extras.editable_sources(site)}
    assert kinds == {True, False}  # both mechanisms are there: a path in a .pth, and a finder's mapping
    folder = tmp_path / "solution"
    folder.mkdir()
    (folder / "use.py").write_text(
        "import os\nimport bb_editable_src, bb_editable_flat\nprint('IMPORTED', bb_editable_src.WHERE, "
        "bb_editable_flat.WHERE)\n"
        f"for p in {[str(p / 'notes.txt') for p in projects[:2]]!r}:\n    print('NOTES', os.path.exists(p))\n"
        "try:\n    import bb_editable_hidden\nexcept ModuleNotFoundError as exc:\n    print('HIDDEN', exc.name)\n")
    run, log = sandboxed([str(venv / "bin" / "python"), "use.py"], folder, tmp_path, registry)
    assert run.outcome.returncode == 0, log
    assert "IMPORTED src flat" in log and log.count("NOTES False") == 2 and "HIDDEN bb_editable_hidden" in log, log
    notes = [line for line in log.splitlines() if line.startswith("[benchbot]") and RESULTS_NOTE not in line]
    hidden_source = (data_dir / "src" / "hiddenproj" / "src").resolve()  # the folder its .pth file names
    assert len(notes) == 1 and notes[0].startswith(f"[benchbot] the editable install's source {hidden_source} "), log
    assert f"is inside {data_dir.resolve()}, which the sandbox hides" in notes[0]


def test_editable_sources_are_read_from_pth_files_egg_links_and_finders(tmp_path):
    """What the two editable mechanisms write, and the legacy ``.egg-link``, read without importing anything."""
    site = tmp_path / "site-packages"
    site.mkdir()
    source, package = tmp_path / "proj", tmp_path / "flat" / "pkg"
    source.mkdir()
    package.mkdir(parents=True)
    (site / "__editable__.proj-1.pth").write_text(f"{source}\n# a comment\nimport sys; sys.exit(1)\n/nowhere\n")
    (site / "old.egg-link").write_text(f"{source}\n.\n")
    (site / "__editable___flat_1_finder.py").write_text(
        f"import sys\nMAPPING: dict[str, str] = {{'pkg': {str(package)!r}}}\nNAMESPACES: dict[str, list[str]] = "
        f"{{}}\nraise SystemExit('never imported')\n")
    found = extras.editable_sources(site)
    assert [(s.path, s.origin.name, s.whole) for s in found] == [
        (source, "__editable__.proj-1.pth", False), (source, "old.egg-link", False),
        (package, "__editable___flat_1_finder.py", True)]
    assert [s.path for s in extras.editable_sources(site, paths=False)] == [package]


# ------------------------------------------------------------------------------------------------ the display
DISPLAY_PROBE = r'''
import os, sys
print("DISPLAY", os.environ.get("DISPLAY"), "XAUTHORITY", os.environ.get("XAUTHORITY"))
try:
    import tkinter
    root = tkinter.Tk()
    print("SCREEN", root.winfo_screenwidth(), root.winfo_screenheight())
    root.destroy()
except Exception as exc:  # tkinter.TclError: no display
    print("NO SCREEN", type(exc).__name__, str(exc).splitlines()[0])
import matplotlib
import matplotlib.pyplot as plt
plt.figure()
print("BACKEND", matplotlib.get_backend().lower())
'''


def _free_display() -> int:
    for number in range(150, 250):
        if not os.path.exists(f"/tmp/.X11-unix/X{number}") and not os.path.exists(f"/tmp/.X{number}-lock"):
            return number
    pytest.skip("no free X11 display number")


@pytest.fixture
def xvfb(tmp_path):
    """A real X server (Xvfb) that needs a cookie: ``(display number, Xauthority file)``."""
    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb is not installed (Debian/Ubuntu: apt-get install xvfb; .ci/run installs it)")
    try:
        import tkinter  # noqa: F401
    except ImportError:
        pytest.skip("this Python has no tkinter, which matplotlib's TkAgg (the original viewer's backend) needs")
    number = _free_display()
    auth = tmp_path / "Xauthority"
    cookie = os.urandom(16)
    auth.write_bytes(extras.write_xauthority([(256, socket.gethostname().encode(), str(number).encode(),
                                               b"MIT-MAGIC-COOKIE-1", cookie)]))
    server = subprocess.Popen(["Xvfb", f":{number}", "-auth", str(auth), "-nolisten", "tcp"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 20
    while not os.path.exists(f"/tmp/.X11-unix/X{number}"):
        if server.poll() is not None or time.monotonic() > deadline:
            server.kill()
            pytest.skip(f"Xvfb :{number} did not start")
        time.sleep(0.05)
    yield number, auth
    server.terminate()
    server.wait(timeout=10)


@pytest.mark.slow
def test_the_users_x11_display_reaches_a_sandboxed_solution(tmp_path, registry, xvfb):
    """The original viewer's case: with ``DISPLAY`` set, Tk connects inside the sandbox (the display's socket and
    its cookie, rewritten for the sandbox's own host name) and matplotlib picks TkAgg. A cookie that does not match
    is refused by the server, so the cookie really is what got it in; ``BENCHBOT_SANDBOX_DISPLAY=0`` turns the
    display off: Agg, with one line saying so."""
    number, auth = xvfb
    folder = tmp_path / "solution"
    folder.mkdir()
    (folder / "probe.py").write_text(DISPLAY_PROBE)
    base = {k: v for k, v in os.environ.items() if k not in ("MPLBACKEND", "WAYLAND_DISPLAY")}
    run, log = sandboxed([sys.executable, "probe.py"], folder, tmp_path,
                         registry, env=dict(base, DISPLAY=f":{number}", XAUTHORITY=str(auth)))
    assert run.outcome.returncode == 0, log
    assert f"DISPLAY :{number} XAUTHORITY {extras.INSIDE_XAUTHORITY}" in log and "SCREEN 1280 1024" in log, log
    assert "BACKEND tkagg" in log and not [line for line in log.splitlines()
                                          if line.startswith("[benchbot]") and RESULTS_NOTE not in line], log
    wrong = tmp_path / "wrong"
    wrong.write_bytes(extras.write_xauthority([(256, b"x", str(number).encode(), b"MIT-MAGIC-COOKIE-1", b"0" * 16)]))
    run, log = sandboxed([sys.executable, "probe.py"], folder, tmp_path, registry,
                         env=dict(base, DISPLAY=f":{number}", XAUTHORITY=str(wrong)))
    assert "NO SCREEN TclError" in log, log
    run, log = sandboxed([sys.executable, "probe.py"], folder, tmp_path, registry,
                         env=dict(base, DISPLAY=f":{number}", XAUTHORITY=str(auth), BENCHBOT_SANDBOX_DISPLAY="0"))
    assert run.outcome.returncode == 0 and "BACKEND agg" in log and "DISPLAY None" in log, log
    assert (f"[benchbot] the display (DISPLAY=:{number}) cannot be passed into the sandbox "
            "(BENCHBOT_SANDBOX_DISPLAY=0)") in log


def test_a_display_that_cannot_be_passed_leaves_the_solution_drawing_off_screen(tmp_path, registry):
    """No X server behind ``DISPLAY`` (the reviewer's ``:93``), or one over the network (which the sandbox cannot
    reach): matplotlib draws with Agg instead of failing on TkAgg, and the log says so in one line."""
    folder = tmp_path / "solution"
    folder.mkdir()
    (folder / "plot.py").write_text("import matplotlib, matplotlib.pyplot as plt\nplt.figure()\n"
                                    "print('BACKEND', matplotlib.get_backend().lower())\n")
    number = _free_display()
    base = {k: v for k, v in os.environ.items() if k not in ("MPLBACKEND", "WAYLAND_DISPLAY")}
    for display, why in ((f":{number}", f"no X11 socket /tmp/.X11-unix/X{number}"),
                         ("lab-host:10.0", "DISPLAY=lab-host:10.0 is reached over the network")):
        run, log = sandboxed([sys.executable, "plot.py"], folder, tmp_path, registry,
                             env=dict(base, DISPLAY=display, MPLBACKEND="TkAgg"))
        assert run.outcome.returncode == 0 and "BACKEND agg" in log, log
        lines = [line for line in log.splitlines() if line.startswith("[benchbot]") and RESULTS_NOTE not in line]
        assert len(lines) == 1 and f"({why}" in lines[0] and lines[0].endswith(
            "the solution draws off screen (MPLBACKEND=Agg)"), log


def test_a_wayland_display_socket_reaches_a_sandboxed_solution(tmp_path, registry):
    """``WAYLAND_DISPLAY``'s socket in ``XDG_RUNTIME_DIR`` is bound in: a client inside connects to it (a socket
    standing in for the compositor here, which answers)."""
    runtime = tmp_path / "run-user"
    runtime.mkdir(mode=0o700)
    heard = []
    with socket.socket(socket.AF_UNIX) as compositor:
        compositor.bind(str(runtime / "wayland-7"))
        compositor.listen()

        def answer():
            conn, _ = compositor.accept()
            with conn:
                heard.append(conn.recv(64))
                conn.sendall(b"welcome")

        thread = threading.Thread(target=answer, daemon=True)
        thread.start()
        folder = tmp_path / "solution"
        folder.mkdir()
        (folder / "client.py").write_text(
            "import os, socket\ns = socket.socket(socket.AF_UNIX)\n"
            "s.connect(os.path.join(os.environ['XDG_RUNTIME_DIR'], os.environ['WAYLAND_DISPLAY']))\n"
            "s.sendall(b'hello'); print('ANSWER', s.recv(64).decode())\n")
        base = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
        run, log = sandboxed([sys.executable, "client.py"], folder, tmp_path, registry,
                             env=dict(base, WAYLAND_DISPLAY="wayland-7", XDG_RUNTIME_DIR=str(runtime)))
        thread.join(timeout=10)
    assert run.outcome.returncode == 0 and "ANSWER welcome" in log and heard == [b"hello"], log


def test_xauthority_entries_round_trip_and_are_rewritten_for_any_host(tmp_path):
    entries = [(256, b"laptop", b"0", b"MIT-MAGIC-COOKIE-1", bytes(range(16))), (0, b"\x7f\0\0\1", b"12", b"", b"")]
    data = extras.write_xauthority(entries)
    assert extras.read_xauthority(data) == entries and extras.read_xauthority(data[:-3]) == entries[:1]
    (tmp_path / "a").write_bytes(data)
    copy = tmp_path / "copy"
    copy.mkdir()
    fake = tmp_path / "X0"
    with socket.socket(socket.AF_UNIX) as server:
        server.bind(str(fake))
        original, extras.X11_SOCKETS = extras.X11_SOCKETS, tmp_path
        try:
            access = extras.display_access({"DISPLAY": ":0", "XAUTHORITY": str(tmp_path / "a")}, copy)
        finally:
            extras.X11_SOCKETS = original
    assert access.binds == [(fake, str(fake)), (copy / "Xauthority", extras.INSIDE_XAUTHORITY)]
    assert extras.read_xauthority((copy / "Xauthority").read_bytes()) == [
        (0xFFFF, b"", b"0", b"MIT-MAGIC-COOKIE-1", bytes(range(16)))]
    assert access.env == {"DISPLAY": ":0", "XAUTHORITY": extras.INSIDE_XAUTHORITY} and access.note == ""


def test_editable_sources_survive_odd_pth_lines_and_finders(tmp_path):
    """A solution's own site-packages may hold anything: a 5,000-character .pth line and a finder whose MAPPING is
    no usable literal are skipped, never a traceback."""
    from benchbot.solutions.sandbox_extras import editable_sources

    (tmp_path / "long.pth").write_text("x" * 5000 + "\n")
    (tmp_path / "__editable___odd_finder.py").write_text("MAPPING = {[1]: 2}\nNAMESPACES = {}\n")
    assert editable_sources(tmp_path) == []
