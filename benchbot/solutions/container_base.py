"""The base image of containerised solutions, ``benchbot/submission:base`` (the original BenchBot's name: its
examples' Dockerfiles start ``FROM benchbot/submission:base``), made on this machine without any image registry
(docs/containers.md).

Two layers:

1. a root file system with Python 3 and pip: by default Debian (:data:`DEBIAN_SUITES`: the release whose Python is
   this Python's minor version), made by ``mmdebstrap`` from the Debian mirror this machine's apt uses and imported
   into the engine as ``benchbot/submission-rootfs:<release>`` (kept: a rebuild of the base reuses it); or any image
   the engine has or can pull (``--from python:3.11-slim`` where the machine has the internet);
2. BenchBot's client and every distribution it needs (:func:`distribution_closure`: the core's requirements, and its
   ``vis`` extra, matplotlib, when installed here), copied from the Python that BenchBot runs in into the image's
   site-packages: the very versions this machine runs, so the image needs no package index either. Their compiled
   parts need the image's Python to be this Python's minor version (checked).

pip is told it may install into the system's Python (``PIP_BREAK_SYSTEM_PACKAGES=1``; Debian's marker file is
removed), as in the original image, so that an original Dockerfile's ``RUN pip install numpy`` finds numpy there.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import IO

from benchbot.core.errors import BenchbotError, UsageError
from benchbot.solutions.container_engine import runtime_args, settable_ulimits

#: The base image's tag (the original's).
BASE_TAG = "benchbot/submission:base"
#: The Debian release whose ``python3`` is each Python minor version.
DEBIAN_SUITES = {(3, 11): "bookworm", (3, 13): "trixie"}
#: Debian packages of the root file system (beside the ``apt`` variant's essential ones).
DEBIAN_PACKAGES = ("python3", "python3-pip", "python-is-python3", "ca-certificates")
#: The mirror used when this machine's apt names none.
DEFAULT_MIRROR = "http://deb.debian.org/debian"
#: The core's extras copied in when every distribution they need is installed here.
EXTRAS = ("vis",)
#: BenchBot's own import packages (an editable install's files are found through them).
OWN_PACKAGES = ("benchbot", "benchbot_api")
#: Seconds mmdebstrap may take.
ROOTFS_TIMEOUT_S = 1800


@dataclass
class BaseImage:
    """What :func:`build_base` made: ``tag``; ``source`` (the first layer's image); ``python`` (its version);
    ``distributions`` copied; ``rootfs_s``/``layer_s``: seconds spent making each layer (0 for a root file system
    reused)."""

    tag: str
    source: str
    python: str
    distributions: int
    rootfs_s: float
    layer_s: float


def debian_suite(version: tuple[int, int] = sys.version_info[:2]) -> str:
    """The Debian release whose ``python3`` is ``version``.

    Raises:
        UsageError: Debian has no release with it (say how to use another base)."""
    suite = DEBIAN_SUITES.get(tuple(version))
    if suite is None:
        known = ", ".join(f"{a}.{b} ({s})" for (a, b), s in DEBIAN_SUITES.items())
        raise UsageError(f"no Debian release ships Python {version[0]}.{version[1]}, the Python BenchBot runs in "
                         f"(known: {known})", f"use --from python:{version[0]}.{version[1]}-slim (needs the "
                         "internet), or run BenchBot with one of those Pythons")
    return suite


def apt_mirror(sources: Path = Path("/etc/apt")) -> str:
    """The first Debian archive URI of this machine's apt sources (deb822 ``URIs:`` lines, or ``deb URI ...``
    lines), :data:`DEFAULT_MIRROR` when none is found (security and updates archives are skipped)."""
    files = sorted((sources / "sources.list.d").glob("*.sources")) + [sources / "sources.list"] + sorted(
        (sources / "sources.list.d").glob("*.list"))
    for path in files:
        try:
            lines = path.read_text(errors="replace").splitlines()
        except OSError:
            continue
        for line in lines:
            for uri in _uris(line.split("#", 1)[0].split()):
                if uri.startswith(("http://", "https://")) and uri.rstrip("/").endswith("/debian"):
                    return uri
    return DEFAULT_MIRROR


def _uris(words: list[str]) -> list[str]:
    """The archive URIs of one apt sources line: a deb822 ``URIs:`` line's, or a ``deb [options] URI ...`` line's."""
    if words[:1] == ["URIs:"]:
        return words[1:]
    if words[:1] != ["deb"]:
        return []
    rest = words[1:]
    if rest and rest[0].startswith("["):  # [arch=amd64 signed-by=...]
        closing = next((i for i, w in enumerate(rest) if w.endswith("]")), len(rest) - 1)
        rest = rest[closing + 1:]
    return rest[:1]


def make_rootfs(tool: str, suite: str, mirror: str, log: IO | None) -> str:
    """``mmdebstrap`` a Debian ``suite`` with :data:`DEBIAN_PACKAGES` from ``mirror`` (documentation, manuals and
    translations left out; pip's system-Python marker removed), import it as
    ``benchbot/submission-rootfs:<suite>``; returns that tag.

    Raises:
        UsageError: mmdebstrap is not installed. BenchbotError: it failed, or the import did.
    """
    if shutil.which("mmdebstrap") is None:
        raise UsageError("making the base image offline needs mmdebstrap, which is not installed",
                         "install it (Debian/Ubuntu: sudo apt-get install mmdebstrap), or use --from IMAGE")
    tag = f"benchbot/submission-rootfs:{suite}"
    output = {"stdout": log, "stderr": subprocess.STDOUT} if log is not None else {}
    with tempfile.TemporaryDirectory(prefix="benchbot-rootfs-") as tmp:
        tarball = Path(tmp) / "rootfs.tar"
        argv = ["mmdebstrap", "--quiet", "--variant=apt", "--include=" + ",".join(DEBIAN_PACKAGES),
                *(f"--dpkgopt=path-exclude=/usr/share/{d}/*" for d in ("doc", "man", "locale", "info")),
                "--customize-hook=rm -f \"$1\"/usr/lib/python3*/EXTERNALLY-MANAGED", suite, str(tarball), mirror]
        _run(argv, "mmdebstrap", log, output, timeout=ROOTFS_TIMEOUT_S)
        _run([tool, "import", "--change", 'CMD ["python3"]', str(tarball), tag], f"{tool} import", log, output)
    return tag


def _run(argv: list[str], what: str, log: IO | None, output: dict, timeout: float | None = None) -> None:
    """Run a step of the build; raise a one-line BenchbotError naming ``what`` when it fails."""
    if log is not None:
        log.write("$ " + " ".join(argv) + "\n")
        log.flush()
    try:
        proc = subprocess.run(argv, stdin=subprocess.DEVNULL, timeout=timeout, **output)
    except subprocess.TimeoutExpired:
        raise BenchbotError(f"{what} did not finish within {timeout:g} s", "check the mirror and the network") from None
    if proc.returncode != 0:
        raise BenchbotError(f"{what} failed (exit status {proc.returncode})", "see its output above")


def distribution_closure(root: str = "benchbot", extras: tuple[str, ...] = EXTRAS) -> list[metadata.Distribution]:
    """``root`` and every installed distribution its requirements reach (markers evaluated for this Python), with
    ``extras`` of ``root`` where all they need is installed; sorted by name.

    Raises:
        BenchbotError: a required distribution is not installed (naming it)."""
    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name

    def requirements(dist: metadata.Distribution, extra: str) -> list:
        reqs = [Requirement(r) for r in dist.requires or []]
        return [r for r in reqs if r.marker is None or r.marker.evaluate({"extra": extra})]

    def installed(req) -> bool:
        try:
            metadata.distribution(req.name)
        except metadata.PackageNotFoundError:
            return False
        return True

    top = metadata.distribution(root)
    chosen = [e for e in extras if all(installed(r) for r in requirements(top, e) if r.marker is not None)]
    found: dict[str, metadata.Distribution] = {canonicalize_name(root): top}
    todo = requirements(top, "") + [r for e in chosen for r in requirements(top, e) if r.marker is not None]
    while todo:
        req = todo.pop()
        key = canonicalize_name(req.name)
        if key in found:
            continue
        try:
            found[key] = metadata.distribution(req.name)
        except metadata.PackageNotFoundError:
            raise BenchbotError(f"{req.name}, which BenchBot needs, is not installed in {sys.prefix}",
                                "reinstall BenchBot (pip install benchbot)") from None
        for extra in sorted(req.extras) or [""]:
            todo += requirements(found[key], extra)
    return [found[k] for k in sorted(found)]


def _editable(dist: metadata.Distribution) -> bool:
    try:
        return bool(json.loads(dist.read_text("direct_url.json") or "{}").get("dir_info", {}).get("editable"))
    except ValueError:
        return False


def _place(source: Path, target: Path) -> None:
    """``source`` at ``target``: a hard link where the file system allows one (instant), else a copy."""
    target.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def stage_distributions(dists: list[metadata.Distribution], dest: Path) -> int:
    """Lay out ``dists``'s installed files under ``dest`` as a site-packages folder: each file its ``RECORD`` lists
    inside its site-packages (scripts elsewhere, ``.pth`` files and ``direct_url.json`` left out); for BenchBot
    installed editable (from a checkout), its packages :data:`OWN_PACKAGES` and its JSON Schemas as a wheel lays
    them out (``benchbot/schemas``), compiled caches left out. Returns the number of files.

    Raises:
        BenchbotError: a distribution lists no files (installed without a RECORD)."""
    count = 0
    for dist in dists:
        root = Path(dist.locate_file("")).resolve()
        if dist.files is None:
            raise BenchbotError(f"{dist.metadata['Name']} lists no installed files (no RECORD)",
                                f"reinstall it: pip install --force-reinstall {dist.metadata['Name']}")
        for rel in dist.files:
            source = Path(dist.locate_file(rel)).resolve()
            if not source.is_file() or not source.is_relative_to(root) or source.suffix == ".pth" \
                    or source.name == "direct_url.json":
                continue
            _place(source, dest / source.relative_to(root))
            count += 1
        if _editable(dist) and dist.metadata["Name"].lower() == "benchbot":
            count += _stage_checkout(dest)
    return count


def _stage_checkout(dest: Path) -> int:
    """BenchBot's packages and schemas from the checkout an editable install points at (see
    :func:`stage_distributions`)."""
    import importlib.util

    from benchbot.core.specs import schema_dir

    count = 0
    folders = [(Path(importlib.util.find_spec(p).origin).parent, dest / p) for p in OWN_PACKAGES]
    folders.append((schema_dir(), dest / "benchbot" / "schemas"))
    for source, target in folders:
        for path in sorted(source.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts and path.suffix != ".pyc":
                _place(path, target / path.relative_to(source))
                count += 1
    return count


def image_python(tool: str, image: str) -> tuple[str, str]:
    """``(version, purelib)`` of the image's ``python3``: ``("3.11.2", "/usr/local/lib/python3.11/dist-packages")``.

    Raises:
        BenchbotError: the image cannot run ``python3`` (one line, with the engine's last words)."""
    code = "import sys, sysconfig; print('%d.%d.%d' % sys.version_info[:3]); print(sysconfig.get_path('purelib'))"
    argv = [tool, "run", "--rm", "--network", "none", *runtime_args(tool), *settable_ulimits(64), image,
            "python3", "-c", code]
    proc = subprocess.run(argv, capture_output=True, text=True, stdin=subprocess.DEVNULL)
    lines = proc.stdout.split()
    if proc.returncode != 0 or len(lines) != 2:
        why = (proc.stderr.strip().splitlines() or [f"exit status {proc.returncode}"])[-1]
        raise BenchbotError(f"the image {image} cannot run python3 ({why})", "choose an image with Python 3")
    return lines[0], lines[1]


def containerfile(source: str, purelib: str, python: str) -> str:
    """The second layer's Containerfile (module docstring)."""
    from benchbot import __version__

    return (f"FROM {source}\n"
            f"COPY site-packages/ {purelib}/\n"
            "ENV PIP_BREAK_SYSTEM_PACKAGES=1 PYTHONUNBUFFERED=1\n"
            f"LABEL org.benchbot.version=\"{__version__}\" org.benchbot.python=\"{python}\"\n"
            "WORKDIR /benchbot_submission\n"
            "CMD [\"python3\"]\n")


def build_base(tool: str, *, source: str = "debian", mirror: str | None = None, tag: str = BASE_TAG,
               log: IO | None = None, reuse_rootfs: bool = True) -> BaseImage:
    """Make the base image (module docstring) with the engine ``tool``.

    Args:
        source: ``"debian"`` (mmdebstrap, no registry) or an image with Python 3 to start from.
        mirror: the Debian mirror (default :func:`apt_mirror`).
        tag: the base image's tag.
        log: where the steps' output goes (default: this process's).
        reuse_rootfs: keep an existing ``benchbot/submission-rootfs:<release>``.

    Raises:
        UsageError: no Debian release for this Python, no mmdebstrap. BenchbotError: a step failed, or the image's
            Python is not this Python's minor version.
    """
    started = time.monotonic()
    if source == "debian":
        suite = debian_suite()
        first = f"benchbot/submission-rootfs:{suite}"
        have = subprocess.run([tool, "image", "inspect", first], capture_output=True).returncode == 0
        if not (have and reuse_rootfs):
            first = make_rootfs(tool, suite, mirror or apt_mirror(), log)
    else:
        first = source
    rootfs_s = time.monotonic() - started
    python, purelib = image_python(tool, first)
    here = "%d.%d" % sys.version_info[:2]
    if not python.startswith(here + "."):
        raise BenchbotError(f"the image {first} has Python {python}, BenchBot runs in Python {here}: their compiled "
                            "packages differ", f"start from an image with Python {here} (e.g. --from "
                            f"python:{here}-slim)")
    started = time.monotonic()
    dists = distribution_closure()
    with tempfile.TemporaryDirectory(prefix="benchbot-base-") as tmp:
        context = Path(tmp)
        stage_distributions(dists, context / "site-packages")
        (context / "Containerfile").write_text(containerfile(first, purelib, python))
        output = {"stdout": log, "stderr": subprocess.STDOUT} if log is not None else {}
        _run([tool, "build", *runtime_args(tool), "-f", str(context / "Containerfile"), "-t", tag, str(context)],
             f"{tool} build of {tag}", log, output)
    return BaseImage(tag, first, python, len(dists), round(rootfs_s, 1), round(time.monotonic() - started, 1))
