"""``benchbot doctor``: what works here, with a fix for each problem; exit 0 when the default main job
(``benchbot batch --example semslam_geometric --envs miniroom:1``) can run."""

from __future__ import annotations

import importlib.metadata as md
import importlib.util
import json
import os
import platform
import shutil
import socket
import subprocess
import sys
import tempfile
from dataclasses import asdict, dataclass
from typing import Callable

import typer
from rich.table import Table
from rich.text import Text

from benchbot.cli.common import err, handle_errors, is_tty, out, print_json
from benchbot.core import settings

MAIN_JOB = {"tasks": "semantic_slam:passive:ground_truth", "robots": "carter", "environments": "miniroom:1",
            "evaluators": "omq", "examples": "semslam_geometric", "ground_truths": "miniroom:1"}
MAIN_PLUGINS = ("worlds", "sim_taichi", "task_semslam", "eval_omq")

RENDER_SCRIPT = r"""
import contextlib, json, sys, time
arch = sys.argv[1]
t0 = time.monotonic()
with contextlib.redirect_stdout(sys.stderr):
    if arch == "vulkan":  # sim_taichi renders on cpu/cuda; check that Taichi itself runs a kernel on Vulkan
        import taichi as ti
        ti.init(arch=ti.vulkan, log_level=ti.ERROR)
        got = str(ti.lang.impl.current_cfg().arch).split(".")[-1]
        x = ti.field(ti.f32, shape=8)
        @ti.kernel
        def fill():
            for i in x:
                x[i] = i
        fill()
        result = {"arch": got, "render": "taichi kernel only (sim_taichi renders on cpu/cuda)", "shape": [8]}
    else:
        from benchbot.core.registry import Registry
        reg = Registry()
        robot, env = reg.get("robots", "carter"), reg.get("environments", "miniroom:1")
        backend = reg.backend_factory(robot["type"])(robot, {"arch": arch, "width": 32, "height": 24, "seed": 0})
        backend.load_scene(env, seed=0)
        rgb = backend.observe(["image_rgb"])["image_rgb"]
        got = getattr(getattr(backend, "_renderer", None), "arch", None) or arch
        result = {"arch": str(got), "render": "one 32x24 frame of miniroom:1", "shape": list(rgb.shape)}
        backend.close()
result["seconds"] = round(time.monotonic() - t0, 2)
print(json.dumps(result))
"""


@dataclass
class Check:
    """One finding: ``name``, ``ok``, ``required`` (needed by the default main job), ``detail``, ``fix``."""

    name: str
    ok: bool
    required: bool
    detail: str
    fix: str = ""


def _version(dist: str) -> str:
    try:
        return md.version(dist)
    except md.PackageNotFoundError:
        return ""


def check_python() -> Check:
    v = sys.version_info
    ok = (3, 11) <= v[:2] <= (3, 13)
    return Check("python", ok, True, f"{platform.python_implementation()} {platform.python_version()} ({sys.executable})",
                 "" if ok else "use CPython 3.11-3.13 (Taichi wheels): uv venv --python 3.12")


def check_packages() -> Check:
    names = ["benchbot", "benchbot-worlds", "benchbot-sim-taichi", "benchbot-task-semslam", "benchbot-eval-omq", "taichi",
             "numpy", "scipy", "pluggy", "jsonschema"]
    versions = {n: _version(n) or "missing" for n in names}
    missing = [n for n in names[:5] if versions[n] == "missing"]
    plugins = ", ".join(f"{n.removeprefix('benchbot-')} {versions[n]}" for n in names[1:5])
    libraries = ", ".join(f"{n} {versions[n]}" for n in names[5:])
    detail = f"benchbot {versions['benchbot']}; plugins of the main job: {plugins}; libraries: {libraries}"
    return Check("packages", not missing, True, detail,
                 f"install them: benchbot install {' '.join(missing)}  (in the repo: uv sync)" if missing else "")


def check_plugins() -> list[Check]:
    from benchbot.core.registry import Registry

    reg = Registry()
    failed = [p for p in reg.plugins if p.status == "failed"]
    problems = sum(len(p.problems) for p in reg.plugins)
    loaded = [p.name for p in reg.plugins if p.status == "loaded"]
    checks = [Check("plugins", not failed, False,
                    f"loaded: {', '.join(loaded) or 'none'}" + "".join(f"; {p.name} FAILED: {p.error}" for p in failed)
                    + (f"; {problems} spec(s) skipped" if problems else ""),
                    "see `benchbot plugins` for the errors; reinstall or uninstall the broken plugin" if failed or problems else "")]
    missing_plugins = [n for n in MAIN_PLUGINS if n not in loaded]
    missing = [f"{kind[:-1]} {name}" for kind, name in MAIN_JOB.items() if name not in reg.entries[kind]]
    checks.append(Check("main-job content", not missing and not missing_plugins, True,
                        "task, robot, environment, ground truth, evaluator and example of the main job are installed"
                        if not missing and not missing_plugins else f"missing: {', '.join(missing_plugins + missing)}",
                        "" if not missing and not missing_plugins else
                        "install benchbot-worlds, benchbot-sim-taichi, benchbot-task-semslam and benchbot-eval-omq (in the repo: "
                        "uv sync); "
                        "check BENCHBOT_DISABLE_PLUGINS"))
    return checks


def check_render(arch: str, timeout_s: float) -> Check:
    required = arch == "cpu"
    fixes = {"cpu": "reinstall taichi (uv pip install --reinstall taichi); see the error above",
             "cuda": "optional (the CPU is the default): for GPU rendering install an NVIDIA driver with CUDA "
                     "(nvidia-smi must work)",
             "vulkan": "optional (the CPU is the default; the simulator does not render on Vulkan): install a Vulkan "
                       "driver (vulkaninfo must work)"}
    # a file, not -c: Taichi reads the kernels' source code
    with tempfile.TemporaryDirectory(prefix="benchbot-doctor-") as tmp:
        script = os.path.join(tmp, "render_check.py")
        with open(script, "w") as f:
            f.write(RENDER_SCRIPT)
        try:
            proc = subprocess.run([sys.executable, script, arch], capture_output=True, text=True,
                                  timeout=timeout_s, env={**os.environ, "TI_LOG_LEVEL": "error"})
        except subprocess.TimeoutExpired:
            proc = None
    if proc is None:
        return Check(f"taichi {arch}", False, required, f"no frame within {timeout_s:.0f} s",
                     f"retry with --timeout {int(timeout_s * 3)} (the first run compiles kernels)")
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or [f"exit code {proc.returncode}"])[-1]
        return Check(f"taichi {arch}", False, required, f"failed: {last[:200]}", fixes[arch])
    try:
        result = json.loads(proc.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return Check(f"taichi {arch}", False, required, "no result printed", fixes[arch])
    if arch != "cpu" and arch not in result["arch"]:
        fell_back = "the CPU" if result["arch"] in ("x64", "arm64", "cpu") else result["arch"]
        return Check(f"taichi {arch}", False, False, f"no {arch.upper() if arch == 'cuda' else arch.title()} device "
                     f"(Taichi ran on {fell_back} instead)", fixes[arch])
    return Check(f"taichi {arch}", True, required, f"{result['render']} in {result['seconds']} s")


def check_gpu() -> Check:
    smi = shutil.which("nvidia-smi")
    if not smi:
        return Check("gpu", False, False, "no nvidia-smi: no NVIDIA GPU/driver visible", "optional: the simulator runs on the CPU")
    try:
        proc = subprocess.run([smi, "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"],
                              capture_output=True, text=True, timeout=15)
    except subprocess.TimeoutExpired:
        return Check("gpu", False, False, "nvidia-smi timed out", "check the NVIDIA driver")
    ok = proc.returncode == 0 and proc.stdout.strip() != ""
    return Check("gpu", ok, False, "; ".join(proc.stdout.strip().splitlines()) if ok else (proc.stderr.strip() or "nvidia-smi failed")[:200],
                 "" if ok else "reinstall or load the NVIDIA driver")


def check_module(name: str, label: str, fix: str) -> Check:
    found = [m for m in name.split("|") if importlib.util.find_spec(m) is not None]
    return Check(label, bool(found), False, f"importable: {', '.join(found)}" if found else f"{' or '.join(name.split('|'))} not importable",
                 "" if found else fix)


def _pyc_header_fresh(header: bytes, source: os.stat_result) -> bool:
    """Whether a ``.pyc``'s 16-byte header (PEP 552: magic, flags, then the source's modification time and size, or
    a hash Python checks itself) is this Python's and matches ``source``'s stat."""
    if len(header) < 16 or header[:4] != importlib.util.MAGIC_NUMBER:
        return False
    flags = int.from_bytes(header[4:8], "little")
    if flags & 1:  # hash-based
        return True
    return (int.from_bytes(header[8:12], "little") == int(source.st_mtime) & 0xFFFFFFFF
            and int.from_bytes(header[12:16], "little") == source.st_size & 0xFFFFFFFF)


def runs_from_source(modules: "list | None" = None) -> list[str]:
    """The source files of ``modules`` (default: every module this process has imported) that have no up-to-date
    compiled bytecode (``__pycache__/*.pyc``, or under ``sys.pycache_prefix``): their import compiles them again.
    A ``.pyc`` is up to date when its header has this Python's magic number and the source's modification time and
    size (or is hash-based, checked by Python itself); modules without a ``.py`` source (built in, extensions,
    frozen) are left out."""
    out = []
    for module in list(sys.modules.values()) if modules is None else modules:
        source = getattr(module, "__file__", None) or ""
        if not source.endswith(".py"):
            continue
        try:
            cached, info = importlib.util.cache_from_source(source), os.stat(source)
            with open(cached, "rb") as pyc:
                header = pyc.read(16)
        except (OSError, NotImplementedError, ValueError):
            out.append(source)
            continue
        if not _pyc_header_fresh(header, info):
            out.append(source)
    return out


#: Fewer modules than this without bytecode (a checkout's files edited since it was compiled) cost milliseconds.
FEW_FROM_SOURCE = 50


def _pyc_writable(source: str) -> bool:
    """Whether Python can write the compiled bytecode of ``source``: its cache folder is writable, or (not made yet)
    the folder above it is."""
    folder = os.path.dirname(importlib.util.cache_from_source(source))
    return os.access(folder if os.path.isdir(folder) else os.path.dirname(folder), os.W_OK)


def check_bytecode() -> Check:
    """Whether this process's modules (a command's: the CLI, the registry, NumPy, Typer, Rich, Pydantic) ran from
    compiled bytecode. Where Python may not write it (``PYTHONDONTWRITEBYTECODE``, or a folder it cannot write),
    every command compiles the missing ones again (docs/performance.md)."""
    missing = runs_from_source()
    if not missing:
        return Check("bytecode", True, False, f"the {len(sys.modules)} modules of a command load compiled bytecode")
    if not sys.flags.dont_write_bytecode and all(_pyc_writable(f) for f in missing):
        return Check("bytecode", True, False, f"{len(missing)} modules have no compiled bytecode yet: Python writes it "
                     "on their first import")
    if len(missing) < FEW_FROM_SOURCE:
        return Check("bytecode", True, False, f"{len(missing)} modules a command imports are compiled again in every "
                     f"process (files edited since they were compiled: milliseconds)")
    why = "PYTHONDONTWRITEBYTECODE is set" if sys.flags.dont_write_bytecode else "their folders are not writable"
    return Check("bytecode", False, False,
                 f"{len(missing)} modules a command imports have no up-to-date compiled bytecode and {why}: every "
                 f"command compiles them again (docs/performance.md)", _compile_fix(missing))


def _compile_fix(missing: list[str]) -> str:
    """The fix for source files ``missing`` compiled bytecode: ``uv sync --compile-bytecode``, or ``compileall`` of
    their folders (a site-packages folder as a whole; three named at most)."""
    folders = sorted({f.split("/site-packages/")[0] + "/site-packages" if "/site-packages/" in f
                      else os.path.dirname(f) for f in missing})
    return (f"run `uv sync --compile-bytecode` once, or `{os.path.basename(sys.executable)} -m compileall -q "
            f"{' '.join(folders[:3])}{' …' if len(folders) > 3 else ''}`")


#: Modules the installed example solutions import and a command does not: SciPy's ``ndimage`` (``semslam_geometric``'s
#: clustering, with what it loads: SciPy's array-API layer, ``scipy.special``).
SOLUTION_MODULES = ("scipy.ndimage",)


def check_solution_bytecode() -> Check:
    """Whether the modules that sandboxed solutions import beyond a command's (:data:`SOLUTION_MODULES`, imported
    here, with what they load) have compiled bytecode. A sandboxed solution sees this Python's folders read-only, so
    it can never write bytecode: a module without it is compiled again in every episode (docs/service.md, *What is
    left*: bytecode). Where this process may write bytecode, importing them here writes it, and the check then
    passes."""
    before = set(sys.modules)
    for name in SOLUTION_MODULES:
        try:
            importlib.import_module(name)
        except ImportError:
            continue
    loaded = [sys.modules[n] for n in sorted(set(sys.modules) - before)] or \
        [m for n, m in list(sys.modules.items()) if any(n == r or n.startswith(r + ".") for r in SOLUTION_MODULES)]
    missing = runs_from_source(loaded)
    if not missing:
        return Check("solution bytecode", True, False, f"the {len(loaded)} modules that sandboxed solutions import "
                     f"beyond a command's ({', '.join(SOLUTION_MODULES)}) load compiled bytecode")
    return Check("solution bytecode", False, False,
                 f"{len(missing)} modules that sandboxed solutions import ({', '.join(SOLUTION_MODULES)} and what it "
                 "loads) have no compiled bytecode, which a sandboxed solution cannot write: every episode compiles "
                 "them again", _compile_fix(missing))


def check_containers() -> Check:
    """Whether a container engine answers (the one containerised solutions use: Docker where its daemon answers, else
    Podman) and whether the base image of containerised solutions is there (not required)."""
    from benchbot.core.errors import UsageError
    from benchbot.solutions.container_base import BASE_TAG
    from benchbot.solutions.container_engine import container_engine, engine_facts

    try:
        tool = container_engine()
    except UsageError as exc:
        return Check("containers", False, False, exc.message, f"optional (containerised solutions): {exc.hint}")
    base = subprocess.run([tool, "image", "inspect", BASE_TAG], capture_output=True, timeout=60).returncode == 0
    return Check("containers", True, False, f"{engine_facts(tool).describe()} answers; base image {BASE_TAG} "
                 f"{'present' if base else 'missing'}", "" if base else "make the base image: benchbot container-base")


def check_sandbox() -> Check:
    """Whether the solution sandbox can be made here (required: the main job runs its example sandboxed)."""
    from benchbot.core.errors import UsageError
    from benchbot.solutions.sandbox import bwrap_version, check_available

    try:
        bwrap = check_available()
    except UsageError as exc:
        return Check("sandbox", False, True, exc.message, exc.hint)
    return Check("sandbox", True, True, f"solutions run sandboxed with {bwrap_version(bwrap)}")


def check_port(port: int = 10000) -> Check:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind(("127.0.0.1", port))
            return Check(f"port {port}", True, False, f"127.0.0.1:{port} is free")
        except OSError as exc:
            return Check(f"port {port}", False, False, f"127.0.0.1:{port} is in use ({exc.strerror})",
                         "stop what listens there (e.g. another `benchbot run`) or use `benchbot run --port 0`")


def check_data_dir() -> Check:
    from benchbot.packs.pack_layout import data_dir

    path = data_dir()
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path, prefix=".doctor-"):
            pass
        return Check("data directory", True, False, f"{path} is writable")
    except OSError as exc:
        return Check("data directory", False, False, f"{path}: {exc.strerror or exc}",
                     "set BENCHBOT_DATA_DIR (or XDG_DATA_HOME) to a writable folder")


def check_settings() -> Check:
    """Whether every setting is well declared and has a valid value (not required: a bad one fails only what reads
    it): :func:`benchbot.core.settings.problems`."""
    found = settings.problems()
    if not found:
        return Check("settings", True, False, f"{len(settings.all_settings())} settings, each with a valid value "
                     "(the table below)")
    return Check("settings", False, False, "; ".join(found), "set a valid value or unset it; a plugin named must fix "
                 "its benchbot_settings (docs/plugin-guide.md, Settings)")


def run_checks(render: bool = True, timeout_s: float = 180.0, on_check: Callable[[str], None] = lambda _: None
               ) -> list[Check]:
    """Every check, in order (renders run in one subprocess per arch, each limited to ``timeout_s`` seconds);
    ``on_check`` is told what is checked next, as a phrase ("the solution sandbox")."""
    def step(what: str, check: Callable[[], "Check | list[Check]"]) -> list[Check]:
        on_check(what)
        result = check()
        return result if isinstance(result, list) else [result]

    checks = step("Python", check_python) + step("the installed packages", check_packages)
    checks += step("the plugins", check_plugins)
    if render:
        for arch in ("cpu", "cuda", "vulkan"):
            limit = timeout_s if arch == "cpu" else min(timeout_s, 90.0)
            what = "one kernel run" if arch == "vulkan" else "one rendered frame"
            checks += step(f"Taichi on {arch}: {what} (the first run compiles kernels: up to {limit:.0f} s)",
                           lambda arch=arch, limit=limit: check_render(arch, limit))
    for what, check in (
        ("the GPU", check_gpu),
        ("ROS 2", lambda: check_module("rclpy|cyclonedds", "ros",
                                       "optional (real robots): install ROS 2 (rclpy) or `pip install cyclonedds`")),
        ("the solution sandbox", check_sandbox), ("container engines", check_containers),
        ("Ray", lambda: check_module("ray", "ray", "optional (distributed batches): benchbot install ray")),
        ("port 10000", lambda: check_port(10000)), ("the data directory", check_data_dir),
        ("the settings", check_settings), ("compiled bytecode", check_bytecode),
        ("the solutions' compiled bytecode", check_solution_bytecode),
    ):
        checks += step(what, check)
    return checks


def register(app: typer.Typer) -> None:
    @app.command("doctor")
    @handle_errors
    def doctor(
        as_json: bool = typer.Option(False, "--json", help="Print JSON: {ok, checks: [{name, ok, required, detail, fix}], "
                                     "settings: [{name, value, source, owner, meaning, problem}]}."),
        render: bool = typer.Option(True, "--render/--no-render", help="Render one frame per Taichi backend (subprocesses)."),
        timeout: float = typer.Option(180.0, "--timeout", min=1.0, help="Seconds each render may take."),
    ) -> None:
        """Check this machine: Python and packages, plugins, Taichi backends (one rendered frame each), GPU, ROS,
        the solution sandbox (bubblewrap), Docker/Podman, Ray, port 10000, the data directory; and show BenchBot's settings (environment variables)
        with their effective values and where each comes from. Exit code 0 when the default main job can run."""
        if not is_tty():  # a log or a pipe: a plain line per check as it starts (on stderr; --json's on stdout)
            checks = run_checks(render, timeout,
                                on_check=lambda what: err.print(f"checking {what} …", highlight=False, markup=False))
        elif as_json:
            checks = run_checks(render, timeout)
        else:
            with err.status("checking …", spinner="dots") as status:
                checks = run_checks(render, timeout, on_check=lambda what: status.update(f"checking {what} …"))
        ok = all(c.ok for c in checks if c.required)
        if as_json:
            print_json({"ok": ok, "checks": [asdict(c) for c in checks], "settings": settings.effective()})
        else:
            table = Table("check", "", "detail", "fix")
            for c in checks:
                mark = "[green]ok[/]" if c.ok else ("[red]FAIL[/]" if c.required else "[yellow]no[/]")
                table.add_row(c.name, mark, c.detail, c.fix)
            out.print(table)
            shown = Table("setting", "value", "from", "read by", "meaning")
            for row in settings.effective():
                value = "" if row["value"] is None else row["value"]
                where = row["source"] + (f" (invalid: {row['problem']})" if row["problem"] else "")
                shown.add_row(*(Text(str(v)) for v in (row["name"], value, where, row["owner"], row["meaning"])))
            out.print(shown)
            out.print("[green]the main job can run here[/]" if ok else "[red]the main job cannot run here: see the FAIL rows[/]")
        if not ok:
            raise typer.Exit(1)
