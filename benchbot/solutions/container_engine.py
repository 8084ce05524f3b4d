"""The container engine that runs containerised solutions (Docker or Podman), what it is, and building a solution's
image (docs/containers.md).

The engine is Docker where its daemon answers, else Podman (daemonless: it answers wherever it is installed); both
take the same command lines here. :func:`engine_facts` says what the manifest records of it (version, rootless or
not, the cgroup version that its limits go through) and which OCI runtime it is told to use: Podman's default,
``crun``, cannot make containers on a host whose cgroup v2 hierarchy is mounted beside v1 ("hybrid") with controllers
in it; there ``runc`` is used when it is installed (:func:`runtime_args`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import resource
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from benchbot.core.errors import BenchbotError, UsageError

#: The engines tried, in order: the first that answers runs containers.
ENGINES = ("docker", "podman")
#: Seconds an engine's ``info`` may take before it counts as not answering.
INFO_TIMEOUT_S = 15
#: The unified (v2) hierarchy of a hybrid cgroup host: controllers there stop crun.
HYBRID_UNIFIED = Path("/sys/fs/cgroup/unified/cgroup.controllers")


def container_engine() -> str:
    """The first of ``docker``/``podman`` whose engine answers (``<tool> info`` exits 0 within 15 s).

    Raises:
        UsageError: none is installed, or the installed clients reach no engine (one line naming which).
    """
    found = []
    for tool in ENGINES:
        if shutil.which(tool) is None:
            continue
        found.append(tool)
        if _info(tool) is not None:
            return tool
    if not found:
        raise UsageError("containerised submissions need Docker or Podman, and neither is installed",
                         "install one (Debian/Ubuntu: sudo apt-get install podman), or run the submission with "
                         "--native")
    raise UsageError(f"{' and '.join(found)} installed but no container engine answers ({found[0]} info failed)",
                     "start the engine (e.g. `sudo systemctl start docker`), install podman, or use --native")


@functools.cache
def _info(tool: str) -> dict | None:
    """``<tool> info`` as JSON, None when the engine does not answer."""
    fmt = "json" if tool == "podman" else "{{json .}}"
    try:
        probe = subprocess.run([tool, "info", "--format", fmt], capture_output=True, text=True,
                               timeout=INFO_TIMEOUT_S)
    except (OSError, subprocess.TimeoutExpired):
        return None
    if probe.returncode != 0:
        return None
    try:
        info = json.loads(probe.stdout)
    except ValueError:
        return {}
    return info if isinstance(info, dict) else {}


@dataclass(frozen=True)
class EngineFacts:
    """What a manifest records of the engine, and the runtime it is told to use.

    Attributes:
        tool: ``docker`` or ``podman``.
        version: the engine's version (``4.3.1``), ``""`` when it does not say.
        rootless: the containers run as the user (Podman without root, Docker's rootless mode).
        cgroup_version: ``"1"`` or ``"2"`` (``""`` unknown): the memory and pids limits go through it.
        runtime: the OCI runtime passed with ``--runtime`` (``runc``), ``""`` for the engine's default.
    """

    tool: str
    version: str
    rootless: bool
    cgroup_version: str
    runtime: str = ""

    def describe(self) -> str:
        """``podman 4.3.1 (root, cgroup v1, runtime runc)``."""
        parts = ["rootless" if self.rootless else "root", f"cgroup v{self.cgroup_version or '?'}"]
        if self.runtime:
            parts.append(f"runtime {self.runtime}")
        return f"{self.tool} {self.version or '(version unknown)'} ({', '.join(parts)})"

    def limits_enforced(self) -> bool:
        """Whether the engine can apply memory and pids limits: not rootless Podman on cgroup v1."""
        return not (self.tool == "podman" and self.rootless and self.cgroup_version == "1")


@functools.cache
def engine_facts(tool: str) -> EngineFacts:
    """The :class:`EngineFacts` of ``tool`` (asked once per process; empty facts when it does not answer)."""
    info = _info(tool) or {}
    if tool == "podman":
        host = info.get("host") or {}
        cgroup = str(host.get("cgroupVersion") or "").lstrip("v")
        rootless = bool((host.get("security") or {}).get("rootless"))
        version = str((info.get("version") or {}).get("Version") or "")
        default_runtime = str((host.get("ociRuntime") or {}).get("name") or "")
    else:
        cgroup = str(info.get("CgroupVersion") or "")
        rootless = any("rootless" in str(o) for o in info.get("SecurityOptions") or [])
        version = str(info.get("ServerVersion") or "")
        default_runtime = str(info.get("DefaultRuntime") or "")
    runtime = "runc" if tool == "podman" and default_runtime == "crun" and _crun_blocked() else ""
    return EngineFacts(tool, version, rootless, cgroup, runtime)


def _crun_blocked() -> bool:
    """A hybrid cgroup host with controllers in its v2 hierarchy (crun refuses it) where runc is installed."""
    try:
        controllers = HYBRID_UNIFIED.read_text().split()
    except OSError:
        return False
    return bool(controllers) and shutil.which("runc") is not None


def runtime_args(tool: str) -> list[str]:
    """``["--runtime", "runc"]`` where :func:`engine_facts` chose runc, else ``[]``."""
    runtime = engine_facts(tool).runtime
    return ["--runtime", runtime] if runtime else []


def settable_ulimits(processes: int) -> list[str]:
    """``--ulimit`` flags for ``nofile`` (this process's hard limit, at most 2**20) and ``nproc`` (``processes``):
    Podman as root otherwise asks the kernel for 1048576 of each, which a root without ``CAP_SYS_RESOURCE`` (a
    root in a container or VM sandbox) may not set, and the container fails to start."""
    nofile = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
    nofile = 1 << 20 if nofile == resource.RLIM_INFINITY else min(nofile, 1 << 20)
    return ["--ulimit", f"nofile={nofile}:{nofile}", "--ulimit", f"nproc={processes}:{processes}"]


# ------------------------------------------------------------------------------------------------- a solution's image
def container_files(registry, *, path: Path | None = None, example: str | None = None) -> tuple[Path, Path]:
    """(Dockerfile, build context) of ``--containerised PATH`` (a folder means ``PATH/Dockerfile``; the context is
    the Dockerfile's folder) or of an example's ``container_directory``/``container_filename`` (docs/cli.md).

    Raises:
        UsageError: no Dockerfile there. SpecError: unknown example.
    """
    if example is not None:
        entry = registry.entry("examples", example)
        if "container_directory" not in entry.spec and "container_filename" not in entry.spec:
            raise UsageError(f"example '{example}' has no container set up (no container_directory or "
                             "container_filename in its spec)", f"run it natively: --example {example}")
        base = entry.path.parent if entry.path else Path.cwd()
        context = base / entry.spec.get("container_directory", ".")
        name = entry.spec.get("container_filename")
        dockerfile = base / name if name else context / "Dockerfile"
        if not dockerfile.is_file():
            raise UsageError(f"example '{example}' has no Dockerfile ({dockerfile})", "run it natively instead")
        return dockerfile, context
    assert path is not None
    dockerfile = path / "Dockerfile" if path.is_dir() else path
    if not dockerfile.is_file():
        raise UsageError(f"--containerised: no Dockerfile at {dockerfile}",
                         "give a folder holding a Dockerfile, or the file")
    return dockerfile.resolve(), dockerfile.parent.resolve()


def container_image_tag(directory: Path) -> str:
    """``benchbot/submission:<first 10 hex of sha256(directory)>`` (the original hashed ``$PWD``)."""
    return "benchbot/submission:" + hashlib.sha256(f"{Path(directory).resolve()}\n".encode()).hexdigest()[:10]


def build_image(tool: str, dockerfile: Path, context: Path, log: IO | None = None) -> str:
    """Build ``dockerfile`` with build context ``context`` (the submission's folder, not the current one as in the
    original) and tag it :func:`container_image_tag` of ``context``; the build's output goes to ``log`` (else to
    this process's standard error: standard output is for data). The build has the engine's default network (``RUN pip install`` works where the machine has
    the internet); the solution's run has none. Returns the tag.

    Raises:
        BenchbotError: the build failed (one line; the engine's output says why).
    """
    tag = container_image_tag(context)
    output = {"stdout": log if log is not None else sys.stderr, "stderr": subprocess.STDOUT}
    argv = [tool, "build", *runtime_args(tool), "-f", str(dockerfile), "-t", tag, str(context)]
    try:
        build = subprocess.run(argv, stdin=subprocess.DEVNULL, **output)
    except OSError as exc:
        raise BenchbotError(f"cannot start {tool}: {exc.strerror}", "check the engine's install") from None
    if build.returncode != 0:
        raise BenchbotError(f"{tool} build of {dockerfile} failed (exit status {build.returncode})",
                            "see the build output above (or the episode's log); the base image must be present "
                            "locally (`benchbot container-base`) or pullable")
    return tag


def image_command(tool: str, tag: str) -> list[str]:
    """The command the image ``tag`` runs: its ``ENTRYPOINT`` followed by its ``CMD`` (a shell-form ``CMD x`` is
    ``/bin/sh -c x``).

    Raises:
        BenchbotError: the image cannot be inspected, or names no command.
    """
    probe = subprocess.run([tool, "image", "inspect", "--format", "{{json .Config.Entrypoint}}\t{{json .Config.Cmd}}",
                            tag], capture_output=True, text=True)
    words: list[str] = []
    try:
        for part in probe.stdout.strip().split("\t") if probe.returncode == 0 else []:
            value = json.loads(part)
            words += [value] if isinstance(value, str) else list(value or [])
    except ValueError:
        words = []
    if probe.returncode != 0 or not words:
        why = (probe.stderr.strip().splitlines() or ["no ENTRYPOINT and no CMD"])[-1]
        raise BenchbotError(f"the image {tag} names no command to run ({why})",
                            "end the Dockerfile with CMD, e.g. CMD [\"python3\", \"my_solution.py\"]")
    return [str(w) for w in words]
