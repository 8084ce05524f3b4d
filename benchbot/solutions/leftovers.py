"""Private folders that say whether their owner still lives, and the clean-up of those a killed process left: the
temporary folders ``/tmp/benchbot-episode-*`` and ``/tmp/benchbot-sandbox-*``, the episodes' frames folders
``/dev/shm/benchbot-frames-*`` (:func:`benchbot.protocol.shared_frames.episode_folder`) and the sandboxes' cgroups.
A batch killed with ``kill -9`` cannot remove them.

An owned folder has an *owner file* that its owner holds an exclusive ``flock`` on for as long as the folder lives
(:func:`lock_owner_file`; the file also names the owner's PID); the kernel releases the lock when the owner dies,
however it dies. A temporary folder's owner file is its ``.owner`` (:func:`owned_tempdir`); a frames folder's is
beside it, ``/dev/shm/benchbot-frames-<32 hex>.owner``, so that the sandboxed solution that sees the folder sees
nothing but its frames. :func:`clean_leftovers` removes the folders whose lock it can take: their owner is gone. A
folder without an owner file (being made at that moment, or left by an older BenchBot) is never touched, and neither
is one whose owner lives (another batch running beside this one, an episode's backend serving frames). The lock file
is locked under a temporary name and only then renamed to its own, so no other process can ever take the lock of a
folder whose owner is alive.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import stat
import tempfile
from pathlib import Path
from typing import Iterator

#: The prefixes of the folders :func:`clean_leftovers` looks at in the temporary folder.
PREFIXES = ("benchbot-episode-", "benchbot-sandbox-")
#: A temporary folder's owner file, inside it.
OWNER = ".owner"
#: Where the episodes' frames folders are made (:data:`benchbot.protocol.shared_frames.SHM_DIR`, a tmpfs).
SHM_DIR = "/dev/shm"
#: The prefix of an episode's frames folder in :data:`SHM_DIR` (:func:`benchbot.protocol.shared_frames.episode_folder`).
FRAMES_PREFIX = "benchbot-frames-"
#: What a frames folder's owner file adds to the folder's name (``benchbot-frames-<32 hex>.owner``, beside it).
FRAMES_OWNER_SUFFIX = ".owner"


def lock_owner_file(path: Path | str) -> int:
    """Make ``path`` this process's owner file: made as ``<path>.<pid>`` (mode 0600, never through a link), locked
    (``flock``, exclusive), written with this process's PID, then renamed to ``path`` (replacing a dead owner's
    file). The lock lasts until the returned descriptor is closed or this process dies.

    Returns:
        The descriptor holding the lock (the caller closes it once the folder is removed).

    Raises:
        OSError: the file cannot be made or renamed (e.g. another user's file is in the way, in a sticky folder).
    """
    path = Path(path)
    pending = path.with_name(f"{path.name}.{os.getpid()}")
    fd = os.open(pending, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC | os.O_NOFOLLOW, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.write(fd, f"{os.getpid()}\n".encode())
        os.rename(pending, path)
    except OSError:
        os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(pending)
        raise
    return fd


def take_abandoned_lock(path: Path | str) -> int | None:
    """The descriptor of owner file ``path``, locked by this process, when ``path`` is a regular file of this user
    (never followed as a link) whose owner is gone (its lock can be taken); ``None`` when its owner lives, it is
    missing, or it is not ours to judge. The caller removes what it owned, then closes the descriptor. Never
    raises."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK)
    except OSError:
        return None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode) or info.st_uid != os.getuid():
            raise OSError("not ours")
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        # still the file at that path (not one a new owner has just renamed over it)
        if os.lstat(path).st_ino != info.st_ino:
            raise OSError("replaced")
    except OSError:  # its owner lives, or not ours
        os.close(fd)
        return None
    return fd


@contextlib.contextmanager
def owned_tempdir(prefix: str) -> Iterator[Path]:
    """A new folder in the temporary folder (``tempfile.mkdtemp(prefix=prefix)``, mode 0700), locked as this
    process's (its ``.owner``: :func:`lock_owner_file`) until the block ends, then removed.

    Raises:
        OSError: the folder or its owner file cannot be made."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    fd = None
    try:
        fd = lock_owner_file(folder / OWNER)
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)
        if fd is not None:
            os.close(fd)


def _is_own_folder(folder: Path) -> bool:
    """Whether ``folder`` is a real directory (no link) of this user."""
    try:
        info = folder.lstat()
    except OSError:
        return False
    return stat.S_ISDIR(info.st_mode) and info.st_uid == os.getuid()


def _listed(folder: Path, prefixes: tuple[str, ...]) -> list[Path]:
    """The entries of ``folder`` whose names start with one of ``prefixes`` ([] when it cannot be read)."""
    try:
        return [p for p in folder.iterdir() if p.name.startswith(prefixes)]
    except OSError:
        return []


def _dead_tempdirs(tmp: Path) -> list[Path]:
    """Remove the folders of :data:`PREFIXES` in ``tmp`` whose ``.owner``'s owner is gone; returns them."""
    removed = []
    for folder in _listed(tmp, PREFIXES):
        if not _is_own_folder(folder):
            continue
        fd = take_abandoned_lock(folder / OWNER)
        if fd is None:  # no owner file (being made, or not ours to judge), or its owner lives
            continue
        try:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
        finally:
            os.close(fd)
    return removed


def _dead_frames_folders(shm: Path) -> list[Path]:
    """Remove the frames folders ``benchbot-frames-*`` in ``shm`` (with their files) whose owner file's owner (the
    backend that served the episode) is gone, and such owner files left without their folder; returns the folders
    removed. A folder without an owner file beside it is never touched."""
    removed = []
    for owner in _listed(shm, (FRAMES_PREFIX,)):
        if not owner.name.endswith(FRAMES_OWNER_SUFFIX):
            continue
        fd = take_abandoned_lock(owner)
        if fd is None:
            continue
        try:
            folder = owner.with_name(owner.name[:-len(FRAMES_OWNER_SUFFIX)])
            if _is_own_folder(folder):
                shutil.rmtree(folder, ignore_errors=True)
                removed.append(folder)
            with contextlib.suppress(OSError):
                owner.unlink()
        finally:
            os.close(fd)
    return removed


def clean_leftovers(tmp: Path | str | None = None, shm: Path | str | None = SHM_DIR) -> list[Path]:
    """Remove what killed owners left: the folders of :data:`PREFIXES` in ``tmp`` (default: the temporary folder),
    the frames folders of :data:`FRAMES_PREFIX` in ``shm`` (``None``: none looked at) whose owner is gone (its lock
    can be taken), and the pids and memory cgroups of sandboxes whose owner is gone. A live owner's are kept.

    Returns:
        The folders removed (temporary folders, frames folders, then cgroups). Never raises.
    """
    removed = _dead_tempdirs(Path(tmp or tempfile.gettempdir()))
    if shm is not None:
        removed += _dead_frames_folders(Path(shm))
    removed += _dead_cgroups()
    return removed


def _dead_cgroups() -> list[Path]:
    """Remove the cgroups of sandboxes (:class:`benchbot.solutions.sandbox_limits.SandboxCgroups`, in every
    hierarchy it uses) whose owner (the PID in the name) is gone; the kernel refuses to remove one that still holds a
    process. Never raises."""
    from benchbot.solutions.sandbox_limits import CGROUP_PREFIX, cgroup_root

    removed = []
    roots = dict.fromkeys(root for root in (cgroup_root("pids"), cgroup_root("memory")) if root is not None)
    for root in roots:
        try:
            folders = [p for p in root.iterdir() if p.name.startswith(CGROUP_PREFIX)]
        except OSError:
            continue
        for folder in folders:
            try:
                owner = int(folder.name.split("-")[2])
                os.kill(owner, 0)
                continue  # its owner lives
            except (ValueError, IndexError):
                continue
            except ProcessLookupError:
                pass
            except OSError:
                continue
            try:
                folder.rmdir()
                removed.append(folder)
            except OSError:
                pass
    return removed
