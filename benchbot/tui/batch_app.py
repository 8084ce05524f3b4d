"""The batch view: a live table of a run directory's episodes (it observes, it never drives).

:class:`BatchApp` receives typed messages (:class:`ManifestChanged`, :class:`ProgressChanged`,
:class:`ConfigChanged`, :class:`EpisodeScoresChanged`, :class:`ScoresChanged`) from a
:class:`~benchbot.tui.watch.FileWatcher`, which checks the run directory's files' stat every ``poll_s`` seconds and
reads a file only when it changed: ``manifest.json`` (the plan and every episode's record, written atomically by the
batch after each episode), ``progress.json`` (live step counts, written by the batch at most 4 times a second:
:mod:`benchbot.batch.progress`), ``config.json`` (the expected steps of passive tasks), ``episode_scores.json`` and
``scores.json`` (the evaluation method's primary score, once the batch is evaluated; its name from the manifest's
``scores``, which the method declares). The view keeps what the messages carry (:class:`BatchFiles`) and redraws the
cells that changed; a one-second tick moves the wall times of running episodes and the ETA (no file is read then).
It works for a batch running in this process (``benchbot batch`` runs it in a background thread) or in another one
(``benchbot tui RUN_DIR``), and for a finished one: one way in for all three, since the files are written for the
other process and the finished batch anyway.
"""

from __future__ import annotations

import asyncio
import signal
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from rich.markup import escape
from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.css.query import NoMatches
from textual.message import Message
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Log, Static

from benchbot.batch.narration import format_seconds
from benchbot.batch.plan import expected_steps
from benchbot.batch.progress import PROGRESS, read_progress
from benchbot.tui.watch import FileWatcher, Watched, read_json

COLUMNS = ("#", "environment", "robot", "repeat", "status", "steps", "wall", "score")
"""The episode table's column keys; the last one is headed by the primary score's name (:func:`primary_score`)."""
#: Bytes of an episode's log that the log screen shows (its end).
LOG_TAIL_BYTES = 256 * 1024
#: Statuses of an episode that will not change any more in this batch.
FINAL_STATUSES = ("ok", "failed", "no_results", "error", "bad_results", "timeout", "resource_limit")
STATUS_STYLE = {"ok": "green", "running": "yellow", "pending": "dim", "failed": "red", "no_results": "red",
                "timeout": "red", "bad_results": "red", "resource_limit": "red",
                "error": "bold red"}
#: Seconds between two redraws of the running episodes' wall times and the ETA (from what the view holds).
TICK_S = 1.0


def expected_steps_by_env(config: dict | None) -> dict[str, int]:
    """``{environment string: steps}`` from ``config.json``'s content, by
    :func:`benchbot.batch.plan.expected_steps`: a passive task's trajectory lengths; ``{}`` for active tasks.

    Raises:
        AttributeError, TypeError: ``config`` is not of ``config.json``'s shape (:func:`_or_empty` catches them).
    """
    if not config:
        return {}
    task = config.get("task") or {}
    return {env: steps for env, scenes in (config.get("environments") or {}).items()
            if (steps := expected_steps(task, scenes)) is not None}


def primary_score(manifest: dict, scores: Any = None) -> str | None:
    """The name of the batch's primary score: the manifest's ``scores`` declaration (what the evaluation method
    declares, :class:`benchbot.core.evaluation.ScoreSet`), else the first real-valued score of
    ``episode_scores.json``'s entries (``scores``), else None (not evaluated yet)."""
    from benchbot.core.evaluation import ScoreSet, observed_scores

    try:
        return ScoreSet.from_json(manifest.get("scores")).primary.name
    except (ValueError, AttributeError, TypeError):
        pass
    entries = [e.get("scores") if isinstance(e.get("scores"), dict) else e
               for e in (scores if isinstance(scores, list) else []) if isinstance(e, dict)]
    try:
        return observed_scores(str(manifest.get("evaluate_with") or ""),
                               [{k: v for k, v in e.items() if k not in ("index", "repeat", "seed")} for e in entries]
                               ).primary.name
    except ValueError:
        return None


def episode_scores(scores: Any, name: str | None) -> dict[int, float]:
    """``{episode index: score}`` of the score ``name`` from ``episode_scores.json``'s parsed content: a list of
    ``{"index": i, name: x}`` or ``{"index": i, "scores": {name: x}}``; entries without both are skipped,
    anything but a list (or no name) gives ``{}``."""
    out: dict[int, float] = {}
    for entry in scores if isinstance(scores, list) and name else []:
        inner = entry.get("scores") if isinstance(entry.get("scores"), dict) else entry
        if name in inner and "index" in entry:
            out[int(entry["index"])] = float(inner[name])
    return out


def _or_empty(read: Callable[[Any], dict], content: Any) -> dict:
    """``read(content)``, or ``{}`` when the file has valid JSON of another shape (the view shows what it can)."""
    try:
        return read(content)
    except (AttributeError, KeyError, TypeError, ValueError):
        return {}


@dataclass
class BatchFiles:
    """What the view holds of a run directory: each file's content as its message carried it.

    Attributes:
        manifest: ``manifest.json`` (a dict for a batch's; None: missing or unreadable).
        progress: ``progress.json``'s episodes (:func:`benchbot.batch.progress.read_progress`; ``{}``: none).
        expected: ``{environment: steps}`` of a passive task, from ``config.json`` (:func:`expected_steps_by_env`).
        episode_scores: ``episode_scores.json`` (a list once the batch is evaluated; else None).
        scores: ``scores.json`` (the combined scores; else None).
    """

    manifest: Any = None
    progress: dict = field(default_factory=dict)
    expected: dict = field(default_factory=dict)
    episode_scores: Any = None
    scores: Any = None

    @classmethod
    def read(cls, run_dir: Path) -> "BatchFiles":
        """All of ``run_dir``'s files at once (what the messages would carry)."""
        return cls(read_json(run_dir / "manifest.json"), read_progress(run_dir),
                   read_expected(run_dir / "config.json"), read_json(run_dir / "episode_scores.json"),
                   read_json(run_dir / "scores.json"))


def read_expected(config_path: Path) -> dict[str, int]:
    """``{environment: steps}`` from a ``config.json`` (:func:`expected_steps_by_env`); ``{}`` when it is missing,
    unreadable or of another shape."""
    return _or_empty(expected_steps_by_env, read_json(config_path))


def batch_rows(run_dir: Path, now: float | None = None) -> tuple[dict, list[tuple]]:
    """The header facts and the table rows of ``run_dir`` now: :func:`rows_of` its files, read at once."""
    return rows_of(BatchFiles.read(run_dir), now)


def rows_of(files: BatchFiles, now: float | None = None) -> tuple[dict, list[tuple]]:
    """The header facts and the table rows of a run directory whose files hold ``files``.

    Args:
        files: the run directory's files (:class:`BatchFiles`).
        now: the current Unix time (s) for running episodes' wall time (default ``time.time()``).

    Returns:
        ``(summary, rows)``: ``summary`` has ``task``, ``episodes``, ``counts`` (``{status: n}``), ``finished``
        (bool), ``evaluation_error``, ``score_name`` (the primary score's, or None), ``combined`` (its combined
        value, or None), ``done`` (episodes that ended), ``progress``
        (0–1: ended episodes plus running ones' step fractions, over all), ``logs`` (``{index: log path relative
        to run_dir}``); each row is ``(index, env, robot, repeat, status,
        steps text, wall text, score text)``. Empty when there is no manifest yet.

    Raises:
        AttributeError, KeyError, TypeError, ValueError: a manifest of another shape (edited by hand).
    """
    manifest = files.manifest
    if not isinstance(manifest, dict):
        return {}, []
    now = time.time() if now is None else now
    live, expected, episode_scores_ = files.progress, files.expected, files.episode_scores
    name = primary_score(manifest, episode_scores_)
    omq = _or_empty(lambda content: episode_scores(content, name), episode_scores_)
    counts: dict[str, int] = {}
    logs: dict[int, str] = {}
    progress_sum = 0.0
    rows = []
    for record in manifest.get("episodes", []):
        index = int(record["index"])
        status, steps, wall = record.get("status", "pending"), record.get("steps", 0), record.get("wall_s")
        p = live.get(str(index))
        if isinstance(p, dict) and status != "ok" and p.get("state") == "running":
            status, steps = "running", p.get("step", 0)
            wall = now - float(p["started"]) if "started" in p else None
        elif status == "pending":
            wall = None
        counts[status] = counts.get(status, 0) + 1
        total = expected.get(record["env"])
        steps_text = f"{steps}/{total}" if total else str(steps)
        if status == "running" and not steps and isinstance(p, dict) and p.get("stage"):
            steps_text = f"{p['stage']} …"  # the backend is still starting: what it is doing
        logs[index] = str(record.get("log", ""))
        if status in FINAL_STATUSES:
            progress_sum += 1.0
        elif status == "running" and total:
            progress_sum += min(1.0, float(steps) / float(total))
        rows.append((index, record["env"], record["robot"], record.get("repeat", 0), status, steps_text,
                     format_seconds(wall), f"{omq[index]:.4f}" if index in omq else ""))
    scores = files.scores
    combined = None
    if isinstance(scores, dict):
        inner = scores.get("scores") if isinstance(scores.get("scores"), dict) else scores
        combined = inner.get(name) if name else None
    summary = {"task": manifest.get("task", ""), "episodes": len(rows), "counts": counts,
               "finished": "finished" in manifest, "evaluation_error": manifest.get("evaluation_error", ""),
               "score_name": name, "combined": combined if isinstance(combined, (int, float)) else None,
               "logs": logs,
               "done": sum(n for k, n in counts.items() if k in FINAL_STATUSES),
               "progress": progress_sum / len(rows) if rows else 1.0}
    return summary, rows


class EtaEstimator:
    """Estimates the time left from the progress fraction seen over time by this view (so it works for a batch
    watched from another process, or resumed): ``elapsed since first seen × (1 − p) / (p − p₀)``."""

    def __init__(self) -> None:
        self.first: tuple[float, float] | None = None

    def update(self, summary: dict, now: float) -> float | None:
        """Seconds left (None until progress has been seen to advance, 0 when finished)."""
        p = float(summary.get("progress", 0.0))
        if summary.get("finished") or p >= 1.0:
            return 0.0
        if self.first is None:
            self.first = (now, p)
            return None
        t0, p0 = self.first
        if p <= p0 or now <= t0:
            return None
        return (now - t0) * (1.0 - p) / (p - p0)


def summary_text(summary: dict, eta_s: float | None) -> str:
    """The view's header (rich markup): task, episode counts by status, the overall progress line, the combined
    primary score."""
    counts = " · ".join(f"[{STATUS_STYLE.get(k, '')}]{k} {v}[/]" for k, v in sorted(summary["counts"].items()))
    n = summary["episodes"]
    state = "[green]finished[/]" if summary["finished"] else "[yellow]running[/]"
    text = f"task [b]{escape(str(summary['task']))}[/b] · {n} episode{'s' if n != 1 else ''} · {counts} · {state}"
    if summary.get("combined") is not None:
        text += f" · {escape(str(summary['score_name']))} [b]{summary['combined']:.4f}[/b]"
    done, width = summary.get("done", 0), 30
    filled = int(round(width * float(summary.get("progress", 0.0))))
    eta = "" if summary["finished"] else f" · ETA {format_seconds(eta_s)}" if eta_s is not None else " · ETA …"
    text += f"\n[b]{done}/{n}[/b] episodes done [green]{'━' * filled}[/][dim]{'━' * (width - filled)}[/]" \
            f" {100 * float(summary.get('progress', 0.0)):.0f}%{eta}"
    if summary["evaluation_error"]:
        text += f"\n[red]evaluation failed:[/] {escape(str(summary['evaluation_error']))}"
    return text


class WatchingApp(App):
    """An app fed by typed messages from a :class:`~benchbot.tui.watch.FileWatcher`: subclasses set ``poll_s`` (the
    watcher's seconds between checks of the files' stat), handle their messages, and call :meth:`follow_files` from
    their ``on_mount`` (not ``super().on_mount()``: Textual already calls the handlers of every class in the MRO).

    Keys: ``q`` quits the view; Ctrl-C (the key, or SIGINT/SIGTERM sent to the process) quits it at once with
    :attr:`interrupted` set and return code 130, so the command that showed it stops its work as it would on Ctrl-C
    without a view (Textual's own "press ctrl+q to quit" dialog is replaced).
    """

    poll_s: float = 0.5
    BINDINGS = [Binding("ctrl+c", "interrupt", "stop", priority=True, show=False)]

    #: True when the view was closed by Ctrl-C (or SIGINT/SIGTERM) rather than by ``q`` or by itself.
    interrupted: bool = False

    def follow_files(self, watched: list[Watched]) -> None:
        """Post the messages of ``watched`` now (the first frame shows the files), then whenever one changes (a
        watcher thread, stopped on unmount); route SIGINT and SIGTERM to :meth:`action_interrupt`."""
        self._catch_signals()
        self._watcher = FileWatcher(self, watched, self.poll_s)
        for message in self._watcher.scan():
            self.post_message(message)
        self._watcher.start()

    #: Called at once on Ctrl-C (before the view closes, which takes a while on a busy machine): what stops the
    #: work starts with the key press.
    on_interrupt: Callable[[], None] | None = None

    def action_interrupt(self) -> None:
        """Ctrl-C: close the view now, marked :attr:`interrupted` (return code 130)."""
        self.interrupted = True
        if self.on_interrupt is not None:
            self.on_interrupt()
        self.exit(return_code=130)

    def _catch_signals(self) -> None:
        # In raw mode the terminal sends Ctrl-C as a key; `kill -INT`/`kill -TERM` still arrive as signals, and
        # Python's handlers would raise inside Textual's event loop. Only the main thread can handle signals.
        if threading.current_thread() is not threading.main_thread():
            return
        loop = asyncio.get_running_loop()
        self._previous_handlers = {}
        for signum in (signal.SIGINT, signal.SIGTERM):
            try:
                self._previous_handlers[signum] = signal.getsignal(signum)
                loop.add_signal_handler(signum, self.action_interrupt)
            except (RuntimeError, ValueError, NotImplementedError):  # no signals here (tests' loops, Windows)
                self._previous_handlers.pop(signum, None)

    def on_unmount(self) -> None:
        """Stop the watcher; give SIGINT and SIGTERM back to the handlers they had before :meth:`follow_files`."""
        watcher = getattr(self, "_watcher", None)
        if watcher is not None:
            watcher.stop()
        loop = asyncio.get_running_loop()
        for signum, handler in getattr(self, "_previous_handlers", {}).items():
            loop.remove_signal_handler(signum)
            signal.signal(signum, handler)


class LogChanged(Message):
    """An episode's log changed: ``text``, its last :data:`LOG_TAIL_BYTES` (``None``: there is no log yet, or it
    cannot be read: ``problem`` says why), and ``size`` in bytes."""

    def __init__(self, text: str | None, size: int | None, problem: str = "") -> None:
        super().__init__()
        self.text, self.size, self.problem = text, size, problem


def read_log_tail(path: Path) -> LogChanged:
    """The :class:`LogChanged` of the log at ``path`` (its end, at most :data:`LOG_TAIL_BYTES`)."""
    try:
        with open(path, "rb") as f:
            size = f.seek(0, 2)
            f.seek(max(0, size - LOG_TAIL_BYTES))
            text = f.read().decode("utf-8", errors="replace")
    except FileNotFoundError:
        return LogChanged(None, None)
    except OSError as exc:  # removed or replaced while it was read
        return LogChanged(None, None, f"cannot read the log: {exc.strerror or exc}")
    return LogChanged(text, size)


class LogScreen(Screen):
    """One episode's log (its last :data:`LOG_TAIL_BYTES`), followed while it grows (:class:`LogChanged` messages
    from a watcher of the file); Escape or q goes back."""

    BINDINGS = [Binding("escape", "app.pop_screen", "back"), Binding("q", "app.pop_screen", "back")]
    DEFAULT_CSS = "LogScreen Log { height: 1fr; }"

    def __init__(self, path: Path, title: str, poll_s: float = 0.5) -> None:
        super().__init__()
        self.path, self.title_text, self.poll_s = path, title, poll_s
        self._watcher: FileWatcher | None = None

    def compose(self) -> ComposeResult:
        yield Static(f"[b]{escape(self.title_text)}[/b] · {escape(str(self.path))}", id="log-title")
        yield Log(id="episode-log", auto_scroll=True)
        yield Footer()

    def on_mount(self) -> None:
        self._watcher = FileWatcher(self, [Watched(self.path, read_log_tail)], self.poll_s)
        for message in self._watcher.scan():
            self.post_message(message)
        self._watcher.start()

    def on_unmount(self) -> None:
        if self._watcher is not None:
            self._watcher.stop()

    def on_log_changed(self, message: LogChanged) -> None:
        """Show the log's end as the message carries it."""
        log = self.query_one(Log)
        log.clear()
        if message.text is None:
            log.write_line(f"({message.problem or 'no log yet: the episode has not started'})")
            return
        if message.size > LOG_TAIL_BYTES:
            log.write_line(f"[… the first {message.size - LOG_TAIL_BYTES} bytes are not shown]")
        log.write_lines(message.text.splitlines())


class ManifestChanged(Message):
    """``manifest.json`` changed: ``manifest``, its content (None: missing or unreadable)."""

    def __init__(self, manifest: Any) -> None:
        super().__init__()
        self.manifest = manifest


class ProgressChanged(Message):
    """``progress.json`` changed: ``episodes``, ``{index: {state, step, started, stage}}`` (``{}``: none)."""

    def __init__(self, episodes: dict) -> None:
        super().__init__()
        self.episodes = episodes


class ConfigChanged(Message):
    """``config.json`` changed: ``expected``, ``{environment: steps}`` of a passive task (``{}``: none)."""

    def __init__(self, expected: dict) -> None:
        super().__init__()
        self.expected = expected


class EpisodeScoresChanged(Message):
    """``episode_scores.json`` changed: ``entries``, its content (a list once evaluated; else None)."""

    def __init__(self, entries: Any) -> None:
        super().__init__()
        self.entries = entries


class ScoresChanged(Message):
    """``scores.json`` changed: ``scores``, its content (the combined scores; else None)."""

    def __init__(self, scores: Any) -> None:
        super().__init__()
        self.scores = scores


def run_dir_files(run_dir: Path) -> list[Watched]:
    """The files of ``run_dir`` the batch view follows, each with the message it becomes."""
    return [Watched(run_dir / "manifest.json", lambda p: ManifestChanged(read_json(p))),
            Watched(run_dir / PROGRESS, lambda p: ProgressChanged(read_progress(p.parent))),
            Watched(run_dir / "config.json", lambda p: ConfigChanged(read_expected(p))),
            Watched(run_dir / "episode_scores.json", lambda p: EpisodeScoresChanged(read_json(p))),
            Watched(run_dir / "scores.json", lambda p: ScoresChanged(read_json(p)))]


def fit(text: str, width: int) -> str:
    """``text`` in at most ``width`` characters: whole if it fits, else without its parenthesised detail
    ("building the scene (miniroom:1) …" → "building the scene …"), else cut with "…"."""
    if len(text) <= width:
        return text
    if " (" in text:
        short = text.split(" (")[0] + (" …" if text.endswith("…") else "")
        if len(short) <= width:
            return short
        text = short
    return text[: max(0, width - 1)] + "…"


#: Columns the view keeps free beside the table (its vertical scrollbar, when the rows overflow).
SCROLLBAR_COLUMNS = 2


class EpisodeTable(DataTable):
    """The episode table: a row-cursor :class:`~textual.widgets.DataTable` whose Enter (open the episode's log) is
    shown in the footer."""

    BINDINGS = [Binding("enter", "select_cursor", "episode log")]


class BatchApp(WatchingApp):
    """A live table of a batch's episodes, with an overall progress line; Enter on a row opens its log.

    Args:
        run_dir: the run directory to watch.
        poll_s: seconds between two checks of its files' stat (a file is read only when it changed).
        is_done: optional callable; when it returns True (the batch thread ended) the app shows the final state
            and exits after ``linger_s`` seconds.
        linger_s: seconds the final state stays on screen once ``is_done()`` is True.
        clock: the current Unix time (tests freeze it).
    """

    TITLE = "BenchBot batch"
    CSS = """
    #summary { height: auto; padding: 0 1; }
    DataTable { height: 1fr; }
    """
    BINDINGS = [Binding("q", "quit", "quit view (the batch goes on)"),
                Binding("ctrl+c", "interrupt", "stop the batch", priority=True)]

    def __init__(self, run_dir: Path | str, *, poll_s: float = 0.5, is_done: Callable[[], bool] | None = None,
                 linger_s: float = 1.0, clock: Callable[[], float] = time.time) -> None:
        super().__init__()
        self.run_dir = Path(run_dir)
        self.poll_s, self.is_done, self.linger_s, self.clock = poll_s, is_done, linger_s, clock
        self.files = BatchFiles()
        self._exit_scheduled = False  # not `_closing`: Textual's MessagePump uses that name
        self._logs: dict[str, tuple[str, str]] = {}
        self._shown: dict[str, tuple] = {}  # row key -> the cells on screen
        self._episodes_running = False  # not `_running`: Textual's MessagePump uses that name
        self._show_pending = False
        self._summary_shown: str | None = None
        self._eta = EtaEstimator()

    def compose(self) -> ComposeResult:
        yield Static(id="summary")
        yield EpisodeTable(id="episodes", cursor_type="row", zebra_stripes=True)
        yield Footer()

    def on_mount(self) -> None:
        self.sub_title = str(self.run_dir.name)
        self.follow_files(run_dir_files(self.run_dir))
        self.set_interval(TICK_S, self._tick)

    def on_manifest_changed(self, message: ManifestChanged) -> None:
        self.files.manifest = message.manifest
        self._changed()

    def on_progress_changed(self, message: ProgressChanged) -> None:
        self.files.progress = message.episodes
        self._changed()

    def on_config_changed(self, message: ConfigChanged) -> None:
        self.files.expected = message.expected
        self._changed()

    def on_episode_scores_changed(self, message: EpisodeScoresChanged) -> None:
        self.files.episode_scores = message.entries
        self._changed()

    def on_scores_changed(self, message: ScoresChanged) -> None:
        self.files.scores = message.scores
        self._changed()

    def _changed(self) -> None:
        """A message changed :attr:`files`: draw once the messages queued already are handled too (the files of
        the first scan come together: a run directory is never drawn half read)."""
        if not self._show_pending:
            self._show_pending = True
            self.call_later(self._show_after_messages)

    def _show_after_messages(self) -> None:
        self._show_pending = False
        self.show()

    def _tick(self) -> None:
        """Every :data:`TICK_S`: while episodes run, their wall times and the ETA move on; with ``is_done``, see
        whether the batch ended. Nothing is read."""
        if self._episodes_running or (self.is_done is not None and not self._exit_scheduled):
            self.show()

    def show(self) -> None:
        """Draw what :attr:`files` holds now: the header, and the table cells that changed."""
        try:
            self._show()
        except NoMatches:  # the app is closing
            pass

    def _show(self) -> None:
        try:
            summary, rows = rows_of(self.files, self.clock())
        except (AttributeError, KeyError, TypeError, ValueError) as exc:  # a manifest edited by hand, not ours
            self._update_summary(
                f"[red]{escape(str(self.run_dir / 'manifest.json'))} is not a batch manifest[/] ({escape(repr(exc))})")
            return
        table = self.query_one(DataTable)
        if not summary:
            self._update_summary(f"waiting for {self.run_dir / 'manifest.json'} …")
            return
        self._episodes_running = summary["counts"].get("running", 0) > 0
        self._update_summary(summary_text(summary, self._eta.update(summary, self.clock())))
        name = summary.get("score_name") or "score"
        if not table.columns:  # the first manifest: the score column headed by its name from the start
            for key in COLUMNS:
                table.add_column(name if key == COLUMNS[-1] else key, key=key)
        column = table.columns.get(COLUMNS[-1])
        if column is not None and str(column.label) != name:
            column.label = Text(name)
            table.refresh()
        self._show_rows(table, summary, rows, name)
        if self.is_done is not None and not self._exit_scheduled and self.is_done():
            self._exit_scheduled = True
            self.set_timer(self.linger_s, self.exit)

    def _update_summary(self, text: str) -> None:
        """Put ``text`` (rich markup) in the header, unless it is there already (a redraw costs a layout)."""
        if text != self._summary_shown:
            self.query_one("#summary", Static).update(text)
            self._summary_shown = text

    def _show_rows(self, table: DataTable, summary: dict, rows: list[tuple], name: str) -> None:
        """Put ``rows`` in the table, updating only the cells that differ from what is shown."""
        # the steps cell (a stage's name while the backend starts) gets what the other columns leave of the
        # screen's width, so that at 80 columns the wall and score columns stay on it
        headers = {k: (name if k == COLUMNS[-1] else k) for k in COLUMNS}
        others = sum(max([len(headers[k])] + [len(str(r[i])) for r in rows]) for i, k in enumerate(COLUMNS)
                     if k != "steps")
        room = self.size.width - others - 2 * table.cell_padding * len(COLUMNS) - SCROLLBAR_COLUMNS
        room = max(len("steps"), len("9999/9999"), room)
        for row in rows:
            row = (*row[:5], fit(str(row[5]), room), *row[6:])
            key = str(row[0])
            self._logs[key] = (f"episode {row[0]} · {row[1]} · {row[2]} · repeat {row[3]}",
                               summary["logs"].get(row[0], ""))
            cells = list(row)
            cells[4] = f"[{STATUS_STYLE.get(row[4], '')}]{row[4]}[/]"
            shown = self._shown.get(key)
            if shown is None:
                table.add_row(*cells, key=key)
            else:
                for column, value, before in zip(COLUMNS, cells, shown):
                    if value != before:  # a new layout only for a longer text (columns never narrow)
                        table.update_cell(key, column, value, update_width=len(str(value)) > len(str(before)))
            self._shown[key] = tuple(cells)

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        self.open_log(event.row_key.value)

    def open_log(self, key: str | None) -> None:
        """Show episode ``key``'s log (:class:`LogScreen`)."""
        if key in self._logs and self._logs[key][1]:
            title, log = self._logs[key]
            self.push_screen(LogScreen(self.run_dir / log, title, self.poll_s))
