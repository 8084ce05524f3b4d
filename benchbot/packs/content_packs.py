"""Content packs: folders in the original BenchBot add-on layout (docs/plugin-guide.md), installed by path.

A pack holds spec files in type folders — ``tasks/``, ``robots/``, ``environments/``, ``formats/``,
``evaluation_methods/`` (our kind ``evaluators``), ``ground_truths/`` (JSON), ``examples/``, ``batches/`` — each
file directly inside a folder of that name, anywhere in the pack (the original's discovery rule; files in
sub-folders of a type folder are ignored). ``benchbot install ./my_pack`` validates every file, refuses names that
clash with installed content, and copies the pack atomically to ``<data dir>/packs/<name>/`` with a manifest
``.benchbot-pack.json``; the built-in plugin ``benchbot.plugins.installed_packs`` loads the installed packs.
``benchbot install --dry-run`` runs :func:`install_pack` with ``dry_run=True``: every check of a real install,
the same errors and exit code, and nothing copied.

A spec whose name is already installed is no clash when the two are identical in meaning
(:mod:`benchbot.core.spec_meaning`): it is reported as already provided and the installed copy is used. Nor is an
original add-on's spec copied unchanged whose name a first-party plugin re-implements (formats_object_map's
formats, eval_omq's ``omq``, the examples of the built-in names, robots_isaac's ``carter``:
:func:`benchbot.packs.original_addons.built_in_counterpart`): it is reported as already provided, the built-in is
used, and the pack's copy (and its code, which then needs no ``--allow-code``) is never loaded (the manifest's
``built_in``). A robot whose type no installed plugin runs never replaces an installed robot of its name; under a
new name it installs and is listed as unavailable with the reason (``Registry.unavailable_reason``). A ground truth
of an environment that has one already is another *set* of ground truths (the original's ``isaac_develop`` and
``bear_develop``, else named after the pack), offered beside the default. A real clash is refused naming both
sources, unless the pack is installed with ``override=True`` (``--override``): its spec then replaces the other
source's while the pack is installed (the manifest's ``overrides``).

An original add-on whose content lives elsewhere — a ``.remote`` file naming a URL to download and a folder to
unzip it into (the original's environments and Omniverse robots) — is recognised by its markers
(:data:`benchbot.packs.original_addons.ADDON_MARKERS`); BenchBot downloads nothing, so installing it is refused with
an explanation: what it would download, and which installed content corresponds
(:data:`benchbot.packs.original_addons.KNOWN_REMOTES`). ``.dependencies`` and ``.dependencies-python`` are
reported, never installed.

Security: symlinks leaving the pack, symlinked folders and special files are refused; ``map_path`` may not be
absolute (except Unreal ``/Game/...`` asset paths, which must stay in ``/Game/`` once normalised) nor leave the
pack; nothing in a pack is imported or run unless it was installed with ``allow_code=True`` (``--allow-code``),
which it must be when it declares Python functions that live in the pack (formats/evaluation methods) or examples
(their ``native_command`` runs from the pack). What the user allowed is recorded outside the pack, in
``<data dir>/code-approvals.json``, with the digest of the pack's files (:func:`pack_digest`): its code runs only
while the pack is unchanged since, whatever the pack's manifest says.
A function a pack names that is not pack code must be in a module that an installed plugin's own formats or
evaluators name (:func:`plugin_function_modules`, e.g. ``benchbot_eval_omq.omq``); the standard library and any
other module never (``os:system`` would run shell commands through ``POST /results_functions/create``). This is
checked when a pack is installed (:func:`verify_pack`) and again when the registry imports a pack's functions
(:func:`installed_function_problem`), so a spec or manifest edited by hand after installation gains nothing.

Pack code is imported under the synthetic package ``benchbot_packs.<pack>`` (never on ``sys.path``): the
original's ``functions: {evaluate: "omq.evaluate"}`` next to ``evaluation_methods/omq.yaml`` becomes
``benchbot_packs.<pack>.evaluation_methods.omq:evaluate``; use relative imports between pack modules.
"""

from __future__ import annotations

import hashlib
import json
import os
import posixpath
import re
import shutil
import stat
import sys
import tempfile
import time
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from benchbot.core.errors import SpecError
from benchbot.packs.pack_layout import (
    FOLDER_KINDS, IGNORED, MANIFEST, PackError, data_dir, packs_dir, spec_files,
)

if TYPE_CHECKING:  # pragma: no cover
    from benchbot.core.registry import Registry

CODE_APPROVALS = "code-approvals.json"
"""The user's record, in the data directory (outside every pack), of the packs installed with ``--allow-code``:
``{"packs": {name: {"digest": "sha256:…", "source": folder, "approved_at": Unix s}}}``. A pack's code runs only
while its files still have the digest recorded when the user allowed it (:func:`code_approval_problem`)."""
NAMESPACE = "benchbot_packs"
_NAME_RE = re.compile(r"^[a-z][a-z0-9_]{0,63}$")
_IDENT_RE = re.compile(r"^[A-Za-z_]\w*$")
_FUNCTION_RE = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*$")
PLUGIN = "content_packs"
"""The entry-point name of the built-in plugin that loads installed packs (``benchbot.plugins.installed_packs``)."""
LOAD_ERROR_KEY = "_load_error"
"""A spec dict carrying this key is reported by the registry as that one-line problem instead of registered."""
OVERRIDE_KEY = "_benchbot_override"
"""Set (only) by :func:`load_installed_specs` on a spec that its pack's manifest lists in ``overrides``: the
registry lets it replace another source's spec of the same name. Removed from every spec file a pack holds."""


def approvals_path() -> Path:
    """``<data dir>/code-approvals.json`` (:data:`CODE_APPROVALS`)."""
    return data_dir() / CODE_APPROVALS


_DIGESTS: dict[str, tuple[list, str]] = {}
"""``{pack folder: (stat signature, digest)}``: a pack is hashed again only when one of its files changed (its
size, mtime, ctime or inode: ctime cannot be set back by a user)."""


def pack_digest(root: Path) -> str:
    """``sha256:<hex>`` of a pack's files as installed: every file's path and bytes (a symlink's target), in path
    order, leaving out the manifest, ``__pycache__``, ``*.pyc`` and the other folders an install does not copy.
    Adding, removing, renaming or editing any file changes it."""
    root = Path(root)
    entries: list[tuple[str, Path, os.stat_result]] = []
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        dirnames[:] = sorted(d for d in dirnames if d not in IGNORED)
        for fname in sorted(filenames):
            path = Path(dirpath) / fname
            if fname in IGNORED or fname.endswith(".pyc"):
                continue
            entries.append((path.relative_to(root).as_posix(), path, path.lstat()))
    entries.sort(key=lambda e: e[0])
    signature = [(rel, st.st_mode, st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino) for rel, _, st in entries]
    cached = _DIGESTS.get(str(root))
    if cached is not None and cached[0] == signature:
        return cached[1]
    total = hashlib.sha256()
    for rel, path, st in entries:
        if stat.S_ISLNK(st.st_mode):
            content = b"symlink:" + os.fsencode(os.readlink(path))
        elif stat.S_ISREG(st.st_mode):
            with open(path, "rb") as f:
                content = b"file:" + hashlib.file_digest(f, "sha256").digest()
        else:
            content = b"special:" + str(stat.S_IFMT(st.st_mode)).encode()
        total.update(rel.encode("utf-8", "surrogateescape") + b"\0" + content + b"\0")
    digest = f"sha256:{total.hexdigest()}"
    _DIGESTS[str(root)] = (signature, digest)
    return digest


def _read_approvals() -> dict:
    """``{pack: record}`` of :data:`CODE_APPROVALS` (``{}`` when missing, unreadable or malformed)."""
    from benchbot.core.limits import MAX_SPEC_BYTES
    from benchbot.core.safe_load import load_data_file

    path = approvals_path()
    if not path.is_file():
        return {}
    try:
        data = load_data_file(path, MAX_SPEC_BYTES, PackError)
    except PackError:
        return {}
    packs = data.get("packs") if isinstance(data, dict) else None
    return packs if isinstance(packs, dict) else {}


def _record_approval(pack: str, record: dict | None) -> None:
    """Set (``record``) or remove (``None``) ``pack``'s entry of :data:`CODE_APPROVALS`, atomically."""
    from benchbot.core import atomic

    packs = _read_approvals()
    if record is None and pack not in packs:
        return
    if record is None:
        packs.pop(pack)
    else:
        packs[pack] = record
    atomic.write_json(approvals_path(), {"packs": packs})


def code_approval_problem(pack: str, pack_dir: Path) -> str | None:
    """Why the code of the installed pack ``pack`` (in ``pack_dir``) may not be imported or run, in one line that
    says how to allow it, or ``None`` when the user installed it with ``--allow-code`` and no file of the pack has
    changed since (its :func:`pack_digest` is the one in :data:`CODE_APPROVALS`). The pack's own manifest is not
    asked: it lies inside the pack, where anyone who can plant code can edit it too."""
    record = _read_approvals().get(pack)
    source = read_manifest(pack_dir).get("source") or "DIR"
    again = f"to run its code, read it, then install it again: benchbot install --force --allow-code {source}"
    if not isinstance(record, dict) or not isinstance(record.get("digest"), str):
        return f"pack '{pack}' was installed without --allow-code ({again})"
    try:
        digest = pack_digest(pack_dir)
    except OSError as exc:
        return f"pack '{pack}' cannot be read to check its code ({exc.strerror or exc})"
    if digest != record["digest"]:
        return f"pack '{pack}' has changed since it was installed with --allow-code ({again})"
    return None


def pack_name(text: str) -> str:
    """A pack name from a folder name or ``--name``: lower case, ``-``/``.``/spaces → ``_``.

    Raises:
        PackError: the result is not ``[a-z][a-z0-9_]*`` (at most 64 characters).
    """
    name = re.sub(r"[-. ]+", "_", text.strip().lower())
    if not _NAME_RE.match(name):
        raise PackError(f"'{text}' is not a valid pack name", "use letters, digits and _ (starting with a letter), or pass --name")
    return name


@dataclass
class PackFile:
    """One spec file of a pack.

    Attributes:
        kind: registry kind (``evaluators`` for ``evaluation_methods/``).
        path: absolute path of the file.
        rel: path relative to the pack root (POSIX).
        spec: the spec as the registry will see it (functions rewritten, ``map_path`` resolved, ``_file_path``
            set), or ``None`` when the file could not be parsed.
        error: the first problem with the file (``"<rel>: <$.path>: <message>"``), or ``""``.
        name: its index name (``name``; ``name:variant`` for environments/ground truths), or ``""``.
        code: why this file needs ``--allow-code`` (one line per reason).
    """

    kind: str
    path: Path
    rel: str
    spec: dict | None = None
    error: str = ""
    name: str = ""
    code: list[str] = field(default_factory=list)


@dataclass
class PackScan:
    """What :func:`scan_pack` found.

    Attributes:
        name: the pack name.
        root: the pack folder (resolved).
        files: every spec file, valid or not.
        errors: safety problems and invalid files, one line each.
        warnings: what installs but is read in a way its author may not expect (a start pose's quaternion that is
            not unit length: :func:`start_pose_warning`), one line each.
    """

    name: str
    root: Path
    files: list[PackFile] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def code(self) -> list[str]:
        """Every reason this pack needs ``--allow-code``."""
        return [c for f in self.files for c in f.code]


def _check_tree(root: Path) -> list[str]:
    """Safety problems of the files under ``root``: escaping symlinks, symlinked folders, special files."""
    problems = []
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        dirnames[:] = [d for d in dirnames if d not in IGNORED]
        for entry in dirnames + filenames:
            path = Path(dirpath) / entry
            rel = path.relative_to(root).as_posix()
            mode = path.lstat().st_mode
            if stat.S_ISLNK(mode):
                try:
                    target = path.resolve()
                except (OSError, RuntimeError):  # a symlink loop (RuntimeError before Python 3.13)
                    problems.append(f"{rel}: symlink to {os.readlink(path)} cannot be resolved (a symlink loop?)")
                    continue
                if not target.is_relative_to(root):
                    problems.append(f"{rel}: symlink to {os.readlink(path)} leaves the pack")
                elif target.is_dir():
                    problems.append(f"{rel}: symlinked folders are not allowed")
            elif not (stat.S_ISDIR(mode) or stat.S_ISREG(mode)):
                problems.append(f"{rel}: not a regular file or folder")
    return problems


def _pack_module(root: Path, folder: Path, dotted: str, pack: str) -> str | None:
    """The ``benchbot_packs.<pack>.…`` module of ``dotted`` (a module path relative to ``folder``), or ``None``
    when no such module file exists in the pack."""
    parts = dotted.split(".")
    for base in (folder, root):
        target = base.joinpath(*parts)
        if target.with_suffix(".py").is_file() or (target / "__init__.py").is_file():
            rel = base.relative_to(root).parts
            if not all(_IDENT_RE.match(p) for p in rel):
                return None
            return ".".join((NAMESPACE, pack, *rel, *parts))
    return None


def _adapt_functions(pf: PackFile, spec: dict, root: Path, pack: str) -> None:
    """Rewrite ``functions`` that live in the pack to ``benchbot_packs.<pack>...:attr`` and note the code."""
    functions = spec.get("functions")
    if not isinstance(functions, dict):
        return
    folder = pf.path.parent
    for fn_name, value in list(functions.items()):
        if not isinstance(value, str):
            continue
        if ":" in value:
            module, _, attr = value.partition(":")
        else:  # the original's "module.attr" relative to the YAML's folder
            module, _, attr = value.rpartition(".")
        if not module or not all(_IDENT_RE.match(p) for p in module.split(".")) or not _IDENT_RE.match(attr or ""):
            raise SpecError(f"{pf.rel}: $.functions.{fn_name}: '{value}' is not module.attr or module:attr", "")
        if module.split(".")[0] == NAMESPACE:
            raise SpecError(f"{pf.rel}: $.functions.{fn_name}: '{value}' may not name {NAMESPACE} directly",
                            "name the module relative to the spec's folder, e.g. omq.evaluate")
        inside = _pack_module(root, folder, module, pack)
        if inside is not None:
            functions[fn_name] = f"{inside}:{attr}"
            pf.code.append(f"{pf.rel}: functions.{fn_name} runs pack code '{value}'")
        elif ":" not in value:
            raise SpecError(f"{pf.rel}: $.functions.{fn_name}: '{value}': no module {module.replace('.', '/')}.py "
                            f"in {folder.relative_to(root).as_posix() or '.'}/ of the pack",
                            "add the module or use an installed module as module:attr")


def _pack_target(pf: PackFile, where: str, name: str, root: Path, inside_hint: str) -> Path:
    """The resolved path of ``name`` (a path a spec of the pack gives, relative to the spec's folder) that must lie
    inside the pack ``root``.

    Raises:
        SpecError: one line starting with ``where``: ``name`` is absolute (or ``~``), holds a NUL character, cannot
            be resolved (a symlink loop, a name too long) or leaves the pack (``inside_hint`` is the hint).
    """
    if os.path.isabs(name) or name.startswith("~"):
        raise SpecError(f"{where}: absolute path '{name}' is not allowed in a pack",
                        "give a path relative to the spec's folder, inside the pack")
    if "\0" in name:
        raise SpecError(f"{where}: {name[:80]!r} holds a NUL character", "give a file name of the pack")
    try:
        target = (pf.path.parent / name).resolve()
    except (OSError, RuntimeError) as exc:  # a symlink loop (RuntimeError before Python 3.13), a name too long
        raise SpecError(f"{where}: {name[:80]!r} cannot be resolved ({exc.__class__.__name__})",
                        "give a file name of the pack") from None
    if not target.is_relative_to(root):
        raise SpecError(f"{where}: '{name}' leaves the pack", inside_hint)
    return target


def _asked(test) -> bool:
    """``test()`` (say ``path.is_file``); ``False`` where the file system cannot answer (a name too long)."""
    try:
        return test()
    except OSError:
        return False


def _adapt_home_files(pf: PackFile, spec: dict, root: Path) -> None:
    """Resolve an environment's ``home_files`` (the ground-truth files its home's floor plan is derived from)
    against the spec's folder; refuse absolute paths, paths leaving the pack and missing files, one line naming the
    entry. A list of another form is left to the schema's one-line error."""
    files = spec.get("home_files")
    if pf.kind != "environments" or not isinstance(files, list):
        return
    resolved = []
    for i, name in enumerate(files):
        if not isinstance(name, str) or not name:
            return
        where = f"{pf.rel}: $.home_files[{i}]"
        target = _pack_target(pf, where, name, root, "keep the home's ground-truth files inside the pack")
        if not _asked(target.is_file):
            raise SpecError(f"{where}: '{name}' does not exist",
                            "list the ground-truth JSON files of the home's variants, relative to the spec's folder")
        resolved.append(str(target))
    spec["home_files"] = resolved


def _adapt_paths(pf: PackFile, spec: dict, root: Path) -> None:
    """Resolve a relative ``map_path`` (and ``home_files``: :func:`_adapt_home_files`) against the spec's folder;
    refuse absolute ones and ones leaving the pack."""
    _adapt_home_files(pf, spec, root)
    map_path = spec.get("map_path")
    if pf.kind != "environments" or not isinstance(map_path, str) or not map_path:
        return
    if os.path.isabs(map_path) or map_path.startswith("~"):
        if map_path.startswith("/Game/"):  # an Unreal asset path (original sim_unreal environments)
            normal = posixpath.normpath(map_path)  # judged once normalised: /Game/../../etc/x is /etc/x
            if normal.startswith("/Game/"):
                spec["map_path"] = normal
                return
            raise SpecError(f"{pf.rel}: $.map_path: '{map_path}' leaves /Game/ (it is '{normal}' once normalised)",
                            "an Unreal asset path stays inside /Game/; other maps go in the pack, as a path "
                            "relative to the spec's folder")
    target = _pack_target(pf, f"{pf.rel}: $.map_path", map_path, root, "keep the map inside the pack")
    if not _asked(target.exists):
        raise SpecError(f"{pf.rel}: $.map_path: '{map_path}' names no file of the pack (it would be "
                        f"{target.relative_to(root).as_posix()}): put the map file there, or correct map_path (a path "
                        "relative to the environment file)", "give map_path as a file of the pack, e.g. "
                        "../maps/room_1.json")
    spec["map_path"] = str(target)


def start_pose_warning(pf: PackFile) -> str:
    """The warning for an environment whose ``start_pose`` quaternion is not unit length (``""`` for one that is,
    or for another kind of spec): the pose, the heading it is read with, as the original read it (the yaw the
    unit-quaternion formula gives for the four numbers as written: :func:`benchbot.core.geometry.start_pose_to_se2`),
    the heading of the normalised quaternion, and the unit quaternion that says the former."""
    import math

    pose = pf.spec.get("start_pose") if pf.kind == "environments" and isinstance(pf.spec, dict) else None
    if not isinstance(pose, list) or len(pose) != 7 or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pose):
        return ""
    norm = math.sqrt(sum(v * v for v in pose[:4]))
    if norm == 0 or abs(norm - 1.0) <= 1e-3:
        return ""
    from benchbot.core.geometry import pose7_to_se2, start_pose_to_se2

    read = float(start_pose_to_se2(pose)[2])
    normalised = float(pose7_to_se2(pose)[2])
    unit = [round(math.cos(read / 2), 4), 0, 0, round(math.sin(read / 2), 4)]
    shown = ", ".join(f"{v:g}" for v in pose)
    return (f"{pf.rel}: $.start_pose: [{shown}] has a quaternion of length {norm:.3f}, not 1: it is read as the "
            f"original BenchBot read it, a heading of {math.degrees(read):.1f} degrees (normalised it would be "
            f"{math.degrees(normalised):.1f}); to say so with a unit quaternion write "
            f"[{', '.join(f'{v:g}' for v in unit)}, {', '.join(f'{v:g}' for v in pose[4:])}]")


def scan_pack(path: Path | str, name: str | None = None) -> PackScan:
    """Find, check and validate every spec file of the pack folder ``path``.

    Args:
        path: the pack folder.
        name: the pack name (default: derived from the folder name).

    Returns:
        A :class:`PackScan`; problems are in ``errors`` (and per file in ``PackFile.error``), never raised.

    Raises:
        PackError: ``path`` is not a folder, or the name is invalid.
    """
    from benchbot.core.specs import KIND_SCHEMAS, entry_name, load_spec_file, singular, validate

    given = Path(path).expanduser()
    if not given.is_dir():
        raise PackError(f"{given}: not a folder", "give the path of a content pack folder")
    root = given.resolve()
    scan = PackScan(pack_name(name or root.name), root)
    scan.errors.extend(_check_tree(root))
    for kind, file in spec_files(root):
        pf = PackFile(kind, file, file.relative_to(root).as_posix())
        scan.files.append(pf)
        spec: dict | None = None
        try:
            spec = load_spec_file(file)
            spec.pop("_file_path", None)
            spec.pop(OVERRIDE_KEY, None)  # only the manifest (the user's --override) may say so
            if kind in ("formats", "evaluators"):
                _adapt_functions(pf, spec, root, scan.name)
            _adapt_paths(pf, spec, root)
            validate(spec, KIND_SCHEMAS[kind], pf.rel)
            pf.name = entry_name(kind, spec)
        except SpecError as exc:
            pf.error = exc.message.replace(str(file), pf.rel)
            scan.errors.append(pf.error)  # a parsed-but-invalid spec is kept: the registry reports it too
        if kind == "examples":
            pf.code.append(f"{pf.rel}: example runs '{(spec or {}).get('native_command', '?')}' from the pack")
        if spec is not None:
            spec["_file_path"] = str(file)
        pf.spec = spec
        warning = start_pose_warning(pf) if not pf.error else ""
        scan.warnings += [warning] if warning else []
    if not scan.files:
        scan.errors.append(f"no spec files found: expected {', '.join(sorted(set(FOLDER_KINDS) - {'evaluators'}))}/ "
                           "folders with YAML/JSON files (docs/plugin-guide.md)")
    seen: dict[tuple[str, str], str] = {}
    for pf in scan.files:
        if pf.name and (pf.kind, pf.name) in seen:
            scan.errors.append(f"{pf.rel}: {singular(pf.kind)} '{pf.name}' is also defined by "
                               f"{seen[(pf.kind, pf.name)]}")
        elif pf.name:
            seen[(pf.kind, pf.name)] = pf.rel
    return scan


def is_pack_entry(plugin: str, path: Path | None) -> bool:
    """Whether a registry entry (its plugin's name and spec file) comes from an installed content pack."""
    if plugin == PLUGIN:
        return True
    if path is None:
        return False
    try:
        return Path(path).resolve().is_relative_to(packs_dir().resolve())
    except (OSError, RuntimeError):
        return False


def plugin_function_modules(registry: "Registry") -> set[str]:
    """The modules a pack may name functions from: every module named in the ``functions`` of a format or
    evaluator that an installed plugin (not a pack) registers, e.g. ``benchbot_eval_omq.omq``,
    ``benchbot_task_semslam.formats``."""
    modules = set()
    for kind in ("formats", "evaluators"):
        for entry in registry.entries.get(kind, {}).values():
            if is_pack_entry(entry.plugin, entry.path):
                continue
            for value in (entry.spec.get("functions") or {}).values():
                if isinstance(value, str) and ":" in value:
                    modules.add(value.partition(":")[0])
    return modules


def function_problem(value: Any, pack: str, allow_code: bool, allowed: set[str]) -> str | None:
    """Why a pack may not name the (adapted) function path ``value``, or ``None`` when it may.

    Allowed: ``benchbot_packs.<pack>.<module>:<attr>`` (the pack's own code) when ``allow_code``, and
    ``<module>:<attr>`` when ``<module>`` is in ``allowed`` (:func:`plugin_function_modules`). Nothing else: not the
    standard library, not another pack's code, not any other installed module.
    """
    if not isinstance(value, str) or not _FUNCTION_RE.match(value):
        return f"'{value}' is not module:attr"
    module = value.partition(":")[0]
    if module.split(".")[0] == NAMESPACE:
        if not module.startswith(f"{NAMESPACE}.{pack}."):
            return f"'{value}' is the code of another pack"
        if not allow_code:
            return f"'{value}' is pack code, and the pack was installed without --allow-code"
        return None
    if module in allowed:
        return None
    return (f"'{value}' is neither code in the pack nor in a module of an installed plugin's formats/evaluators "
            f"(allowed: {', '.join(sorted(allowed)) or 'none'})")


def _function_errors(scan: PackScan, allow_code: bool, allowed: set[str]) -> list[str]:
    """``<file>: $.functions.<fn>: <problem>`` for every function of the scanned formats/evaluators that a pack may
    not name (pack code is judged allowed here: ``--allow-code`` is checked separately)."""
    problems = []
    for pf in scan.files:
        functions = (pf.spec or {}).get("functions") if pf.kind in ("formats", "evaluators") and not pf.error else None
        for fn_name, value in (functions or {}).items() if isinstance(functions, dict) else ():
            problem = function_problem(value, scan.name, allow_code, allowed)
            if problem:
                problems.append(f"{pf.rel}: $.functions.{fn_name}: {problem}")
    return problems


def _layout_errors(scan: PackScan) -> list[str]:
    """The content problems (:func:`benchbot.packs.layout_checks.layout_problems`) of the pack's layouts: every
    ground truth, and every environment's ``map_path`` that is a ``.json`` file in the pack, checked with the
    environment's own start and trajectory poses; every file of an environment's ``home_files`` must be a ground
    truth (:func:`_home_file_errors`). One line each, no line twice."""
    from benchbot.packs.layout_checks import layout_problems
    from benchbot.core.limits import MAX_SPEC_BYTES
    from benchbot.core.safe_load import load_data_file

    problems: list[str] = []
    for pf in scan.files:
        if pf.error or not isinstance(pf.spec, dict):
            continue
        if pf.kind == "environments":
            problems += _home_file_errors(pf, scan.root)
        if pf.kind == "ground_truths":
            problems += layout_problems(pf.spec, source=pf.rel)
        elif pf.kind == "environments" and isinstance(pf.spec.get("map_path"), str):
            target = Path(pf.spec["map_path"])
            if target.suffix != ".json" or not target.is_absolute() or not target.is_relative_to(scan.root) \
                    or not target.is_file():
                continue  # an Unreal asset path, another simulator's map, or none (the run says so)
            rel = target.relative_to(scan.root).as_posix()
            try:
                layout = load_data_file(target, MAX_SPEC_BYTES, SpecError)
            except SpecError as exc:
                problems.append(f"{pf.rel}: $.map_path: {exc.message.replace(str(target), rel)}")
                continue
            own = "start_pose" in pf.spec or "trajectory_poses" in pf.spec
            problems += layout_problems(layout, source=rel, poses_source=pf.rel if own else None,
                                        start_pose=pf.spec.get("start_pose"),
                                        trajectory_poses=pf.spec.get("trajectory_poses"))
    return list(dict.fromkeys(problems))


def _home_file_errors(pf: PackFile, root: Path) -> list[str]:
    """``<file>: $.home_files[i]: ...`` for each of an environment's ``home_files`` (resolved by the scan) that is
    not a ground-truth JSON file (``{environment, ground_truth: {objects}}``)."""
    from benchbot.core.limits import MAX_SPEC_BYTES
    from benchbot.core.safe_load import load_data_file

    problems = []
    files = pf.spec.get("home_files") if isinstance(pf.spec, dict) else None
    for i, name in enumerate(files if isinstance(files, list) else []):
        target = Path(name)
        rel = target.relative_to(root).as_posix() if target.is_relative_to(root) else name
        where = f"{pf.rel}: $.home_files[{i}]"
        if target.suffix != ".json":
            problems.append(f"{where}: '{rel}' is not a .json file (list the ground-truth JSON files of the home)")
            continue
        try:
            layout = load_data_file(target, MAX_SPEC_BYTES, SpecError)
        except SpecError as exc:
            problems.append(f"{where}: {exc.message.replace(str(target), rel)}")
            continue
        gt = layout.get("ground_truth") if isinstance(layout, dict) else None
        if not isinstance(gt, dict) or not isinstance(gt.get("objects"), list):
            problems.append(f"{where}: '{rel}' is not a ground truth: it has no ground_truth.objects (list the "
                            "ground-truth JSON files {environment, format, ground_truth} of the home)")
    return problems


def verify_pack(path: Path | str, name: str | None = None, *, registry: "Registry") -> PackScan:
    """:func:`scan_pack`, plus the functions check: every function that is not pack code must be in a module of an
    installed plugin's formats/evaluators (:func:`function_problem`), and the content check of the pack's layouts
    (:func:`benchbot.packs.layout_checks.layout_problems`: unknown classes, objects of no size or far from the rest
    of the home, poses inside objects); problems are added to ``errors``.

    Args:
        registry: the installed content (a :class:`~benchbot.core.registry.Registry`).

    Raises:
        PackError: ``path`` is not a folder, or the name is invalid.
    """
    scan = scan_pack(path, name)
    scan.errors.extend(_function_errors(scan, True, plugin_function_modules(registry)))
    scan.errors.extend(_layout_errors(scan))
    return scan


def installed_function_problem(spec_path: Path | None, value: str, registry: "Registry") -> str | None:
    """Why the registry must not import ``value``, a function named by an installed pack's spec at ``spec_path``
    (the pack is the folder of ``packs_dir()`` that holds it), or ``None``. Checked when functions are imported,
    whatever the pack's files say now: its own code only when the user allowed it at install and the pack has not
    changed since (:func:`code_approval_problem`; the pack's manifest is not asked)."""
    pack, approval = "", None
    if spec_path is not None:
        try:
            rel = Path(spec_path).resolve().relative_to(packs_dir().resolve())
            pack = rel.parts[0]
            approval = code_approval_problem(pack, packs_dir() / pack)
        except (ValueError, IndexError, OSError):
            pass
    problem = function_problem(value, pack or "?", approval is None and bool(pack), plugin_function_modules(registry))
    if problem and approval and value.startswith(f"{NAMESPACE}.{pack}."):
        return f"'{value}' is pack code, and {approval}"
    return problem


def imported_function_problem(value: str, obj: Any) -> str | None:
    """Why the object imported for a pack's function path ``value`` may not be called, or ``None``: a function
    re-exported into an allowed plugin module from elsewhere (``from os import system``) is refused, judged by
    its ``__module__``."""
    module = value.partition(":")[0]
    if module.split(".")[0] == NAMESPACE:
        return None  # pack code installed with --allow-code: trusted as a whole
    defined_in = getattr(obj, "__module__", None)
    if not isinstance(defined_in, str) or defined_in.split(".")[0] != module.split(".")[0]:
        return f"'{value}' is defined in {defined_in or 'an unknown module'}, not in {module.split('.')[0]}"
    return None


def read_manifest(pack_dir: Path) -> dict:
    """The manifest of an installed pack (``{}`` when missing, unreadable, or beyond the spec-file limits)."""
    from benchbot.core.limits import MAX_SPEC_BYTES
    from benchbot.core.safe_load import load_data_file

    try:
        data = load_data_file(pack_dir / MANIFEST, MAX_SPEC_BYTES, PackError)
    except PackError:
        return {}
    return data if isinstance(data, dict) else {}


def installed_packs() -> list[dict]:
    """Manifests of the installed packs (sorted by name), each with ``path`` added."""
    base = packs_dir()
    out = []
    if base.is_dir():
        for child in sorted(base.iterdir()):
            if child.is_dir() and not child.name.startswith(".") and (child / MANIFEST).is_file():
                out.append({**read_manifest(child), "name": child.name, "path": str(child)})
    return out


@dataclass
class _Classified:
    provided: list[str] = field(default_factory=list)  # identical in meaning or re-implemented: one line each
    clashes: list[str] = field(default_factory=list)  # real clashes: one line each
    overrides: dict[str, list[str]] = field(default_factory=dict)  # kind -> names that would replace another's
    refused: list[str] = field(default_factory=list)  # clashes that --override cannot settle
    built_in: dict[str, list[str]] = field(default_factory=dict)  # kind -> names a built-in provides: not loaded
    alternatives: list[str] = field(default_factory=list)  # ground truths offered as another set: one line each


def _unavailable_robot(pf: PackFile, registry: "Registry") -> str:
    """Why the pack's robot cannot run on this machine (its type has no robot backend here), or ``""``."""
    robot_type = str(pf.spec.get("type")) if pf.kind == "robots" and pf.spec else ""
    if not robot_type or robot_type in registry.backend_factories:
        return ""
    from benchbot.packs.original_addons import shown

    types = ", ".join(sorted(registry.backend_factories)) or "none"
    return (f"its type '{shown(robot_type, 40)}' needs a robot backend that no installed plugin provides "
            f"(types here: {types})")


def _classify(scan: PackScan, registry: "Registry", replacing: Path | None, override: bool = False) -> _Classified:
    """Each pack file whose name is already installed: identical in meaning or an unchanged original add-on's
    spec that a first-party plugin re-implements (provided), a robot this machine cannot run (the installed one
    stays), a ground truth of another set (an alternative), or a real clash."""
    from benchbot.packs.original_addons import built_in_counterpart, ground_truth_set_of
    from benchbot.core.specs import singular
    from benchbot.core.spec_meaning import differences

    out = _Classified()
    replacing = replacing.resolve() if replacing is not None else None
    for pf in scan.files:
        if not pf.name or pf.spec is None:
            continue
        entry = registry.entries.get(pf.kind, {}).get(pf.name)
        if entry is None:
            continue
        if replacing is not None and entry.path is not None and entry.path.resolve().is_relative_to(replacing):
            # the previous version of this pack: compare with what it overrode, if anything
            entry = getattr(registry, "overridden", {}).get((pf.kind, pf.name))
            if entry is None:
                continue
        what = f"{singular(pf.kind)} '{pf.name}'"
        diff = differences(pf.kind, pf.spec, entry.spec)
        if not diff:
            out.provided.append(f"{pf.rel}: {what} is already provided by {_source(entry, with_path=False)} "
                                "(identical in meaning; that copy is used)")
            continue
        unavailable = _unavailable_robot(pf, registry)
        if unavailable:  # never installed broken: the installed robot stays, --override or not
            out.provided.append(f"{pf.rel}: {what} cannot run here: {unavailable}; the one of "
                                f"{_source(entry, with_path=False)} is kept")
            out.built_in.setdefault(pf.kind, []).append(pf.name)
            continue
        addon = built_in_counterpart(pf.kind, pf.name, pf.spec, pf.path, scan.root)
        if addon is not None and not override and not is_pack_entry(entry.plugin, entry.path):
            out.provided.append(f"{pf.rel}: {what} is the original add-on {addon}'s, unchanged; "
                                f"{_source(entry, with_path=False)} provides its re-implementation, which is used "
                                "(--override installs the add-on's own instead)")
            out.built_in.setdefault(pf.kind, []).append(pf.name)
            continue
        if pf.kind == "ground_truths" and not getattr(entry, "override", False):
            ours = ground_truth_set_of(pf.spec) or scan.name
            theirs = ground_truth_set_of(entry.spec) or entry.plugin
            if ours != theirs:
                out.alternatives.append(f"{pf.rel}: {what} is offered as ground-truth set '{ours}' beside set "
                                        f"'{theirs}' of {_source(entry, with_path=False)}, which stays the default "
                                        f"(choose with --ground-truths {ours}); they differ in {', '.join(diff)}")
                continue
        how = (f"differs only in functions (the pack's own code, not that of {_source(entry, with_path=False)})"
               if diff == ["functions"] else f"differs in {', '.join(diff)}")
        out.clashes.append(f"{pf.rel}: {what} is already installed by {_source(entry)} and {how}")
        out.overrides.setdefault(pf.kind, []).append(pf.name)
        if getattr(entry, "override", False):
            out.refused.append(f"{pf.rel}: {what} of {_source(entry)} is itself an override")
    return out


def _code_needed(scan: PackScan, built_in: dict[str, list[str]]) -> list[str]:
    """Why the pack needs ``--allow-code``, leaving out the files whose spec a built-in provides (never loaded,
    so their code never runs)."""
    return [c for pf in scan.files if pf.name not in built_in.get(pf.kind, []) for c in pf.code]


def _source(entry: Any, with_path: bool = True) -> str:
    """``pack 'x' (path)`` or ``plugin 'x' (path)`` for a registry entry (the path only with ``with_path``)."""
    path = f" ({entry.path})" if with_path and entry.path else ""
    if is_pack_entry(entry.plugin, entry.path) and entry.path is not None:
        try:
            pack = Path(entry.path).resolve().relative_to(packs_dir().resolve()).parts[0]
            return f"pack '{pack}'{path}"
        except (ValueError, IndexError, OSError):
            pass
    return f"plugin '{entry.plugin}'{path}"


def _usability_notes(scan: PackScan, registry: "Registry", overrides: dict[str, list[str]],
                     built_in: dict[str, list[str]], dest: Path) -> list[str]:
    """Notes on content that installs but cannot be used here: robots of a type no plugin runs (listed as
    unavailable), batches naming environments that are not installed."""
    from benchbot.packs.original_addons import compact_names, shown
    from benchbot.core.specs import singular

    notes = []
    envs = set(registry.entries.get("environments", {}))
    envs |= {pf.name for pf in scan.files if pf.kind == "environments" and pf.name}
    for pf in scan.files:
        if pf.error or pf.spec is None:
            continue
        if pf.kind == "robots" and pf.spec.get("type") not in registry.backend_factories:
            other = registry.entries["robots"].get(pf.name)
            if pf.name in built_in.get("robots", []) or (
                    other is not None and pf.name not in overrides.get("robots", [])
                    and not (other.path is not None and Path(other.path).resolve().is_relative_to(dest.resolve()))):
                continue  # not registered from this pack (said already, or provided)
            types = ", ".join(sorted(registry.backend_factories)) or "none"
            notes.append(f"{pf.rel}: {singular(pf.kind)} '{pf.name}' is unavailable here (benchbot list robots says "
                         f"so): its type '{shown(str(pf.spec.get('type')), 40)}' needs a robot backend that no "
                         f"installed plugin provides (types here: {types})")
        if pf.kind == "batches":
            missing: list[str] = []
            for env in pf.spec.get("environments") or []:
                base, _, variants = str(env).partition(":")
                scenes = (f"{base}:{v}" for v in variants.split(":"))
                missing.extend(s for s in scenes if s not in envs and s not in missing)
            if missing:
                notes.append(f"{pf.rel}: batch '{pf.name}' names environments that are not installed: "
                             f"{compact_names(missing)}")
    return notes


STAGED_ATTR = "_dry_run_packs"
"""The attribute of a registry naming the packs a dry run has staged into it (:func:`_stage`)."""


def _stage(registry: "Registry", scan: PackScan, dest: Path, overrides: dict[str, list[str]],
           built_in: dict[str, list[str]] | None = None) -> None:
    """Add the specs of a pack that a dry run found installable to ``registry`` as the real install would (as
    entries of the pack's future folder), so the next pack of the same ``benchbot install --dry-run`` is checked
    against it as a real install checks it against the installed pack. Specs a built-in provides
    (``built_in``) are left out, as the registry leaves them out of an installed pack."""
    from benchbot.core.specs import Entry
    from benchbot.core.spec_meaning import same_meaning

    for pf in scan.files:
        if not pf.name or pf.spec is None or pf.name in (built_in or {}).get(pf.kind, []):
            continue
        entries = registry.entries.setdefault(pf.kind, {})
        override = pf.name in overrides.get(pf.kind, [])
        first = entries.get(pf.name)
        if first is not None and not override:
            same = same_meaning(pf.kind, first.spec, pf.spec)
            if same or first.override:
                continue
        if first is not None and override and hasattr(registry, "overridden"):
            registry.overridden[(pf.kind, pf.name)] = first
        entries[pf.name] = Entry(pf.kind, pf.name, pf.spec, PLUGIN, dest / pf.rel, override)
    setattr(registry, STAGED_ATTR, getattr(registry, STAGED_ATTR, set()) | {scan.name})


def install_pack(path: Path | str, *, name: str | None = None, allow_code: bool = False, force: bool = False,
                 override: bool = False, dry_run: bool = False, registry: "Registry") -> dict:
    """Validate the pack at ``path`` and copy it atomically to ``<data dir>/packs/<name>/``.

    ``dry_run=True`` runs every check of a real install (the same errors, so the same exit code) and copies
    nothing: ``benchbot install --dry-run`` and ``benchbot install`` share this one code path.

    Args:
        path: the pack folder (an original add-on's folder as it is, ``.remote`` and ``.dependencies`` included).
        name: the pack name (default: the folder's name, normalised by :func:`pack_name`).
        allow_code: allow Python functions and examples that live in the pack (``--allow-code``).
        force: replace an installed pack of the same name.
        override: let the pack's specs replace installed specs of the same name that differ in meaning
            (``--override``; recorded in the manifest's ``overrides``, undone by uninstalling the pack).
        dry_run: check everything, change nothing.
        registry: the installed content to check clashes against (a :class:`~benchbot.core.registry.Registry`).

    Returns:
        The manifest (written, or that would be written): ``name``, ``source``, ``allow_code``, ``code``
        (reasons, leaving out code that never runs), ``installed_at`` (Unix s), ``files`` (``{kind: [names]}``),
        ``overrides`` (``{kind: [names]}``), ``built_in`` (``{kind: [names]}`` of specs the registry does not load
        from the pack: an unchanged original add-on's spec that a first-party plugin re-implements, or a robot of
        a name already installed that cannot run here), plus ``path``, ``provided`` (one line each: specs identical
        in meaning to installed ones, the ``built_in`` ones, ground truths offered as another set), ``overridden``
        (one line each), ``notes`` (content that installs but cannot be used here, the add-on's
        ``.dependencies``), ``warnings`` (:attr:`PackScan.warnings`) and ``dry_run``.

    Raises:
        PackError: the folder is an original add-on whose content is a download (``.remote``: what it would
            download and which installed content corresponds) or only a list of other add-ons; invalid or unsafe
            files (``details`` lists every one, e.g. a function outside the pack and the installed plugins'
            modules); code without ``allow_code``; a pack of that name already installed (without ``force``);
            names clashing with installed specs that differ in meaning (without ``override``, naming both
            sources and the fields that differ); or the copy failed.
    """
    from benchbot.packs.original_addons import addon_notes, addon_problem

    given = Path(path).expanduser()
    if given.is_dir():
        problem = addon_problem(given.resolve(), registry)
        if problem is not None:
            raise problem
    scan = verify_pack(path, name, registry=registry)
    if scan.errors:
        raise PackError(f"pack '{scan.name}' ({scan.root}) has {len(scan.errors)} problem(s); nothing installed",
                        "fix the files listed above", scan.errors)
    base = packs_dir()
    dest = base / scan.name
    staged = getattr(registry, STAGED_ATTR, set())
    exists = dest.exists() or scan.name in staged
    found = _classify(scan, registry, dest if exists else None, override)
    code = _code_needed(scan, found.built_in)
    if code and not allow_code:
        raise PackError(f"pack '{scan.name}' contains code that BenchBot would run ({len(code)} place(s)); "
                        "nothing installed", "read the code, then install again with --allow-code",
                        found.provided + code)
    if exists and not force:
        raise PackError(f"a pack named '{scan.name}' is already installed ({dest})",
                        "pass --force to replace it, or --name to install under another name")
    if found.refused and override:
        raise PackError(f"pack '{scan.name}' would override an override: {found.refused[0]}; nothing installed",
                        "uninstall the pack that overrides it, then install again", found.refused)
    if found.clashes and not override:
        first = found.clashes[0]
        more = f" (and {len(found.clashes) - 1} more, listed above)" if len(found.clashes) > 1 else ""
        raise PackError(f"pack '{scan.name}' clashes with installed content: {first}{more}; nothing installed",
                        "install with --override to use the pack's version instead (uninstalling the pack restores "
                        "the other), rename the spec in the pack, or uninstall the other source",
                        found.provided + found.clashes)
    if base.resolve().is_relative_to(scan.root):
        raise PackError(f"the data directory {base} is inside the pack", "install from another folder")
    overrides = found.overrides if override else {}
    manifest: dict[str, Any] = {
        "name": scan.name,
        "source": str(scan.root),
        "allow_code": bool(allow_code),
        "code": code,
        "installed_at": time.time(),
        "files": {},
        "overrides": overrides,
        "built_in": found.built_in,
    }
    for pf in scan.files:
        manifest["files"].setdefault(pf.kind, []).append(pf.name)
    report = {"path": str(dest), "provided": found.provided + found.alternatives, "dry_run": dry_run,
              "warnings": list(scan.warnings),
              "overridden": [c.replace(" is already installed by ", " overrides the one of ", 1) for c in found.clashes]
              if override else [],
              "notes": addon_notes(scan.root) + _usability_notes(scan, registry, overrides, found.built_in, dest)}
    if dry_run:
        _stage(registry, scan, dest, overrides, found.built_in)
        return {**manifest, **report}
    base.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=base, prefix=f".tmp-{scan.name}-"))
    old: Path | None = None
    try:
        shutil.copytree(scan.root, tmp, symlinks=False, dirs_exist_ok=True,
                        ignore=shutil.ignore_patterns(*IGNORED, "*.pyc"))
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
        if dest.exists():
            old = base / f".old-{scan.name}-{os.getpid()}-{time.monotonic_ns()}"
            os.rename(dest, old)
        os.rename(tmp, dest)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if old is not None and not dest.exists():
            os.rename(old, dest)
        raise PackError(f"cannot install pack '{scan.name}' into {dest}: {exc.strerror or exc}",
                        "check that the data directory is writable (BENCHBOT_DATA_DIR)") from None
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    try:  # what the user allowed, kept outside the pack: the pack's code runs only while its digest is this one
        _record_approval(scan.name, {"digest": pack_digest(dest), "source": str(scan.root),
                                     "approved_at": manifest["installed_at"]} if allow_code else None)
    except OSError as exc:
        raise PackError(f"pack '{scan.name}' was installed into {dest}, but {approvals_path()} cannot be written "
                        f"({exc.strerror or exc}): its code will not run",
                        "check that the data directory is writable (BENCHBOT_DATA_DIR), then install again") from None
    return {**manifest, **report}


def uninstall_pack(name: str) -> Path:
    """Remove the installed pack ``name`` (renamed away first, then deleted).

    Returns:
        The folder it was installed in.

    Raises:
        PackError: no such pack.
    """
    dest = packs_dir() / pack_name(name)
    if not (dest / MANIFEST).is_file():
        names = ", ".join(p["name"] for p in installed_packs()) or "none"
        raise PackError(f"no content pack named '{name}' is installed (installed packs: {names})",
                        "see `benchbot plugins`")
    trash = dest.parent / f".old-{dest.name}-{os.getpid()}-{time.monotonic_ns()}"
    os.rename(dest, trash)
    shutil.rmtree(trash, ignore_errors=True)
    try:
        _record_approval(dest.name, None)
    except OSError:
        pass  # a stale approval matches no future pack: its digest names these files exactly
    return dest


def _register_namespace(pack: str, pack_dir: Path) -> None:
    """Make ``benchbot_packs.<pack>`` importable from ``pack_dir`` (only called for packs allowed to run code)."""
    ns = sys.modules.get(NAMESPACE)
    if ns is None:
        ns = types.ModuleType(NAMESPACE, "Code of content packs installed with --allow-code.")
        ns.__path__ = []  # type: ignore[attr-defined]
        sys.modules[NAMESPACE] = ns
    module_name = f"{NAMESPACE}.{pack}"
    existing = sys.modules.get(module_name)
    if existing is not None and list(getattr(existing, "__path__", [])) == [str(pack_dir)]:
        return
    for key in [k for k in sys.modules if k == module_name or k.startswith(module_name + ".")]:
        del sys.modules[key]
    mod = types.ModuleType(module_name, f"Code of the content pack '{pack}'.")
    mod.__path__ = [str(pack_dir)]  # type: ignore[attr-defined]
    sys.modules[module_name] = mod
    setattr(ns, pack, mod)


def load_installed_specs() -> dict[str, list[Any]]:
    """``{kind: [spec dict or path]}`` of every installed pack, for the registry.

    Invalid files are returned as well (dicts with ``_file_path``, or the path when unparsable) so the registry
    reports them naming the file; a file the scan refuses (:func:`scan_pack`: a ``map_path`` leaving the pack or
    ``/Game/``, a function that is not ``module:attr``, an invalid spec) as ``{_file_path, _load_error}``: the
    checks of an install hold for files edited after it. Code of a pack is made importable only when the user
    allowed it at install and the pack is unchanged since (:func:`code_approval_problem`: a manifest edited to
    ``allow_code: true`` and a ``.py`` dropped in gain nothing); otherwise a file that needs it (pack functions,
    examples) is returned as ``{_file_path, _load_error}`` for the registry to report, in one line saying how to
    re-install, instead of registering it. A spec that the pack's manifest lists in ``overrides`` (installed with
    ``--override``) carries :data:`OVERRIDE_KEY`.
    """
    out: dict[str, list[Any]] = {}
    for manifest in installed_packs():
        pack_dir = Path(manifest["path"])
        try:
            scan = scan_pack(pack_dir, manifest["name"])
        except PackError:
            continue
        built_in = manifest.get("built_in") if isinstance(manifest.get("built_in"), dict) else {}
        built_in = {k: v for k, v in built_in.items() if isinstance(v, list)}
        code = _code_needed(scan, built_in)
        refused = code_approval_problem(scan.name, pack_dir) if code else None
        if code and refused is None:
            _register_namespace(scan.name, scan.root)
        overrides = manifest.get("overrides") if isinstance(manifest.get("overrides"), dict) else {}
        for pf in scan.files:
            if pf.name and pf.name in built_in.get(pf.kind, []):
                continue  # a built-in provides it (the original add-on's, re-implemented) or it cannot run here
            if pf.error and pf.spec is not None:  # refused by the scan (say, a map_path edited to leave the pack)
                where = f"{pf.path}{pf.error[len(pf.rel):]}" if pf.error.startswith(pf.rel) else pf.error
                out.setdefault(pf.kind, []).append({"_file_path": str(pf.path), LOAD_ERROR_KEY: where})
                continue
            if pf.code and refused:  # not allowed at install, or changed since: never run the new code
                out.setdefault(pf.kind, []).append({"_file_path": str(pf.path), LOAD_ERROR_KEY: (
                    f"{pf.path}: {pf.code[0].partition(': ')[2]}, but {refused}")})
                continue
            names = overrides.get(pf.kind)
            if pf.spec is not None and pf.name and isinstance(names, list) and pf.name in names:
                pf.spec[OVERRIDE_KEY] = True  # installed with --override: replaces another source's spec
            out.setdefault(pf.kind, []).append(pf.spec if pf.spec is not None else pf.path)
    return out
