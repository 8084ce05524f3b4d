"""The sensor watchdog judges silence by what the robot sent: a robot still publishing while BenchBot's
own process is starved (its reading thread held up, its checks late) never faults; a robot that stops publishing
faults with one line naming the topic, its last header stamp and the setting; over HTTP that fault is a 503 (not a
500) whose one-line message the client shows. Over Cyclone DDS here; the last test over rclpy (marked ``rclpy``:
``.ci/ros2``)."""

from __future__ import annotations

import copy
import json
import os
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request

import numpy as np
import pytest

from benchbot.core.errors import RobotFaultError
from benchbot_robot_ros2.backend import Ros2RobotBackend
from benchbot_robot_ros2.testing import FAKE_SPEC, FakeRobot
from benchbot_robot_ros2.transport import rclpy_available
from benchbot_robot_ros2.watchdog import SilenceWatch, header_stamp_s

ENV = {"name": "fake", "variant": 1, "type": "real", "map_path": "-", "start_pose": [1, 0, 0, 0, 0, 0, 0]}
SETTING = "ros2.sensor_timeout_s of robot 'fake_ros2'"


# ------------------------------------------------------------------------------------------- the watch alone
def test_a_late_check_after_messages_with_moving_stamps_is_no_silence():
    """The process slept 1.5 s (the check is late) while the robot kept publishing: no silence."""
    w = SilenceWatch("odometry", "/odom", limit_s=0.5, max_step_s=0.1, setting=SETTING)
    t0 = time.monotonic()
    w.restart(t0)
    w.note(100.00)
    assert w.check(t0 + 0.05) <= 0.1 and w.fresh
    for i in range(1, 75):  # 1.5 s of messages, read late
        w.note(100.00 + 0.02 * i)
    assert w.check(t0 + 1.55) <= 0.1 and not w.silent


def test_a_late_check_counts_no_more_than_a_punctual_one():
    """Nothing arrived (or nothing has been read yet) by a check 1.5 s late: it adds ``max_step_s``, not 1.5 s;
    only a silence over the limit of punctual checks faults."""
    w = SilenceWatch("odometry", "/odom", limit_s=0.5, max_step_s=0.1, setting=SETTING)
    t0 = time.monotonic()
    w.restart(t0)
    w.note(100.0)
    w.check(t0)
    assert w.check(t0 + 1.5) == pytest.approx(0.1) and not w.silent
    t = t0 + 1.5
    checks = 0
    while not w.silent:  # steps of 0.06 s: no sum lands on the limit, where rounding would decide
        t += 0.06
        w.check(t)
        checks += 1
    assert checks == 7  # 0.1 + 6 x 0.06 = 0.46 s, 0.1 + 7 x 0.06 = 0.52 s > 0.5 s
    line = w.fault_line()
    assert "\n" not in line and "odometry (/odom) silent for 0.52 s during a motion" in line
    assert "stamped 100.000 s" in line and "limit 0.50 s: ros2.sensor_timeout_s of robot 'fake_ros2'" in line


def test_a_repeated_stamp_is_no_progress_and_a_jump_back_is():
    """A driver repeating one message (the same stamp) is silent; a robot clock that jumped back (a restart) is
    not; messages without a stamp count as progress."""
    w = SilenceWatch("laser", "/scan", limit_s=0.3, max_step_s=0.1, setting=SETTING)
    t = time.monotonic()
    w.restart(t)
    w.note(5.0)
    w.check(t)
    for _ in range(10):
        t += 0.05
        w.note(5.0)
        w.check(t)
    assert w.silent and "/scan" in w.fault_line()
    w.note(1.0)  # the clock jumped back
    w.check(t + 0.05)
    assert not w.silent
    w.note(None)
    w.note(0.0)
    assert w.check(t + 0.1) <= 0.1 and w.received == 14


def test_the_fault_line_says_when_nothing_ever_came():
    w = SilenceWatch("tf", "/tf", 0.3, 0.1, SETTING)
    w.restart(0.0)
    for k in range(1, 5):
        w.check(0.1 * k)
    assert w.silent and "no message received yet" in w.fault_line()


def test_header_stamps_of_messages_and_tf(transport):
    from benchbot_robot_ros2 import convert

    odom = transport.message("nav_msgs/msg/Odometry")
    convert.set_stamp(odom.header.stamp, 12.5)
    assert header_stamp_s(odom) == pytest.approx(12.5)
    tf = transport.message("tf2_msgs/msg/TFMessage")
    a = transport.message("geometry_msgs/msg/TransformStamped")
    b = transport.message("geometry_msgs/msg/TransformStamped")
    convert.set_stamp(a.header.stamp, 3.0)
    convert.set_stamp(b.header.stamp, 4.0)
    tf.transforms = [a, b]
    assert header_stamp_s(tf) == pytest.approx(4.0)
    assert header_stamp_s(transport.message("geometry_msgs/msg/Twist")) is None


# ------------------------------------------------------------------------------------------- a starved backend
class _GatedTransport:
    """The transport, with every callback held at a gate: while the gate is shut, the transport's reading thread
    waits inside it and DDS queues what the robot sends (a reading thread that is not scheduled)."""

    def __init__(self, inner) -> None:
        self.inner = inner
        self.gate = threading.Event()
        self.gate.set()

    def subscribe(self, topic, ros_type, callback, **kwargs):
        def gated(msg):
            self.gate.wait(10)
            callback(msg)
        return self.inner.subscribe(topic, ros_type, gated, **kwargs)

    def __getattr__(self, name):
        return getattr(self.inner, name)


def _backend(transport, **ros2):
    spec = copy.deepcopy(FAKE_SPEC)
    spec["ros2"].update(ros2)
    return Ros2RobotBackend(spec, {"transport": transport})


@pytest.mark.slow
def test_a_starved_reading_thread_and_a_late_check_do_not_fault(transport):
    """Mid-motion the reading thread stops taking messages and the control loop's next check runs 1.5 s late (5x
    ``sensor_timeout_s``), judging while the robot's messages are still queued: the motion goes on and ends. Before
    the stamp-based watchdog this was ``odometry (/odom) silent for 1.50 s``."""
    gated = _GatedTransport(transport)
    with FakeRobot(transport, cmd_timeout_s=0.5) as robot:
        b = _backend(gated)
        b.load_scene(ENV)
        original = b._check_fresh
        stall = {"due": None, "done": False}

        def late_check():
            if stall["due"] is not None and time.monotonic() >= stall["due"] and not stall["done"]:
                stall["done"] = True
                gated.gate.clear()  # the reading thread is starved from now on ...
                time.sleep(1.5)  # ... and so is the control loop
                try:
                    return original()  # judged late, with the messages of 1.5 s queued and not yet read
                finally:
                    gated.gate.set()
            return original()

        b._check_fresh = late_check
        stall["due"] = time.monotonic() + 0.4
        outcome = b.move_to(np.array([2.0, 0.0, 0.0]))
        assert stall["done"] and not outcome.collided
        assert abs(robot.pose[0] - 2.0) < 0.05
        b.close()


def fault_when_odometry_stops(backend, robot) -> RobotFaultError:
    """Drive ``backend`` towards x = 5 m, silence the stand-in ``robot``'s odometry 0.5 s into the motion and return
    the :class:`RobotFaultError` the motion raised (the test fails when it raised none, or another error)."""
    errors = []

    def drive():
        try:
            backend.move_to(np.array([5.0, 0.0, 0.0]))
        except Exception as exc:  # noqa: BLE001
            errors.append(exc)

    t = threading.Thread(target=drive)
    t.start()
    time.sleep(0.5)
    robot.silence.add("odom")
    t.join(10)
    assert errors and isinstance(errors[0], RobotFaultError), errors
    return errors[0]


def test_a_robot_that_stops_publishing_faults_with_one_line(transport):
    """The stand-in's odometry stops mid-motion: a zero Twist, then a RobotFaultError of one line naming /odom, the
    last header stamp and the setting."""
    with FakeRobot(transport) as robot:
        b = _backend(transport)
        b.load_scene(ENV)
        fault = fault_when_odometry_stops(b, robot)
        message = fault.message
        assert "\n" not in message and message.startswith("ROS 2 robot fault: odometry (/odom) silent for ")
        assert "no new message since the one stamped " in message and SETTING in message
        assert "ros2.sensor_timeout_s" in fault.hint
        assert robot.cmd == (0.0, 0.0)
        b.close()


def test_a_motion_does_not_start_on_a_silent_topic(transport):
    """TF silent before the motion: no motion command is sent; the fault names /tf."""
    with FakeRobot(transport) as robot:
        b = _backend(transport)
        b.load_scene(ENV)
        robot.silence.add("tf")
        time.sleep(0.3)
        n = len(robot.cmds)
        with pytest.raises(RobotFaultError, match=r"tf \(/tf\) silent for 0\.3\d s during a motion"):
            b.move_to(np.array([1.0, 0.0, 0.0]))
        assert all(c[1] == 0.0 and c[2] == 0.0 for c in robot.cmds[n:])
        b.close()


# ------------------------------------------------------------------------------------------- over HTTP
def _task():
    return {"name": "fault_probe", "actions": ["move_distance", "move_angle"], "observations": ["laser", "poses"],
            "localisation": "ground_truth", "scene_count": 1}


@pytest.mark.slow
def test_a_fault_over_http_is_a_503_the_client_shows_as_one_line(transport, registry_for_http):
    """The original protocol's action route answers a robot fault with 503 and ``{error, hint}`` (the original
    client treats any status >= 300 as a failure of that route); the native client raises ``BackendRefused``
    (a ``ConnectionError``) whose text is one line naming the topic. Never a 500."""
    from benchbot.api.benchbot import BackendRefused, BenchBot
    from benchbot.server import ServerThread, build_app
    from benchbot.core.session import RunSpec, start_service

    with FakeRobot(transport) as robot:
        run = RunSpec(_task(), copy.deepcopy(FAKE_SPEC), [dict(ENV)], {}, "fake:1")
        service = start_service(registry_for_http, run,
                                factory=lambda spec, options: _backend(transport))
        server = ServerThread(build_app(service)).start()
        try:
            request = urllib.request.Request(server.address.rstrip("/") + "/connections/move_distance",
                                             data=json.dumps({"distance": 0.3}).encode(),
                                             headers={"Content-Type": "application/json"}, method="POST")
            with urllib.request.urlopen(request, timeout=60) as reply:
                assert reply.status == 200  # the robot publishes: the motion is made
            robot.silence.add("odom")
            time.sleep(0.6)
            with pytest.raises(urllib.error.HTTPError) as info:
                urllib.request.urlopen(request, timeout=60)
            assert info.value.code == 503
            body = json.loads(info.value.read())
            assert body["error"].startswith("ROS 2 robot fault: odometry (/odom) silent for ")
            assert "\n" not in body["error"] and "ros2.sensor_timeout_s" in body["error"]
            release = urllib.request.Request(server.address.rstrip("/") + "/robot/release", data=b"{}",
                                             headers={"Content-Type": "application/json"}, method="POST")
            urllib.request.urlopen(release, timeout=10).close()  # the next client may take the episode
            client = BenchBot(supervisor_address=server.address, auto_start=False)
            with pytest.raises(BackendRefused) as refused:
                client.transport.step("move_distance", {"distance": 0.3}, None)
            text = str(refused.value)
            assert refused.value.status == 503 and "\n" not in text
            assert text.startswith("BenchBot backend refused /native/step (503): ROS 2 robot fault: odometry (/odom)")
            client.close()
        finally:
            server.stop()
            service.close()


@pytest.fixture(scope="module")
def registry_for_http():
    from benchbot.core.registry import get_registry

    return get_registry()


# ------------------------------------------------------------------------------------------- a stopped process
STARVED_BACKEND = r"""
import copy, json, sys, time
import numpy as np
from benchbot_robot_ros2.backend import Ros2RobotBackend
from benchbot_robot_ros2.testing import FAKE_SPEC
spec = copy.deepcopy(FAKE_SPEC)
spec["ros2"].update(sensor_timeout_s=0.5, transport=sys.argv[2], domain_id=int(sys.argv[1]))
b = Ros2RobotBackend(spec, {})
env = {"name": "fake", "variant": 1, "type": "real", "map_path": "-", "start_pose": [1, 0, 0, 0, 0, 0, 0]}
out = {"faults": [], "motions": 0}
try:
    b.load_scene(env)
    print("ready", flush=True)
    for goal in ([1.5, 0, 0], [1.5, 0, 1.5707963], [0.0, 0, 0]):
        try:
            b.move_to(np.array(goal))
        except Exception as exc:
            out["faults"].append(str(exc))
        out["motions"] += 1
finally:
    b.close()
print(json.dumps(out), flush=True)
"""


def run_starved_backend(domain: int, transport_kind: str, pauses: int = 3, pause_s: float = 1.5) -> dict:
    """Run :data:`STARVED_BACKEND` (three motions against a stand-in publishing on ``domain``) in a subprocess that
    is stopped (SIGSTOP) for ``pause_s`` ``pauses`` times while it drives: the scheduler does not run it at all,
    as on an overloaded machine (load 40-68). Returns its report ``{faults, motions}``."""
    env = dict(os.environ)
    env.pop("ROS_DOMAIN_ID", None)
    proc = subprocess.Popen([sys.executable, "-c", STARVED_BACKEND, str(domain), transport_kind], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert line.strip() == "ready", (line, proc.stderr.read() if proc.poll() is not None else "")
        for _ in range(pauses):
            time.sleep(1.0)
            os.kill(proc.pid, signal.SIGSTOP)
            time.sleep(pause_s)
            os.kill(proc.pid, signal.SIGCONT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGCONT)
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err[-2000:]
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.slow
def test_a_stopped_backend_process_does_not_fault_a_publishing_robot(domain_id):
    """BenchBot's process (Cyclone DDS) is stopped three times for 1.5 s (3x ``sensor_timeout_s``) while it drives
    a stand-in that keeps publishing: all three motions end, none faults."""
    from benchbot_robot_ros2.transport import CycloneTransport

    dom = domain_id + 21
    tr = CycloneTransport(dom, "loopback", node_name="benchbot_stand_in")
    try:
        with FakeRobot(tr, cmd_timeout_s=0.5):
            report = run_starved_backend(dom, "cyclonedds")
    finally:
        tr.close()
    assert report == {"faults": [], "motions": 3}


@pytest.mark.slow
@pytest.mark.rclpy
@pytest.mark.skipif(not rclpy_available(), reason="rclpy is not importable (no ROS 2 Jazzy here)")
def test_over_rclpy_a_stopped_backend_goes_on_and_a_silent_robot_faults(domain_id):
    """The same over the rclpy transport (Fast DDS; TF through its Cyclone DDS participant), stand-in and backend
    alike: the stopped backend process faults none of its three motions; odometry falling silent faults with the
    one line."""
    from benchbot_robot_ros2.transport import RclpyTransport

    dom = domain_id + 22
    tr = RclpyTransport(dom, "loopback", node_name="benchbot_stand_in")
    try:
        with FakeRobot(tr, cmd_timeout_s=0.5) as robot:
            assert run_starved_backend(dom, "rclpy") == {"faults": [], "motions": 3}
            spec = copy.deepcopy(FAKE_SPEC)
            spec["ros2"].update(transport="rclpy", domain_id=dom)
            b = Ros2RobotBackend(spec, {})
            try:
                b.load_scene(ENV)
                message = fault_when_odometry_stops(b, robot).message
                assert message.startswith("ROS 2 robot fault: odometry (/odom) silent for ")
                assert SETTING in message and "\n" not in message
            finally:
                b.close()
    finally:
        tr.close()


@pytest.mark.rclpy
@pytest.mark.skipif(not rclpy_available(), reason="rclpy is not importable (no ROS 2 Jazzy here)")
def test_rclpy_poll_delivers_what_the_spinning_thread_has_not(domain_id):
    """With the rclpy transport's spinning thread stopped (a thread that is not scheduled), messages that arrived
    stay queued in rmw; ``poll`` delivers all of them on the calling thread."""
    from benchbot_robot_ros2 import convert
    from benchbot_robot_ros2.transport import RclpyTransport

    dom = domain_id + 23
    a = RclpyTransport(dom, "loopback", node_name="benchbot_poll_a")
    b = RclpyTransport(dom, "loopback", node_name="benchbot_poll_b")
    try:
        got = []
        b.subscribe("/t/poll", "geometry_msgs/msg/Twist", got.append)
        pub = a.publisher("/t/poll", "geometry_msgs/msg/Twist")
        deadline = time.monotonic() + 20
        while not got and time.monotonic() < deadline:  # discovery
            pub.publish(convert.fill_twist(a.message("geometry_msgs/msg/Twist"), 0.0, 0.0))
            time.sleep(0.05)
        assert got
        b._stop.set()
        b._thread.join(5)
        time.sleep(0.2)
        before = len(got)
        for k in range(5):
            pub.publish(convert.fill_twist(a.message("geometry_msgs/msg/Twist"), 0.1 * (k + 1), 0.0))
            time.sleep(0.01)
        time.sleep(0.3)
        assert len(got) == before  # nobody reads them now
        assert b.poll(["/t/poll"]) == 5
        assert [m.linear.x for m in got[before:]] == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5])
        assert b.errors == 0, b.last_error
    finally:
        a.close()
        b.close()
