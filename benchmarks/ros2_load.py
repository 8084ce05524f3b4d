"""Does a ROS 2 robot's episode survive a machine under heavy CPU load? (Cyclone DDS on loopback.)

A stand-in robot (``benchbot_robot_ros2.testing.FakeRobot``: odometry, laser and TF at 50 Hz, stamped with its wall
clock; it stops when no /cmd_vel came for 0.5 s, as robot bases do) runs in a process of its own at a higher
priority (``--stand-in-nice``, -10 where allowed: a real robot has CPUs of its own), so it keeps publishing.
``--hogs`` busy-loop processes (each ends itself after ``--seconds``, so the load is bounded even if this script is
killed) load every core while ``Ros2RobotBackend`` in this process puts the robot at its start pose (``reset:
drive``, what ``benchbot run`` does first) and then drives back and forth (1 m, and a 90° turn) until the time is
up. ``--pause-s S`` also stops this process (SIGSTOP, then SIGCONT) for S seconds every ``--pause-every-s``: a
process the scheduler did not run at all, as a machine at load 40-68 once did to BenchBot for 1.4-2.2 s. It
prints the motions made, the faults and their lines, the load average and the longest gap between two watchdog
checks (how late the starved process got round to one).

    python benchmarks/ros2_load.py [--hogs 40] [--seconds 60] [--pause-s 1.5] [--timeout 0.5] [--json]

``--timeout`` is the robot's ``sensor_timeout_s`` (turtlebot4's 0.5 s). On the 2-core development machine,
``--hogs 40 --seconds 40 --pause-s 1.5 --pause-every-s 3`` before the watchdog judged by header stamps faulted at start-up and in 32 of
32 motions (``odometry (/odom) silent for 1.53 s during a motion (limit 0.50 s)``); after it, none.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import multiprocessing as mp
import os
import platform
import sys
import time

import smoke  # this folder is on sys.path when a script here runs


def hog(seconds: float, nice: int) -> None:
    """Spin one CPU for ``seconds`` (then exit), at ``nice`` added to the inherited niceness (negative: only where
    this user may raise priority)."""
    try:
        os.nice(nice)
    except OSError:
        pass
    end = time.monotonic() + seconds
    x = 0
    while time.monotonic() < end:
        x += 1


def pauser(pid: int, pause_s: float, every_s: float, seconds: float) -> None:
    """Stop process ``pid`` (SIGSTOP) for ``pause_s`` every ``every_s`` during ``seconds``: a process the scheduler
    did not run at all for that long, as on an overloaded machine seen at load 40-68."""
    import signal

    end = time.monotonic() + seconds
    while time.monotonic() < end:
        time.sleep(every_s)
        os.kill(pid, signal.SIGSTOP)
        time.sleep(pause_s)
        os.kill(pid, signal.SIGCONT)


def stand_in(domain_id: int, seconds: float, ready, nice: int) -> None:
    """The stand-in robot for ``seconds``, at ``nice`` (when this user may set it)."""
    try:
        os.nice(nice)
    except OSError:
        pass
    from benchbot_robot_ros2.testing import FakeRobot
    from benchbot_robot_ros2.transport import CycloneTransport

    transport = CycloneTransport(domain_id, "loopback", node_name="benchbot_stand_in")
    with FakeRobot(transport, cmd_timeout_s=0.5):
        ready.set()
        time.sleep(seconds)
    transport.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hogs", type=int, default=40, help="busy-loop processes (the load average they make)")
    ap.add_argument("--seconds", type=float, default=60.0, help="how long the load (and the driving) lasts")
    ap.add_argument("--timeout", type=float, default=0.5, help="sensor_timeout_s of the robot (s)")
    ap.add_argument("--stand-in-nice", type=int, default=-10,
                    help="niceness of the stand-in robot's process (0: the same priority as the load)")
    ap.add_argument("--hog-nice", type=int, default=0,
                    help="niceness of the hogs relative to this process (negative: they outrank it)")
    ap.add_argument("--pause-s", type=float, default=0.0,
                    help="also stop this process (SIGSTOP) for this long every --pause-every-s seconds")
    ap.add_argument("--pause-every-s", type=float, default=3.0)
    ap.add_argument("--domain-id", type=int, default=171)
    ap.add_argument("--json", action="store_true")
    a = smoke.parse_args(ap, argv, hogs=4, seconds=5.0)

    from benchbot_robot_ros2.transport import LOOPBACK_URI

    os.environ.setdefault("CYCLONEDDS_URI", LOOPBACK_URI)
    import numpy as np

    from benchbot.core.errors import BackendError
    from benchbot_robot_ros2.backend import Ros2RobotBackend
    from benchbot_robot_ros2.testing import FAKE_SPEC

    ctx = mp.get_context("spawn")
    ready = ctx.Event()
    robot = ctx.Process(target=stand_in, args=(a.domain_id, a.seconds + 30, ready, a.stand_in_nice), daemon=True)
    robot.start()
    if not ready.wait(60):
        raise SystemExit("the stand-in robot did not start within 60 s")
    spec = copy.deepcopy(FAKE_SPEC)
    spec["ros2"].update(sensor_timeout_s=a.timeout, startup_timeout_s=60, transport="cyclonedds")
    env = {"name": "fake", "variant": 1, "type": "real", "map_path": "-", "start_pose": [1, 0, 0, 0, 0.5, 0, 0]}

    gaps: list[float] = []
    original_check = Ros2RobotBackend._check_fresh
    last = [None]

    def timed_check(self, *args, **kwargs):
        now = time.monotonic()
        if last[0] is not None and self._moving:
            gaps.append(now - last[0])
        last[0] = now
        return original_check(self, *args, **kwargs)

    Ros2RobotBackend._check_fresh = timed_check
    hogs = [ctx.Process(target=hog, args=(a.seconds, a.hog_nice), daemon=True) for _ in range(a.hogs)]
    if a.pause_s > 0:
        hogs.append(ctx.Process(target=pauser, args=(os.getpid(), a.pause_s, a.pause_every_s, a.seconds),
                                daemon=True))
    for p in hogs:
        p.start()
    time.sleep(min(2.0, a.seconds / 4))  # let the load build up
    faults: list[str] = []
    motions = 0
    startup_s, durations = 0.0, []
    end = time.monotonic() + a.seconds - min(2.0, a.seconds / 4)
    b = None
    try:
        b = Ros2RobotBackend(spec, {"ros2_domain_id": a.domain_id})
        t0 = time.monotonic()
        try:
            b.load_scene(env)  # drives to the start pose (reset: drive)
        except BackendError as exc:
            faults.append(f"start-up: {exc.message}")
        startup_s = time.monotonic() - t0
        goals = [np.array([1.5, 0.0, 0.0]), np.array([1.5, 0.0, math.pi / 2]), np.array([0.5, 0.0, 0.0])]
        i = 0
        while time.monotonic() < end:
            last[0] = None
            t0 = time.monotonic()
            try:
                b.move_to(goals[i % len(goals)])
            except BackendError as exc:
                faults.append(exc.message)
            durations.append(time.monotonic() - t0)
            motions += 1
            i += 1
    finally:
        load = os.getloadavg()[0]
        for p in hogs:
            p.terminate()
        if b is not None:
            b.close()
        robot.terminate()
        Ros2RobotBackend._check_fresh = original_check
    out = {
        "machine": f"{platform.node()} ({os.cpu_count()} cores)",
        "hogs": a.hogs,
        "load_average_1min": round(load, 1),
        "sensor_timeout_s": a.timeout,
        "stand_in_nice": a.stand_in_nice,
        "hog_nice": a.hog_nice,
        "pause_s": a.pause_s,
        "startup_s": round(startup_s, 2),
        "motions": motions,
        "motion_s_max": round(max(durations), 2) if durations else None,
        "faults": len(faults),
        "fault_lines": faults[:5],
        "longest_check_gap_s": round(max(gaps), 3) if gaps else None,
        "checks_late_past_timeout": sum(g > a.timeout for g in gaps),
    }
    if a.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:26s} {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
