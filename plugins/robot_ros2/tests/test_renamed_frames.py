"""A ROS 2 robot with renamed frames and topics, end to end: turtlebot4's definition (``oakd_…`` camera frame and
topics, ``rplidar_link``), made to run in the simulator's scenes, served by ``serve-sim --ros-robot`` from a
simulated robot whose laser reaches 2 m (so miniroom:4 has open space beyond it: REP 117's +Inf on the wire), run
by ``benchbot batch --record`` with a solution of its own, and the recording read back with an independent reader.
Simulated time (/clock) starts when the scene is ready, at the wall clock.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml

from benchbot.core.registry import get_registry
from benchbot_robot_ros2.transport import CycloneTransport

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
TURTLEBOT_CAMERA = "oakd_rgb_camera_optical_frame"

#: A solution that turns on the spot and prints what the API gave it of the laser (no return: range_max).
TURN = '''
import json, os
import numpy as np
from benchbot_api import ActionResult, Agent, BenchBot

class Turn(Agent):
    def __init__(self):
        self.done = 0
    def is_done(self, action_result):
        return action_result != ActionResult.SUCCESS or self.done >= 2
    def pick_action(self, observations, action_list):
        laser = observations["laser"]
        ranges = laser["scans"][:, 0]
        print("laser", json.dumps({"range_max": laser["range_max"], "at_max": int((ranges >= laser["range_max"]).sum()),
                                   "finite": bool(np.isfinite(ranges).all()), "beams": len(ranges),
                                   "camera": observations["image_rgb_info"]["frame_id"]}), flush=True)
        self.done += 1
        return "move_angle", {"angle": 45}
    def save_result(self, filename, empty_results, results_format_fns):
        json.dump(empty_results, open(filename, "w"))

BenchBot(agent=Turn()).run()
'''


def _pack(folder: Path) -> Path:
    """A content pack of two robots: ``carter_short`` (the simulated carter with a 2 m laser) and
    ``turtlebot4_sim`` (turtlebot4's definition, for the simulator's scenes: loopback, reset by topic)."""
    reg = get_registry()
    carter = yaml.safe_load(reg.entry("robots", "carter").path.read_text())
    carter["name"] = "carter_short"
    carter["sensors"]["laser"]["range_max"] = 2.0
    turtlebot = yaml.safe_load(reg.entry("robots", "turtlebot4").path.read_text())
    turtlebot.update(name="turtlebot4_sim", environment_types=["world", "sim_taichi"], speed_factor=1.0)
    turtlebot["ros2"].update(network="loopback", reset="topic", transport="cyclonedds")
    (folder / "robots").mkdir(parents=True)
    for spec in (carter, turtlebot):
        (folder / "robots" / f"{spec['name']}.yaml").write_text(yaml.safe_dump(spec))
    return folder


@pytest.mark.slow
def test_turtlebot4_frames_and_topics_end_to_end_with_a_recording(tmp_path, domain_id):
    from benchbot.packs.content_packs import install_pack
    from benchbot.core.registry import Registry

    dom = domain_id + 13
    env = dict(os.environ, BENCHBOT_DATA_DIR=str(tmp_path / "data"), ROS_DOMAIN_ID=str(dom),
               BENCHBOT_ROS2_TIME_SCALE="4", COLUMNS="200")
    os.environ["BENCHBOT_DATA_DIR"], saved = str(tmp_path / "data"), os.environ["BENCHBOT_DATA_DIR"]
    try:
        install_pack(_pack(tmp_path / "pack"), registry=Registry())
    finally:
        os.environ["BENCHBOT_DATA_DIR"] = saved
    log = open(tmp_path / "serve-sim.log", "w")
    bridge = subprocess.Popen([*BENCHBOT, "ros2", "serve-sim", "--env", "miniroom:4", "--robot", "carter_short",
                               "--ros-robot", "turtlebot4_sim", "--camera-size", "64x48", "--time-scale", "4",
                               "--transport", "cyclonedds", "--arch", "cpu"], env=env, stdout=log, stderr=subprocess.STDOUT)
    wire = CycloneTransport(dom, "loopback", node_name="benchbot_wire_probe")
    seen: dict[str, object] = {}
    got = threading.Event()

    def keep(key):
        def callback(msg):
            seen.setdefault(key, msg)
            if {"scan", "rgb"} <= set(seen):
                got.set()
        return callback

    first_clock: list[tuple[int, int]] = []  # (simulated ns, wall ns at receipt) of the first /clock

    def on_clock(msg):
        if not first_clock:
            first_clock.append((msg.clock.sec * 1_000_000_000 + msg.clock.nanosec, time.time_ns()))

    wire.subscribe("/clock", "rosgraph_msgs/msg/Clock", on_clock)
    wire.subscribe("/scan", "sensor_msgs/msg/LaserScan", keep("scan"))
    wire.subscribe("/oakd/rgb/preview/image_raw", "sensor_msgs/msg/Image", keep("rgb"))
    try:
        deadline = time.monotonic() + 180
        while not got.wait(0.5) and bridge.poll() is None and time.monotonic() < deadline:
            pass
        assert got.is_set(), (tmp_path / "serve-sim.log").read_text()[-3000:]
        # simulated time starts when the scene is ready, at the wall clock: not seconds behind it
        assert first_clock and abs(first_clock[0][1] - first_clock[0][0]) < 1.0e9, first_clock
        scan, rgb = seen["scan"], seen["rgb"]
        assert scan.header.frame_id == "rplidar_link" and rgb.header.frame_id == TURTLEBOT_CAMERA
        assert scan.range_max == pytest.approx(2.0)
        infinite = [r for r in scan.ranges if math.isinf(r)]
        assert infinite and all(r > 0 for r in infinite)  # REP 117: no return within range_max is +Inf
        assert all(math.isinf(r) or scan.range_min <= r < scan.range_max for r in scan.ranges)

        (tmp_path / "solution").mkdir()
        (tmp_path / "solution" / "turn.py").write_text(TURN)
        proc = subprocess.run([*BENCHBOT, "batch", "--native", "python turn.py", "--envs", "miniroom:4", "--robot",
                               "turtlebot4_sim", "--task", "semantic_slam:active:ground_truth", "--record", "--no-tui",
                               "--json", "--output-dir", str(tmp_path / "runs")], cwd=tmp_path / "solution", env=env,
                              capture_output=True, text=True, timeout=600)
        result = json.loads(proc.stdout)
        episode = result["episodes"][0]
        run_dir = Path(result["run_dir"])
        episode_log = (run_dir / episode["log"]).read_text()
        assert episode["status"] == "ok", (episode, episode_log[-2000:], proc.stderr[-2000:])
        lasers = [json.loads(line.split("laser ", 1)[1]) for line in episode_log.splitlines() if "laser {" in line]
        assert lasers and all(x["range_max"] == 2.0 and x["finite"] and x["at_max"] > 0 for x in lasers)
        assert lasers[0]["camera"] == TURTLEBOT_CAMERA  # camera info's frame, passed through
    finally:
        wire.close()
        bridge.terminate()
        try:
            bridge.wait(20)
        except subprocess.TimeoutExpired:
            bridge.kill()
        log.close()

    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    recordings = sorted(run_dir.rglob("*.mcap"))
    assert len(recordings) == 1, recordings
    frames, static, inf_beams, scan_frames = set(), set(), 0, set()
    with open(recordings[0], "rb") as f:
        decoded = list(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
    for _, channel, _, msg in decoded:
        topic = channel.topic
        if topic == "/camera/color/image_raw":
            frames.add(msg.header.frame_id)
        elif topic == "/tf_static":
            static |= {(t.header.frame_id, t.child_frame_id) for t in msg.transforms}
        elif topic == "/scan":
            scan_frames.add(msg.header.frame_id)
            inf_beams += sum(1 for r in msg.ranges if math.isinf(r))
    assert frames == {TURTLEBOT_CAMERA} and scan_frames == {"rplidar_link"}
    assert static == {("base_link", TURTLEBOT_CAMERA), ("base_link", "rplidar_link")}
    assert inf_beams > 0  # the API's range_max is recorded as REP 117's +Inf again
