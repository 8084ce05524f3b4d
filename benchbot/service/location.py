"""Where the simulator service lives, and which service serves this installation.

* The folder of its sockets and locks (:func:`runtime_dir`): ``$XDG_RUNTIME_DIR/benchbot`` where the user has a
  runtime folder short enough for a Unix socket's path, else ``<temporary folder>/benchbot-service-<uid>``; made
  with mode 0700 and refused unless it is a real folder of this user's that no one else may enter
  (:func:`private_dir`). Sandboxed solutions never see it (:func:`benchbot.solutions.sandbox.hidden_folders` hides
  it, and the service refuses a peer in another user namespace, :func:`benchbot.service.protocol.peer_problem`).
* Its socket and lock there: ``service.sock`` and ``service.lock``; one service per user and machine.
* Whether it may serve a command (:func:`installation_key`): a digest of what the service's results depend on besides
  a request — the Python and its ``sys.path``, BenchBot's and its plugins' distributions, the files of their packages
  (their sizes and modification times: an edit of a checkout makes a new key), the installed content packs and the
  ``BENCHBOT_*``/``TI_*`` settings of the environment (the service's own excepted). A command whose key is not the
  running service's replaces the service when it is idle, and runs in its own process when it is busy
  (:func:`benchbot.service.client.start`).
* Its log (:func:`log_path`): ``<cache dir>/service/service.log`` (the cache directory, hidden from sandboxed
  solutions).
"""

from __future__ import annotations

import hashlib
import importlib.metadata as md
import importlib.util
import os
import socket
import stat
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from benchbot.core.errors import UsageError

#: Settings of the service itself: they never make a different service (they are left out of the key).
OWN_SETTINGS = ("BENCHBOT_SERVICE", "BENCHBOT_SERVICE_IDLE_S", "BENCHBOT_DEBUG")
#: Environment variables whose values the key includes (by prefix).
KEYED_PREFIXES = ("BENCHBOT_", "TI_")
#: Characters of the key used in file names.
KEY_CHARS = 16


@dataclass(frozen=True)
class ServiceLocation:
    """The files of one service.

    Attributes:
        key: the installation key a command wants served (:func:`installation_key`, :data:`KEY_CHARS` hex digits).
        folder: the private folder of the user's service (:func:`runtime_dir`).
        socket: its Unix socket, ``<folder>/service.sock``.
        lock: the lock file held while a command starts or replaces it, ``<folder>/service.lock``.
        log: its log file (:func:`log_path`).
    """

    key: str
    folder: Path
    socket: Path
    lock: Path
    log: Path


#: The most bytes a Unix socket's path may have on Linux (``sun_path`` holds 108, its closing NUL included).
SOCKET_PATH_MAX = 107
#: The longest name of a socket the service makes in its folder: a pool worker's (``worker-<pid>-<count>.sock``,
#: a pid of up to 7 digits and a count of up to 9).
LONGEST_SOCKET_NAME = "worker-4194304-999999999.sock"


def socket_folders() -> list[Path]:
    """Where the service's sockets may go, in order of preference: ``$XDG_RUNTIME_DIR/benchbot`` when that variable
    names a folder of this user's, then ``<temporary folder>/benchbot-service-<uid>`` (neither is created)."""
    folders = []
    runtime = os.environ.get("XDG_RUNTIME_DIR", "").strip()
    if runtime:
        try:
            info = os.stat(runtime)
            if stat.S_ISDIR(info.st_mode) and info.st_uid == os.geteuid():
                folders.append(Path(runtime) / "benchbot")
        except OSError:
            pass
    return [*folders, Path(tempfile.gettempdir()) / f"benchbot-service-{os.geteuid()}"]


def runtime_dir() -> Path:
    """The folder of this user's service sockets (not created): the first of :func:`socket_folders` in which every
    socket the service makes has a path short enough for a Unix socket (:data:`SOCKET_PATH_MAX` bytes).

    Raises:
        UsageError: no such folder fits (a very long ``XDG_RUNTIME_DIR`` and ``TMPDIR``); one line with the fix.
    """
    folders = socket_folders()
    for folder in folders:
        if len(os.fsencode(str(folder / LONGEST_SOCKET_NAME))) <= SOCKET_PATH_MAX:
            return folder
    longest = len(os.fsencode(str(folders[-1] / LONGEST_SOCKET_NAME)))
    raise UsageError(f"the simulator service's socket folder {folders[-1]} is too long for a Unix socket's path "
                     f"({longest} bytes with its sockets' names; at most {SOCKET_PATH_MAX})",
                     "set TMPDIR or XDG_RUNTIME_DIR to a shorter folder (e.g. TMPDIR=/tmp), or run with --no-service")


def private_dir(folder: Path) -> Path:
    """``folder``, made (mode 0700) if missing, after checking that only this user can enter it: a real folder (not
    a link), owned by this user, with no permission for group or others.

    Raises:
        UsageError: it exists but is a link, not a folder, another user's, or open to others (someone could put a
            socket of their own there); one line naming it, with the fix.
    """
    try:
        folder.mkdir(mode=0o700, parents=False, exist_ok=True)
    except FileNotFoundError:
        folder.parent.mkdir(parents=True, exist_ok=True)
        folder.mkdir(mode=0o700, exist_ok=True)
    info = os.lstat(folder)
    fix = f"remove it (rm -r {folder}) so that BenchBot makes it again, or run with --no-service"
    if stat.S_ISLNK(info.st_mode) or not stat.S_ISDIR(info.st_mode):
        raise UsageError(f"the simulator service's folder {folder} is not a folder of its own (a link or a file)", fix)
    if info.st_uid != os.geteuid():
        raise UsageError(f"the simulator service's folder {folder} belongs to user id {info.st_uid}, not to you "
                         f"({os.geteuid()})", fix)
    if info.st_mode & 0o077:
        raise UsageError(f"the simulator service's folder {folder} is open to other users (mode "
                         f"{stat.S_IMODE(info.st_mode):04o}; it must be 0700)", f"chmod 700 {folder}, or {fix}")
    return folder


def log_path() -> Path:
    """``<cache dir>/service/service.log``: where the service writes its messages (not created)."""
    from benchbot.packs.pack_layout import cache_dir

    return cache_dir().expanduser() / "service" / "service.log"


def locate(key: str | None = None) -> ServiceLocation:
    """The service's files, for a command wanting ``key`` served (default: this installation's,
    :func:`installation_key`); nothing is made."""
    key = key or installation_key()
    folder = runtime_dir()
    return ServiceLocation(key, folder, folder / "service.sock", folder / "service.lock", log_path())


def _package_folders() -> list[Path]:
    """The folders of ``benchbot`` and of every plugin's top-level package (entry-point group ``benchbot``), found
    without importing the plugins."""
    tops = {"benchbot"} | {entry.value.split(":")[0].split(".")[0] for entry in md.entry_points(group="benchbot")}
    folders = []
    for top in sorted(tops):
        try:
            spec = importlib.util.find_spec(top)
        except (ImportError, ValueError):
            continue
        folders += [Path(p) for p in (spec.submodule_search_locations or [])] if spec is not None else []
    return folders


def _tree_digest(digest, folder: Path) -> None:
    """Add every file under ``folder`` (relative path, size, modification time in ns) to ``digest``; caches
    (``__pycache__``) left out."""
    for root, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            path = os.path.join(root, name)
            try:
                info = os.stat(path)
            except OSError:
                continue
            digest.update(f"{os.path.relpath(path, folder)}\0{info.st_size}\0{info.st_mtime_ns}\n".encode())


def _packs_digest(digest, data: Path) -> None:
    """Add the installed content packs to ``digest``: the data directory's and its ``packs`` folder's entries (name,
    modification time in ns). Installing, updating or removing a pack replaces an entry there; the packs' own files
    (thousands of assets) are not read."""
    for folder in (data, data / "packs"):
        try:
            entries = sorted(os.scandir(folder), key=lambda e: e.name)
        except OSError:
            continue
        for entry in entries:
            try:
                digest.update(f"{entry.path}\0{entry.stat(follow_symlinks=False).st_mtime_ns}\n".encode())
            except OSError:
                continue


def installation_key(environ: dict[str, str] | None = None) -> str:
    """The key of the service that may serve this process (module docstring): :data:`KEY_CHARS` hex digits of a
    SHA-256 over the Python, ``sys.path``, BenchBot's and its plugins' distributions and package files, the data
    directory's installed packs and the ``BENCHBOT_*``/``TI_*`` variables of ``environ`` (default ``os.environ``)
    except :data:`OWN_SETTINGS`. Takes a few milliseconds (file metadata only)."""
    from benchbot.core.specs import schema_dir
    from benchbot.packs.pack_layout import data_dir

    environ = os.environ if environ is None else environ
    digest = hashlib.sha256()
    digest.update(f"{sys.executable}\0{sys.version}\0{os.pathsep.join(sys.path)}\n".encode())
    for entry in sorted(md.entry_points(group="benchbot"), key=lambda e: e.name):
        dist = entry.dist
        digest.update(f"{entry.name}={entry.value} {dist.name if dist else ''} {dist.version if dist else ''}\n"
                      .encode())
    for folder in [*_package_folders(), schema_dir()]:
        digest.update(f"{folder}\n".encode())
        if folder.is_dir():
            _tree_digest(digest, folder)
    _packs_digest(digest, data_dir().expanduser())
    for name in sorted(environ):
        if name.startswith(KEYED_PREFIXES) and name not in OWN_SETTINGS:
            digest.update(f"{name}={environ[name]}\n".encode())
    return digest.hexdigest()[:KEY_CHARS]


def listen_private(path: str, backlog: int) -> socket.socket:
    """A listening Unix socket at ``path``, mode 0600 from its creation on (umask 0177 while it is bound), with
    ``backlog`` pending connections; a stale file at ``path`` is replaced. The service's own socket and each pool
    worker's (:mod:`benchbot.service.daemon`, :mod:`benchbot.service.worker`).

    Raises:
        OSError: the socket cannot be bound (a folder that is not writable, a path too long for a Unix socket).
    """
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    old = os.umask(0o177)
    try:
        listener.bind(path)
    finally:
        os.umask(old)
    os.chmod(path, 0o600)
    listener.listen(backlog)
    return listener
