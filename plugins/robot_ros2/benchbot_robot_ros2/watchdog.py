"""Whether a robot's topic fell silent, judged by what the robot sent, not by when this process read it.

A sensor watchdog that compares the wall time of the last *receipt* with the wall time now blames the robot for
every moment BenchBot's own process was not scheduled: on a machine under heavy load (seen at load average 40-68
on 2 cores) the process slept 1.4-2.2 s, nothing was read meanwhile, and the robot, still publishing, was stopped
with "odometry silent". :class:`SilenceWatch` judges instead by the messages themselves:

* **Progress** is a new message whose header stamp moved on from the message before it (a stamp that differs: a
  robot clock that jumps back after a restart counts, a driver that repeats one stamp does not; a message without
  a stamp — zero — counts as progress). The receiving thread notes each message (:meth:`SilenceWatch.note`); the
  checking thread first takes what DDS has queued but not yet delivered (``Transport.poll``), then checks.
* **Silence** is counted only over the checks' punctual intervals: from the receipt of the last progress, and
  between two checks, at most ``max_step_s`` (a few control periods) counts. A check that comes late — the process was starved — adds no more than a punctual
  one, so a robot is never blamed for time in which BenchBot could not have heard it; its messages, queued
  meanwhile, are read at the next checks and show progress.

A true silence (no progress over ``limit_s`` of punctual checks) is reported by :meth:`SilenceWatch.fault_line`:
one line naming the topic, the last header stamp received and the setting that sets the limit.

Thread-safety: :meth:`note` runs on the transport's threads, everything else on the checking thread.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any


def header_stamp_s(msg: Any) -> float | None:
    """The header stamp of ``msg`` in seconds (the robot's clock: ROS time, wall or simulated), the newest of a
    ``tf2_msgs/TFMessage``'s transforms; ``None`` when the message has no header stamp or it cannot be read."""
    try:
        header = getattr(msg, "header", None)
        if header is not None:
            return float(header.stamp.sec) + float(header.stamp.nanosec) * 1e-9
        transforms = getattr(msg, "transforms", None)
        if transforms is not None:
            stamps = [float(t.header.stamp.sec) + float(t.header.stamp.nanosec) * 1e-9 for t in list(transforms)]
            return max(stamps) if stamps else None
    except Exception:  # noqa: BLE001 - a malformed message has no stamp to judge by
        return None
    return None


class SilenceWatch:
    """The silence watchdog of one topic (module doc).

    Args:
        what: the observation's name in messages (``odometry``, ``laser``, ``tf``).
        topic: the ROS 2 topic (``/odom``).
        limit_s: silence (s) past which :meth:`silent` is true: ``sensor_timeout_s``.
        max_step_s: the most one interval between two checks adds to the silence (s): a few control periods.
        setting: where ``limit_s`` comes from, for the fault line (``ros2.sensor_timeout_s of robot 'x'``).

    Attributes:
        received: messages noted so far. last_stamp_s: the header stamp of the newest (s; None: none had one).
        silence_s: the silence counted at the last check (s). fresh: whether progress was seen since
        :meth:`restart`.
    """

    def __init__(self, what: str, topic: str, limit_s: float, max_step_s: float, setting: str) -> None:
        self.what, self.topic, self.setting = what, topic, setting
        self.limit_s, self.max_step_s = float(limit_s), float(max_step_s)
        self._lock = threading.Lock()
        self.received = 0
        self._moved = 0  # messages whose stamp moved on from the one before (or had none)
        self._moved_at = -math.inf  # when the newest of them was noted (monotonic s)
        self.last_stamp_s: float | None = None
        self._seen_moved = 0
        self._last_check: float | None = None
        self.silence_s = 0.0
        self.fresh = False

    def note(self, stamp_s: float | None) -> None:
        """A message arrived with header stamp ``stamp_s`` (s; None or 0: it has none). Transport thread."""
        with self._lock:
            self.received += 1
            if not stamp_s or stamp_s != self.last_stamp_s:
                self._moved += 1
                self._moved_at = time.monotonic()
            if stamp_s:
                self.last_stamp_s = stamp_s

    def restart(self, now: float) -> None:
        """Start judging afresh at ``now`` (monotonic s), e.g. when a motion starts: silence 0, and only messages
        noted from now on are progress (:attr:`fresh` turns true at the first)."""
        with self._lock:
            self._seen_moved = self._moved
        self._last_check = now
        self.silence_s = 0.0
        self.fresh = False

    def check(self, now: float) -> float:
        """Judge at ``now`` (monotonic s): progress since the last check restarts the silence from the newest such
        message's receipt (at most ``max_step_s`` ago), else the interval since the last check (at most
        ``max_step_s``) is added. Returns the silence (s)."""
        with self._lock:
            moved, moved_at = self._moved, self._moved_at
        step = 0.0 if self._last_check is None else min(max(now - self._last_check, 0.0), self.max_step_s)
        self._last_check = now
        if moved > self._seen_moved:
            self._seen_moved = moved
            self.silence_s = min(max(now - moved_at, 0.0), self.max_step_s)
            self.fresh = True
        else:
            self.silence_s += step
        return self.silence_s

    @property
    def silent(self) -> bool:
        """Whether the silence counted at the last check is past ``limit_s``."""
        return self.silence_s > self.limit_s

    def fault_line(self, during: str = "during a motion") -> str:
        """One line for a true silence: topic, silence, the last header stamp and the setting of the limit."""
        if self.received == 0:
            last = "no message received yet"
        elif self.last_stamp_s is None:
            last = f"the last of {self.received} messages had no header stamp"
        else:
            last = f"no new message since the one stamped {_stamp_text(self.last_stamp_s)}"
        return (f"ROS 2 robot fault: {self.what} ({self.topic}) silent for {self.silence_s:.2f} s {during} ({last}; "
                f"limit {self.limit_s:.2f} s: {self.setting}); the robot was stopped")


def _stamp_text(stamp_s: float) -> str:
    """``1732456789.123 s`` (and its UTC time when it looks like a wall-clock stamp, after the year 2001)."""
    text = f"{stamp_s:.3f} s"
    if math.isfinite(stamp_s) and stamp_s > 1e9:
        import datetime

        when = datetime.datetime.fromtimestamp(stamp_s, datetime.timezone.utc)
        text += f" = {when.strftime('%H:%M:%S.%f')[:-3]} UTC"
    return text
