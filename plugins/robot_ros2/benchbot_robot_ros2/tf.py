"""A small TF buffer: the newest transform of every (parent → child) edge from ``/tf`` and ``/tf_static``.

Lookups compose edges through the tree; a dynamic edge received ``max_age_s`` before the newest dynamic transform
counts as lost (a localiser that stopped while odometry goes on). Age is judged against what arrived, not against
the wall clock: a process that was not scheduled for a while (a machine under heavy load) reads its queued
messages late and must not find all of TF stale; TF silent altogether is the backend's watchdog's to judge
(:mod:`benchbot_robot_ros2.watchdog`). Thread-safe (written by the transport's thread, read by the backend's).
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np

from benchbot_robot_ros2.convert import transform_to_matrix


class TfLookupError(LookupError):
    """No (fresh) chain of transforms links the two frames."""


class TfBuffer:
    """Newest transforms by child frame.

    Args:
        max_age_s: dynamic transforms received this long (s) before the newest dynamic one are lost (static ones
            never are).
    """

    def __init__(self, max_age_s: float = 1.0) -> None:
        self.max_age_s = float(max_age_s)
        self._edges: dict[str, tuple[str, np.ndarray, float, bool]] = {}  # child -> (parent, T_parent_child, t, static)
        self._lock = threading.Lock()
        self._newest = -float("inf")  # receipt time (monotonic s) of the newest dynamic transform

    def add_message(self, msg: Any, static: bool = False) -> None:
        """Store every ``TransformStamped`` of a ``tf2_msgs/TFMessage`` at once (a lookup sees all of a message's
        edges or none: after a pause, a lookup between two edges of one message would find the second one stale);
        malformed entries are skipped (the first problem is re-raised as ValueError after the good ones are
        stored)."""
        problem = None
        parsed = []
        for ts in list(msg.transforms):
            try:
                parent, child = str(ts.header.frame_id).lstrip("/"), str(ts.child_frame_id).lstrip("/")
                if not parent or not child or parent == child:
                    raise ValueError(f"transform with frames {parent!r} → {child!r}")
                parsed.append((child, parent, transform_to_matrix(ts.transform)))
            except Exception as exc:  # noqa: BLE001
                problem = problem or exc
        with self._lock:
            now = time.monotonic()
            for child, parent, T in parsed:
                self._edges[child] = (parent, T, now, static)
            if parsed and not static:
                self._newest = max(self._newest, now)
        if problem is not None:
            raise ValueError(f"malformed transform: {problem}")

    def _chain(self, frame: str, now: float) -> tuple[list[str], np.ndarray]:
        """Frames from ``frame`` up to its root, and T_root_frame."""
        T = np.eye(4)
        path = [frame]
        while frame in self._edges and len(path) < 64:
            parent, T_pc, t, static = self._edges[frame]
            if not static and now - t > self.max_age_s:
                raise TfLookupError(f"transform {parent} → {frame} was received {now - t:.2f} s before the newest "
                                    f"transform (limit {self.max_age_s:.2f} s)")
            T = T_pc @ T
            frame = parent
            path.append(frame)
        return path, T

    def lookup(self, target: str, source: str) -> np.ndarray:
        """``T_target_source`` (4, 4) float64: maps points of ``source`` into ``target``.

        Raises:
            TfLookupError: the frames are not connected, or a transform on the way is stale.
        """
        with self._lock:
            now = self._newest
            p_t, T_rt = self._chain(target, now)
            p_s, T_rs = self._chain(source, now)
        if p_t[-1] != p_s[-1]:
            raise TfLookupError(f"no transform between '{target}' and '{source}' (trees rooted at '{p_t[-1]}' and "
                                f"'{p_s[-1]}')")
        return np.linalg.inv(T_rt) @ T_rs

    def frames(self) -> list[str]:
        """Every child frame seen so far."""
        with self._lock:
            return sorted(self._edges)
