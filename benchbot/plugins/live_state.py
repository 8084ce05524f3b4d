"""An observer that keeps a small snapshot of a running episode in a folder, for the live view (``benchbot run
--tui``, ``benchbot tui STATE_DIR``).

Files (both replaced atomically, at most ``max_rate_hz`` times a second):

* ``state.json``: ``task``, ``robot``, ``environments`` (names), ``step``, ``rate_hz`` (steps per second over the
  last ~5 s), ``state`` (the episode's flags: ``is_collided``, ``is_dirty``, ``is_finished``, ``is_running``,
  ``scene_number``, ``scene_count``), ``pose`` ``[x m, y m, yaw rad]`` (map frame, ground truth), ``last_action``
  ``{action, args, result}`` (or None), ``preview`` (the preview file's name or None), ``log`` (the last 200 lines),
  ``log_total`` (lines ever logged).
* ``preview.npy``: the last RGB observation, downsampled by striding to at most ``preview_width`` columns,
  (h, w, 3) uint8.

:class:`LiveStateWriter` renders nothing: it reads ``Episode.last_observation``. Its hooks and :meth:`refresh` run on
the backend thread (observer hooks, or ``BackendService.call``).
"""

from __future__ import annotations

import io
import os
import tempfile
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from benchbot.core import atomic
from benchbot.core.hookspecs import hookimpl

STATE = "state.json"
PREVIEW = "preview.npy"


def downsample(rgb: np.ndarray, max_width: int) -> np.ndarray:
    """``rgb`` (H, W, 3+) uint8 strided to at most ``max_width`` columns (rows by the same factor) → (h, w, 3) uint8,
    C-contiguous (it may share memory with ``rgb`` when no striding is needed: do not modify it)."""
    factor = max(1, int(np.ceil(rgb.shape[1] / max_width)))
    return np.ascontiguousarray(rgb[::factor, ::factor, :3], dtype=np.uint8)  # one copy (astype made a second)


def write_npy(path: Path, array: np.ndarray) -> None:
    """Save ``array`` as ``.npy`` atomically."""
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(buffer.getvalue())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


class LiveStateWriter:
    """Writes a running episode's snapshot to ``folder`` (module doc).

    Args:
        folder: where ``state.json`` and ``preview.npy`` go (created).
        preview_width: columns of the preview at most.
        max_rate_hz: snapshots written per second at most.
    """

    def __init__(self, folder: Path | str, *, preview_width: int = 96, max_rate_hz: float = 4.0) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.preview_width, self.min_interval = preview_width, 1.0 / max_rate_hz
        self.episode: Any = None
        self.info: dict = {}
        self.last_action: dict | None = None
        self.log: deque[str] = deque(maxlen=200)
        self.step_times: deque[tuple[float, int]] = deque(maxlen=64)
        self._written_at = 0.0
        self._written_key: tuple | None = None
        self._preview_of: Any = None
        self.step = 0
        self.log_total = 0  # lines ever logged (``log`` keeps the last 200)

    def attach(self, episode: Any) -> None:
        """Observe ``episode`` (backend thread); writes the first snapshot."""
        self.episode = episode
        self.info = {"task": episode.task["name"], "robot": episode.robot["name"],
                     "environments": [f"{e['name']}:{e['variant']}" for e in episode.environments]}
        self._log(f"episode started: {self.info['task']} | {self.info['robot']} | "
                  f"{', '.join(self.info['environments'])}")
        self.refresh(force=True)

    @hookimpl
    def benchbot_episode_started(self, info: dict) -> None:
        """A new episode (backend thread): keep its ``task``, ``robot`` and ``environments`` for the snapshot."""
        self.info = {k: info.get(k) for k in ("task", "robot", "environments")}

    @hookimpl
    def benchbot_step(self, info: dict) -> None:
        """After every action (backend thread): keep it; write a snapshot when due."""
        self.step = int(info["step"])
        self.step_times.append((time.monotonic(), self.step))
        self.last_action = {"action": info.get("action"), "args": dict(info.get("args") or {}),
                            "result": info.get("result")}
        args = ", ".join(f"{k}={v}" for k, v in self.last_action["args"].items())
        self._log(f"step {self.step}: {info.get('action')}({args}) → {info.get('result')}")
        self.refresh(force=info.get("result") != "SUCCESS")

    def _log(self, line: str) -> None:
        self.log.append(line)
        self.log_total += 1

    def rate(self) -> float:
        """Steps per second over the last ~5 s (0 with fewer than two steps)."""
        now = time.monotonic()
        recent = [(t, s) for t, s in self.step_times if now - t <= 5.0]
        if len(recent) < 2 or recent[-1][0] <= recent[0][0]:
            return 0.0
        return (recent[-1][1] - recent[0][1]) / (recent[-1][0] - recent[0][0])

    def refresh(self, force: bool = False) -> bool:
        """Write the snapshot if something changed and it is due (backend thread). Returns whether it wrote."""
        if self.episode is None:
            return False
        last = getattr(self.episode, "last_observation", None)
        key = (self.step, self.log_total, id(last[1]) if last else None)
        now = time.monotonic()
        if key == self._written_key or (not force and now - self._written_at < self.min_interval):
            return False
        preview = None
        if last is not None and "image_rgb" in last[1]:
            if last[1] is not self._preview_of:
                write_npy(self.folder / PREVIEW, downsample(np.asarray(last[1]["image_rgb"]), self.preview_width))
                self._preview_of = last[1]
            preview = PREVIEW
        ep = self.episode
        state = ep.state()
        atomic.write_json(self.folder / STATE, {
            **self.info, "step": self.step, "rate_hz": round(self.rate(), 2),
            "state": {k: state[k] for k in ("is_collided", "is_dirty", "is_finished", "is_running", "scene_number",
                                            "scene_count")},
            "pose": [round(float(v), 4) for v in ep.backend.base_pose()],
            "last_action": self.last_action, "preview": preview, "log": list(self.log),
            "log_total": self.log_total,
        })
        self._written_at, self._written_key = now, key
        return True
