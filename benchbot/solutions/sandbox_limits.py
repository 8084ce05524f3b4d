"""What a sandboxed solution may use of the machine, how it is enforced, and how an episode that went past a limit is
told apart (docs/security.md, "Resource limits").

Every limit is a kernel resource limit that the sandbox's first process (:mod:`benchbot.solutions.socket_relay`) sets on
the solution's process, inside the sandbox, before it starts (``setrlimit`` in ``preexec_fn``; soft and hard, and the
solution holds no capability to raise them):

* memory: a cgroup's memory limit over the whole sandbox where this process may make one (:class:`SandboxCgroups`:
  cgroup v1's ``memory.limit_in_bytes``, and ``memory.memsw.limit_in_bytes`` where swap is accounted, or v2's
  ``memory.max`` and ``memory.swap.max``), beside ``RLIMIT_DATA`` of each process
  (:data:`~benchbot.core.limits.SANDBOX_MEMORY_BYTES`; why not ``RLIMIT_AS``: see its docstring). Past the cgroup's
  limit the kernel's OOM killer ends a process of the sandbox, which the cgroup counts (``oom_kill``);
* processes: a cgroup's ``pids.max`` over the whole sandbox where this process may make one (cgroup v1's ``pids``,
  as root on most machines; v2's where delegated), else ``RLIMIT_NPROC``
  (:data:`~benchbot.core.limits.SANDBOX_PROCESSES`). ``RLIMIT_NPROC`` counts tasks per user and user namespace: set
  inside the sandbox's own user namespace it counts the sandbox's tasks, not the host's processes of the same user;
  but the kernel never applies it to root (user id 0 outside the namespace), which is why the cgroup comes first;
* the size of any one file it writes: ``RLIMIT_FSIZE`` (:data:`~benchbot.core.limits.SANDBOX_FILE_BYTES`), beside
  the size-capped tmpfs of its ``/tmp`` (:data:`~benchbot.core.limits.SANDBOX_TMP_BYTES`);
* CPU time of each process: ``RLIMIT_CPU`` (:data:`~benchbot.core.limits.SANDBOX_CPU_S`; ``SIGXCPU``, then
  ``SIGKILL`` a second later);
* the disk its outputs folder takes, all files together: measured while it runs (:func:`outputs_watch`,
  :data:`~benchbot.core.limits.SANDBOX_OUTPUTS_BYTES`), the sandbox stopped past it.

The cgroups are made in the hierarchy this process may write (cgroup v1's ``memory`` and ``pids``, or a delegated
cgroup v2); where none can be made, the rlimits stand alone, and the manifest records which mechanism held each
limit (:meth:`SandboxLimits.record`).

How an episode past a limit is recognised (:func:`exceeded`): the cgroup's ``pids.events`` (forks refused), the
signal that ended it (``SIGXCPU``: CPU time; ``SIGXFSZ``: file size), the memory cgroup's OOM kills, a file of its outputs folder exactly at the
file size limit (a write past it was refused), or, when it failed, the last lines of its log naming the failure the
limit causes (``MemoryError``, "Cannot allocate memory"; ``EAGAIN`` from ``fork``, "can't start new thread";
``EFBIG``). A solution can fake the log lines, but that only turns its own failed episode into ``resource_limit``.
"""

from __future__ import annotations

import os
import re
import signal
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from benchbot.core.limits import (SANDBOX_CPU_S, SANDBOX_FILE_BYTES, SANDBOX_MEMORY_BYTES, SANDBOX_OUTPUTS_BYTES,
                                  SANDBOX_PROCESSES, SANDBOX_TMP_BYTES, Limit)

#: Bytes of the end of an episode's log searched for the failure a limit causes.
LOG_TAIL_BYTES = 64 << 10

_MEMORY = re.compile(r"MemoryError|Unable to allocate|Cannot allocate memory|std::bad_alloc|out of memory")
_PROCESSES = re.compile(r"Resource temporarily unavailable|can't start new thread|fork: retry|\[Errno 11\]")
_FILE = re.compile(r"File too large|\[Errno 27\]")


@dataclass(frozen=True)
class SandboxLimits:
    """The limits of one sandboxed solution (by default the variables of the ``SANDBOX_*`` limits': :meth:`current`; a
    challenge may give its own)."""

    memory_bytes: int
    processes: int
    file_bytes: int
    cpu_s: int
    tmp_bytes: int
    outputs_bytes: int = SANDBOX_OUTPUTS_BYTES.default

    @classmethod
    def current(cls) -> "SandboxLimits":
        """The limits the environment sets now (each variable's default when unset).

        Raises:
            UsageError: a variable is not a valid value (one line naming it)."""
        return cls(SANDBOX_MEMORY_BYTES.value(), SANDBOX_PROCESSES.value(), SANDBOX_FILE_BYTES.value(),
                   int(SANDBOX_CPU_S.value()), SANDBOX_TMP_BYTES.value(), SANDBOX_OUTPUTS_BYTES.value())

    def relay_args(self) -> list[str]:
        """:mod:`benchbot.solutions.socket_relay`'s ``--rlimit`` arguments setting them on the solution."""
        limits = [("DATA", self.memory_bytes, self.memory_bytes), ("NPROC", self.processes, self.processes),
                  ("FSIZE", self.file_bytes, self.file_bytes), ("CPU", self.cpu_s, self.cpu_s + 1)]
        return [arg for name, soft, hard in limits for arg in ("--rlimit", f"{name}={soft}:{hard}")]

    def record(self) -> dict:
        """What a manifest records (``limits``): every value and how each is enforced on this host."""
        return {"memory_bytes": self.memory_bytes, "processes": self.processes, "file_bytes": self.file_bytes,
                "cpu_s": self.cpu_s, "tmp_bytes": self.tmp_bytes, "outputs_bytes": self.outputs_bytes, "mechanism": {
                    "memory_bytes": memory_mechanism(),
                    "processes": processes_mechanism(),
                    "file_bytes": "RLIMIT_FSIZE, each file",
                    "cpu_s": "RLIMIT_CPU, each process", "tmp_bytes": "tmpfs size of the sandbox's /tmp",
                    "outputs_bytes": "the outputs folder's total, measured while the solution runs",
                    "cgroup_v2": cgroup_v2()}}

    def reason(self, which: str) -> str:
        """The one-line reason of an episode past the limit ``which`` (``memory``, ``processes``, ``file``,
        ``cpu``, ``outputs``)."""
        limit, what = {"memory": (SANDBOX_MEMORY_BYTES, "memory limit"),
                       "processes": (SANDBOX_PROCESSES, "limit on processes and threads"),
                       "file": (SANDBOX_FILE_BYTES, "file size limit"),
                       "cpu": (SANDBOX_CPU_S, "CPU time limit"),
                       "outputs": (SANDBOX_OUTPUTS_BYTES, "limit on its outputs folder")}[which]
        value = {"memory": self.memory_bytes, "processes": self.processes, "file": self.file_bytes,
                 "cpu": self.cpu_s, "outputs": self.outputs_bytes}[which]
        return f"the solution exceeded its {what} of {_describe(limit, value)} ({limit.env})"


def _describe(limit: Limit, value: int) -> str:
    return limit.describe(value)


def processes_mechanism() -> str:
    """How the processes limit is enforced here, for the manifest."""
    if cgroup_root("pids") is not None:
        return "cgroup pids.max over the whole sandbox (processes and threads)"
    if os.getuid() == 0:
        return "RLIMIT_NPROC in the sandbox's user namespace: NOT enforced (root is exempt; no writable pids cgroup)"
    return "RLIMIT_NPROC in the sandbox's user namespace (processes and threads)"


def memory_mechanism() -> str:
    """How the memory limit is enforced here, for the manifest."""
    if cgroup_root("memory") is not None:
        return "cgroup memory limit over the whole sandbox, and RLIMIT_DATA of each process"
    return "RLIMIT_DATA, each process (no writable memory cgroup)"


def cgroup_root(controller: str) -> Path | None:
    """The folder of this process's cgroup in a hierarchy with ``controller`` (``pids``, ``memory``) that it may make
    cgroups in (cgroup v1's hierarchy of that controller; v2's where the controller is delegated to it), None when
    there is none."""
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
        mounts = [line.split() for line in Path("/proc/self/mounts").read_text().splitlines()]
    except OSError:
        return None
    for line in lines:
        number, controllers, path = (line.split(":", 2) + ["", ""])[:3]
        if controller in controllers.split(","):
            where = next((m[1] for m in mounts if len(m) > 3 and m[2] == "cgroup" and controller in m[3].split(",")),
                         None)
        elif number == "0" and cgroup_v2() == "available":
            where = next((m[1] for m in mounts if len(m) > 2 and m[2] == "cgroup2"), None)
        else:
            continue
        if where is None:
            continue
        folder = Path(where) / path.lstrip("/")
        if (folder / "cgroup.procs").is_file() and os.access(folder, os.W_OK):
            return folder
    return None


#: The files that set a limit in each controller's cgroup: cgroup v1's, then v2's (the first that exists is used).
_LIMIT_FILES = {"pids": (("pids.max",),), "memory": (("memory.limit_in_bytes", "memory.memsw.limit_in_bytes"),
                                                    ("memory.max", "memory.swap.max"))}
#: A prefix of the cgroups made for sandboxes: ``benchbot-sandbox-<owner pid>-<n>-<random>``.
CGROUP_PREFIX = "benchbot-sandbox-"


class SandboxCgroups:
    """Cgroups of their own for one sandbox, one per controller this process may use (``pids``: ``pids.max``;
    ``memory``: the memory limit, swap included where accounted), a context manager (removed afterwards). The
    command :meth:`wrap` returns joins them before it starts bubblewrap, so every task of the sandbox counts;
    :meth:`refused` says whether a fork was refused at the limit, :meth:`out_of_memory` whether the OOM killer ended
    a task at the memory limit. Named ``benchbot-sandbox-<pid>-<n>-<random>`` (its owner's PID: one a killed batch
    left is removed by :func:`benchbot.solutions.leftovers.clean_leftovers`). A controller whose cgroup cannot be
    made is left out (its rlimit stands alone)."""

    _count = 0

    def __init__(self, limits: SandboxLimits) -> None:
        SandboxCgroups._count += 1
        name = f"{CGROUP_PREFIX}{os.getpid()}-{SandboxCgroups._count}-{os.urandom(3).hex()}"
        self.folders: dict[str, Path] = {}
        made: set[Path] = set()
        for controller, value in (("pids", limits.processes), ("memory", limits.memory_bytes)):
            root = cgroup_root(controller)
            if root is None:
                continue
            folder = root / name  # cgroup v2: one folder for both controllers
            try:
                if folder not in made:
                    folder.mkdir()
                    made.add(folder)
                _write_limit(folder, controller, value)
                self.folders[controller] = folder
            except OSError:
                continue
        for folder in made - set(self.folders.values()):
            _remove(folder)

    def wrap(self, command: list[str]) -> list[str]:
        """``command`` started from a shell that first moves itself into each cgroup (then ``exec``)."""
        procs = [str(folder / "cgroup.procs") for folder in dict.fromkeys(self.folders.values())]
        if not procs:
            return command
        joins = " && ".join(f'echo $$ > "${i + 1}"' for i in range(len(procs)))
        shift = f"shift {len(procs)}"
        return ["/bin/sh", "-c", f'{joins} && {shift} && exec "$@"', "sh", *procs, *command]

    def refused(self) -> bool:
        """A fork or thread was refused at ``pids.max``."""
        events = _read_counts(self.folders.get("pids"), "pids.events")
        return events.get("max", 0) > 0

    def out_of_memory(self) -> bool:
        """The OOM killer ended a task of the sandbox at its memory limit."""
        folder = self.folders.get("memory")
        return (_read_counts(folder, "memory.oom_control").get("oom_kill", 0) > 0
                or _read_counts(folder, "memory.events").get("oom_kill", 0) > 0)

    def close(self) -> None:
        for folder in dict.fromkeys(self.folders.values()):
            _remove(folder)
        self.folders = {}

    def __enter__(self) -> "SandboxCgroups":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _write_limit(folder: Path, controller: str, value: int) -> None:
    """Set ``controller``'s limit ``value`` in ``folder`` (the first file set of :data:`_LIMIT_FILES` it holds; the
    swap-inclusive file too where present). Raises OSError where the limit cannot be set."""
    for files in _LIMIT_FILES[controller]:
        if (folder / files[0]).exists():
            (folder / files[0]).write_text(str(value))
            for extra in files[1:]:
                if (folder / extra).exists():
                    # v1: memory+swap at the same value (no swap past it); v2: no swap at all
                    (folder / extra).write_text(str(value) if extra.startswith("memory.memsw") else "0")
            return
    raise OSError(f"no {controller} limit file in {folder}")


def _read_counts(folder: Path | None, name: str) -> dict[str, int]:
    """``key value`` lines of a cgroup file as ``{key: value}`` (``{}`` when it cannot be read)."""
    if folder is None:
        return {}
    try:
        pairs = [line.split() for line in (folder / name).read_text().splitlines()]
    except OSError:
        return {}
    return {p[0]: int(p[1]) for p in pairs if len(p) == 2 and p[1].isdigit()}


def _remove(folder: Path) -> None:
    """Remove a sandbox's cgroup, waiting up to 1 s for its last tasks to be reaped. Never raises."""
    for _ in range(50):
        try:
            folder.rmdir()
            return
        except FileNotFoundError:
            return
        except OSError:
            time.sleep(0.02)


def cgroup_v2() -> str:
    """Whether this process's cgroup v2 could cap a sandbox as a whole (``available: /sys/fs/cgroup/...``), or why
    not (``unavailable: ...``), for the manifest."""
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
    except OSError as exc:
        return f"unavailable: /proc/self/cgroup: {exc.strerror}"
    own = next((line[3:] for line in lines if line.startswith("0::")), None)
    if own is None:
        return "unavailable: no cgroup v2 hierarchy (cgroup v1 only)"
    mounts = []
    try:
        for line in Path("/proc/self/mounts").read_text().splitlines():
            fields = line.split()
            if len(fields) > 2 and fields[2] == "cgroup2":
                mounts.append(fields[1])
    except OSError:
        pass
    if not mounts:
        return "unavailable: cgroup2 is not mounted"
    folder = Path(mounts[0]) / own.lstrip("/")
    try:
        controllers = set((folder / "cgroup.controllers").read_text().split())
    except OSError as exc:
        return f"unavailable: this process's cgroup v2 cannot be read ({exc.strerror})"
    missing = sorted({"memory", "pids"} - controllers)
    if missing:
        return f"unavailable: the {' and '.join(missing)} controller{'s' if len(missing) > 1 else ''} not " \
               f"delegated to this process's cgroup v2 (a cgroup v1 hierarchy may hold them)"
    if not os.access(folder, os.W_OK):
        return "unavailable: this process's cgroup v2 is not writable by this user"
    return "available"


def outputs_watch(limits: SandboxLimits, outputs: Path) -> "Callable[[], str]":
    """A ``stop_when`` for :func:`benchbot.solutions.process_group.run_child`: the reason of the outputs limit once
    the files under ``outputs`` (links not followed) take more than ``limits.outputs_bytes`` of disk, else ``""``."""

    def over() -> str:
        return limits.reason("outputs") if disk_bytes(outputs) > limits.outputs_bytes else ""

    return over


def disk_bytes(folder: Path) -> int:
    """Bytes of disk the files under ``folder`` take (allocated blocks, links not followed; what cannot be read
    counts 0). Never raises."""
    total = 0
    for root, _, files in os.walk(folder):
        for name in files:
            try:
                total += os.lstat(os.path.join(root, name)).st_blocks * 512
            except OSError:
                continue
    return total


def exceeded(limits: SandboxLimits, returncode: int, outputs: Path, log: Path | None) -> str:
    """The one-line reason why a sandboxed solution that ended with ``returncode`` (its sandbox's: ``128 + n`` for
    a signal ``n``) went past one of ``limits`` (module docstring), ``""`` when nothing says it did."""
    if returncode in (128 + signal.SIGXCPU, -signal.SIGXCPU):
        return limits.reason("cpu")
    if returncode in (128 + signal.SIGXFSZ, -signal.SIGXFSZ) or _file_at(outputs, limits.file_bytes):
        return limits.reason("file")
    if returncode == 0 or log is None:
        return ""
    try:
        with open(log, "rb") as f:
            f.seek(max(0, os.fstat(f.fileno()).st_size - LOG_TAIL_BYTES))
            tail = f.read().decode("utf-8", "replace")
    except OSError:
        return ""
    for pattern, which in ((_FILE, "file"), (_MEMORY, "memory"), (_PROCESSES, "processes")):
        if pattern.search(tail):
            return limits.reason(which)
    return ""


def _file_at(folder: Path, size: int) -> bool:
    """A regular file under ``folder`` (links not followed) of exactly ``size`` bytes: one a write past the file size
    limit stopped at."""
    for root, _, files in os.walk(folder):
        for name in files:
            try:
                st = os.lstat(os.path.join(root, name))
            except OSError:
                continue
            if st.st_size == size and not os.path.islink(os.path.join(root, name)):
                return True
    return False
