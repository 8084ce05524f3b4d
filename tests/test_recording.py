"""Recording an episode as MCAP (ROS 2 messages) and replaying it as a robot backend, on the real simulator."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchbot.api import ActionResult, Agent
from benchbot.api.benchbot import BenchBot
from benchbot.core.evaluation import evaluate
from benchbot.server import ServerThread, build_app
from benchbot.core.session import resolve_run, start_service
from benchbot.plugins.recorder import attach_recorder, detach_recorder
from benchbot.plugins.replay import Recording, RecordingError, start_replay_service

TASK = "semantic_slam:passive:ground_truth"
ENV = "miniroom:4"
SMALL = {"width": 64, "height": 48}


class Collect(Agent):
    """Follows the trajectory, keeps every observation, saves an empty map."""

    def __init__(self) -> None:
        self.observations: list[dict] = []

    def is_done(self, action_result):
        return action_result != ActionResult.SUCCESS

    def pick_action(self, observations, action_list):
        self.observations.append(observations)
        return "move_next", {}

    def save_result(self, filename, empty_results, results_format_fns):
        self.results = empty_results


def _drive(bot: BenchBot, tmp_path, name: str) -> tuple[list[dict], str]:
    agent = Collect()
    observations, result = bot.reset()
    while not agent.is_done(result):
        action, kwargs = agent.pick_action(observations, bot.actions)
        observations, result = bot.step(action, **kwargs)
    agent.observations.append(observations)
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(bot.empty_results()))
    return agent.observations, str(path)


def _assert_same(a, b, where=""):
    if isinstance(a, dict):
        assert set(a) == set(b), where
        for k in a:
            _assert_same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape and a.dtype == b.dtype, where
        if a.dtype.kind == "f":
            np.testing.assert_allclose(a.astype(np.float32), b.astype(np.float32), rtol=1e-6, atol=1e-6, err_msg=where)
        else:
            np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, float):
        assert np.float32(a) == pytest.approx(np.float32(b), rel=1e-6, abs=1e-6), where
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _assert_same(x, y, f"{where}[{i}]")
    else:
        assert a == b, where


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Record a passive miniroom:4 episode (33 poses, 64x48) through an in-process client."""
    from benchbot.core.registry import get_registry

    reg = get_registry()
    tmp = tmp_path_factory.mktemp("rec")
    run = resolve_run(reg, TASK, "carter", ENV)
    service = start_service(reg, run, seed=0, options=SMALL)
    try:
        recorder = attach_recorder(reg, service, run, tmp / "episode.mcap", seed=0, options=SMALL)
        bot = BenchBot(backend=service)
        observations, results = _drive(bot, tmp, "recorded")
        path = detach_recorder(reg, service, recorder)
    finally:
        service.close()
    return reg, tmp, path, observations, results


def test_recording_has_ros2_messages_and_metadata(recorded):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    _, _, path, observations, _ = recorded
    assert len(observations) == 34  # the start + 33 trajectory poses
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        schemas = {s.name for s in summary.schemas.values()}
        topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        counts = {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}
        decoded = {ch.topic: msg for _, ch, _, msg in reader.iter_decoded_messages()}
    assert {"sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo", "sensor_msgs/msg/LaserScan",
            "tf2_msgs/msg/TFMessage", "geometry_msgs/msg/Twist"} <= schemas
    assert topics["/camera/color/image_raw"] == "sensor_msgs/msg/Image"
    assert counts["/camera/color/image_raw"] == 34 and counts["/tf"] == 34 and counts["/cmd_vel"] == 33
    assert decoded["/camera/depth/image_raw"].encoding == "32FC1"
    assert decoded["/camera/color/image_raw"].encoding == "rgb8"
    assert (decoded["/camera/color/image_raw"].height, decoded["/camera/color/image_raw"].width) == (48, 64)
    assert {t.child_frame_id for t in decoded["/tf"].transforms} == {"robot"}
    assert {(t.header.frame_id, t.child_frame_id) for t in decoded["/tf_static"].transforms} == \
        {("robot", "camera"), ("robot", "lidar")}
    assert counts["/tf_static"] == 1  # the sensors are fixed on the robot
    rec = Recording(path)
    assert rec.run["task"]["name"] == TASK and len(rec.steps) == 33
    times = [s["time_ns"] for s in rec.steps]
    assert times == sorted(times) and times[0] > rec.start_ns > 0


def test_replay_gives_identical_observations_and_the_same_omq(recorded):
    reg, tmp, path, recorded_obs, recorded_results = recorded
    service, spec = start_replay_service(path, reg)
    try:
        server = ServerThread(build_app(service)).start()  # the same HTTP machinery as a simulator
        try:
            bot = BenchBot(supervisor_address=server.address)
            replayed_obs, replayed_results = _drive(bot, tmp, "replayed")
            bot.close()
        finally:
            server.stop()
    finally:
        service.close()
    assert spec.task["name"] == TASK
    assert len(replayed_obs) == len(recorded_obs)
    for i, (a, b) in enumerate(zip(recorded_obs, replayed_obs)):
        _assert_same(a, b, f"step {i}")
    scores = [evaluate([p], "omq", reg, required_envs=[ENV]).to_json() for p in (recorded_results, replayed_results)]
    assert scores[0] == scores[1]


def test_replay_rejects_other_files(tmp_path):
    bad = tmp_path / "x.mcap"
    bad.write_bytes(b"not mcap")
    with pytest.raises(RecordingError):
        Recording(bad)
    with pytest.raises(RecordingError):
        Recording(tmp_path / "missing.mcap")


@pytest.mark.parametrize("metadata, named", [
    ({"environments": [{"name": "miniroom"}]}, "benchbot.run environments[0] lacks variant"),
    ({"environments": {"name": "miniroom", "variant": 1}}, "benchbot.run needs task, robot and environments"),
    ({"steps": [{"time_ns": 1}]}, "benchbot.steps[0] lacks pose, collided, duration_s"),
    ({"frames": [{"step": 0, "time_ns": 1, "names": []}, "x"]}, "benchbot.frames[1] lacks step, time_ns, names"),
])
def test_replay_names_a_damaged_metadata_record_in_one_line(tmp_path, metadata, named):
    from mcap.writer import Writer

    records = {"environments": [{"name": "miniroom", "variant": 1}], "steps": [], "frames": [], **metadata}
    path = tmp_path / "damaged.mcap"
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="test")
        run = {"task": {}, "robot": {}, "environments": records["environments"]}
        for name, value in (("run", run), ("steps", records["steps"]), ("frames", records["frames"])):
            writer.add_metadata(f"benchbot.{name}", {"json": json.dumps(value)})
        writer.finish()
    with pytest.raises(RecordingError) as err:
        Recording(path)
    assert named in err.value.message and "\n" not in err.value.message


def test_benchbot_replay_serves_the_recording_and_stops_on_sigterm(recorded):
    """``benchbot replay FILE`` as a user runs it: the backend comes up on a free port, answers as the supervisor with
    the recorded task, and SIGTERM ends it as Ctrl-C does (exit 130)."""
    import os
    import re
    import signal
    import subprocess
    import sys

    import httpx

    from benchbot.server import SUPERVISOR_GREETING

    path = recorded[2]
    proc = subprocess.Popen([sys.executable, "-m", "benchbot.cli", "replay", str(path), "--port", "0"],
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            env=dict(os.environ, COLUMNS="200"))
    line = ""
    try:
        for line in proc.stderr:  # closes (and ends the loop) if the command exits before it is ready
            if "backend ready" in line:
                break
        address = re.search(r"http://127\.0\.0\.1:\d+", line)
        assert address, f"no 'backend ready' line; last line: {line!r}"
        assert httpx.get(address[0] + "/", timeout=10).json() == SUPERVISOR_GREETING
        assert httpx.get(address[0] + "/config/task/name", timeout=10).json() == TASK
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 130
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
