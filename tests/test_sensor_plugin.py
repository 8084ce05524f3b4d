"""A sensor that only a plugin adds: the plugin below (defined here, registered like an installed one) declares an
IMU observation kind (``benchbot_observations``), a robot backend that senses it (the real Taichi simulator, 64×48,
with an IMU on its base), a robot and a task that asks for it. Nothing else changes, and the IMU flows through an
episode's observations, the structure check, the contract check, a recording (its own ROS 2 type, read back by an
independent CDR decoder) and its replay, and the Gym observation space (docs/plugin-guide.md, "Adding a sensor")."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from benchbot.api.benchbot import BenchBot
from benchbot.core.geometry import wrap_angle
from benchbot.core.hookspecs import hookimpl
from benchbot.core.observations import Channel, GymEntry, ObservationKind, RecordContext
from benchbot.core.registry import Registry
from benchbot.core.ros_messages import MessageType, definition, header
from benchbot.core.session import resolve_run, start_service

TASK = "semantic_slam:passive:imu"
ROBOT = "carter_imu"
ENV = "miniroom:4"
SMALL = {"width": 64, "height": 48}
STEPS = 4
GRAVITY = 9.80665

# ------------------------------------------------------------------------------------------ the plugin
IMU_TYPE = MessageType(  # sensor_msgs/msg/Imu of ROS 2 Jazzy
    "sensor_msgs/msg/Imu",
    definition("std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
               "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
               "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n",
               ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Quaternion", "geometry_msgs/Vector3"]),
    "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b")
SHAPES = {"orientation_xyzw": (4,), "angular_velocity": (3,), "linear_acceleration": (3,)}


def imu_check(imu, observations) -> list[str]:
    if not (isinstance(imu, dict) and set(imu) == set(SHAPES)):
        return [f"imu: expected keys {', '.join(SHAPES)}"]
    for key, shape in SHAPES.items():
        value = imu[key]
        if not (isinstance(value, np.ndarray) and value.shape == shape and value.dtype == np.float64):
            return [f"imu.{key}: expected {shape} float64, got {getattr(value, 'shape', type(value).__name__)}"]
    return []


def imu_to_messages(imu: dict, context: RecordContext) -> dict[str, dict]:
    def vector(v):
        return dict(zip("xyz", map(float, v)))

    return {"imu": {"header": header(context.time_ns, context.frames["robot"]),
                    "orientation": dict(zip("xyzw", map(float, imu["orientation_xyzw"]))),
                    "orientation_covariance": [0.0] * 9,
                    "angular_velocity": vector(imu["angular_velocity"]), "angular_velocity_covariance": [0.0] * 9,
                    "linear_acceleration": vector(imu["linear_acceleration"]),
                    "linear_acceleration_covariance": [0.0] * 9}}


def imu_from_messages(message, metadata) -> dict:
    msg = message("imu")
    q, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
    return {"orientation_xyzw": np.array([q.x, q.y, q.z, q.w]), "angular_velocity": np.array([w.x, w.y, w.z]),
            "linear_acceleration": np.array([a.x, a.y, a.z])}


IMU = ObservationKind(
    "imu", "{'orientation_xyzw': (4,) float64 unit quaternion of the robot in map, 'angular_velocity': (3,) float64 "
    "rad/s, 'linear_acceleration': (3,) float64 m/s² (gravity included)}; robot frame", imu_check,
    channels=(Channel("imu", "/imu/data", "sensor_msgs/msg/Imu"),), message_types=(IMU_TYPE,),
    to_messages=imu_to_messages, from_messages=imu_from_messages,
    gym=GymEntry("imu", lambda spaces, v: spaces.Box(-np.inf, np.inf, (6,), np.float64),
                 lambda v: np.concatenate([v["angular_velocity"], v["linear_acceleration"]])))


def create_imu_backend(robot_spec: dict, options: dict):
    """The simulator with an IMU on its base: its yaw rate over the last motion, gravity, its orientation."""
    from benchbot_sim_taichi.backend import TaichiSimBackend

    class ImuSimBackend(TaichiSimBackend):
        yaw_rate = 0.0

        def load_scene(self, environment, *, seed=0):
            super().load_scene(environment, seed=seed)
            self.yaw_rate = 0.0

        def move_to(self, goal):
            before = self.base_pose()[2]
            outcome = super().move_to(goal)
            turned = wrap_angle(self.base_pose()[2] - before)
            self.yaw_rate = turned / outcome.duration_s if outcome.duration_s > 0 else 0.0
            return outcome

        def observe(self, names):
            return self._with_imu(names, super().observe)

        def observe_borrowed(self, names):
            return self._with_imu(names, super().observe_borrowed)

        def _with_imu(self, names, observe):
            out = observe([n for n in names if n != "imu"])
            if "imu" in names:
                yaw = self.base_pose()[2]
                out["imu"] = {"orientation_xyzw": np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]),
                              "angular_velocity": np.array([0.0, 0.0, self.yaw_rate]),
                              "linear_acceleration": np.array([0.0, 0.0, GRAVITY])}
            return {n: out[n] for n in names}

        def batched(self, count):
            """The simulator's batched robots, with the IMU too (its Gym value: no yaw rate, gravity)."""
            from benchbot_sim_taichi.batched import TaichiBatchedRobots

            class ImuBatchedRobots(TaichiBatchedRobots):
                observations = (*TaichiBatchedRobots.observations, "imu")

                def observe(self, names, *, on_device=False):
                    out = super().observe([n for n in names if n != "imu"], on_device=on_device)
                    if "imu" in names:
                        out["imu"] = np.tile([0.0, 0.0, 0.0, 0.0, 0.0, GRAVITY], (self.count, 1))
                    return out

            return ImuBatchedRobots(self, count)

    return ImuSimBackend(robot_spec, options)


class ImuPlugin:
    """The whole plugin: its kind, its backend, its robot (carter with an IMU) and a task observing the IMU."""

    def __init__(self, carter: dict) -> None:
        robot = {k: copy.deepcopy(v) for k, v in carter.items() if k != "_file_path"}
        robot.update(name=ROBOT, type="sim_taichi_imu", environment_types=["world", "sim_taichi"],
                     observations=[*carter["observations"], "imu"])
        robot["connections"]["imu"] = {"connection": "ros_to_api"}
        self.robot = robot

    @hookimpl
    def benchbot_observations(self):
        return [IMU]

    @hookimpl
    def benchbot_robot_backends(self):
        return {"sim_taichi_imu": create_imu_backend}

    @hookimpl
    def benchbot_robots(self):
        return [self.robot]

    @hookimpl
    def benchbot_tasks(self):
        return [{"name": TASK, "type": "semantic_slam", "actions": ["move_next"],
                 "observations": ["image_rgb", "image_depth", "image_depth_info", "laser", "poses", "imu"],
                 "localisation": "ground_truth", "results_format": "object_map", "scene_count": 1}]


# ------------------------------------------------------------------------------------------ the tests
@pytest.fixture(scope="module")
def episode(tmp_path_factory):
    """A recorded passive episode of STEPS steps with the plugin's robot; then the Gym environment on the same
    backend. Returns ``(registry, recording path, observations, gym result)``."""
    from benchbot.core.registry import get_registry
    from benchbot.gym import BenchBotEnv
    from benchbot.plugins.recorder import attach_recorder, detach_recorder

    reg = Registry(extra_plugins={"imu_sensor": ImuPlugin(get_registry().get("robots", "carter"))})
    path = tmp_path_factory.mktemp("imu") / "episode.mcap"
    service = start_service(reg, resolve_run(reg, TASK, ROBOT, ENV), options=SMALL)
    try:
        recorder = attach_recorder(reg, service, resolve_run(reg, TASK, ROBOT, ENV), path, options=SMALL)
        bot = BenchBot(backend=service)
        seen = [bot.reset()[0]]
        for _ in range(STEPS):
            seen.append(bot.step("move_next")[0])
        bot.close()
        detach_recorder(reg, service, recorder)
        env = BenchBotEnv(backend=service, max_steps=2)
        first, _ = env.reset()
        stepped = env.step(0)[0]
        gym = (env.observation_space, first, stepped)
        env.close()
    finally:
        service.close()
    return reg, path, seen, gym


def test_the_plugins_sensor_is_in_the_episodes_observations_and_passes_the_checks(episode):
    from benchbot.plugins.testing import check_observations, check_robot_backend

    reg, _, seen, _ = episode
    assert reg.observations["imu"] is IMU
    assert next(p for p in reg.plugins if p.name == "imu_sensor").registers["observations"] == ["imu"]
    assert all(set(obs) == {*reg.get("tasks", TASK)["observations"], "scene_number"} for obs in seen)
    assert any(obs["imu"]["angular_velocity"][2] != 0.0 for obs in seen[1:])  # the trajectory turns
    for obs in seen:
        check_observations(obs, reg.get("tasks", TASK)["observations"], registry=reg)
        np.testing.assert_allclose(obs["imu"]["linear_acceleration"], [0.0, 0.0, GRAVITY])
    bad = dict(seen[1], imu={**seen[1]["imu"], "angular_velocity": np.zeros(2)})
    with pytest.raises(AssertionError, match=r"imu.angular_velocity: expected \(3,\) float64, got \(2,\)"):
        check_observations(bad, ["imu"], registry=reg)
    robot, environment = reg.get("robots", ROBOT), reg.scenes(ENV)[0]
    obs = check_robot_backend(create_imu_backend, robot, environment, registry=reg)  # the sensor is a sensor
    assert "imu" in obs and "laser" in obs


def test_the_plugins_sensor_is_recorded_on_its_own_topic_and_replayed_exactly(episode):
    from mcap.reader import make_reader
    from rosbags.typesys import Stores, get_typestore

    from benchbot.plugins.replay import start_replay_service

    reg, path, seen, _ = episode
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        channel = next(c for c in summary.channels.values() if c.topic == "/imu/data")
        raw = [m.data for _, c, m in reader.iter_messages(topics=["/imu/data"])]
    typestore = get_typestore(Stores.ROS2_JAZZY)
    assert summary.schemas[channel.schema_id].name == "sensor_msgs/msg/Imu"
    assert channel.metadata["topic_type_hash"] == typestore.hash_rihs01("sensor_msgs/msg/Imu")
    assert len(raw) == STEPS + 1
    first = typestore.deserialize_cdr(raw[0], "sensor_msgs/msg/Imu")  # an independent reader agrees
    assert first.header.frame_id == "robot" and first.linear_acceleration.z == GRAVITY

    service, spec = start_replay_service(path, reg)
    try:
        bot = BenchBot(backend=service)
        replayed = [bot.reset()[0]] + [bot.step("move_next")[0] for _ in range(STEPS)]
        bot.close()
    finally:
        service.close()
    assert spec.robot["name"] == ROBOT
    for a, b in zip(seen, replayed):
        for key in ("orientation_xyzw", "angular_velocity", "linear_acceleration"):
            np.testing.assert_array_equal(a["imu"][key], b["imu"][key])
        np.testing.assert_array_equal(a["image_rgb"], b["image_rgb"])


def test_the_plugins_sensor_has_its_gym_entry(episode):
    _, _, _, (space, first, stepped) = episode
    assert set(space.spaces) == {"image_rgb", "image_depth", "laser", "pose", "imu"}
    assert space["imu"].shape == (6,) and space.contains(first) and space.contains(stepped)
    np.testing.assert_allclose(stepped["imu"][3:], [0.0, 0.0, GRAVITY])


def test_the_plugins_sensor_is_in_the_vector_environment(monkeypatch):
    """The Gym vector environment reads the registry's observation kinds: the plugin's IMU, which its batched robots
    sense, has its entry (the plugin's Gym space, as ``BenchBot-v0``'s) beside the core's kinds."""
    pytest.importorskip("gymnasium")
    import benchbot.core.registry as registry_module
    from benchbot.gym_vector import make_vector_env_class

    reg = Registry(extra_plugins={"imu_sensor": ImuPlugin(registry_module.get_registry().get("robots", "carter"))})
    monkeypatch.setattr(registry_module, "get_registry", lambda: reg)
    vec = make_vector_env_class()(2, task=TASK, env=ENV, robot=ROBOT, options=SMALL, max_steps=3)
    try:
        space = vec.single_observation_space
        assert set(space.spaces) == {"image_rgb", "image_depth", "laser", "pose", "imu"}
        assert space["imu"] == IMU.gym.space(__import__("gymnasium").spaces, None)
        obs, _ = vec.reset()
        assert obs["imu"].shape == (2, 6) and vec.observation_space.contains(obs)
        obs = vec.step(np.zeros(2, dtype=np.int64))[0]
        np.testing.assert_allclose(obs["imu"][:, 3:], [[0.0, 0.0, GRAVITY]] * 2)
    finally:
        vec.close()


class _Message:
    """A ROS message of any type for :class:`_Transport`: fields made on first use."""

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        child = _Message()
        setattr(self, name, child)
        return child


class _Transport:
    """A ROS 2 transport that keeps what is published: ``sent[topic]`` → ``[(ROS type, message)]``."""

    def __init__(self):
        self.sent = {}

    def message(self, ros_type):
        return _Message()

    def publisher(self, topic, ros_type, *, latched=False):
        sent = self.sent.setdefault(topic, [])
        return type("P", (), {"publish": lambda _, msg: sent.append((ros_type, msg))})()

    def subscribe(self, *args, **kwargs):
        return None

    def close(self):
        pass


def test_the_plugins_sensor_is_published_by_the_ros2_sim_bridge(monkeypatch):
    """serve-sim reads the registry's observation kinds: the plugin's IMU, which its robot observes, goes out on the
    kind's own topic and type (its recorder channel), converted by the kind; the camera and laser as before."""
    pytest.importorskip("benchbot_robot_ros2")
    import benchbot.core.registry as registry_module
    import benchbot_robot_ros2.transport as transport_module
    from benchbot_robot_ros2.sim_bridge import SimBridge, published_kinds

    reg = Registry(extra_plugins={"imu_sensor": ImuPlugin(registry_module.get_registry().get("robots", "carter"))})
    ros_robot = copy.deepcopy(reg.get("robots", "carter_ros2"))  # the ROS side reads the IMU too
    ros_robot["observations"].append("imu")
    assert published_kinds(reg.observations, reg.get("robots", "carter"), reg.get("robots", "carter_ros2")) == {}
    ((kind, topics),) = published_kinds(reg.observations, reg.get("robots", ROBOT), ros_robot).values()
    assert kind is IMU and topics == {"imu": "/imu/data"}
    transport = _Transport()
    monkeypatch.setattr(registry_module, "get_registry", lambda: reg)
    monkeypatch.setattr(transport_module, "make_transport", lambda *args, **kwargs: transport)
    bridge = SimBridge(ENV, robot=ROBOT, width=SMALL["width"], height=SMALL["height"], ros_robot=ros_robot)
    try:
        bridge.run(duration_s=0.3)
    finally:
        bridge.close()
    ((ros_type, imu), *_) = transport.sent["/imu/data"]
    assert ros_type == "sensor_msgs/msg/Imu" and imu.header.frame_id == bridge.frames["robot"]
    assert imu.linear_acceleration.z == pytest.approx(GRAVITY) and imu.header.stamp.sec > 0
    assert transport.sent[bridge.topics["rgb"]] and transport.sent[bridge.topics["scan"]]
