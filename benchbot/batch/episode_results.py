"""A batch's results files, each read once: by the batch process as an episode's record arrives (or, for an episode
finished before ``--resume``, as the batch resumes), and the parsed results handed to the evaluation
(:func:`benchbot.core.evaluation.evaluate`'s ``loaded``), which validates and scores them without reading the file
again.
"""

from __future__ import annotations

from pathlib import Path

from benchbot.batch.plan import EpisodeRecord
from benchbot.core.errors import BenchbotError
from benchbot.core.evaluation import LoadedResult, load_results


class EpisodeResults:
    """The results of a batch's ``ok`` episodes, read once each.

    Attributes:
        run_dir: the run directory (records name their results file relative to it).
        keep: whether the parsed results are kept for the evaluation (a batch with an evaluation method); without,
            a file is only checked.
        loaded: ``{str(run_dir / record.results): its results}`` of the episodes checked ``ok`` (with ``keep``).
    """

    def __init__(self, run_dir: Path, keep: bool) -> None:
        self.run_dir = Path(run_dir)
        self.keep = keep
        self.loaded: dict[str, list[LoadedResult]] = {}

    def check(self, record: EpisodeRecord) -> None:
        """Read an ``ok`` episode's results file (:func:`benchbot.core.evaluation.load_results`: within the limits
        of :mod:`benchbot.core.safe_load`); one that is missing, unreadable, beyond a limit, not JSON or not a JSON
        object turns the record ``bad_results`` with the one-line reason naming the file (such an episode runs
        again with ``--retries`` or ``--resume``). Its format is checked when the batch is evaluated. A record that
        is not ``ok`` is left as it is."""
        if record.status != "ok":
            return
        path = str(self.run_dir / record.results)
        self.loaded.pop(path, None)
        try:
            results = load_results(path)
        except BenchbotError as exc:
            record.status, record.error = "bad_results", exc.message
            return
        if self.keep:
            self.loaded[path] = results
