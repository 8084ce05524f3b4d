"""How soon the ROS 2 backend stops a robot whose laser falls silent mid-motion (Cyclone DDS on loopback).

A fake ROS 2 robot (``benchbot_robot_ros2.testing.FakeRobot``: odometry, laser and TF at its own rate, records every
``/cmd_vel`` it hears) drives under ``Ros2RobotBackend.move_to``; after ``--drive-s`` its laser stops publishing.
Each trial measures the seconds from the silence to the first zero Twist the robot hears. The design bound is
``sensor_timeout_s`` (``--timeout``) plus one control period (1 / ``rate_hz``) plus DDS delivery; this script prints
the median and worst of ``--trials`` trials and that bound, so the figure lives here and not in a timed unit test
(``plugins/robot_ros2/tests/test_safety.py`` checks only that the stop comes and lasts).

    python benchmarks/ros2_safety.py [--trials 10] [--timeout 0.3] [--domain-id 173] [--json]
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import platform
import statistics
import threading
import time

import smoke  # this folder is on sys.path when a script here runs


def one_trial(transport, timeout_s: float, drive_s: float) -> float:
    """Seconds from the laser's silence to the first zero Twist heard by the fake robot.

    Raises:
        RuntimeError: no zero Twist came within 10 s.
    """
    import numpy as np

    from benchbot.core.errors import BackendError
    from benchbot_robot_ros2.backend import Ros2RobotBackend
    from benchbot_robot_ros2.testing import FAKE_SPEC, FakeRobot

    spec = copy.deepcopy(FAKE_SPEC)
    spec["ros2"]["sensor_timeout_s"] = timeout_s
    env = {"name": "fake", "variant": 1, "type": "real", "map_path": "-", "start_pose": [1, 0, 0, 0, 0, 0, 0]}
    with FakeRobot(transport) as robot:
        backend = Ros2RobotBackend(spec, {"transport": transport})
        backend.load_scene(env)

        def drive() -> None:
            try:
                backend.move_to(np.array([5.0, 0.0, 0.0]))
            except BackendError:
                pass  # the fault this trial provokes

        thread = threading.Thread(target=drive)
        thread.start()
        time.sleep(drive_s)
        t_silence = time.monotonic()
        robot.silence.add("scan")
        thread.join(10)
        backend.close()
        zeros = [c for c in robot.cmds if c[0] > t_silence and c[1] == 0.0 and c[2] == 0.0]
        if not zeros:
            raise RuntimeError("no zero Twist within 10 s of the laser's silence")
        return zeros[0][0] - t_silence


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--timeout", type=float, default=0.3, help="sensor_timeout_s of the robot (s)")
    ap.add_argument("--drive-s", type=float, default=0.6, help="seconds of driving before the silence")
    ap.add_argument("--domain-id", type=int, default=173)
    ap.add_argument("--json", action="store_true")
    a = smoke.parse_args(ap, argv, trials=1, drive_s=0.3)

    from benchbot_robot_ros2.backend import DEFAULTS
    from benchbot_robot_ros2.testing import FAKE_SPEC
    from benchbot_robot_ros2.transport import LOOPBACK_URI, CycloneTransport

    os.environ.setdefault("CYCLONEDDS_URI", LOOPBACK_URI)
    transport = CycloneTransport(a.domain_id, "loopback")
    try:
        latencies = [one_trial(transport, a.timeout, a.drive_s) for _ in range(a.trials)]
    finally:
        transport.close()
    rate_hz = float(FAKE_SPEC["ros2"].get("rate_hz", DEFAULTS["rate_hz"]))
    out = {
        "machine": f"{platform.node()} ({os.cpu_count()} cores)",
        "trials": a.trials,
        "sensor_timeout_s": a.timeout,
        "design_bound_s": round(a.timeout + 1.0 / rate_hz, 3),
        "stop_latency_median_s": round(statistics.median(latencies), 3),
        "stop_latency_max_s": round(max(latencies), 3),
    }
    if a.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:24s} {v}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
