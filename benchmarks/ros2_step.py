"""Step latency through ROS 2 versus direct simulation, in one run.

The Taichi simulator (carter, miniroom, ``--width``×``--height``) is served over ROS 2 (Cyclone DDS on loopback) by
``benchbot_robot_ros2.sim_bridge`` in a subprocess, at ``--time-scale`` (1 = real time, what a real robot does). The
same episode (``semantic_slam:passive:ground_truth``) runs twice in this process: ``direct`` (the sim_taichi backend,
simulated time) and ``ros2`` (Ros2RobotBackend: pose controller at 20 Hz over /cmd_vel, TF, camera topics). Each
round times one ``move_next`` (motion) and one observation of every sensor (``observe``), interleaved; medians.

For ROS 2 the motion is dominated by the robot's real driving time (and the original's 0.65 s settle), not by the
transport; ``observe`` shows the transport's cost (waiting for fresh camera frames at ``--camera-hz``).

    python benchmarks/ros2_step.py [--rounds 5] [--width 160 --height 120] [--time-scale 1] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time

import smoke  # this folder is on sys.path when a script here runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--env", default="miniroom:4")
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--camera-hz", type=float, default=10.0)
    ap.add_argument("--domain-id", type=int, default=171)
    ap.add_argument("--json", action="store_true")
    a = smoke.parse_args(ap, argv, rounds=1, width=32, height=24)

    from benchbot_robot_ros2.transport import LOOPBACK_URI

    os.environ.setdefault("CYCLONEDDS_URI", LOOPBACK_URI)
    os.environ["ROS_DOMAIN_ID"] = str(a.domain_id)
    os.environ["BENCHBOT_ROS2_TIME_SCALE"] = str(a.time_scale)
    bridge = subprocess.Popen([sys.executable, "-m", "benchbot_robot_ros2.sim_bridge", "--env", a.env,
                               "--camera-size", f"{a.width}x{a.height}", "--time-scale", str(a.time_scale),
                               "--camera-hz", str(a.camera_hz), "--transport", "cyclonedds"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        from benchbot.core.episode import Episode
        from benchbot.core.registry import get_registry
        from benchbot_robot_ros2.backend import Ros2RobotBackend
        from benchbot_sim_taichi.backend import create_backend

        import contextlib

        reg = get_registry()
        task, envs = reg.get("tasks", "semantic_slam:passive:ground_truth"), reg.scenes(a.env)
        t0 = time.perf_counter()
        ros = Episode(task, reg.get("robots", "carter_ros2"), envs, Ros2RobotBackend(reg.get("robots", "carter_ros2"), {}))
        ros_start = time.perf_counter() - t0
        with contextlib.redirect_stdout(sys.stderr):  # Taichi's banner: keep --json clean
            sim = Episode(task, reg.get("robots", "carter"), envs,
                          create_backend(reg.get("robots", "carter"), {"width": a.width, "height": a.height,
                                                                       "arch": "cpu"}))
        times = {k: [] for k in ("direct_move_ms", "ros2_move_ms", "direct_observe_ms", "ros2_observe_ms")}
        for _ in range(a.rounds):
            for name, ep in (("direct", sim), ("ros2", ros)):
                t = time.perf_counter()
                ep.act("move_next")
                times[f"{name}_move_ms"].append((time.perf_counter() - t) * 1e3)
                t = time.perf_counter()
                ep.observe()
                times[f"{name}_observe_ms"].append((time.perf_counter() - t) * 1e3)
        ros.backend.close()
        sim.backend.close()
    finally:
        bridge.terminate()
        bridge.wait(10)
    out = {k: round(statistics.median(v), 1) for k, v in times.items()}
    out.update(rounds=a.rounds, width=a.width, height=a.height, env=a.env, time_scale=a.time_scale,
               camera_hz=a.camera_hz, ros2_first_scene_s=round(ros_start, 2), transport="cyclonedds",
               machine=f"{platform.machine()} {os.cpu_count()} cpus", python=platform.python_version())
    if a.json:
        print(json.dumps(out, indent=2))
    else:
        for k, v in out.items():
            print(f"{k:>22}: {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
