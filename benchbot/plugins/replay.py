"""Replaying a recorded episode (an MCAP file of :mod:`benchbot.plugins.recorder`) as a robot backend.

:class:`ReplayBackend` serves the recorded observations instead of simulating: ``load_scene`` goes to the first
recorded frame of that scene, every ``move_to`` advances to the next recorded step (whatever the goal: the
recording decides where the robot goes), ``observe`` decodes the recorded ROS 2 messages back into the reference
structures (docs/observations.md: REP 118's NaN depth back to 0.0, REP 117's +Inf ranges back to ``range_max``)
and ``frame_transforms`` comes from the recorded ``/tf`` and ``/tf_static`` (frame names as
:func:`~benchbot.plugins.recorder.tf_frames`; recordings made before ``/tf_static`` and those names have every
frame on ``/tf`` under its BenchBot name, and replay as well). It plugs into the same
:class:`~benchbot.core.episode.Episode` / :class:`~benchbot.server.BackendService` / ``ServerThread``
machinery as a simulator (:func:`start_replay_service`), so a solution of a *passive* task can be re-run and
re-scored without a simulator. Precision: images, depth, camera matrices are exact; laser ranges are float32
(``sensor_msgs/LaserScan``); poses go through quaternions (about 1e-15).
"""

from __future__ import annotations

import json
import math
from bisect import bisect_right
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from benchbot.core import observations as observation_kinds
from benchbot.core.errors import BackendError, BenchbotError, ExitCode
from benchbot.core.geometry import quaternion_wxyz_to_matrix
from benchbot.core.robot import MotionOutcome, RobotBackend
from benchbot.plugins.recorder import TF_STATIC, TOPICS, tf_frames


class RecordingError(BenchbotError):
    """A recording is missing, unreadable or not a BenchBot episode recording."""

    exit_code = ExitCode.USAGE


def _transform(tf: Any) -> np.ndarray:
    t, q = tf.transform.translation, tf.transform.rotation
    T = np.eye(4)
    T[:3, :3] = quaternion_wxyz_to_matrix(np.array([q.w, q.x, q.y, q.z]))
    T[:3, 3] = [t.x, t.y, t.z]
    return T


class Recording:
    """A recorded episode read into memory.

    Attributes:
        run: the ``benchbot.run`` metadata (``task``, ``robot``, ``environments``, ``results_format``, ``seed``,
            ``options``, ``env_string``). steps: the ``benchbot.steps`` metadata. frames: ``benchbot.frames``.
        start_ns: the time of the start (``benchbot.clock``; 0 in recordings made before it).
        messages: ``{topic: [(log_time_ns, decoded message)]}`` in time order.

    Raises:
        RecordingError: the file is missing, not MCAP, or lacks the BenchBot metadata.
    """

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        if not self.path.is_file():
            raise RecordingError(f"{self.path}: no such recording", "record one with --record")
        try:
            from mcap.reader import make_reader
            from mcap_ros2.decoder import DecoderFactory
        except ImportError:
            raise RecordingError("replaying needs the MCAP reader", "install it: uv pip install 'benchbot[record]'") from None
        try:
            with open(self.path, "rb") as f:
                reader = make_reader(f, decoder_factories=[DecoderFactory()])
                meta = {m.name: m.metadata for m in reader.iter_metadata()}
                self.messages: dict[str, list[tuple[int, Any]]] = {}
                for _schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
                    self.messages.setdefault(channel.topic, []).append((message.log_time, decoded))
        except BenchbotError:
            raise
        except Exception as exc:
            raise RecordingError(f"{self.path}: not a readable MCAP file ({exc})", "was the recording finished?") from None
        try:
            self.run = json.loads(meta["benchbot.run"]["json"])
            self.steps = json.loads(meta["benchbot.steps"]["json"])
            self.frames = json.loads(meta["benchbot.frames"]["json"])
            clock = json.loads(meta["benchbot.clock"]["json"]) if "benchbot.clock" in meta else {}
            self.start_ns = int(clock.get("start_ns", 0)) if isinstance(clock, dict) else 0
        except (KeyError, json.JSONDecodeError, TypeError, ValueError):
            raise RecordingError(f"{self.path}: no BenchBot metadata (benchbot.run/steps/frames)",
                                 "only files written by `--record` can be replayed") from None
        run_ok = isinstance(self.run, dict) and all(k in self.run for k in ("task", "robot", "environments"))
        if not (run_ok and isinstance(self.run["environments"], list) and self.run["environments"]
                and isinstance(self.steps, list)
                and isinstance(self.frames, list)):
            raise RecordingError(f"{self.path}: malformed BenchBot metadata (benchbot.run needs task, robot and "
                                 "environments; benchbot.steps/frames must be lists)",
                                 "only files written by `--record` can be replayed")
        self._check_records()
        # log times per topic, for the bisections of at() / latest() (called for every observation)
        self._times = {topic: [t for t, _ in entries] for topic, entries in self.messages.items()}

    #: The fields every record of the metadata needs (what the replay reads), by where it is.
    RECORD_FIELDS = {"benchbot.run environments": ("name", "variant"),
                     "benchbot.steps": ("time_ns", "pose", "collided", "duration_s"),
                     "benchbot.frames": ("step", "time_ns", "names")}

    def _check_records(self) -> None:
        """Raise :class:`RecordingError` naming the first record of :attr:`RECORD_FIELDS` that is no JSON object
        with its fields, so a damaged file is one line up front instead of a ``KeyError`` mid-replay."""
        records = (self.run["environments"], self.steps, self.frames)
        for (where, fields), items in zip(self.RECORD_FIELDS.items(), records):
            for i, item in enumerate(items):
                missing = [f for f in fields if not isinstance(item, dict) or f not in item]
                if missing:
                    raise RecordingError(f"{self.path}: malformed BenchBot metadata: {where}[{i}] lacks "
                                         f"{', '.join(missing)}", "only files written by `--record` can be replayed")

    def at(self, topic: str, time_ns: int) -> Any:
        """The message of ``topic`` logged at ``time_ns``, or None."""
        entries, times = self.messages.get(topic, []), self._times.get(topic, [])
        i = bisect_right(times, time_ns) - 1
        return entries[i][1] if i >= 0 and times[i] == time_ns else None

    def latest(self, topic: str, time_ns: int) -> Any:
        """The last message of ``topic`` logged at or before ``time_ns``, or None."""
        entries = self.messages.get(topic, [])
        i = bisect_right(self._times.get(topic, []), time_ns) - 1
        return entries[i][1] if i >= 0 else None


class ReplayBackend(RobotBackend):
    """A :class:`RobotBackend` serving a :class:`Recording` (module doc).

    Args:
        recording: the recording.
        robot_spec: the robot spec (the recording's).
        kinds: the observation kinds that decode the recorded messages (``Registry.observations``; default the
            built-in ones, :data:`benchbot.core.observations.BUILT_IN`).
    """

    def __init__(self, recording: Recording, robot_spec: dict, kinds: dict | None = None) -> None:
        self.recording = recording
        self.robot_spec = robot_spec
        self.kinds = observation_kinds.BUILT_IN if kinds is None else kinds
        self.moves = 0  # == the episode's step_count: every action makes exactly one move_to
        self.loaded = False

    def _time(self) -> int:
        if self.moves == 0:
            return self.recording.start_ns
        if self.moves > len(self.recording.steps):
            raise BackendError(
                f"the recording has {len(self.recording.steps)} steps; step {self.moves} was not recorded",
                "a replay can only repeat the recorded trajectory (passive tasks)")
        return int(self.recording.steps[self.moves - 1]["time_ns"])

    def load_scene(self, environment: dict, *, seed: int = 0) -> None:
        """Go to the recorded frame of the current step (the first one at the start).

        Raises:
            BackendError: ``environment`` is not one the recording was made in.
        """
        names = [f"{e['name']}:{e['variant']}" for e in self.recording.run["environments"]]
        if f"{environment['name']}:{environment['variant']}" not in names:
            raise BackendError(f"environment {environment['name']}:{environment['variant']} was not recorded",
                               f"the recording has {', '.join(names)}")
        self.loaded = True

    def _robot_transform(self) -> dict[str, np.ndarray]:
        t = self._time()
        tf = self.recording.latest(TOPICS["tf"][0], t)
        if tf is None:
            raise BackendError("the recording has no /tf before this step", "was it written by --record?")
        static = self.recording.latest(TF_STATIC[0], t)
        by_child = {s.child_frame_id: _transform(s) for s in (static.transforms if static is not None else [])}
        by_child.update({s.child_frame_id: _transform(s) for s in tf.transforms})
        names = tf_frames(self.robot_spec)
        robot_frame = self.robot_spec.get("robot_frame", "robot")

        def edge(name: str, *fallbacks: str) -> np.ndarray | None:
            for child in (names[name], *fallbacks):
                if child in by_child:
                    return by_child[child]
            return None

        T_map_robot = edge("robot", robot_frame)
        if T_map_robot is None:
            raise BackendError(f"the recorded /tf has no '{names['robot']}' frame", "was it written by --record?")
        out = {"robot": T_map_robot}
        for name in ("camera", "lidar"):
            T_robot_sensor = edge(name, name)
            if T_robot_sensor is not None:
                out[name] = T_map_robot @ T_robot_sensor
        if robot_frame not in out:
            out[robot_frame] = T_map_robot.copy()
        return out

    def base_pose(self) -> np.ndarray:
        """``[x, y, yaw]`` of the recorded step (the exact recorded pose)."""
        if self.moves > 0 and self.moves <= len(self.recording.steps):
            return np.asarray(self.recording.steps[self.moves - 1]["pose"], dtype=np.float64)
        T = self._robot_transform()["robot"]
        return np.array([T[0, 3], T[1, 3], math.atan2(T[1, 0], T[0, 0])])

    def move_to(self, goal: np.ndarray) -> MotionOutcome:
        """Advance to the next recorded step (``goal`` is ignored).

        Raises:
            BackendError: the recording has no more steps.
        """
        self.moves += 1
        self._time()
        step = self.recording.steps[self.moves - 1]
        return MotionOutcome(collided=bool(step["collided"]), duration_s=float(step["duration_s"]))

    def frame_transforms(self) -> dict[str, np.ndarray]:
        """``T_map_<frame>`` of ``robot``, ``camera``, ``lidar`` from the recorded ``/tf`` at this step."""
        return self._robot_transform()

    def observe(self, names: Sequence[str]) -> dict[str, Any]:
        """The recorded observations of this step, decoded into the reference structures by their kinds'
        ``from_messages`` (:mod:`benchbot.core.observations`).

        Raises:
            KeyError: a name that was not recorded at this step (or is not a sensor, or of no kind that decodes
                recorded messages).
            BackendError: the frame lists a name whose message is missing from the file.
            RecordingError: a recorded message cannot be read (an image encoding other than the recorder's).
        """
        t = self._time()
        frame = next((f for f in self.recording.frames if f["time_ns"] == t and f["step"] == self.moves), None)
        out: dict[str, Any] = {}
        for name in names:
            kind = self.kinds.get(name)
            if frame is None or name not in frame["names"] or kind is None or not kind.channels:
                raise KeyError(name)
            topics = {ch.key: ch.topic for ch in kind.channels}

            def message(key: str, topics: dict = topics) -> Any:
                msg = self.recording.at(topics[key], t)
                if msg is None:
                    raise BackendError(f"the recording has no {topics[key]} message at step {self.moves}",
                                       "was it written by --record (and finished)?")
                return msg

            try:
                out[name] = kind.from_messages(message, frame)
            except ValueError as exc:
                raise RecordingError(str(exc), "replay recordings written by --record") from None
        return out


def start_replay_service(path: Path | str, registry: Any = None, *, on_step: Any = None):
    """A :class:`~benchbot.server.BackendService` replaying ``path``: the recorded task, robot and
    environments (from its metadata), an :class:`~benchbot.core.episode.Episode` over a :class:`ReplayBackend`,
    with the observer hooks of ``registry`` (default: the process's) and the results-format functions.

    Returns:
        ``(service, run_spec)``.

    Raises:
        RecordingError: the file cannot be replayed. SpecError: its results format is not installed.
    """
    from benchbot.core.registry import get_registry
    from benchbot.core.session import RunSpec, start_service

    recording = Recording(path)
    registry = registry or get_registry()
    run = recording.run
    spec = RunSpec(run["task"], run["robot"], run["environments"], run.get("results_format") or {},
                   run.get("env_string") or ":".join([run["environments"][0]["name"]] + [str(e["variant"]) for e in run["environments"]]))
    service = start_service(registry, spec, seed=int(run.get("seed", 0)), on_step=on_step,
                            factory=lambda robot, options: ReplayBackend(recording, robot, registry.observations))
    return service, spec
