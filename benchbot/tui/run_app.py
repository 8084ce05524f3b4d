"""The live view of one episode (``benchbot run --tui``): task, robot, environment, robot state and pose, step count
and rate, the last action and its result, a camera preview drawn with half-block characters, and the log.

:class:`RunApp` is fed typed messages (:class:`LiveStateChanged`, :class:`PreviewChanged`) by a
:class:`~benchbot.tui.watch.FileWatcher` of the folder that :class:`benchbot.plugins.live_state.LiveStateWriter`
keeps (``state.json``, ``preview.npy``): the watcher checks the files' stat every ``poll_s`` seconds and reads one
only when it changed. The view never reads a file, and never touches the episode.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from rich.style import Style
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.css.query import NoMatches
from textual.message import Message
from textual.widgets import Footer, Log, Static

from benchbot.plugins.live_state import PREVIEW, STATE
from benchbot.tui.batch_app import WatchingApp
from benchbot.tui.watch import Watched, read_json

HALF_BLOCK = "▀"


def half_blocks(rgb: np.ndarray, width: int | None = None) -> Text:
    """``rgb`` (H, W, 3) uint8 as text: one cell per column and two rows (``▀``: foreground = upper pixel,
    background = lower pixel), strided to at most ``width`` columns."""
    rgb = np.asarray(rgb, dtype=np.uint8)
    if width and rgb.shape[1] > width:
        f = int(math.ceil(rgb.shape[1] / width))
        rgb = rgb[::f, ::f]
    if rgb.shape[0] % 2:
        rgb = np.concatenate([rgb, np.zeros_like(rgb[:1])], axis=0)
    text = Text(no_wrap=True, overflow="crop")
    for r in range(0, rgb.shape[0], 2):
        for top, bottom in zip(rgb[r], rgb[r + 1]):
            text.append(HALF_BLOCK, Style(color=f"rgb({top[0]},{top[1]},{top[2]})",
                                          bgcolor=f"rgb({bottom[0]},{bottom[1]},{bottom[2]})"))
        if r + 2 < rgb.shape[0]:
            text.append("\n")
    return text


def describe(state: dict, address: str = "") -> str:
    """The status panel's text (rich markup) for a ``state.json``; ``address`` is the backend's, shown first.

    The supervisor's ``is_dirty`` flag (the robot has moved since the scene started, so ``next``/``reset`` must
    return it first) is shown as "moved since the scene started"."""
    flags = state.get("state") or {}
    pose = state.get("pose") or [0.0, 0.0, 0.0]
    last = state.get("last_action")
    status = ("[bold red]COLLIDED[/]" if flags.get("is_collided") else "[green]finished[/]" if flags.get("is_finished")
              else "[yellow]running[/]" if flags.get("is_running") else "[dim]stopped[/]")
    lines = [f"[b]backend[/b]      {address}"] if address else []
    lines += [
        f"[b]task[/b]         {state.get('task', '?')}",
        f"[b]robot[/b]        {state.get('robot', '?')}",
        f"[b]environment[/b]  {', '.join(state.get('environments') or [])}"
        f"  (scene {flags.get('scene_number', 0) + 1}/{flags.get('scene_count', 1)})",
        f"[b]state[/b]        {status}" + ("  [yellow]moved since the scene started[/]" if flags.get("is_dirty") else ""),
        f"[b]pose[/b]         x {pose[0]:+.3f} m  y {pose[1]:+.3f} m  yaw {math.degrees(pose[2]):+.1f}°  (map)",
        f"[b]steps[/b]        {state.get('step', 0)}  ({state.get('rate_hz', 0.0):.2f} steps/s)",
    ]
    if last:
        args = ", ".join(f"{k}={v}" for k, v in (last.get("args") or {}).items())
        colour = "green" if last.get("result") == "SUCCESS" else "yellow" if last.get("result") == "FINISHED" else "red"
        lines.append(f"[b]last action[/b]  {last.get('action')}({args}) → [{colour}]{last.get('result')}[/]")
    else:
        lines.append("[b]last action[/b]  none yet")
    return "\n".join(lines)


class LiveStateChanged(Message):
    """``state.json`` changed: ``state``, its content (a dict; module :mod:`benchbot.plugins.live_state`)."""

    def __init__(self, state: dict) -> None:
        super().__init__()
        self.state = state


class PreviewChanged(Message):
    """``preview.npy`` changed: ``rgb``, the camera preview, (h, w, 3) uint8."""

    def __init__(self, rgb: np.ndarray) -> None:
        super().__init__()
        self.rgb = rgb


def read_state(path: Path) -> LiveStateChanged | None:
    """The :class:`LiveStateChanged` of ``state.json`` at ``path``; None when it is missing, unreadable or no dict."""
    state = read_json(path)
    return LiveStateChanged(state) if isinstance(state, dict) else None


def read_preview(path: Path) -> PreviewChanged | None:
    """The :class:`PreviewChanged` of ``preview.npy`` at ``path``; None when it is missing, unreadable or not
    (h, w, 3)."""
    try:
        rgb = np.load(path, allow_pickle=False)
    except (OSError, ValueError):
        return None
    return PreviewChanged(rgb) if rgb.ndim == 3 and rgb.shape[2] >= 3 else None


class RunApp(WatchingApp):
    """The live view of a running episode.

    Args:
        state_dir: the live-state folder (``state.json``, ``preview.npy``).
        poll_s: seconds between two checks of its files' stat (a file is read only when it changed).
        preview_width: columns of the camera preview.
        address: the backend's address, shown in the sub-title (optional).
    """

    TITLE = "BenchBot run"
    CSS = """
    #top { height: auto; }
    #status { width: 1fr; padding: 0 1; height: auto; }
    #preview { width: auto; height: auto; padding: 0 1; }
    Log { height: 1fr; border-top: solid $primary; }
    """
    BINDINGS = [Binding("q", "quit", "quit (stops the backend)"),
                Binding("ctrl+c", "interrupt", "stop the backend", priority=True)]

    def __init__(self, state_dir: Path | str, *, poll_s: float = 0.5, preview_width: int = 64,
                 address: str = "") -> None:
        super().__init__()
        self.state_dir = Path(state_dir)
        self.poll_s, self.preview_width, self.address = poll_s, preview_width, address
        self._log_lines = 0

    def compose(self) -> ComposeResult:
        with Vertical():
            with Horizontal(id="top"):
                yield Static("", id="status")
                yield Static("", id="preview")
            yield Log(id="log", auto_scroll=True)
        yield Footer()

    def on_mount(self) -> None:
        if self.address:
            self.sub_title = self.address
        waiting = "waiting for a solution to connect (e.g. `benchbot submit --example hello_active`) …"
        self.query_one("#status", Static).update(
            (f"[b]backend[/b]      {self.address}\n" if self.address else "") + waiting)
        self.follow_files([Watched(self.state_dir / STATE, read_state),
                           Watched(self.state_dir / PREVIEW, read_preview)])

    def on_preview_changed(self, message: PreviewChanged) -> None:
        """Draw the new camera preview."""
        try:
            self.query_one("#preview", Static).update(half_blocks(message.rgb, self.preview_width))
        except NoMatches:  # the app is closing
            pass

    def on_live_state_changed(self, message: LiveStateChanged) -> None:
        """Show the new state and append the log lines it adds."""
        try:
            self._show_state(message.state)
        except NoMatches:  # the app is closing
            pass

    def _show_state(self, state: dict) -> None:
        self.query_one("#status", Static).update(describe(state, self.address))
        lines = state.get("log") or []
        total = int(state.get("log_total", len(lines)))
        log = self.query_one(Log)
        if total < self._log_lines:  # another episode wrote this folder: start again
            log.clear()
            self._log_lines = 0
        new = min(total - self._log_lines, len(lines))
        if new > 0:
            log.write_lines(lines[-new:])
        self._log_lines = total
