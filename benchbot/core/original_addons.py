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
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from benchbot.core.content_packs import FOLDER_KINDS, PackError, _spec_files

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
    return any(path.resolve().is_relative_to(target) for _, path in _spec_files(root))


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
    from benchbot.core.registry import singular

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
    if _spec_files(root):
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
