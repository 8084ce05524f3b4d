"""The batch view: a live table of a run directory's episodes (it observes, it never drives).

:class:`BatchApp` polls the run directory every ``poll_s`` seconds and reads ``manifest.json`` (the plan and every
episode's record, written atomically by the batch after each episode), ``progress.json`` (live step counts, written
by the batch at most 4 times a second: :mod:`benchbot.batch.progress`), ``config.json`` (the expected steps of
passive tasks) and ``episode_scores.json`` (the evaluation method's primary score, once the batch is evaluated; its
name from the manifest's ``scores``, which the method declares). It works for a batch running in this
process (``benchbot batch`` runs it in a background thread) or in another one (``benchbot tui RUN_DIR``), and for a
finished one: one way in for all three, since the files are written for the other process and the finished batch
anyway.
"""

from __future__ import annotations

import asyncio
import json
import signal
import threading
import time
from pathlib import Path
from typing import Any, Callable

from rich.markup import escape
from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.css.query import NoMatches
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Log, Static

from benchbot.batch.plan import expected_steps
from benchbot.batch.progress import read_progress

COLUMNS = ("#", "environment", "robot", "repeat", "status", "steps", "wall", "score")
"""The episode table's column keys; the last one is headed by the primary score's name (:func:`primary_score`)."""
#: Bytes of an episode's log that the log screen shows (its end).
LOG_TAIL_BYTES = 256 * 1024
#: Statuses of an episode that will not change any more in this batch.
FINAL_STATUSES = ("ok", "failed", "no_results", "error", "bad_results", "timeout", "resource_limit")
STATUS_STYLE = {"ok": "green", "running": "yellow", "pending": "dim", "failed": "red", "no_results": "red",
                "timeout": "red", "bad_results": "red", "resource_limit": "red",
                "error": "bold red"}


def read_json(path: Path) -> Any:
    """``path``'s JSON, or None when it is missing or unreadable (files are replaced atomically: never half)."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


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


def format_seconds(seconds: float | None) -> str:
    """``m:ss`` (``h:mm:ss`` past an hour); ``""`` for None."""
    if seconds is None:
        return ""
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def batch_rows(run_dir: Path, now: float | None = None) -> tuple[dict, list[tuple]]:
    """The header facts and the table rows of ``run_dir`` now.

    Args:
        run_dir: a run directory of ``benchbot batch``.
        now: the current Unix time (s) for running episodes' wall time (default ``time.time()``).

    Returns:
        ``(summary, rows)``: ``summary`` has ``task``, ``episodes``, ``counts`` (``{status: n}``), ``finished``
        (bool), ``evaluation_error``, ``score_name`` (the primary score's, or None), ``combined`` (its combined
        value, or None), ``done`` (episodes that ended), ``progress``
        (0–1: ended episodes plus running ones' step fractions, over all), ``logs`` (``{index: log path relative
        to run_dir}``); each row is ``(index, env, robot, repeat, status,
        steps text, wall text, score text)``. Empty when there is no manifest yet.
    """
    manifest = read_json(run_dir / "manifest.json")
    if not isinstance(manifest, dict):
        return {}, []
    now = time.time() if now is None else now
    live = read_progress(run_dir)
    expected = _or_empty(expected_steps_by_env, read_json(run_dir / "config.json"))
    episode_scores_ = read_json(run_dir / "episode_scores.json")
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
    scores = read_json(run_dir / "scores.json")
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


class PollingApp(App):
    """An app that re-reads files every ``poll_s`` seconds: subclasses set ``poll_s``, implement ``_refresh``
    (a :class:`~textual.css.query.NoMatches` it raises while the app is closing is ignored) and call
    :meth:`start_polling` from their ``on_mount`` (not ``super().on_mount()``: Textual already calls the handlers of
    every class in the MRO).

    Keys: ``q`` quits the view; Ctrl-C (the key, or SIGINT/SIGTERM sent to the process) quits it at once with
    :attr:`interrupted` set and return code 130, so the command that showed it stops its work as it would on Ctrl-C
    without a view (Textual's own "press ctrl+q to quit" dialog is replaced).
    """

    poll_s: float = 0.5
    BINDINGS = [Binding("ctrl+c", "interrupt", "stop", priority=True, show=False)]

    #: True when the view was closed by Ctrl-C (or SIGINT/SIGTERM) rather than by ``q`` or by itself.
    interrupted: bool = False

    def start_polling(self) -> None:
        """Refresh now, then every ``poll_s`` seconds; route SIGINT and SIGTERM to :meth:`action_interrupt`."""
        self._catch_signals()
        self.refresh_view()
        self.set_interval(self.poll_s, self.refresh_view)

    def refresh_view(self) -> None:
        """Re-read the files and update the widgets in place."""
        try:
            self._refresh()
        except NoMatches:  # the app is closing
            pass

    def _refresh(self) -> None:
        raise NotImplementedError

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
        """Give SIGINT and SIGTERM back to the handlers they had before :meth:`start_polling`."""
        loop = asyncio.get_running_loop()
        for signum, handler in getattr(self, "_previous_handlers", {}).items():
            loop.remove_signal_handler(signum)
            signal.signal(signum, handler)


class LogScreen(Screen):
    """One episode's log (its last :data:`LOG_TAIL_BYTES`), followed while it grows; Escape or q goes back."""

    BINDINGS = [Binding("escape", "app.pop_screen", "back"), Binding("q", "app.pop_screen", "back")]
    DEFAULT_CSS = "LogScreen Log { height: 1fr; }"

    def __init__(self, path: Path, title: str) -> None:
        super().__init__()
        self.path, self.title_text, self._log_size = path, title, -1

    def compose(self) -> ComposeResult:
        yield Static(f"[b]{escape(self.title_text)}[/b] · {escape(str(self.path))}", id="log-title")
        yield Log(id="episode-log", auto_scroll=True)
        yield Footer()

    def on_mount(self) -> None:
        self.follow()
        self.set_interval(0.5, self.follow)

    def follow(self) -> None:
        """Re-read the log when its size changed."""
        try:
            size = self.path.stat().st_size
        except OSError:
            size = None
        if size == self._log_size:
            return
        self._log_size = size
        log = self.query_one(Log)
        log.clear()
        if size is None:
            log.write_line("(no log yet: the episode has not started)")
            return
        try:
            with open(self.path, "rb") as f:
                f.seek(max(0, size - LOG_TAIL_BYTES))
                text = f.read().decode("utf-8", errors="replace")
        except OSError as exc:  # removed or replaced since its size was read
            log.write_line(f"(cannot read the log: {exc.strerror or exc})")
            return
        if size > LOG_TAIL_BYTES:
            log.write_line(f"[… the first {size - LOG_TAIL_BYTES} bytes are not shown]")
        log.write_lines(text.splitlines())


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


class BatchApp(PollingApp):
    """A live table of a batch's episodes, with an overall progress line; Enter on a row opens its log.

    Args:
        run_dir: the run directory to watch.
        poll_s: seconds between reads of its files.
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
        self._exit_scheduled = False  # not `_closing`: Textual's MessagePump uses that name
        self._logs: dict[str, tuple[str, str]] = {}
        self._eta = EtaEstimator()

    def compose(self) -> ComposeResult:
        yield Static(id="summary")
        yield EpisodeTable(id="episodes", cursor_type="row", zebra_stripes=True)
        yield Footer()

    def on_mount(self) -> None:
        self.sub_title = str(self.run_dir.name)
        table = self.query_one(DataTable)
        manifest = read_json(self.run_dir / "manifest.json")
        name = primary_score(manifest, read_json(self.run_dir / "episode_scores.json")) \
            if isinstance(manifest, dict) else None
        for key in COLUMNS:
            table.add_column(name if key == COLUMNS[-1] and name else key, key=key)
        self.start_polling()

    def _refresh(self) -> None:
        try:
            summary, rows = batch_rows(self.run_dir, self.clock())
        except (AttributeError, KeyError, TypeError, ValueError) as exc:  # a manifest edited by hand, not ours
            self.query_one("#summary", Static).update(
                f"[red]{escape(str(self.run_dir / 'manifest.json'))} is not a batch manifest[/] ({escape(repr(exc))})")
            return
        table = self.query_one(DataTable)
        if not summary:
            self.query_one("#summary", Static).update(f"waiting for {self.run_dir / 'manifest.json'} …")
            return
        self.query_one("#summary", Static).update(summary_text(summary, self._eta.update(summary, self.clock())))
        name = summary.get("score_name") or "score"
        column = table.columns.get(COLUMNS[-1])
        if column is not None and str(column.label) != name:
            column.label = Text(name)
            table.refresh()
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
            if key in table.rows:
                for column, value in zip(COLUMNS, cells):
                    table.update_cell(key, column, value, update_width=True)
            else:
                table.add_row(*cells, key=key)
        if self.is_done is not None and not self._exit_scheduled and self.is_done():
            self._exit_scheduled = True
            self.set_timer(self.linger_s, self.exit)

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        self.open_log(event.row_key.value)

    def open_log(self, key: str | None) -> None:
        """Show episode ``key``'s log (:class:`LogScreen`)."""
        if key in self._logs and self._logs[key][1]:
            title, log = self._logs[key]
            self.push_screen(LogScreen(self.run_dir / log, title))
