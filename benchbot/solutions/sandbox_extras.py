"""What a sandboxed solution is given beyond its own folder, BenchBot's Python and the system's folders
(:mod:`benchbot.solutions.sandbox`; docs/security.md, "Isolation levels"), each checked so that no ground truth comes with
it:

* **An installed content pack's example** runs from BenchBot's data directory, which the sandbox hides. Its own
  folder — the folder of the script its ``native_command`` runs (``.hello_args/`` for ``python3
  .hello_args/hello_args``) — is shown read-only over the empty data directory, nothing else of the pack
  (:func:`pack_example_folder`), once :func:`ground_truth_problem` found in it no ground truth: no file that the
  registry names or a byte-for-byte copy of one (a hard link too), no JSON file in the ground-truth layout, and no
  symbolic link leading out of the folder.
* **Editable installs** (``pip install -e``, as the original's installer made of ``benchbot_api``) of the Python that
  runs the solution keep their code in a source folder outside the environment, named by a ``.pth`` file, an
  ``.egg-link`` or a setuptools ``__editable__`` finder in its site-packages (:func:`editable_sources`). Their Python
  packages and modules are shown read-only, as BenchBot's own editable folders are; one inside a hidden folder, or
  holding a ground truth, is not, and the solution's log says why in one line.
* **The user's display** (:func:`display_access`): the X11 socket of a local ``DISPLAY`` (``/tmp/.X11-unix/X<n>``)
  with that display's cookie from the Xauthority file (rewritten for any host name: the sandbox has its own), and
  the Wayland socket of ``WAYLAND_DISPLAY``. A display holds no file of ground truth, but a client of it can read
  the screen and send keys to other windows: passing it trusts the solution with the user's desktop (docs/security.md;
  ``BENCHBOT_SANDBOX_DISPLAY=0`` keeps it out). Where none can be passed (a display
  over the network, which the sandbox cannot reach, a missing socket, ``BENCHBOT_SANDBOX_DISPLAY=0``), the solution
  draws off screen (``MPLBACKEND=Agg``) and its log says so in one line.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

from benchbot.core.errors import UsageError

#: The most files :func:`ground_truth_problem` looks at in one folder; a folder with more is refused.
MAX_CHECKED_FILES = 20000
#: Where a sandboxed solution finds its display's cookie (``XAUTHORITY``).
INSIDE_XAUTHORITY = "/run/benchbot/Xauthority"
#: The X11 sockets' folder (``DISPLAY=:<n>`` is the socket ``X<n>`` there).
X11_SOCKETS = Path("/tmp/.X11-unix")
#: Turns the display off for sandboxed solutions when ``0``, ``no``, ``off`` or ``false``.
DISPLAY_SETTING = "BENCHBOT_SANDBOX_DISPLAY"
_LOCAL_DISPLAY = re.compile(r"(?:unix)?:(\d+)(?:\.\d+)?")
_FAMILY_WILD = 0xFFFF


# ------------------------------------------------------------------------------------------------ ground truth
def registry_files(registry) -> set[str]:
    """The absolute paths of the files that hold ground truth or build a layout, as ``registry``'s environments and
    ground truths name them (their spec files, ``map_path``, ``home_files``, mesh files; overridden entries too) and
    as they exist on this machine."""
    from benchbot.server.redaction import ground_truth_strings

    files: set[str] = set()
    for kind in ("environments", "ground_truths"):
        entries = list(registry.entries[kind].values())
        entries += [e for (k, _), e in registry.overridden.items() if k == kind]
        for entry in entries:
            files |= {str(entry.path)} if entry.path else set()
            files |= ground_truth_strings([entry.spec, entry.spec.get("environment") or {}])
    return {f for f in files if os.path.isabs(f) and os.path.exists(f)}


@dataclass
class GroundTruthFiles:
    """The files that hold ground truth or a layout as the registry names them, to recognise them and their copies.

    Attributes:
        inodes: ``{(st_dev, st_ino): path}`` of each (a hard link is the same file).
        by_size: ``{size: [path, ...]}``, so that only files of a matching size are hashed.
    """

    inodes: dict[tuple[int, int], Path] = field(default_factory=dict)
    by_size: dict[int, list[Path]] = field(default_factory=dict)
    _digests: dict[Path, bytes] = field(default_factory=dict)

    @classmethod
    def of(cls, registry) -> "GroundTruthFiles":
        """The files of ``registry``'s environments and ground truths (:func:`registry_files`)."""
        found = cls()
        for name in registry_files(registry):
            try:
                st = os.stat(name)
            except OSError:
                continue
            if stat.S_ISREG(st.st_mode):
                found.inodes[(st.st_dev, st.st_ino)] = Path(name)
                found.by_size.setdefault(st.st_size, []).append(Path(name))
        return found

    def _digest(self, path: Path) -> bytes:
        if path not in self._digests:
            with open(path, "rb") as f:
                self._digests[path] = hashlib.file_digest(f, "sha256").digest()
        return self._digests[path]

    def same_as(self, path: Path, st: os.stat_result) -> Path | None:
        """The registry's file that ``path`` (a regular file, ``st`` its stat) is, or is a byte copy of; else None."""
        if (st.st_dev, st.st_ino) in self.inodes:
            return self.inodes[(st.st_dev, st.st_ino)]
        candidates = self.by_size.get(st.st_size, [])
        if not candidates:
            return None
        try:
            mine = self._digest(path)
            return next((c for c in candidates if self._digest(c) == mine), None)
        except OSError:
            return None


def is_ground_truth_layout(data) -> bool:
    """Whether parsed JSON ``data`` is a ground truth or a layout: the original's ``{environment, format,
    ground_truth: {objects}}`` file (what a BEAR map file is too), or an ``object_map_ground_truth`` instance (objects
    with a ``class`` and a ``centroid``; a results file's objects have ``label_probs`` instead)."""
    if not isinstance(data, dict):
        return False
    truth = data.get("ground_truth")
    if isinstance(truth, dict) and isinstance(truth.get("objects"), list):
        return True
    objects = data.get("objects")
    return isinstance(objects, list) and any(isinstance(o, dict) and "class" in o and "centroid" in o
                                             for o in objects)


def _json_layout(path: Path, size: int) -> bool:
    """Whether the file ``path`` is JSON (its first non-blank byte ``{``) in the ground-truth layout."""
    from benchbot.core.limits import MAX_RESULTS_BYTES

    if size > MAX_RESULTS_BYTES.value():
        return False
    try:
        with open(path, "rb") as f:
            head = f.read(4096).lstrip()
            if not head.startswith(b"{"):
                return False
            data = json.loads(head + f.read())
    except (OSError, ValueError, RecursionError):
        return False
    return is_ground_truth_layout(data)


def ground_truth_problem(folder: Path, known: GroundTruthFiles, skip: list[Path] | tuple = ()) -> str:
    """Why ``folder`` must not be shown to a solution, ``""`` when it may: it holds a ground truth (a file the
    registry names, a copy of one, a JSON file in the ground-truth layout: :func:`is_ground_truth_layout`), a symbolic
    link leading out of it, a folder it cannot list, or more than :data:`MAX_CHECKED_FILES` files. Folders in ``skip``
    (hidden anyway) are not looked into. Links are never followed; FIFOs and devices are never opened. Copies it
    does not recognise (a ground truth as YAML, compressed, or a JSON file over ``MAX_RESULTS_BYTES``) pass.

    Returns:
        ``"<path relative to folder> is ..."`` (one clause), or ``""``.
    """
    root = Path(folder).resolve()
    skipped = [Path(s) for s in skip]
    count = 0
    unlisted: list[OSError] = []
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False, onerror=unlisted.append):
        if unlisted:  # a folder it may enter but not list: what it holds cannot be checked
            where = Path(unlisted[0].filename or root)
            return f"{where.relative_to(root).as_posix() if where.is_relative_to(root) else where} cannot be listed " \
                   "(so it cannot be checked for ground truth)"
        here = Path(dirpath)
        dirnames[:] = sorted(d for d in dirnames if not any((here / d) == s for s in skipped))
        for name in sorted(filenames) + [d for d in dirnames if (here / d).is_symlink()]:
            path = here / name
            rel = path.relative_to(root).as_posix()
            count += 1
            if count > MAX_CHECKED_FILES:
                return f"it holds more than {MAX_CHECKED_FILES} files, too many to check for ground truth"
            try:
                st = path.lstat()
            except OSError:
                continue
            if stat.S_ISLNK(st.st_mode):
                target = Path(os.path.realpath(path))
                if not target.is_relative_to(root):
                    return f"{rel} is a symbolic link leading out of it (to {target})"
                continue
            if not stat.S_ISREG(st.st_mode):
                continue
            same = known.same_as(path, st)
            if same is not None:
                return f"{rel} is a ground-truth or layout file of the registry ({same.name})"
            if _json_layout(path, st.st_size):
                return f"{rel} is a ground truth (a JSON file with ground-truth objects)"
    return ""


# ------------------------------------------------------------------------------------------------ pack examples
def pack_example_folder(argv: list[str], cwd: Path) -> Path | None:
    """The own folder of an installed content pack's example run as ``argv`` in ``cwd``: the folder of the first
    word of the command (after the interpreter) that names a file or folder relative to ``cwd`` (``.hello_args/`` for
    ``python3 .hello_args/hello_args``), else ``cwd`` itself. ``None`` when ``cwd`` is not inside an installed pack
    (``<data dir>/packs/<pack>/``).

    Raises:
        UsageError: that folder is not inside the pack.
    """
    from benchbot.packs.pack_layout import packs_dir

    packs = packs_dir().expanduser().resolve()
    cwd = Path(cwd).resolve()
    if not cwd.is_relative_to(packs) or cwd == packs:
        return None
    pack = packs / cwd.relative_to(packs).parts[0]
    words = argv[1:] if argv and os.path.isabs(argv[0]) else argv
    own = cwd
    for word in words:
        if word.startswith("-") or "\0" in word:
            continue
        path = Path(os.path.normpath(cwd / word))
        if os.path.lexists(path):
            own = path if path.is_dir() and not path.is_symlink() else path.parent
            break
    own = own.resolve()
    if not own.is_relative_to(pack):
        raise UsageError(f"the example's folder {own} is not inside its pack {pack}",
                         "keep an example's files in its pack and install the pack again")
    return own


def check_pack_example(argv: list[str], cwd: Path, registry) -> Path | None:
    """The folder of the installed pack's example ``argv`` (run in ``cwd``) to show read-only in the sandbox
    (:func:`pack_example_folder`), checked; ``None`` when ``cwd`` is not in an installed pack.

    Raises:
        UsageError: the folder holds a ground truth or a link out of it (one line naming the file, and the fix).
    """
    own = pack_example_folder(argv, cwd)
    if own is None:
        return None
    problem = ground_truth_problem(own, GroundTruthFiles.of(registry))
    if problem:
        raise UsageError(f"the example's folder {own} is shown to it in the sandbox, but {problem}",
                         "an example that reads the ground truth on purpose runs only with --no-sandbox; otherwise "
                         "take that file out of the pack's example folder and install the pack again")
    return own


# ------------------------------------------------------------------------------------------------ editable installs
@dataclass(frozen=True)
class EditableSource:
    """A source an editable install puts on the import path.

    Attributes:
        path: a folder of the import path (``whole=False``: only its Python packages and modules are shown), or one
            package folder or module file (``whole=True``: a setuptools finder's mapping).
        origin: the file that names it (``.pth``, ``.egg-link`` or finder module).
        whole: see ``path``.
    """

    path: Path
    origin: Path
    whole: bool


def site_packages(prefix: Path) -> list[Path]:
    """The ``site-packages`` folders of the Python environment or installation at ``prefix``."""
    return sorted(p for p in Path(prefix).glob("lib*/python*/site-packages") if p.is_dir())


def _finder_paths(module: Path) -> list[Path]:
    """The package folders and module files a setuptools ``__editable___*_finder.py`` maps (its ``MAPPING`` and
    ``NAMESPACES`` literals, read with :mod:`ast`, never imported)."""
    try:
        tree = ast.parse(module.read_text(encoding="utf-8", errors="replace"))
    except (OSError, SyntaxError, ValueError, MemoryError, RecursionError):
        return []
    found: list[Path] = []
    for node in tree.body:
        target = node.target if isinstance(node, ast.AnnAssign) else (
            node.targets[0] if isinstance(node, ast.Assign) and len(node.targets) == 1 else None)
        if not isinstance(target, ast.Name) or target.id not in ("MAPPING", "NAMESPACES") or node.value is None:
            continue
        try:
            value = ast.literal_eval(node.value)
        except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):  # a literal of no usable shape
            continue
        for item in value.values() if isinstance(value, dict) else ():
            for path in item if isinstance(item, list) else [item]:
                if isinstance(path, str) and os.path.isabs(path):
                    found.append(Path(path))
    return found


def editable_sources(site: Path, paths: bool = True) -> list[EditableSource]:
    """The sources that the editable installs of the site-packages folder ``site`` put on the import path: the
    folders that its ``.pth`` files (their lines that are not ``import`` statements) and ``.egg-link`` files name
    (with ``paths``), and what its setuptools ``__editable___*_finder.py`` modules map. Paths that do not exist are
    left out; nothing is imported or run."""
    site = Path(site)
    found: list[EditableSource] = []
    if paths:
        for origin in sorted(site.glob("*.pth")) + sorted(site.glob("*.egg-link")):
            try:
                with open(origin, "rb") as f:
                    lines = f.read(1 << 20).decode("utf-8", errors="replace").splitlines()
            except OSError:
                continue
            if origin.suffix == ".egg-link":
                lines = lines[:1]
            for line in lines:
                line = line.strip()
                if not line or line.startswith(("#", "import ", "import\t")) or "\0" in line:
                    continue
                path = Path(os.path.normpath(site / line))
                if os.path.isdir(path):  # never raises (a name too long, a folder it may not enter)
                    found.append(EditableSource(path.resolve(), origin, False))
    for origin in sorted(site.glob("__editable___*_finder.py")):
        found += [EditableSource(p.resolve(), origin, True) for p in _finder_paths(origin) if p.exists()]
    return found


def python_entries(folder: Path) -> list[Path]:
    """What of an import-path folder a solution needs: its Python packages (folders with ``__init__.py``), modules
    (``.py`` files, extension modules) and distribution metadata (``*.dist-info``, ``*.egg-info``), never the folder
    with whatever else it holds."""
    entries = []
    try:
        children = sorted(Path(folder).iterdir())
    except OSError:
        return []
    for child in children:
        if os.path.isdir(child) and (os.path.isfile(child / "__init__.py")
                                     or child.suffix in (".dist-info", ".egg-info")):
            entries.append(child.resolve())
        elif os.path.isfile(child) and (child.suffix == ".py" or child.suffix == ".so"):
            entries.append(child.resolve())
    return entries


@dataclass
class EditableView:
    """What :func:`editable_view` decided: ``shown`` (paths to show read-only) and ``notes`` (one line each, for
    the solution's log: a source that is not shown, and why)."""

    shown: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def editable_view(prefixes: list[Path], own_prefixes: list[Path], shown: list[Path], hidden: list[Path],
                  registry) -> EditableView:
    """The editable installs' sources to show a solution, from the site-packages of ``prefixes`` (the Python
    environments it runs with): every source of :func:`editable_sources` (of ``own_prefixes``, BenchBot's Python,
    only the finders' mappings: its import path is shown already) that no folder of ``shown`` holds; of a folder of
    the import path its :func:`python_entries`. One inside a ``hidden`` folder is left out (silently where it is an
    installed plugin's package, hidden on purpose; otherwise with a note), and so is one holding a ground truth
    (:func:`ground_truth_problem`, with a note)."""
    view = EditableView()
    plugin_tops = {p.module.split(".")[0] for p in registry.plugins}
    known: GroundTruthFiles | None = None
    own = {Path(p).resolve() for p in own_prefixes}
    seen: set[Path] = set()
    sources: set[Path] = set()

    def hidden_by(path: Path, origin: Path) -> bool:
        cover = next((h for h in hidden if path.is_relative_to(h)), None)
        if cover is not None and path.name.removesuffix(".py") not in plugin_tops:
            view.notes.append(f"[benchbot] the editable install's source {path} (named by {origin}) is inside {cover}, "
                              "which the sandbox hides: not shown, so importing it fails; install it from a folder "
                              "outside BenchBot's data, cache and run directories")
        return cover is not None

    for prefix in dict.fromkeys(Path(p).resolve() for p in prefixes):
        for site in site_packages(prefix):
            for source in editable_sources(site, paths=prefix not in own):
                if source.path in sources or any(source.path.is_relative_to(s) for s in shown):
                    continue
                sources.add(source.path)
                if hidden_by(source.path, source.origin):
                    continue
                for path in [source.path] if source.whole else python_entries(source.path):
                    if path in seen or any(path.is_relative_to(s) for s in shown):
                        continue
                    seen.add(path)
                    if hidden_by(path, source.origin):
                        continue
                    if known is None:
                        known = GroundTruthFiles.of(registry)
                    problem = (ground_truth_problem(path, known, skip=hidden) if path.is_dir()
                               else _file_problem(path, known))
                    if problem:
                        view.notes.append(
                            f"[benchbot] the editable install's source {path} (named by {source.origin}) is not shown "
                            f"to the sandboxed solution: {problem}; take the ground truth out of it")
                        continue
                    view.shown.append(path)
    return view


def _file_problem(path: Path, known: GroundTruthFiles) -> str:
    """:func:`ground_truth_problem` for one module file."""
    try:
        st = path.stat()
    except OSError:
        return ""
    if known.same_as(path, st) is not None or _json_layout(path, st.st_size):
        return f"{path.name} is a ground truth"
    return ""


# ------------------------------------------------------------------------------------------------ the display
@dataclass
class DisplayAccess:
    """How a sandboxed solution reaches the user's display (:func:`display_access`).

    Attributes:
        binds: ``(host path, path inside)`` to bind read-only (sockets, the cookie file).
        env: variables to set (``None``: remove it).
        note: one line for the solution's log when a display was named but none can be passed (``""`` otherwise).
    """

    binds: list[tuple[Path, str]] = field(default_factory=list)
    env: dict[str, str | None] = field(default_factory=dict)
    note: str = ""


def read_xauthority(data: bytes) -> list[tuple[int, bytes, bytes, bytes, bytes]]:
    """The entries ``(family, address, number, name, data)`` of an Xauthority file's bytes (big-endian 16-bit
    family, then four strings each preceded by its 16-bit length); a truncated tail is ignored."""
    entries = []
    at = 0
    while at + 2 <= len(data):
        family = int.from_bytes(data[at:at + 2], "big")
        at += 2
        fields = []
        for _ in range(4):
            if at + 2 > len(data):
                return entries
            size = int.from_bytes(data[at:at + 2], "big")
            fields.append(data[at + 2:at + 2 + size])
            at += 2 + size
        if at > len(data):
            return entries
        entries.append((family, *fields))
    return entries


def write_xauthority(entries: list[tuple[int, bytes, bytes, bytes, bytes]]) -> bytes:
    """The bytes of an Xauthority file holding ``entries`` (:func:`read_xauthority`'s form)."""
    out = bytearray()
    for family, *fields in entries:
        out += family.to_bytes(2, "big")
        for value in fields:
            out += len(value).to_bytes(2, "big") + value
    return bytes(out)


def _is_socket(path: Path) -> bool:
    try:
        return stat.S_ISSOCK(os.stat(path).st_mode)
    except OSError:
        return False


def _x11(env: Mapping[str, str], private: Path) -> tuple[DisplayAccess | None, str]:
    """The X11 display of ``env``'s ``DISPLAY`` as :class:`DisplayAccess`, or (None, why it cannot be passed)."""
    display = env.get("DISPLAY", "")
    match = _LOCAL_DISPLAY.fullmatch(display)
    if match is None:
        return None, f"DISPLAY={display} is reached over the network, which the sandbox has none of"
    number = match.group(1)
    socket = X11_SOCKETS / f"X{number}"
    if not _is_socket(socket):
        return None, f"no X11 socket {socket}"
    access = DisplayAccess(binds=[(socket, str(socket))], env={"DISPLAY": display})
    file = env.get("XAUTHORITY") or (os.path.join(env["HOME"], ".Xauthority") if env.get("HOME") else "")
    cookies = []
    try:
        with open(file, "rb") as f:
            entries = read_xauthority(f.read(1 << 20))
        # the sandbox's host name is its own: the cookie of this display, for any host (FamilyWild)
        cookies = list(dict.fromkeys((_FAMILY_WILD, b"", n, name, data) for _, _, n, name, data in entries
                                     if n == number.encode()))
    except OSError:
        pass
    if cookies:
        copy = Path(private) / "Xauthority"
        fd = os.open(copy, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(write_xauthority(cookies))
        access.binds.append((copy, INSIDE_XAUTHORITY))
        access.env["XAUTHORITY"] = INSIDE_XAUTHORITY
    else:
        access.env["XAUTHORITY"] = None
    return access, ""


def _wayland(env: Mapping[str, str]) -> tuple[DisplayAccess | None, str]:
    """The Wayland display of ``env``'s ``WAYLAND_DISPLAY`` as :class:`DisplayAccess`, or (None, why not)."""
    name = env.get("WAYLAND_DISPLAY", "")
    runtime = env.get("XDG_RUNTIME_DIR", "")
    if not os.path.isabs(name) and not runtime:
        return None, f"WAYLAND_DISPLAY={name} but no XDG_RUNTIME_DIR to find its socket in"
    socket = Path(name if os.path.isabs(name) else os.path.join(runtime, name))
    if not _is_socket(socket):
        return None, f"no Wayland socket {socket}"
    return DisplayAccess(binds=[(socket, str(socket))], env={"WAYLAND_DISPLAY": name, "XDG_RUNTIME_DIR": runtime}), ""


def display_access(env: Mapping[str, str], private: Path) -> DisplayAccess:
    """How a sandboxed solution started with the environment ``env`` reaches the user's display: the X11 socket of
    a local ``DISPLAY`` (``:0``, ``unix:0.0``) with that display's cookies from ``XAUTHORITY`` (else
    ``~/.Xauthority``), written to a file in ``private`` for any host name, and the Wayland socket of
    ``WAYLAND_DISPLAY``. Where a display is named but none can be passed (over the network, no socket,
    ``BENCHBOT_SANDBOX_DISPLAY=0``), ``DISPLAY`` and ``WAYLAND_DISPLAY`` are removed, ``MPLBACKEND=Agg`` is set
    (matplotlib draws off screen) and ``note`` says so in one line."""
    named = [v for v in ("DISPLAY", "WAYLAND_DISPLAY") if env.get(v)]
    if not named:
        return DisplayAccess()
    reasons = []
    access = DisplayAccess()
    if str(env.get(DISPLAY_SETTING, "")).strip().lower() in ("0", "no", "off", "false"):
        reasons.append(f"{DISPLAY_SETTING}={env.get(DISPLAY_SETTING)}")
    else:
        for variable, find in (("DISPLAY", lambda: _x11(env, private)), ("WAYLAND_DISPLAY", lambda: _wayland(env))):
            if variable not in named:
                continue
            found, why = find()
            if found is None:
                reasons.append(why)
                access.env[variable] = None
            else:
                access.binds += found.binds
                access.env.update(found.env)
    if access.binds:
        return access
    shown = ", ".join(f"{v}={env.get(v)}" for v in named)
    return DisplayAccess(env={"DISPLAY": None, "WAYLAND_DISPLAY": None, "XAUTHORITY": None, "MPLBACKEND": "Agg"},
                         note=f"[benchbot] the display ({shown}) cannot be passed into the sandbox "
                              f"({'; '.join(reasons)}): the solution draws off screen (MPLBACKEND=Agg)")
