"""The batch view: a live table of a run directory's episodes (it observes, it never drives).

:class:`BatchApp` polls the run directory every ``poll_s`` seconds and reads ``manifest.json`` (the plan and every
episode's record, written atomically by the batch after each episode), ``progress.json`` (live step counts, written
by ``benchbot batch`` at most 4 times a second), ``config.json`` (the expected steps of passive tasks) and
``episode_scores.json`` (OMQ, once the batch is evaluated). It works for a batch running in this process (``benchbot
batch`` runs it in a background thread) or in another one (``benchbot tui RUN_DIR``), and for a finished one.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Callable

from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.css.query import NoMatches
from textual.widgets import DataTable, Footer, Static

PROGRESS = "progress.json"
COLUMNS = ("#", "environment", "robot", "repeat", "status", "steps", "wall", "OMQ")
STATUS_STYLE = {"ok": "green", "running": "yellow", "pending": "dim", "failed": "red", "no_results": "red",
                "error": "bold red"}


def read_json(path: Path) -> Any:
    """``path``'s JSON, or None when it is missing or unreadable (files are replaced atomically: never half)."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def expected_steps(config: dict | None) -> dict[str, int]:
    """``{environment string: steps}`` of a passive task (the trajectories' lengths); ``{}`` for active tasks."""
    if not config or (config.get("task") or {}).get("actions") != ["move_next"]:
        return {}
    return {env: sum(len(s.get("trajectory_poses") or []) for s in scenes)
            for env, scenes in (config.get("environments") or {}).items()}


def episode_omq(scores: Any) -> dict[int, float]:
    """``{episode index: OMQ}`` from ``episode_scores.json``."""
    out: dict[int, float] = {}
    for entry in scores if isinstance(scores, list) else []:
        inner = entry.get("scores") if isinstance(entry.get("scores"), dict) else entry
        if "OMQ" in inner and "index" in entry:
            out[int(entry["index"])] = float(inner["OMQ"])
    return out


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
        (bool), ``evaluation_error``, ``combined_omq`` (or None); each row is ``(index, env, robot, repeat, status,
        steps text, wall text, OMQ text)``. Empty when there is no manifest yet.
    """
    manifest = read_json(run_dir / "manifest.json")
    if not isinstance(manifest, dict):
        return {}, []
    now = time.time() if now is None else now
    progress = read_json(run_dir / PROGRESS) or {}
    live = progress.get("episodes", {}) if isinstance(progress, dict) else {}
    expected = expected_steps(read_json(run_dir / "config.json"))
    omq = episode_omq(read_json(run_dir / "episode_scores.json"))
    counts: dict[str, int] = {}
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
        total = (p or {}).get("expected") if isinstance(p, dict) else None
        total = total if total is not None else expected.get(record["env"])
        steps_text = f"{steps}/{total}" if total else str(steps)
        rows.append((index, record["env"], record["robot"], record.get("repeat", 0), status, steps_text,
                     format_seconds(wall), f"{omq[index]:.4f}" if index in omq else ""))
    scores = read_json(run_dir / "scores.json")
    combined = None
    if isinstance(scores, dict):
        inner = scores.get("scores") if isinstance(scores.get("scores"), dict) else scores
        combined = inner.get("OMQ")
    summary = {"task": manifest.get("task", ""), "episodes": len(rows), "counts": counts,
               "finished": "finished" in manifest, "evaluation_error": manifest.get("evaluation_error", ""),
               "combined_omq": combined}
    return summary, rows


class PollingApp(App):
    """An app that re-reads files every ``poll_s`` seconds: subclasses set ``poll_s``, implement ``_refresh``
    (a :class:`~textual.css.query.NoMatches` it raises while the app is closing is ignored) and call
    :meth:`start_polling` from their ``on_mount`` (not ``super().on_mount()``: Textual already calls the handlers of
    every class in the MRO)."""

    poll_s: float = 0.5

    def start_polling(self) -> None:
        """Refresh now, then every ``poll_s`` seconds."""
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


class BatchApp(PollingApp):
    """A live table of a batch's episodes.

    Args:
        run_dir: the run directory to watch.
        poll_s: seconds between reads of its files.
        is_done: optional callable; when it returns True (the batch thread ended) the app shows the final state
            and exits after ``linger_s`` seconds.
        clock: the current Unix time (tests freeze it).
    """

    TITLE = "BenchBot batch"
    CSS = """
    #summary { height: auto; padding: 0 1; }
    DataTable { height: 1fr; }
    """
    BINDINGS = [Binding("q", "quit", "quit (the batch goes on)")]

    def __init__(self, run_dir: Path | str, *, poll_s: float = 0.5, is_done: Callable[[], bool] | None = None,
                 linger_s: float = 1.0, clock: Callable[[], float] = time.time) -> None:
        super().__init__()
        self.run_dir = Path(run_dir)
        self.poll_s, self.is_done, self.linger_s, self.clock = poll_s, is_done, linger_s, clock
        self._closing = False

    def compose(self) -> ComposeResult:
        yield Static(id="summary")
        yield DataTable(id="episodes", cursor_type="row", zebra_stripes=True)
        yield Footer()

    def on_mount(self) -> None:
        self.sub_title = str(self.run_dir.name)
        table = self.query_one(DataTable)
        for name in COLUMNS:
            table.add_column(name, key=name)
        self.start_polling()

    def _refresh(self) -> None:
        summary, rows = batch_rows(self.run_dir, self.clock())
        table = self.query_one(DataTable)
        if not summary:
            self.query_one("#summary", Static).update(f"waiting for {self.run_dir / 'manifest.json'} …")
            return
        counts = " · ".join(f"[{STATUS_STYLE.get(k, '')}]{k} {v}[/]" for k, v in sorted(summary["counts"].items()))
        state = "[green]finished[/]" if summary["finished"] else "[yellow]running[/]"
        text = f"task [b]{summary['task']}[/b] · {summary['episodes']} episodes · {counts} · {state}"
        if summary["combined_omq"] is not None:
            text += f" · OMQ [b]{summary['combined_omq']:.4f}[/b]"
        if summary["evaluation_error"]:
            text += f"\n[red]evaluation failed:[/] {summary['evaluation_error']}"
        self.query_one("#summary", Static).update(text)
        for row in rows:
            key = str(row[0])
            cells = list(row)
            cells[4] = f"[{STATUS_STYLE.get(row[4], '')}]{row[4]}[/]"
            if key in table.rows:
                for column, value in zip(COLUMNS, cells):
                    table.update_cell(key, column, value)
            else:
                table.add_row(*cells, key=key)
        if self.is_done is not None and not self._closing and self.is_done():
            self._closing = True
            self.set_timer(self.linger_s, self.exit)
