"""A batch's results files, each read once and scored once: the batch process reads an episode's file as its record
arrives (or, for an episode finished before ``--resume``, as the batch resumes), validates and scores it then with
the batch's evaluation method (:class:`benchbot.core.evaluation.EarlyScores`) while the other episodes still run,
and hands both to the evaluation at the end (:func:`benchbot.core.evaluation.evaluate`'s ``loaded`` and ``early``),
which then neither reads the file again nor scores it again: it only combines.
"""

from __future__ import annotations

from pathlib import Path

from benchbot.batch.plan import EpisodeRecord
from benchbot.core.errors import BenchbotError
from benchbot.core.evaluation import EarlyScores, LoadedResult, load_results


class EpisodeResults:
    """The results of a batch's ``ok`` episodes, read once each and (with ``early``) scored once each.

    Attributes:
        run_dir: the run directory (records name their results file relative to it).
        keep: whether the parsed results are kept for the evaluation (a batch with an evaluation method); without,
            a file is only checked.
        loaded: ``{str(run_dir / record.results): its results}`` of the episodes checked ``ok`` (with ``keep``).
        early: the batch's evaluation method scoring results ahead of the evaluation (None: everything is scored at
            the end, as :func:`~benchbot.core.evaluation.evaluate` does without it).
        unscored: the episodes checked ``ok`` whose results :meth:`score` has not scored yet, as ``{path:
            environment}`` in the order they were checked (those of a resumed batch wait here until
            :meth:`score_waiting` takes them, one per new episode's end).
    """

    def __init__(self, run_dir: Path, keep: bool, early: EarlyScores | None = None) -> None:
        self.run_dir = Path(run_dir)
        self.keep = keep
        self.loaded: dict[str, list[LoadedResult]] = {}
        self.early = early if keep else None
        self.unscored: dict[str, str] = {}

    def check(self, record: EpisodeRecord) -> None:
        """Read an ``ok`` episode's results file (:func:`benchbot.core.evaluation.load_results`: within the limits
        of :mod:`benchbot.core.safe_load`); one that is missing, unreadable, beyond a limit, not JSON or not a JSON
        object turns the record ``bad_results`` with the one-line reason naming the file (such an episode runs
        again with ``--retries`` or ``--resume``). Its format is checked when it is scored (:meth:`score`) or
        when the batch is evaluated. A record that is not ``ok`` is left as it is."""
        if record.status != "ok":
            return
        path = str(self.run_dir / record.results)
        self.loaded.pop(path, None)
        self.unscored.pop(path, None)
        try:
            results = load_results(path)
        except BenchbotError as exc:
            record.status, record.error = "bad_results", exc.message
            return
        if self.keep:
            self.loaded[path] = results
            self.unscored[path] = record.env

    def score(self, record: EpisodeRecord) -> None:
        """Validate and score the results of ``record`` (checked ``ok`` by :meth:`check`) with :attr:`early`, as
        the results of the record's environment; nothing without :attr:`early` or for a record not ``ok``. Its
        status is left as it is: results the method refuses fail their episode when the batch is evaluated, as
        without early scores."""
        path = str(self.run_dir / record.results)
        if self.early is None or record.status != "ok" or path not in self.unscored:
            return
        self.early.add(self.loaded[path], self.unscored.pop(path))

    def score_waiting(self) -> None:
        """Score the oldest results checked but not scored yet (an episode finished before ``--resume``): a
        resumed batch scores one of them as each new episode ends, not all before its first episode starts."""
        if self.early is None or not self.unscored:
            return
        path = next(iter(self.unscored))
        self.early.add(self.loaded[path], self.unscored.pop(path))
