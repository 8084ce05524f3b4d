"""Where a batch's numbers came from, recorded in the manifest: git revisions, the machine, the exact command
(shell-quoted), every installed distribution's version and the hash of the workspace's lock file
(:func:`collect`, the manifest's ``provenance``), and per episode what its backend was (:func:`backend_facts`, each
record's ``backend``: the simulator's plugin and version, its scene style, the Taichi arch and device it ran on, and
the plugin's settings).

``benchbot batch`` calls :func:`collect` once when it writes the manifest and :func:`backend_facts` after each
episode, in the process that ran it; ``benchbot report`` and ``benchbot leaderboard`` print what they recorded next to
the scores and compare runs on it (:func:`conditions`). Nothing here fails a batch: a missing ``git``, a folder
outside any repository, an unreadable ``/proc`` or a backend that cannot say gives ``None`` for that entry.

The host name is deliberately not recorded: manifests are published with leaderboards, and the CPU model, core
count and memory say what a reader needs to compare wall times.
"""

from __future__ import annotations

import hashlib
import importlib.metadata as md
import os
import platform
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
    third-party versions the batch resolved to (NumPy, SciPy, Taichi, ...), whatever the lock file says."""
    out = {}
    for dist in md.distributions():
        name = (dist.metadata["Name"] or "").lower()
        if name:
            out[name] = dist.version
    return dict(sorted(out.items()))


def command_line(argv: list[str] | None = None) -> str:
    """The command as typed, shell-quoted (``shlex.join``) so that it can be pasted back: ``benchbot batch
    --native 'python my.py' --envs miniroom:1``; the program is named by its file name (``benchbot``), not its
    path, and a run through ``python -m benchbot.cli`` is written so (from ``sys.orig_argv``)."""
    argv = list(sys.argv if argv is None else argv)
    if argv and argv[0].endswith("__main__.py") and getattr(sys, "orig_argv", None):
        argv = list(sys.orig_argv)  # `python -m benchbot.cli ...`: the interpreter's own argv says so
    if argv:
        argv[0] = Path(argv[0]).name
    return shlex.join(argv)


def collect(solution_dirs: list[str]) -> dict:
    """The manifest's ``provenance``: ``{benchbot_git, solution_git: {folder: revision}, machine, command, lock,
    packages}`` (:func:`command_line`, :func:`lock_hash`, :func:`packages`).

    Args:
        solution_dirs: the folders the solutions run in (each plan entry's ``cwd``); each distinct one is asked
            for its git revision.
    """
    source = Path(__file__).resolve().parents[2]
    return {"benchbot_git": git_revision(source),
            "solution_git": {d: git_revision(d) for d in dict.fromkeys(solution_dirs)},
            "machine": machine(), "command": command_line(), "lock": lock_hash(source), "packages": packages()}


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
    for info in sorted(Path("/proc/driver/nvidia/gpus").glob("*/information")):
        try:
            for line in info.read_text(errors="replace").splitlines():
                if line.startswith("Model:"):
                    return line.split(":", 1)[1].strip()
        except OSError:
            pass
    try:
        proc = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True,
                              text=True, timeout=GIT_TIMEOUT_S, check=False)
        return proc.stdout.strip().splitlines()[0] if proc.returncode == 0 and proc.stdout.strip() else None
    except (OSError, subprocess.TimeoutExpired):
        return None


STYLE_SETTING = "BENCHBOT_SIM_STYLE"
"""The setting naming the scene style of environments whose spec names none (:mod:`benchbot.core.settings`)."""


def backend_facts(registry, robot: dict, scenes: list[dict], versions: dict | None = None) -> dict:
    """What an episode's backend was, for the record's ``backend`` (call it in the process that ran the episode,
    after the episode, where the backend initialised its libraries):

    ``{"type", "clock", "plugin", "distribution", "version", "style", "arch", "device", "settings"}``: the robot's
    type; the episode's clock, ``simulated`` or ``wall`` (a real robot: an environment of type ``real``,
    :func:`benchbot.core.robot.episode_clock`); the plugin providing its backend and that plugin's distribution and
    version; the scene style (the scenes' own
    ``style``, else the setting ``BENCHBOT_SIM_STYLE`` when that plugin reads it; absent otherwise); the Taichi
    arch and device (:func:`taichi_device`; absent without Taichi); the effective values of the settings that
    plugin reads (:mod:`benchbot.core.settings`). Never raises: what cannot be told is left out.
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
        owned = {s.name: settings.get(s.name) for s in settings.SETTINGS if s.owner == plugin and not s.secret}
        if owned:
            out["settings"] = owned
        named = [str(s["style"]) for s in scenes if isinstance(s, dict) and s.get("style")]
        if len(named) < len(scenes) and STYLE_SETTING in owned:
            named.append(str(owned[STYLE_SETTING]))
        if named:
            out["style"] = "+".join(sorted(set(named)))
    except Exception:  # noqa: BLE001 - provenance never fails an episode
        pass
    out.update(taichi_device())
    return out
