"""Private temporary folders that say whether their owner still lives, and the clean-up of those a killed process
left (``/tmp/benchbot-episode-*``, ``/tmp/benchbot-sandbox-*``: a batch killed with ``kill -9`` cannot remove them).

:func:`owned_tempdir` makes the folder and holds an exclusive ``flock`` on its ``.owner`` file (which also names the
owner's PID) for as long as it lives; the kernel releases the lock when the owner dies, however it dies.
:func:`clean_leftovers` removes the folders whose lock it can take: their owner is gone. A folder without an
``.owner`` file (being made at that moment, or left by an older BenchBot) is never touched, and neither is one whose
owner lives (another batch running beside this one). The lock file is locked under a temporary name and only then
renamed to ``.owner``, so no other process can ever take the lock of a folder whose owner is alive.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

#: The prefixes of the folders :func:`clean_leftovers` looks at in the temporary folder.
PREFIXES = ("benchbot-episode-", "benchbot-sandbox-")
OWNER = ".owner"


@contextlib.contextmanager
def owned_tempdir(prefix: str) -> Iterator[Path]:
    """A new folder in the temporary folder (``tempfile.mkdtemp(prefix=prefix)``), locked as this process's until
    the block ends, then removed."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    fd = None
    try:
        pending = folder / f"{OWNER}.{os.getpid()}"
        fd = os.open(pending, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600)
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.write(fd, f"{os.getpid()}\n".encode())
        os.rename(pending, folder / OWNER)
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)
        if fd is not None:
            os.close(fd)


def clean_leftovers(tmp: Path | str | None = None) -> list[Path]:
    """Remove the folders of :data:`PREFIXES` in ``tmp`` (default: the temporary folder) whose owner is gone (its
    lock can be taken), and the pids cgroups of sandboxes whose owner is gone; returns them. Never raises."""
    removed = []
    try:
        candidates = [p for p in Path(tmp or tempfile.gettempdir()).iterdir() if p.name.startswith(PREFIXES)]
    except OSError:
        return removed
    for folder in candidates:
        try:
            if folder.is_symlink() or not folder.is_dir() or folder.stat().st_uid != os.getuid():
                continue
            fd = os.open(folder / OWNER, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
        except OSError:  # no owner file: being made, or not ours to judge
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # its owner lives
            os.close(fd)
            continue
        try:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
        finally:
            os.close(fd)
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
