"""Where a submission's results file is, and whether this submission wrote it.

The API (:mod:`benchbot.api`) saves results to ``$BENCHBOT_RESULT_LOCATION``, else to
:data:`ORIGINAL_RESULT_LOCATION`. An original ``benchbot_api`` client always saves to
:data:`ORIGINAL_RESULT_LOCATION` (its ``RESULT_LOCATION`` is a constant that ignores the variable). A file counts as
this submission's only when it was written after the submission started (its modification time against a mark taken
on the same file system just before the start), so that a stale file from an earlier run is never scored.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from benchbot.core import settings

#: Where an original ``benchbot_api`` client always writes its results, and where ``benchbot submit`` keeps them
#: unless ``$BENCHBOT_RESULT_LOCATION`` names another file.
ORIGINAL_RESULT_LOCATION = Path(settings.default("BENCHBOT_RESULT_LOCATION"))


def submission_result_location() -> Path:
    """The results file a submission is told to write: ``$BENCHBOT_RESULT_LOCATION`` when set and not empty, else
    :data:`ORIGINAL_RESULT_LOCATION` (both absolute: relative paths are taken from the current folder)."""
    return Path(settings.get("BENCHBOT_RESULT_LOCATION")).absolute()


def clock_mark(folder: Path) -> int:
    """The file-system clock of ``folder`` now, in ns since the epoch: the modification time of a new temporary
    file made there (file systems stamp files with a coarse, possibly remote clock that ``time.time_ns()`` can run
    ahead of); ``time.time_ns()`` when no file can be made there (e.g. the folder does not exist yet)."""
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".benchbot-mark-") as marker:
            return os.fstat(marker.fileno()).st_mtime_ns
    except OSError:
        return time.time_ns()


class ResultWatch:
    """Marks the start of a submission, then finds the results file it wrote.

    Args:
        expected: the file the submission was told to write (``BENCHBOT_RESULT_LOCATION``).
        fallback: another file it may have written instead (:data:`ORIGINAL_RESULT_LOCATION`, for original clients),
            or None; ignored when it is ``expected`` itself.

    Create it just before starting the submission.
    """

    def __init__(self, expected: Path, fallback: Path | None = None) -> None:
        self.expected = Path(expected)
        self.fallback = None if fallback is None or Path(fallback) == self.expected else Path(fallback)
        self._since = {path: clock_mark(path.parent) for path in (self.expected, self.fallback) if path is not None}

    def written(self, path: Path) -> bool:
        """``path`` is a file modified since the mark (by this submission); False when it is missing or unreadable.

        Raises:
            KeyError: ``path`` is neither :attr:`expected` nor :attr:`fallback`.
        """
        try:
            return path.is_file() and path.stat().st_mtime_ns >= self._since[path]
        except OSError:
            return False

    def found(self) -> Path | None:
        """``expected`` when the submission wrote it, else ``fallback`` when it wrote that, else None."""
        for path in (self.expected, self.fallback):
            if path is not None and self.written(path):
                return path
        return None

    def stale(self) -> bool:
        """``expected`` exists but is older than the submission (it was not used)."""
        return self.expected.is_file() and not self.written(self.expected)
