"""Running a containerised solution: no network but its backend, BenchBot's resource limits through the engine's
own flags, its outputs handed back through a size-capped tmpfs (docs/containers.md).

What the container gets (:func:`run_arguments`):

* **network**: ``--network none``: a loopback device of its own and nothing else. The backend is reached through
  one Unix socket bound in at :data:`~benchbot.solutions.sandbox.INSIDE_SOCKET`, which the container's first process
  (:mod:`benchbot.solutions.container_init`, with :mod:`benchbot.solutions.socket_relay`) serves as
  ``127.0.0.1:PORT`` and ``benchbot_supervisor:10000`` inside. (A user-mode network with the host's loopback, as
  slirp4netns's or pasta's, would show the container every service of the host's loopback and, by default, the
  internet; a socket shows it one backend.)
* **files**: its image, read-only (``--read-only``); a private ``/tmp``, a tmpfs of
  :data:`~benchbot.core.limits.SANDBOX_TMP_BYTES`, and its outputs folder
  (:data:`~benchbot.solutions.sandbox.INSIDE_OUTPUTS`), a tmpfs of
  :data:`~benchbot.core.limits.SANDBOX_OUTPUTS_BYTES` (a quota, where the bubblewrap sandbox measures); read-only binds of a hosts file and of the folder holding the two
  scripts above; the backend's socket. No ground truth, no run directory, no device, no capability
  (``--cap-drop ALL``, ``no-new-privileges``).
* **limits** (:class:`~benchbot.solutions.sandbox_limits.SandboxLimits`, the same values and variables as the
  bubblewrap sandbox's): memory ``--memory`` (= ``--memory-swap``: the cgroup's limit over the whole container,
  its tmpfs files included), processes ``--pids-limit`` (the cgroup's ``pids.max``; ``RLIMIT_NPROC`` as well), CPU
  time ``--ulimit cpu`` (each process), file size ``--ulimit fsize``.
* **environment**: the image's, plus the backend's address, ``BENCHBOT_RESULT_LOCATION`` (a file in the outputs
  folder; ``/tmp/benchbot_result``, where original clients write, leads there too), ``BENCHBOT_SHARED_MEMORY=0``,
  ``HOME=/tmp/home``, ``PYTHONUNBUFFERED=1``, ``args``, and, when set here, the token, the client id and the thread
  counts of numerical libraries. Nothing else of the host's environment.

When the solution's command ends, the first process hands back its outputs folder and a report (exit status, the
memory cgroup's OOM kills, the forks the pids cgroup refused, which tmpfs ran full) as a tar stream on the
container's standard output; the solution's own output goes to the container's standard error, which is the
episode's log (capped: :data:`~benchbot.core.limits.MAX_LOG_BYTES`); the engine keeps no log of its own
(``--log-driver none``), so a solution that floods its output fills no disk.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import subprocess
import sys
import tarfile
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import IO

from benchbot.core.errors import BenchbotError, UsageError
from benchbot.core.limits import SANDBOX_TMP_BYTES, human_bytes
from benchbot.solutions import container_init, socket_relay
from benchbot.solutions.container_engine import (EngineFacts, container_engine, engine_facts, image_command,
                                                  runtime_args, settable_ulimits)
from benchbot.solutions.leftovers import owned_tempdir
from benchbot.solutions.process_group import ChildOutcome, run_child
from benchbot.solutions.sandbox import HOSTNAME, INSIDE_OUTPUTS, INSIDE_SOCKET, ORIGINAL_RESULT, inside_address
from benchbot.solutions.sandbox_limits import SandboxLimits, exceeded

#: Where the folder of the container's first process and its relay is bound (read-only).
INSIDE_INIT = "/run/benchbot-init"
#: The container's ``HOME`` (in its private ``/tmp``).
INSIDE_HOME = "/tmp/home"
#: The host's variables passed into the container by name when set here (their values stay off the command line).
PASSED_BY_NAME = ("BENCHBOT_CLIENT_ID", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                  "NUMEXPR_NUM_THREADS", "BENCHBOT_TAICHI_THREADS")
#: Bytes of ``report.json`` read from the container's tar stream at most.
MAX_REPORT_BYTES = 64 << 10


@dataclass
class ContainerRun:
    """How a containerised solution ended and what it left: the :class:`ChildOutcome` of the engine's client
    (``returncode``: the container's exit status, ``128 + n`` when a signal ``n`` ended the command); its results
    file in ``outputs`` (None when it wrote none; only regular files come back, so it is one); the one-line reason
    when it went past a resource limit (``limit``); the report of its first process (``report``, None when it made
    none: the container was stopped, or never started); what it left in its outputs folder that is not a regular
    file or folder, not handed back (``dropped``, relative to it)."""

    outcome: ChildOutcome
    results: Path | None = None
    limit: str = ""
    report: dict | None = None
    dropped: list[str] = field(default_factory=list)


def container_name(tag: str, suffix: str = "") -> str:
    """``benchbot_submission_<tag's hash>_<this process's id><suffix>``: unique among runs on this machine."""
    return f"benchbot_submission_{tag.rsplit(':', 1)[-1]}_{os.getpid()}{suffix}"


def limit_arguments(limits: SandboxLimits) -> list[str]:
    """The engine's flags enforcing ``limits`` (module docstring; ``nproc`` is ``limits.processes`` too, beside the
    pids cgroup), with a ``nofile`` limit this process may set (:func:`settable_ulimits`)."""
    return ["--memory", str(limits.memory_bytes), "--memory-swap", str(limits.memory_bytes),
            "--pids-limit", str(limits.processes),
            "--ulimit", f"cpu={limits.cpu_s}:{limits.cpu_s + 1}",
            "--ulimit", f"fsize={limits.file_bytes}:{limits.file_bytes}", *settable_ulimits(limits.processes)]


def run_arguments(tool: str, tag: str, command: list[str], *, name: str, private: Path, backend_socket: Path,
                  address: str, result_name: str, args: str, limits: SandboxLimits, interactive: bool,
                  env: dict[str, str]) -> list[str]:
    """The engine's ``run`` command line (module docstring) for the image ``tag`` whose own command is ``command``;
    ``private`` holds the hosts file and the ``init`` folder (:func:`_prepare_private`)."""
    inside, ports, _ = inside_address(address)
    argv = [tool, "run", "--rm", "--name", name, *runtime_args(tool), "--network", "none", "--hostname", HOSTNAME,
            "--read-only", *(["--read-only-tmpfs=false"] if tool == "podman" else []),
            "--tmpfs", f"/tmp:rw,size={limits.tmp_bytes},mode=1777",
            "--tmpfs", f"{INSIDE_OUTPUTS}:rw,size={limits.outputs_bytes},mode=1777",
            "--cap-drop", "ALL", "--security-opt", "no-new-privileges", *limit_arguments(limits),
            "--log-driver", "none",  # no copy of its output on the engine's disk: only the episode's capped log
            "-v", f"{private / 'hosts'}:/etc/hosts:ro", "-v", f"{private / 'init'}:{INSIDE_INIT}:ro",
            "-v", f"{backend_socket}:{INSIDE_SOCKET}", *(["-i"] if interactive else [])]
    variables = {"BENCHBOT_SUPERVISOR_ADDRESS": inside, "BENCHBOT_RESULT_LOCATION": f"{INSIDE_OUTPUTS}/{result_name}",
                 "BENCHBOT_SHARED_MEMORY": "0", "HOME": INSIDE_HOME, "PYTHONUNBUFFERED": "1", "args": args}
    for key, value in variables.items():
        argv += ["-e", f"{key}={value}"]
    for key in PASSED_BY_NAME + ("BENCHBOT_TOKEN",):
        if env.get(key):
            argv += ["-e", key]  # the value comes from the engine client's environment
    relay = ["--socket", INSIDE_SOCKET]
    for port in ports:
        relay += ["--port", str(port)]
    argv += ["--entrypoint", "python3", tag, "-I", "-S", f"{INSIDE_INIT}/{Path(container_init.__file__).name}",
             "--outputs", INSIDE_OUTPUTS, "--original-result", ORIGINAL_RESULT, "--home", INSIDE_HOME, *relay,
             "--", *command]
    return argv


def _prepare_private(private: Path, address: str) -> None:
    """The hosts file (the backend's names and the container's as 127.0.0.1) and the ``init`` folder (the first
    process and the relay) in ``private``."""
    _, _, names = inside_address(address)
    (private / "hosts").write_text("127.0.0.1\tlocalhost " + " ".join(names) + f" {HOSTNAME}\n::1\tlocalhost\n")
    init = private / "init"
    init.mkdir()
    for module in (container_init, socket_relay):
        shutil.copyfile(module.__file__, init / Path(module.__file__).name)
    for path in (private, init, *init.iterdir(), private / "hosts"):
        path.chmod(0o755 if path.is_dir() else 0o644)


def run_container(tool: str, tag: str, *, backend_socket: Path, address: str, outputs: Path, result_name: str,
                  args: str = "", token: str | None = None, name_suffix: str = "", log: IO | None = None,
                  timeout_s: float | None = None, stdin: str = "none", limits: SandboxLimits | None = None
                  ) -> ContainerRun:
    """Run the image ``tag`` as a solution (module docstring) against the backend that accepts connections on the
    Unix socket ``backend_socket``, seen inside at ``address`` (:func:`~benchbot.solutions.sandbox.inside_address`).

    Args:
        outputs: an empty host folder that receives the container's outputs folder when its command ends
            (regular files and folders only; what else it left is named in ``log`` and dropped).
        result_name: the results file's name in the outputs folder (``BENCHBOT_RESULT_LOCATION`` inside).
        args: the variable ``args`` inside (the original's ``--args`` of containers).
        token: ``BENCHBOT_TOKEN`` inside (passed through the engine client's environment).
        name_suffix: appended to the container's name (:func:`container_name`).
        log, timeout_s, stdin: as for :func:`~benchbot.solutions.process_group.run_child`; ``stdin="inherit"`` also
            keeps the container's standard input open (``-i``: an interactive solution can be typed to). After a
            timeout the container is removed and nothing of its outputs comes back.
        limits: default :meth:`SandboxLimits.current`.

    Raises:
        BenchbotError: the engine could not start the container (exit status 125), or the image has no ``python3``
            for the first process (one line each; the engine's own words are in ``log``).
    """
    limits = limits or SandboxLimits.current()
    command = image_command(tool, tag)
    name = container_name(tag, name_suffix)
    env = dict(os.environ, **({"BENCHBOT_TOKEN": token} if token else {}))
    with owned_tempdir("benchbot-sandbox-") as private:
        _prepare_private(private, address)
        os.chmod(backend_socket, 0o666)  # the container's user may not be ours; the socket's folder stays private
        stream = private / "stream.tar"
        argv = run_arguments(tool, tag, command, name=name, private=private, backend_socket=backend_socket,
                             address=address, result_name=result_name, args=args, limits=limits,
                             interactive=stdin == "inherit", env=env)
        wrapped = ["/bin/sh", "-c", 'exec >"$0" && exec "$@"', str(stream), *argv]  # stdout: the tar stream
        outcome = None
        try:
            outcome = run_child(wrapped, cwd=private, env=env, log=log, timeout_s=timeout_s, stdin=stdin)
        finally:
            if outcome is None or outcome.timed_out:  # the client was stopped: the container may still run
                stop_now = ["-t", "0"] if tool == "podman" else []  # docker rm -f kills at once
                subprocess.run([tool, "rm", "-f", *stop_now, name], capture_output=True)
        run = ContainerRun(outcome)
        if not outcome.timed_out:
            run.report, run.dropped, problem = unpack_outputs(stream, outputs)
            _note(log, [f"[benchbot] the solution left {INSIDE_OUTPUTS}/{rel}, not a regular file or folder: dropped"
                        for rel in run.dropped] + ([f"[benchbot] {problem}"] if problem else []))
    if run.report is None and not outcome.timed_out:
        _check_started(tool, tag, outcome.returncode)
    if not outcome.timed_out:
        log_path = Path(log.name) if log is not None and isinstance(getattr(log, "name", None), str) else None
        run.limit = container_exceeded(limits, outcome.returncode, run.report, outputs, log_path)
    for candidate in dict.fromkeys((result_name, "benchbot_result")):
        if (outputs / candidate).is_file() and not (outputs / candidate).is_symlink():
            run.results = outputs / candidate
            break
    return run


def _check_started(tool: str, tag: str, returncode: int) -> None:
    """Raise when a container that made no report never ran its first process (module docstring's errors)."""
    if returncode == 125:
        raise BenchbotError(f"{tool} could not start the container of {tag} (exit status 125)",
                            "see the engine's message in the output above (or the episode's log)")
    if returncode in (126, 127):
        raise BenchbotError(f"the image {tag} has no python3 to start BenchBot's relay with (exit status "
                            f"{returncode})", "build it FROM an image with Python 3 (`benchbot container-base` "
                            "makes benchbot/submission:base)")


def _note(log: IO | None, lines: list[str]) -> None:
    for line in lines:
        if log is not None:
            with contextlib.suppress(OSError, ValueError):
                log.write(line + "\n")
                log.flush()
        else:
            print(line, flush=True, file=sys.stderr)


# ------------------------------------------------------------------------------------------------- what came back
def unpack_outputs(stream: Path, outputs: Path) -> tuple[dict | None, list[str], str]:
    """Read the tar stream a container's first process wrote (:mod:`benchbot.solutions.container_init`): its
    ``report.json`` and, into ``outputs``, the regular files and folders under ``outputs/``. Links, devices, pipes
    and names that would leave ``outputs`` are never made. Never raises.

    Returns:
        (the report, or None where there is none; the entries dropped, relative to the outputs folder; ``""``, or
        one line saying the stream was cut short or unreadable).
    """
    report, dropped = None, []
    if not stream.is_file() or stream.stat().st_size == 0:
        return None, [], ""
    try:
        with tarfile.open(stream, "r:") as tar:
            for member in tar:
                if member.name == "report.json" and member.isfile() and member.size <= MAX_REPORT_BYTES:
                    report = _read_report(tar, member)
                elif member.name.startswith("outputs/") and not _unpack_member(tar, member, outputs):
                    dropped.append(member.name[len("outputs/"):])
    except (tarfile.TarError, EOFError, OSError) as exc:
        return report, dropped, f"the container's outputs were cut short ({exc}): what came before is kept"
    return report, dropped, ""


def _read_report(tar: tarfile.TarFile, member: tarfile.TarInfo) -> dict | None:
    try:
        report = json.loads(tar.extractfile(member).read())
    except (ValueError, AttributeError):
        return None
    return report if isinstance(report, dict) else None


def _unpack_member(tar: tarfile.TarFile, member: tarfile.TarInfo, outputs: Path) -> bool:
    """Make one ``outputs/...`` member under ``outputs``; False when it is not made (not a regular file or folder,
    or a name that would leave ``outputs``)."""
    parts = PurePosixPath(member.name).parts[1:]
    if not parts or any(p in ("", ".", "..") for p in parts) or not (member.isfile() or member.isdir()):
        return False
    target = outputs.joinpath(*parts)
    for parent in reversed(target.parents):  # folders made here, never through a link
        if parent == outputs or outputs in parent.parents:
            if parent.is_symlink() or (parent.exists() and not parent.is_dir()):
                return False
            parent.mkdir(exist_ok=True)
    if member.isdir():
        if target.is_symlink() or (target.exists() and not target.is_dir()):
            return False
        target.mkdir(exist_ok=True)
        return True
    source = tar.extractfile(member)
    fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
    with os.fdopen(fd, "wb") as sink:
        shutil.copyfileobj(source, sink, 1 << 20)
    return True


# ------------------------------------------------------------------------------------------------- limits
def container_exceeded(limits: SandboxLimits, returncode: int, report: dict | None, outputs: Path,
                       log: Path | None) -> str:
    """The one-line reason why a containerised solution that ended with ``returncode`` went past one of ``limits``,
    ``""`` when nothing says it did: from its first process's ``report``, the memory cgroup killed a process
    (``oom_kills``), the pids cgroup refused a fork (``pids_refused``), its outputs folder's or its ``/tmp``'s tmpfs
    was written full (``full``); else what :func:`~benchbot.solutions.sandbox_limits.exceeded` finds (CPU time,
    file size, the failures a limit causes named in the log)."""
    report = report or {}
    if returncode != 0 and report.get("oom_kills"):
        return limits.reason("memory")
    if returncode != 0 and report.get("pids_refused"):
        return limits.reason("processes")
    reason = exceeded(limits, returncode, outputs, log)
    if reason or returncode == 0:
        return reason
    filled = report.get("full") or []
    if INSIDE_OUTPUTS in filled:
        return limits.reason("outputs")
    if "/tmp" in filled:
        return f"the solution filled its /tmp of {human_bytes(limits.tmp_bytes)} ({SANDBOX_TMP_BYTES.env})"
    return ""


def limits_record(limits: SandboxLimits, facts: EngineFacts | None = None) -> dict:
    """What a manifest records (``limits``) of a containerised solution's limits: every value and how each is
    enforced by the engine ``facts`` describes (default: the engine :func:`container_engine` picks; empty facts
    where none answers)."""
    if facts is None:
        try:
            facts = engine_facts(container_engine())
        except UsageError:
            facts = EngineFacts("none", "", False, "")
    enforced = facts.limits_enforced()
    cgroup = f"cgroup v{facts.cgroup_version or '?'}"
    unenforced = "NOT enforced: rootless Podman on cgroup v1 cannot set cgroup limits"
    return {"memory_bytes": limits.memory_bytes, "processes": limits.processes, "file_bytes": limits.file_bytes,
            "cpu_s": limits.cpu_s, "tmp_bytes": limits.tmp_bytes, "outputs_bytes": limits.outputs_bytes,
            "mechanism": {
                "memory_bytes": f"--memory and --memory-swap: {cgroup} memory limit over the whole container, its "
                                f"tmpfs files included" if enforced else unenforced,
                "processes": f"--pids-limit: {cgroup} pids.max over the whole container (processes and threads)"
                             if enforced else unenforced,
                "file_bytes": "--ulimit fsize (RLIMIT_FSIZE), each file",
                "cpu_s": "--ulimit cpu (RLIMIT_CPU), each process",
                "tmp_bytes": "--tmpfs /tmp size",
                "outputs_bytes": f"--tmpfs {INSIDE_OUTPUTS} size, all files together (a quota: writes past it "
                                 "fail); the image's file system is read-only",
                "network": "--network none: loopback only; the backend through one Unix socket",
                "engine": facts.describe()}}

