"""The original add-ons' own files beyond their specs: ``.remote``, ``.dependencies`` and ``.dependencies-python``.

The original add-on manager downloaded the URL on the first line of an add-on's ``.remote`` (``URL FOLDER``, often
a Google Drive or CloudStor link) and unzipped it into ``FOLDER`` of the add-on — that is how the Isaac
environments (``envs_isaac_develop``, ...) and the Omniverse robot (``robots_sim_omni``) were delivered — installed
the add-ons named in ``.dependencies`` recursively and the pip lines of ``.dependencies-python`` on the host.

BenchBot downloads nothing and installs no dependencies of a content pack. These files still mark a folder as an
original add-on (:func:`is_addon_folder`: ``benchbot install`` treats it as a content pack, never hands it to
pip); an add-on whose content is still a download is refused with an explanation (:func:`addon_problem`: what it
would download, and which installed content corresponds, from :data:`KNOWN_REMOTES`); the others are reported as
notes (:func:`addon_notes`).

It also knows the original add-ons' own files by content (:data:`ORIGINAL_FILES`: git blob ids of the files at the
add-ons' latest commits), so that an add-on copied unchanged is recognised: its specs whose names BenchBot's
first-party plugins re-implement (:data:`BUILT_IN_COUNTERPARTS`) are "already provided" instead of clashing
(:func:`built_in_counterpart`), and the two BEAR ground-truth sets of the original, ``isaac_develop`` and
``bear_develop``, are told apart (:data:`GROUND_TRUTH_SETS`, :func:`ground_truth_set_of`) and both offered
(:func:`bear_develop_from_isaac_develop`).
"""

from __future__ import annotations

import copy
import hashlib
import json
import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from benchbot.packs.pack_layout import FOLDER_KINDS, PackError, spec_files

if TYPE_CHECKING:  # pragma: no cover
    from benchbot.core.registry import Registry

ADDON_MARKERS = (".remote", ".dependencies", ".dependencies-python")
"""Files that mark a folder as an original add-on even when it holds no type folder."""
MAX_MARKER_BYTES = 64 * 1024
"""The most of a marker file that is read."""


@dataclass(frozen=True)
class KnownRemote:
    """An original add-on whose content was a download (its ``.remote``), and what corresponds to it here.

    Attributes:
        addons: the add-on repositories' names (``benchbot-addons/<name>``).
        urls: the URLs their ``.remote`` named.
        held: what the download held, in words.
        kind: the registry kind of the corresponding content here.
        names: the names it had (environments ``name:variant``), or the names here that stand in for it.
    """

    addons: tuple[str, ...]
    urls: tuple[str, ...]
    held: str
    kind: str
    names: tuple[str, ...]


def _scenes(*names: str) -> tuple[str, ...]:
    return tuple(f"{n}:{v}" for n in names for v in range(1, 6))


KNOWN_REMOTES: tuple[KnownRemote, ...] = (
    KnownRemote(("envs_isaac_develop",), ("https://cloudstor.aarnet.edu.au/plus/s/ZqgsznfVNyxnbxV/download",),
                "the 10 BEAR development scenes for Isaac Sim (Unreal Engine)", "environments",
                _scenes("miniroom", "house")),
    KnownRemote(("envs_bear_develop_sim_omni",),
                ("https://drive.google.com/file/d/1jGJKyg-adoIxpW4y5MRXLVjREfesV68-/view?usp=share_link",),
                "the 10 BEAR development scenes for Isaac Sim (Omniverse)", "environments",
                _scenes("miniroom", "house")),
    KnownRemote(("envs_isaac_challenge",), ("https://cloudstor.aarnet.edu.au/plus/s/aSjCoQxLjVNUuwR/download",),
                "the 15 BEAR challenge scenes for Isaac Sim (Unreal Engine)", "environments",
                _scenes("apartment", "company", "office")),
    KnownRemote(("envs_bear_challenge_sim_omni",),
                ("https://drive.google.com/file/d/1cZ-h6w1EuD9J6Qh7QLk1LUJf1omVCHqx/view?usp=share_link",),
                "the 15 BEAR challenge scenes for Isaac Sim (Omniverse)", "environments",
                _scenes("apartment", "company", "office")),
    KnownRemote(("robots_sim_omni",),
                ("https://drive.google.com/file/d/1mAvuJocmiOxgg-CwCppxyfJyuCusutJd/view?usp=share_link",),
                "the robot carter_omni for Isaac Sim (Omniverse)", "robots", ("carter",)),
)
"""The original add-ons of the benchbot-addons organisation that held only a ``.remote`` (from their repositories:
the URL of each and the scenes their READMEs list), matched by URL or by the add-on folder's name."""


def is_addon_folder(path: Path | str) -> bool:
    """Whether ``path`` is a content pack rather than a Python project: a folder with no ``pyproject.toml``,
    ``setup.py`` or ``setup.cfg`` that holds a type folder (``tasks/``, ``robots/``, ...) anywhere, or one of the
    original add-on's marker files (:data:`ADDON_MARKERS`: ``.remote``, ``.dependencies``, ...)."""
    folder = Path(path).expanduser()
    if not folder.is_dir() or any((folder / f).exists() for f in ("pyproject.toml", "setup.py", "setup.cfg")):
        return False
    if any((folder / m).is_file() for m in ADDON_MARKERS):
        return True
    return any(p.is_dir() for p in folder.rglob("*") if p.name in FOLDER_KINDS)


def shown(text: str, limit: int = 200) -> str:
    """``text`` safe to print: control characters as ``?``, at most ``limit`` characters."""
    text = "".join(c if c.isprintable() else "?" for c in text)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def marker_lines(root: Path, marker: str) -> list[str]:
    """The non-empty, stripped lines of the marker file ``root/marker`` (``[]`` when there is none).

    Raises:
        PackError: it is a symlink, not a regular file, or unreadable (naming the file).
    """
    file = root / marker
    if not file.exists() and not file.is_symlink():
        return []
    if file.is_symlink() or not file.is_file():
        raise PackError(f"{file}: not a regular file", f"make {marker} a plain text file or remove it")
    try:
        with open(file, "rb") as fh:
            text = fh.read(MAX_MARKER_BYTES).decode("utf-8", errors="replace")
    except OSError as exc:
        raise PackError(f"{file}: cannot read it: {exc.strerror or exc}", "check the file's permissions") from None
    return [line.strip() for line in text.splitlines() if line.strip() and not line.strip().startswith("#")]


@dataclass(frozen=True)
class Remote:
    """The first line of an add-on's ``.remote``: ``URL FOLDER`` (the original read only that line).

    Attributes:
        url: what the original add-on manager downloaded (a zip).
        target: the folder of the add-on it unzipped it into (relative, e.g. ``environments``).
    """

    url: str
    target: str


def read_remote(root: Path | str) -> Remote | None:
    """The ``.remote`` of the add-on folder ``root``, or ``None`` when it has none.

    Raises:
        PackError: the file is not ``URL FOLDER`` on its first line, or ``FOLDER`` is absolute or leaves the add-on
            (one line naming the file).
    """
    lines = marker_lines(Path(root), ".remote")
    if not lines:
        return None
    fields = lines[0].split()
    file = Path(root) / ".remote"
    if len(fields) != 2 or "://" not in fields[0]:
        raise PackError(f"{file}: line 1 is '{shown(lines[0], 120)}', not 'URL FOLDER'",
                        "write the URL of the zip and the folder of the add-on to unzip it into, e.g. "
                        "'https://example.org/envs.zip environments'")
    url, target = fields
    parts = Path(target).parts
    if Path(target).is_absolute() or ".." in parts or target.startswith("~"):
        raise PackError(f"{file}: the folder '{shown(target, 80)}' is not inside the add-on",
                        "name a folder relative to the add-on, e.g. environments")
    return Remote(url, target)


def remote_fetched(root: Path, remote: Remote) -> bool:
    """Whether the content of ``remote`` is already in the add-on: spec files in its folder (someone downloaded
    and unzipped it by hand)."""
    target = (root / remote.target).resolve()
    return any(path.resolve().is_relative_to(target) for _, path in spec_files(root))


def _known_remote(root: Path, remote: Remote) -> KnownRemote | None:
    folder = root.name.lower().replace("-", "_")
    for known in KNOWN_REMOTES:
        if remote.url in known.urls:
            return known
    for known in KNOWN_REMOTES:
        if folder in known.addons:
            return known
    return None


def compact_names(names: list[str] | tuple[str, ...]) -> str:
    """``house:1 … house:5, office:1, office:3`` → ``'house:1..5, office:1, office:3'`` (runs of three or more
    consecutive numeric variants of one name shortened; order of first appearance kept)."""
    groups: dict[str, list[str]] = {}
    for n in names:
        base, sep, variant = n.partition(":")
        groups.setdefault(base if sep else n, []).append(variant if sep else "")
    out: list[str] = []
    for base, variants in groups.items():
        if not all(v.isdigit() for v in variants):
            out.extend(f"{base}:{v}" if v else base for v in variants)
            continue
        numbers = sorted({int(v) for v in variants})
        run: list[int] = []
        for number in [*numbers, None]:
            if number is not None and run and number == run[-1] + 1:
                run.append(number)
                continue
            if len(run) >= 3:
                out.append(f"{base}:{run[0]}..{run[-1]}")
            else:
                out.extend(f"{base}:{v}" for v in run)
            run = [number] if number is not None else []
    return ", ".join(out)


def remote_refusal(root: Path, remote: Remote, registry: "Registry") -> PackError:
    """The error (not raised) for an add-on whose ``.remote`` content is not in the folder: what it would
    download, that nothing is downloaded, and which installed content corresponds (:data:`KNOWN_REMOTES`, looked
    up in ``registry``); its ``details`` name the URL, the folder, ``.dependencies`` and the correspondence.

    Raises:
        PackError: ``.dependencies`` is unreadable (naming it).
    """
    from benchbot.core.specs import singular

    name = shown(root.name, 64)
    known = _known_remote(root, remote)
    details = [f".remote: would download {shown(remote.url)} and unzip it into {shown(remote.target, 80)}/"
               + (f" ({known.held})" if known else "")]
    deps = marker_lines(root, ".dependencies")
    if deps:
        details.append(f".dependencies lists {', '.join(shown(d, 80) for d in deps)}: BenchBot installs no add-on's "
                       "dependencies")
    if known is None:
        hint = (f"download it on a machine that can, unzip it into {shown(remote.target, 80)}/ of the add-on, "
                "and install the folder again")
    else:
        entries = registry.entries.get(known.kind, {})
        here = [n for n in known.names if n in entries]
        missing = [n for n in known.names if n not in entries]
        plugins = sorted({entries[n].plugin for n in here})
        kind_words = known.kind.replace("_", " ") if len(known.names) > 1 else singular(known.kind)
        if here:
            details.append(f"corresponding here: {kind_words} {compact_names(here)} (plugin "
                           f"{', '.join(repr(p) for p in plugins)})")
        if missing:
            details.append(f"not available here: {kind_words} {compact_names(missing)}")
        if here and not missing:
            hint = (f"use the installed {kind_words} {compact_names(here)} instead (benchbot list {known.kind}); "
                    "nothing needs installing")
        elif here:
            hint = (f"use the installed {kind_words} {compact_names(here)}; for the others, unzip the download into "
                    f"{shown(remote.target, 80)}/ of the add-on and install the folder again")
        else:
            hint = (f"no installed {known.kind.replace('_', ' ')} correspond; if you have the download, unzip it into "
                    f"{shown(remote.target, 80)}/ of the add-on and install the folder again")
    return PackError(f"add-on '{name}' keeps its {known.kind.replace('_', ' ') if known else 'content'} in a download "
                     f"(.remote: {shown(remote.url, 120)}); BenchBot downloads nothing at install or run time, so "
                     "nothing was installed", hint, details)


def addon_problem(root: Path, registry: "Registry") -> PackError | None:
    """Why an original add-on folder that holds no spec files cannot be installed: its content is a download
    (``.remote``, :func:`remote_refusal`) or it only lists other add-ons (``.dependencies``); ``None`` when it holds
    spec files (a ``.remote`` part not yet downloaded is then a note, :func:`addon_notes`).

    Raises:
        PackError: a marker file is unreadable or malformed (naming it).
    """
    if spec_files(root):
        return None
    remote = read_remote(root)
    if remote is not None:
        return remote_refusal(root, remote, registry)
    deps = marker_lines(root, ".dependencies")
    if deps:
        return PackError(f"add-on '{shown(root.name, 64)}' has no spec files of its own: it only lists other "
                         f"add-ons ({', '.join(shown(d, 80) for d in deps)}); nothing was installed",
                         "install each of those add-on folders by path (BenchBot installs no add-on's dependencies)")
    return None


def addon_notes(root: Path) -> list[str]:
    """Notes about the original add-on's marker files of a pack that does hold spec files: its ``.remote`` (already
    unzipped in it, or a part that is not installed), ``.dependencies`` and ``.dependencies-python`` (never
    installed).

    Raises:
        PackError: a marker file is unreadable or malformed (naming it).
    """
    notes = []
    remote = read_remote(root)
    if remote is not None and remote_fetched(root, remote):
        notes.append(f".remote: its content ({shown(remote.target, 80)}/) is already in the folder; nothing is "
                     "downloaded")
    elif remote is not None:
        notes.append(f".remote: {shown(remote.url)} would be unzipped into {shown(remote.target, 80)}/; BenchBot "
                     "downloads nothing, so that part of the add-on is not installed")
    deps = marker_lines(root, ".dependencies")
    if deps:
        notes.append(f".dependencies lists {', '.join(shown(d, 80) for d in deps)}: BenchBot installs no add-on's "
                     "dependencies (install them by path if you need them)")
    python = marker_lines(root, ".dependencies-python")
    if python:
        notes.append(f".dependencies-python lists {', '.join(shown(d, 40) for d in python)}: a pack installs no "
                     "Python packages (its code may use those of BenchBot's environment)")
    return notes


# --------------------------------------------------------------------------------------------------------------------
# The original add-ons' own files, known by content
# --------------------------------------------------------------------------------------------------------------------
ORIGINAL_FILES: dict[str, tuple[str, str]] = {
    "9c29da543a5304ba86d97da8ff1868718bd725c4": ("formats_object_map", "formats/object_map.py"),
    "96e1d5ef411ce7f3c99a08646d514a8047a6e29f": ("formats_object_map", "formats/object_map.yaml"),
    "a69b3c98a83e7b1bd74e141c7693e92835fdf1f1": ("formats_object_map", "formats/object_map_ground_truth.py"),
    "fae0df709ef2d448fc03d7ba6cee9ee735834e1f": ("formats_object_map", "formats/object_map_ground_truth.yaml"),
    "18a7439efadf02917cbaf11c2b1a01c6304548b1": ("formats_object_map", "formats/object_map_states.py"),
    "2b326454470b524b33ae7c1c38ebb326fae193b2": ("formats_object_map", "formats/object_map_with_states.yaml"),
    "4ad0261a9933253a7f290754b2c860e30d3a9455": ("eval_omq", "evaluation_methods/input_processor.py"),
    "5563b313cdd0846e4b394a19cd448c06468c7c9c": ("eval_omq", "evaluation_methods/iou_tools.py"),
    "1cea08698198ddd8d36957aa5a05265b48a68949": ("eval_omq", "evaluation_methods/omq.py"),
    "754fde03d516c44fdb4aef524712243492bcc11b": ("eval_omq", "evaluation_methods/omq.yaml"),
    "49669fd566f70803d2c9926b72d036d57b1c61a1": ("examples_base", "examples/.hello_active/Dockerfile"),
    "413ecc2093f601399184c80710bb627cceb54a33": ("examples_base", "examples/.hello_active/hello_active"),
    "cf3e3ff29cb6dcdd0ebf9a58b7a9349cad009e5e": ("examples_base", "examples/.hello_active/interactive_agent.py"),
    "7727e169949ea27312caa7006857d7d160888c03": ("examples_base", "examples/.hello_args/Dockerfile"),
    "86a03578b4e33a24186586abc2b14f537568843a": ("examples_base", "examples/.hello_args/hello_args"),
    "2991985756267b090f7ee32a8f95057bb0a6a1b0": ("examples_base", "examples/.hello_benchbot/Dockerfile"),
    "bdb0aea4e942bdd533a867e930c1b5579409bc26": ("examples_base", "examples/.hello_benchbot/hello_benchbot"),
    "504acd1ff13151394954df8730c8fb46d8de7cd0": ("examples_base", "examples/.hello_benchbot/line_agent.py"),
    "5e766853fae60e1e9f98f402bda201f19cb5f56b": ("examples_base", "examples/.hello_passive/Dockerfile"),
    "2a0a24fef5167d659de45f1032b34fafe167a269": ("examples_base", "examples/.hello_passive/guided_agent.py"),
    "eb0d841bc38d41b128533080a8aef69a603e8b96": ("examples_base", "examples/.hello_passive/hello_passive"),
    "aed35b0403728e2d3e64ffd15f1fccd2ea8617a8": ("examples_base", "examples/hello_active.yaml"),
    "a9751929f8911e4a62b3aa60643cee2e121d7053": ("examples_base", "examples/hello_args.yaml"),
    "c3589ae59876c882b9b36c0af167c04508893b4c": ("examples_base", "examples/hello_benchbot.yaml"),
    "5dab496e91e97f50cebac999141d8cfab2fb7ca2": ("examples_base", "examples/hello_passive.yaml"),
    "8a928de77041ebf255e2c02b627338a94e523e33": ("examples_ssu", "examples/.aigym_scd/Dockerfile"),
    "47a517e9d5822c680a018121afd9a35a11c0436f": ("examples_ssu", "examples/.aigym_scd/aigym_scd"),
    "0164a3e66c413dc65a69432ab9f5e2fcbc7b24a2": ("examples_ssu", "examples/.aigym_semantic_slam/Dockerfile"),
    "240d9dd0a28cdd86ffabcd2216f0f64269ba617c": ("examples_ssu", "examples/.aigym_semantic_slam/aigym_semantic_slam"),
    "2c840c9c66d43218c88eb7fb03702900b5a0302b": ("examples_ssu", "examples/.hello_eval_scd/Dockerfile"),
    "f3d1ade110207eca8700ac8ff527b414bcc14e2b": ("examples_ssu", "examples/.hello_eval_scd/eval_scd_agent.py"),
    "576b382138de8e21a9b4770cfe7654a1eff8c5e7": ("examples_ssu", "examples/.hello_eval_scd/ground_truth_miniroom_1.json"),
    "a83b9e1d13d164dc9b831a688ddb1a7a03612fe6": ("examples_ssu", "examples/.hello_eval_scd/ground_truth_miniroom_2.json"),
    "fe774e8c8ef69f10958d797cd0f4da4585402044": ("examples_ssu", "examples/.hello_eval_scd/hello_eval_scd"),
    "5a12ee3aace95b94098b4e222c623e8204f78794": ("examples_ssu", "examples/.hello_eval_semantic_slam/Dockerfile"),
    "85402df8cf9884bb110115a3c911ff5c7010c41d": ("examples_ssu", "examples/.hello_eval_semantic_slam/eval_semantic_slam_agent.py"),
    "576b382138de8e21a9b4770cfe7654a1eff8c5e7": ("examples_ssu", "examples/.hello_eval_semantic_slam/ground_truth_miniroom_1.json"),
    "f5cdd74b9de374e9abaeb84670950ea7d1412567": ("examples_ssu", "examples/.hello_eval_semantic_slam/hello_eval_semantic_slam"),
    "e2e2f2a96e59265bea77048e97084d1e7b5e2245": ("examples_ssu", "examples/.hello_scd/Dockerfile"),
    "2d4253ee8d5466dfe9501474718b415a7b23c17b": ("examples_ssu", "examples/.hello_scd/hello_scd"),
    "dd44740394edf9660341b2042960a8f56e353f8b": ("examples_ssu", "examples/.semantic_slam_attempt/Dockerfile"),
    "89e21a8790f6ddfea8513a40c8b3955656669954": ("examples_ssu", "examples/.semantic_slam_attempt/semantic_slam_attempt"),
    "f9ac472cbcdf815f84e7c05cba2b452d6acd13c1": ("examples_ssu", "examples/.semantic_slam_attempt/votenet_benchbot.py"),
    "ac908b5215655b2dadf87286427678aa4942ad4c": ("examples_ssu", "examples/aigym_scd.yaml"),
    "46bbd1b8459ddee65954a51c2273c1be7cb63889": ("examples_ssu", "examples/aigym_semantic_slam.yaml"),
    "7af17cfc4b6a90c38e9b90473f9e944f414c2afe": ("examples_ssu", "examples/hello_eval_scd.yaml"),
    "18d5d16e6b849daee93569b6e220b510e6d2aa3c": ("examples_ssu", "examples/hello_eval_semantic_slam.yaml"),
    "b06340ab0471110c57d642595c57d46dd93b8184": ("examples_ssu", "examples/hello_scd.yaml"),
    "6a86f60a8f4672e62fe4d910fc8a163d087e1662": ("examples_ssu", "examples/semantic_slam_attempt.yaml"),
    "b1f18bfb1544026c519e858ca336b33bedc1b98b": ("robots_isaac", "robots/carter.yaml"),
    "36b14ebe73188d41c9d5b6532db8a3bf92404d94": ("robots_isaac", "robots/carter_remote.yaml"),
}
"""``{git blob id: (add-on, path)}`` of the spec and code files of the original add-ons whose content BenchBot's
first-party plugins re-implement, at their repositories' latest commits (benchbot-addons/formats_object_map
``c3ad0d1``, eval_omq ``241a3f4``, examples_base ``ce1f617``, examples_ssu ``bc36b28``, robots_isaac ``38403a0``).
A file is recognised only when it is byte for byte one of these (:func:`git_blob_id`)."""

BUILT_IN_COUNTERPARTS: dict[tuple[str, str], str] = {
    ("formats", "object_map"): "formats_object_map",
    ("formats", "object_map_with_states"): "formats_object_map",
    ("formats", "object_map_ground_truth"): "formats_object_map",
    ("evaluators", "omq"): "eval_omq",
    ("examples", "hello_active"): "examples_base",
    ("examples", "hello_passive"): "examples_base",
    ("examples", "hello_eval_semantic_slam"): "examples_ssu",
    ("robots", "carter"): "robots_isaac",
}
"""``{(kind, name): original add-on}``: the original add-ons' specs that a first-party plugin offers under the same
name, re-implemented (``task_semslam``'s formats, ``eval_omq``'s OMQ, whose scores equal the original's within
float32 rounding; the built-in examples of those names; ``sim_taichi``'s ``carter``)."""


def git_blob_id(path: Path | str) -> str:
    """The git blob id of the file at ``path`` (``sha1("blob <size>\\0" + bytes)``, what ``git hash-object`` prints).

    Raises:
        OSError: it cannot be read.
    """
    data = Path(path).read_bytes()
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def _known(path: Path, addon: str) -> bool:
    try:
        return ORIGINAL_FILES.get(git_blob_id(path), ("", ""))[0] == addon
    except OSError:
        return False


def _files_used(kind: str, spec: dict, spec_path: Path, root: Path) -> list[Path] | None:
    """The pack files a spec of ``kind`` runs: for formats and evaluators every ``.py`` beside it (their modules
    and what they import); for examples every file of the folder its ``native_command`` runs from; ``[]`` for
    data-only kinds; ``None`` when that folder is not inside the pack."""
    folder = spec_path.parent
    if kind in ("formats", "evaluators"):
        return sorted(folder.glob("*.py"))
    if kind == "examples":
        try:
            words = shlex.split(str(spec.get("native_command") or ""))
        except ValueError:
            return None
        scripts = [w for w in words[1:] if "/" in w] or words[:1]
        target = (folder / scripts[0]).resolve() if scripts else None
        if target is None or not target.is_relative_to(root) or not target.exists():
            return None
        where = target.parent if target.is_file() else target
        return sorted(p for p in where.rglob("*") if p.is_file())
    return []


def built_in_counterpart(kind: str, name: str, spec: dict, spec_path: Path, root: Path) -> str | None:
    """The original add-on (``formats_object_map``, ...) of which the pack's spec ``name`` is an unchanged copy —
    the spec file and every file it runs (:func:`_files_used`) byte for byte the add-on's (:data:`ORIGINAL_FILES`)
    — when a first-party plugin re-implements that spec under the same name (:data:`BUILT_IN_COUNTERPARTS`);
    ``None`` otherwise (a changed copy is the user's own, and clashes as any other spec would)."""
    addon = BUILT_IN_COUNTERPARTS.get((kind, name))
    if addon is None or not _known(spec_path, addon):
        return None
    used = _files_used(kind, spec, spec_path, Path(root).resolve())
    if used is None or not all(_known(p, addon) for p in used):
        return None
    return addon


# --------------------------------------------------------------------------------------------------------------------
# The original's two sets of BEAR ground truths
# --------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class GroundTruthSet:
    """A set of ground truths the original published as an add-on.

    Attributes:
        name: the set's name here, the add-on's without its kind (``isaac_develop`` for
            ``ground_truths_isaac_develop``).
        addon: the add-on repository's name (``benchbot-addons/<addon>``).
        digests: ``{environment: digest}`` of its files at the add-on's latest commit, as parsed
            (:func:`ground_truth_digest`: a file and a plugin's dict of the same content have the same digest).
        about: one line: where it comes from and how it differs.
    """

    name: str
    addon: str
    digests: dict[str, str]
    about: str


_SAME = {"house:1": "52dea8ccb7741378acfa621373773cf6", "house:2": "b981bf4f8222a0411d59bf29148e9da7",
         "house:3": "62279325266cd259e201f880161c6289", "house:4": "261ab3a9df3fdf5767a344e9159f1444",
         "house:5": "34162e78d2146e50a63dc596db178497", "miniroom:4": "f2d9bae863bbcdd438faa94042bf0010"}

GROUND_TRUTH_SETS: dict[str, GroundTruthSet] = {
    "isaac_develop": GroundTruthSet(
        "isaac_develop", "ground_truths_isaac_develop",
        {**_SAME, "miniroom:1": "ed2e191640d2b60db0967474495f7ea6", "miniroom:2": "2e8c0f781446fbee838676d7badabe8f",
         "miniroom:3": "5bed4941262d425b6227f659dea905b7", "miniroom:5": "7704496b20f89b5c1ec3345786c8274e"},
        "benchbot-addons/ground_truths_isaac_develop 1beb7f5: the BEAR development set (shipped by sim_taichi)"),
    "bear_develop": GroundTruthSet(
        "bear_develop", "ground_truths_bear_develop",
        {**_SAME, "miniroom:1": "d2500ec1cd4daae462b6dc739b2ca2d0", "miniroom:2": "72d0e2966bb5ac860c86bf3be746f1c8",
         "miniroom:3": "5a85a0c45708495696551e32e2e42c4b", "miniroom:5": "2701f23bcbd9066b73fbff413b11d7d6"},
        "benchbot-addons/ground_truths_bear_develop 704728d ('fixed miniroom sink offset', what the original's "
        "default install used): isaac_develop with the sink of miniroom:1, 2, 3 and 5 moved"),
}
"""The original's BEAR development ground truths, two add-ons: the content of each file, by digest."""

DEFAULT_GROUND_TRUTH_SET = "isaac_develop"
"""The set scored against unless another is chosen (the one shipped; every figure of this project used it)."""

BEAR_DEVELOP_SINK = ("SM_AI_vol3_3_sink_01_0", [-0.58994232, 3.07765717, 0.82831787])
"""bear_develop's one change to isaac_develop: this object's centroid in miniroom:1, 2, 3 and 5 (from
(−0.42561001, 2.94, 0.75566704); extent unchanged)."""


def ground_truth_set_name(text: str) -> str:
    """The set a user names: ``bear_develop`` or the add-on's full name ``ground_truths_bear_develop``."""
    return text.removeprefix("ground_truths_")


def _strip_file_paths(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _strip_file_paths(v) for k, v in value.items() if k != "_file_path"}
    if isinstance(value, list):
        return [_strip_file_paths(v) for v in value]
    return value


def ground_truth_digest(spec: dict[str, Any]) -> str:
    """The first 32 hex digits of the SHA-256 of a parsed ground truth (``_file_path`` left out at every depth),
    as JSON with sorted keys and no spaces."""
    text = json.dumps(_strip_file_paths(spec), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def ground_truth_set_of(spec: dict[str, Any] | None) -> str | None:
    """The original's set (``isaac_develop``, ``bear_develop``) a parsed ground truth is an unchanged copy of; for
    one both sets share, the default set. ``None`` for any other (or none)."""
    if not isinstance(spec, dict):
        return None
    digest = ground_truth_digest(spec)
    found = [s.name for s in GROUND_TRUTH_SETS.values() if digest in s.digests.values()]
    return DEFAULT_GROUND_TRUTH_SET if DEFAULT_GROUND_TRUTH_SET in found else (found[0] if found else None)


def bear_develop_from_isaac_develop(env: str, spec: dict[str, Any]) -> dict[str, Any]:
    """The bear_develop ground truth of ``env`` made from its isaac_develop one (a parsed file, not changed): the
    same, but for :data:`BEAR_DEVELOP_SINK` in miniroom:1, 2, 3 and 5.

    Raises:
        KeyError: a miniroom whose ground truth lacks that sink (not isaac_develop's).
    """
    out = copy.deepcopy(spec)
    digest = GROUND_TRUTH_SETS["bear_develop"].digests.get(env)
    if digest is None or digest == GROUND_TRUTH_SETS["isaac_develop"].digests.get(env):
        return out
    objects = [o for o in out["ground_truth"]["objects"] if o.get("ID_name") == BEAR_DEVELOP_SINK[0]]
    if len(objects) != 1:
        raise KeyError(f"{env}: no object {BEAR_DEVELOP_SINK[0]} in its ground truth")
    objects[0]["centroid"] = list(BEAR_DEVELOP_SINK[1])
    return out
