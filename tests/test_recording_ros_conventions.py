"""A recording follows ROS 2's conventions, checked with independent readers (rosbags' MCAP reader and CDR decoder
with ROS 2 Jazzy's definitions, the mcap reader for channel metadata): real-epoch time, rosbag2's QoS and type-hash
channel metadata, static frames on /tf_static, one name per frame, REP 117 scans, REP 118 depth. The robot is carter
with a 1.5 m laser and 20 % of its depth pixels dropped, so "no return" and "no hit" happen in a closed room; the
replay still gives the API's conventions (range_max, 0.0) back exactly."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import time

import numpy as np
import pytest

from benchbot.api.benchbot import BenchBot
from benchbot.core.ros_messages import TYPE_HASHES, laser_message
from benchbot.core.session import resolve_run, start_service
from benchbot.plugins.recorder import attach_recorder, detach_recorder, tf_frames
from benchbot.plugins.replay import start_replay_service

rosbags = pytest.importorskip("rosbags")
from rosbags.rosbag2 import Reader  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
TASK = "semantic_slam:passive:ground_truth"
ENV = "miniroom:4"
SMALL = {"width": 64, "height": 48}
RANGE_MAX = 1.5
STEPS = 4


def _drive(bot: BenchBot, steps: int) -> list[dict]:
    observations, _ = bot.reset()
    seen = [observations]
    for _ in range(steps):
        observations, result = bot.step("move_next")
        seen.append(observations)
    return seen


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    from benchbot.core.registry import get_registry

    reg = get_registry()
    run = resolve_run(reg, TASK, "carter", ENV)
    robot = copy.deepcopy(run.robot)
    robot.setdefault("sensors", {}).setdefault("laser", {})["range_max"] = RANGE_MAX
    robot["sensors"].setdefault("noise", {})["depth_dropout"] = 0.2
    run = dataclasses.replace(run, robot=robot)
    path = tmp_path_factory.mktemp("rec") / "episode.mcap"
    t0 = time.time_ns()
    service = start_service(reg, run, seed=0, options=SMALL)
    try:
        recorder = attach_recorder(reg, service, run, path, seed=0, options=SMALL)
        observations = _drive(BenchBot(backend=service), STEPS)
        detach_recorder(reg, service, recorder)
    finally:
        service.close()
    return reg, path, observations, t0


def _read(path):
    """``{topic: [(log_time, rosbags message)]}`` and the connections, through rosbags alone."""
    out: dict = {}
    with Reader(path) as reader:
        connections = {c.topic: c for c in reader.connections}
        for conn, timestamp, raw in reader.messages():
            out.setdefault(conn.topic, []).append((timestamp, TYPESTORE.deserialize_cdr(raw, conn.msgtype)))
        start = reader.start_time
    return out, connections, start


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def test_time_is_a_real_epoch_and_stamps_are_log_times(recorded):
    _, path, _, t0 = recorded
    messages, _, start = _read(path)
    assert abs(start - t0) < 60e9  # the recording's start, not 1970
    for topic, entries in messages.items():
        for log_time, msg in entries:
            if hasattr(msg, "header"):
                assert _stamp(msg) == log_time, topic
            for tf in getattr(msg, "transforms", []):
                assert _stamp(tf) == log_time, topic


def test_channels_carry_rosbag2_qos_and_type_hashes(recorded):
    from mcap.reader import make_reader

    _, path, _, _ = recorded
    _, connections, _ = _read(path)
    for topic, conn in connections.items():
        (qos,) = conn.ext.offered_qos_profiles
        assert (qos.history.name, qos.reliability.name) == ("KEEP_LAST", "RELIABLE"), topic
        if topic == "/tf_static":
            assert (qos.durability.name, qos.depth) == ("TRANSIENT_LOCAL", 1)
        else:
            assert (qos.durability.name, qos.depth) == ("VOLATILE", 10), topic
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    for channel in summary.channels.values():
        datatype = summary.schemas[channel.schema_id].name
        assert channel.metadata["topic_type_hash"] == TYPESTORE.hash_rihs01(datatype) == TYPE_HASHES[datatype]


def test_one_name_per_frame_and_static_frames_on_tf_static(recorded):
    reg, path, _, _ = recorded
    messages, _, _ = _read(path)
    names = tf_frames(reg.get("robots", "carter"))
    assert names == {"map": "map", "robot": "robot", "camera": "camera", "lidar": "lidar"}
    for topic in ("/camera/color/image_raw", "/camera/depth/image_raw", "/camera/color/camera_info",
                  "/camera/depth/camera_info"):
        assert {m.header.frame_id for _, m in messages[topic]} == {"camera"}, topic
    assert {m.header.frame_id for _, m in messages["/scan"]} == {"lidar"}
    assert {(t.header.frame_id, t.child_frame_id) for _, m in messages["/tf"] for t in m.transforms} == \
        {("map", "robot")}
    (static,) = messages["/tf_static"]
    assert {(t.header.frame_id, t.child_frame_id) for t in static[1].transforms} == \
        {("robot", "camera"), ("robot", "lidar")}


def test_scans_follow_rep117_and_depth_rep118(recorded):
    _, path, _, _ = recorded
    messages, _, _ = _read(path)
    for _, scan in messages["/scan"]:
        ranges = np.asarray(scan.ranges)
        assert np.float32(scan.angle_min) == np.float32(-math.pi) and scan.angle_max < math.pi
        assert scan.range_max == np.float32(RANGE_MAX)
        assert np.isposinf(ranges).any() and np.all(ranges[np.isfinite(ranges)] < RANGE_MAX)
    for _, depth in messages["/camera/depth/image_raw"]:
        d = np.frombuffer(bytes(depth.data), dtype="<f4")
        assert np.isnan(d).any() and np.all(d[~np.isnan(d)] > 0)


def test_replay_gives_the_api_conventions_back(recorded):
    reg, path, recorded_obs, _ = recorded
    service, _ = start_replay_service(path, reg)
    try:
        replayed = _drive(BenchBot(backend=service), STEPS)
    finally:
        service.close()
    for a, b in zip(recorded_obs, replayed, strict=True):
        assert np.array_equal(a["image_depth"], b["image_depth"]) and (b["image_depth"] == 0).any()
        np.testing.assert_array_equal(a["laser"]["scans"][:, 0].astype(np.float32), b["laser"]["scans"][:, 0])
        assert (b["laser"]["scans"][:, 0] == RANGE_MAX).any()
        np.testing.assert_allclose(a["laser"]["scans"][:, 1], b["laser"]["scans"][:, 1], atol=1e-6)
        assert json.dumps(a["image_rgb_info"]["frame_id"]) == json.dumps(b["image_rgb_info"]["frame_id"])


def test_a_scan_angle_of_plus_pi_is_recorded_as_minus_pi():
    """A backend that hands out the first beam at float32(-π) wrapped (just under +π) still records
    angle_min = -π and angle_max < π (the scan used to read angle_min = +π, angle_max = 9.407)."""
    n = 360
    angles = -math.pi + 2 * math.pi / n * np.arange(n)
    angles[0] = math.pi - 8.7e-8
    msg = laser_message({"scans": np.stack([np.ones(n), angles], axis=1), "range_min": 0.1, "range_max": 20.0},
                        "lidar", 0)
    assert msg["angle_min"] == -math.pi
    assert msg["angle_max"] == pytest.approx(math.pi - 2 * math.pi / n)
