"""Where a batch's numbers came from, recorded in the manifest: git revisions, the machine, the exact command
(shell-quoted), every installed distribution's version and the hash of the workspace's lock file
(:func:`collect`, the manifest's ``provenance``), and per episode what its backend was (:func:`backend_facts`, each
record's ``backend``: the simulator's plugin and version, its scene style, the Taichi arch and device it ran on, and
the plugin's settings).

``benchbot batch`` calls :func:`collect` once when it writes the manifest and :func:`backend_facts` after each
episode, in the process that ran it; ``benchbot report`` and ``benchbot leaderboard`` print what they recorded next to
the scores and compare runs on it (:func:`benchbot.batch.run_conditions.conditions`). Nothing here fails a batch: a
missing ``git``, a folder outside any repository, an unreadable ``/proc`` or a backend that cannot say gives ``None``
for that entry.

The host name is deliberately not recorded: manifests are published with leaderboards, and the CPU model, core
count and memory say what a reader needs to compare wall times. Nor is any absolute path: a path under the home
folder is written ``~/...``, any other one relative to the run directory, marked ``$RUN_DIR/...``
(:func:`portable_path`); the plan's folders and commands are made local again when a batch is resumed
(:func:`local_plan`). ``BENCHBOT_MANIFEST_LOCAL=1`` (:func:`keep_paths`) keeps both: the host name in each
episode's ``node``, and the paths as they are.
"""

from __future__ import annotations

import hashlib
import importlib.metadata as md
import os
import platform
import re
import shlex
import subprocess
import sys
from pathlib import Path

GIT_TIMEOUT_S = 5.0
"""Seconds a ``git`` query may take before its entry is recorded as ``None``."""


def git_revision(folder: Path | str) -> str | None:
    """The commit checked out in the git work tree containing ``folder``, with ``+dirty`` when tracked files
    differ from it (``"5746a71…+dirty"``); ``None`` when ``folder`` is not in a work tree or ``git`` is missing."""

    def git(*args: str) -> str | None:
        try:
            proc = subprocess.run(["git", "-C", str(folder), *args], capture_output=True, text=True,
                                  timeout=GIT_TIMEOUT_S, check=False)
        except (OSError, subprocess.TimeoutExpired):
            return None
        return proc.stdout.strip() if proc.returncode == 0 else None

    head = git("rev-parse", "HEAD")
    if not head:
        return None
    status = git("status", "--porcelain", "--untracked-files=no")
    return head + ("+dirty" if status else "")


def _cpu_model() -> str | None:
    try:
        for line in Path("/proc/cpuinfo").read_text(errors="replace").splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or None


def _memory_gib() -> float | None:
    try:
        return round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1)
    except (ValueError, OSError, AttributeError):
        return None


def machine() -> dict:
    """``{system, architecture, cpu, cpus, memory_gib}`` of this machine (memory in GiB; ``None`` where unknown)."""
    return {"system": platform.platform(), "architecture": platform.machine() or None, "cpu": _cpu_model(),
            "cpus": os.cpu_count(), "memory_gib": _memory_gib()}


LOCK_FILE = "uv.lock"
"""The workspace's lock file (uv): its SHA-256 names the resolved third-party versions a checkout runs with."""


def lock_hash(source: Path | None = None) -> dict | None:
    """``{"file": path, "sha256": hex}`` of the lock file at the root of BenchBot's checkout (``source``: that
    root); None when BenchBot runs from an installed wheel (no lock file) or it cannot be read."""
    root = source or Path(__file__).resolve().parents[2]
    path = root / LOCK_FILE
    try:
        return {"file": str(path), "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}
    except OSError:
        return None


def packages() -> dict[str, str]:
    """``{distribution name (lower case): version}`` of every distribution installed in this Python, sorted: the
    third-party versions the batch resolved to (NumPy, SciPy, Taichi, ...), whatever the lock file says. The
    ``Name`` and ``Version`` of each distribution's metadata as ``dist.metadata`` gives them, read from its header
    alone (:func:`metadata_fields`: 6 ms for 96 distributions on the 2-core CPU, where ``dist.metadata`` and
    ``dist.version`` parsed each whole file twice, 53 ms)."""
    out = {}
    for dist in md.distributions():
        # the text dist.metadata parses (importlib.metadata.Distribution.metadata)
        text = dist.read_text("METADATA") or dist.read_text("PKG-INFO") or dist.read_text("") or ""
        fields = metadata_fields(text, ("name", "version"))
        name = (fields.get("name") or "").lower()
        if name:
            out[name] = fields.get("version")
    return dict(sorted(out.items()))


#: A line of a header as :mod:`email.feedparser` tells one (its ``headerRE``): a field, a continuation, a separator.
_HEADER_LINE = re.compile(r"^(From |[\041-\071\073-\176]*:|[\t ])")


def metadata_fields(text: str, names: tuple[str, ...]) -> dict[str, str]:
    """``{lower-case name: value}`` of the first header field of each of ``names`` (lower case) in a core metadata
    text (``METADATA``, ``PKG-INFO``: RFC 822 headers, then a blank line and the description), as the standard
    library's e-mail parser reads a field (:mod:`email.feedparser` with the ``compat32`` policy, what
    ``importlib.metadata`` uses): the name before the first ``:`` matched without regard to case, the value with
    its leading blanks removed and its continuation lines (those starting with a space or a tab) appended. Fields
    not found are left out."""
    found: dict[str, str] = {}
    current: str | None = None
    for line in text.splitlines(keepends=True):
        if not _HEADER_LINE.match(line):  # a blank line, or one that is no field: the end of the header
            break
        if line[0] in " \t":
            if current is not None:
                found[current] += line
            continue
        if line.startswith("From "):  # an mbox separator, no field
            current = None
            continue
        key, colon, value = line.partition(":")
        key = key.lower()
        current = key if colon and key in names and key not in found else None
        if current is not None:
            found[current] = value.lstrip(" \t")
    return {key: value.rstrip("\r\n") for key, value in found.items()}


#: The setting that keeps the host name and absolute paths in manifests (``1``); by default neither is written.
PATHS_SETTING = "BENCHBOT_MANIFEST_LOCAL"
#: How a path outside the home folder starts in a manifest: relative to the run directory.
RUN_DIR_MARK = "$RUN_DIR"


def local_node() -> dict:
    """A local episode's ``node``: ``{"hostname"}`` with ``BENCHBOT_MANIFEST_LOCAL=1``, else ``{}``."""
    import socket

    return {"hostname": socket.gethostname()} if keep_paths() else {}


def keep_paths() -> bool:
    """Whether manifests keep the host name (each record's ``node``) and absolute paths
    (``BENCHBOT_MANIFEST_LOCAL=1``)."""
    from benchbot.core import settings

    return (settings.get(PATHS_SETTING) or "").lower() in ("1", "yes", "true", "on")


def portable_path(path: str, run_dir: Path | str) -> str:
    """``path`` as a manifest writes it: unchanged when it is not absolute or :func:`keep_paths`; ``~/rest`` under
    the home folder; else ``$RUN_DIR/<path relative to run_dir>`` (``$RUN_DIR/../../usr/bin/python3``)."""
    if keep_paths() or not os.path.isabs(path):
        return path
    home = os.path.expanduser("~")
    if home not in ("", "/") and (path == home or path.startswith(home.rstrip("/") + "/")):
        return "~" + path[len(home.rstrip("/")):]
    relative = os.path.relpath(path, run_dir)
    return RUN_DIR_MARK if relative == "." else f"{RUN_DIR_MARK}/{relative}"


def local_path(path: str, run_dir: Path | str) -> str:
    """The inverse of :func:`portable_path` on this machine: ``~/...`` and ``$RUN_DIR/...`` made absolute; any other
    text unchanged."""
    if path == "~" or path.startswith("~/"):
        return os.path.expanduser(path)
    if path == RUN_DIR_MARK or path.startswith(RUN_DIR_MARK + "/"):
        return os.path.normpath(os.path.join(str(run_dir), path[len(RUN_DIR_MARK) + 1:]))
    return path


def portable_plan(plan: list[dict], run_dir: Path | str) -> list[dict]:
    """A manifest's ``plan`` (dicts of :class:`~benchbot.batch.plan.EpisodeSpec`) with every absolute path in its
    ``cwd``, ``argv`` and ``container`` made portable (:func:`portable_path`)."""
    out = []
    for entry in plan:
        entry = dict(entry)
        entry["cwd"] = portable_path(str(entry.get("cwd", "")), run_dir)
        entry["argv"] = [portable_path(str(a), run_dir) for a in entry.get("argv") or []]
        if isinstance(entry.get("container"), dict):
            entry["container"] = {k: portable_path(v, run_dir) if isinstance(v, str) else v
                                  for k, v in entry["container"].items()}
        out.append(entry)
    return out


def local_plan(manifest: dict, run_dir: Path | str) -> dict:
    """``manifest`` with its plan's portable paths made local again (:func:`local_path`), for ``--resume``."""
    plan = []
    for entry in manifest.get("plan") or []:
        if isinstance(entry, dict):
            entry = dict(entry)
            if isinstance(entry.get("cwd"), str):
                entry["cwd"] = local_path(entry["cwd"], run_dir)
            if isinstance(entry.get("argv"), list):
                entry["argv"] = [local_path(a, run_dir) if isinstance(a, str) else a for a in entry["argv"]]
            if isinstance(entry.get("container"), dict):
                entry["container"] = {k: local_path(v, run_dir) if isinstance(v, str) else v
                                      for k, v in entry["container"].items()}
        plan.append(entry)
    return {**manifest, "plan": plan}


def portable_command(argv: list[str], run_dir: Path | str) -> list[str]:
    """The manifest's ``command``: ``argv`` with the program named by its file name and every absolute path made
    portable (:func:`portable_path`)."""
    argv = [str(a) for a in argv]
    if argv and not keep_paths():  # `python -m benchbot.cli` runs benchbot/cli/__main__.py
        argv[0] = "benchbot" if argv[0].endswith("__main__.py") else Path(argv[0]).name
    return [argv[0], *(portable_path(a, run_dir) for a in argv[1:])] if argv else []


def command_line(argv: list[str] | None = None, run_dir: Path | str | None = None) -> str:
    """The command as typed, shell-quoted (``shlex.join``) so that it can be pasted back: ``benchbot batch
    --native 'python my.py' --envs miniroom:1``; the program is named by its file name (``benchbot``), not its
    path, and a run through ``python -m benchbot.cli`` is written so (from ``sys.orig_argv``)."""
    argv = list(sys.argv if argv is None else argv)
    if argv and argv[0].endswith("__main__.py") and getattr(sys, "orig_argv", None):
        argv = list(sys.orig_argv)  # `python -m benchbot.cli ...`: the interpreter's own argv says so
    if argv:
        argv[0] = Path(argv[0]).name
    if not keep_paths():  # an absolute path typed (--output-dir /home/me/runs) is written ~/runs
        argv = [argv[0], *(portable_path(a, run_dir or Path.cwd()) for a in argv[1:])] if argv else argv
    return shlex.join(argv)


def collect(solution_dirs: list[str], run_dir: Path | str | None = None) -> dict:
    """The manifest's ``provenance``: ``{benchbot_git, solution_git: {folder: revision}, machine, command, lock,
    packages}`` (:func:`command_line`, :func:`lock_hash`, :func:`packages`).

    Args:
        solution_dirs: the folders the solutions run in (each plan entry's ``cwd``); each distinct one is asked
            for its git revision (named as :func:`portable_path` writes it).
        run_dir: the run directory, for :func:`portable_path` (default: the current folder).
    """
    source = Path(__file__).resolve().parents[2]
    base = Path.cwd() if run_dir is None else run_dir
    lock = lock_hash(source)
    if lock is not None and not keep_paths():
        lock["file"] = LOCK_FILE  # at the root of BenchBot's checkout
    return {"benchbot_git": git_revision(source),
            "solution_git": {portable_path(d, base): git_revision(d) for d in dict.fromkeys(solution_dirs)},
            "machine": machine(), "command": command_line(run_dir=base), "lock": lock, "packages": packages()}


def taichi_device() -> dict:
    """``{"arch", "device"}`` Taichi runs on in this process (``arch``: ``x64``, ``arm64``, ``cuda``...; ``device``:
    the GPU's name for a GPU arch, else the CPU model); ``{}`` when Taichi was not initialised here."""
    ti = sys.modules.get("taichi")
    if ti is None:
        return {}
    try:
        if ti.lang.impl.get_runtime().prog is None:
            return {}
        arch = str(ti.lang.impl.current_cfg().arch).rsplit(".", 1)[-1]
    except Exception:  # noqa: BLE001 - Taichi's internals: whatever they do, provenance never fails a batch
        return {}
    return {"arch": arch, "device": _gpu_name() if arch in ("cuda", "vulkan", "metal", "opengl") else _cpu_model()}


def _gpu_name() -> str | None:
    """The model of the machine's first NVIDIA GPU (:func:`benchbot.batch.gpus.machine_gpus`), None without one."""
    from benchbot.batch.gpus import machine_gpus

    found = machine_gpus()
    return found[0]["name"] if found else None


STYLE_SETTING = "BENCHBOT_SIM_STYLE"
"""The setting naming the scene style of environments whose spec names none (:mod:`benchbot.core.settings`)."""


def _plugins_used_by(registry, plugin: str) -> set[str]:
    """``plugin`` and the plugins whose distributions its distribution requires (not as an extra): e.g.
    ``{'sim_taichi', 'worlds'}``, the simulator building its scenes with the worlds package."""
    from packaging.requirements import InvalidRequirement, Requirement
    from packaging.utils import canonicalize_name

    info = next((p for p in registry.plugins if p.name == plugin), None)
    required = set()
    for line in (md.requires(info.distribution) or []) if info is not None and info.distribution else []:
        try:
            requirement = Requirement(line)
        except InvalidRequirement:
            continue
        if requirement.marker is None or "extra" not in str(requirement.marker):
            required.add(canonicalize_name(requirement.name))
    return {plugin} | {p.name for p in registry.plugins
                       if p.distribution and canonicalize_name(p.distribution) in required}


def backend_facts(registry, robot: dict, scenes: list[dict], versions: dict | None = None) -> dict:
    """What an episode's backend was, for the record's ``backend`` (call it in the process that ran the episode,
    after the episode, where the backend initialised its libraries):

    ``{"type", "clock", "plugin", "distribution", "version", "style", "arch", "device", "settings"}``: the robot's
    type; the episode's clock, ``simulated`` or ``wall`` (a real robot: an environment of type ``real``,
    :func:`benchbot.core.robot.episode_clock`); the plugin providing its backend and that plugin's distribution and
    version; the scene style (the scenes' own
    ``style``, else the setting ``BENCHBOT_SIM_STYLE`` when that plugin, or a plugin it requires, declares it; absent
    otherwise); the Taichi arch and device (:func:`taichi_device`; absent without Taichi); the effective values of
    the settings that plugin declares (:mod:`benchbot.core.settings`, not the secret ones), and of the style
    setting when the style came from it. Never raises: what cannot be told is left out.
    """
    from benchbot.core import settings

    from benchbot.core.robot import episode_clock

    out: dict = {"type": str(robot.get("type", "")), "clock": episode_clock(scenes)}
    try:
        plugin = registry.backend_factories[out["type"]][0]
        out["plugin"] = plugin
        info = next((p for p in registry.plugins if p.name == plugin), None)
        if info is not None and info.distribution:
            out["distribution"] = info.distribution
            out["version"] = (versions or {}).get(info.distribution) or md.version(info.distribution)
        declared = settings.all_settings(registry.plugin_manager)
        owned = {s.name: settings.get(s) for s in declared if s.owner == plugin and not s.secret}
        style = next((s for s in declared if s.name == STYLE_SETTING
                      and s.owner in _plugins_used_by(registry, plugin)), None)
        named = [str(s["style"]) for s in scenes if isinstance(s, dict) and s.get("style")]
        if len(named) < len(scenes) and style is not None:
            owned[STYLE_SETTING] = settings.get(style)
            named.append(str(owned[STYLE_SETTING]))
        if owned:
            out["settings"] = owned
        if named:
            out["style"] = "+".join(sorted(set(named)))
    except Exception:  # noqa: BLE001 - provenance never fails an episode
        pass
    out.update(taichi_device())
    return out
