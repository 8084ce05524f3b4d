"""The observation kinds (benchbot.core.observations): the core's seven, each declared once, match
docs/observations.md and the recorder's wire format; a plugin's kinds join through ``benchbot_observations`` and a
bad one is left out with a one-line problem while the others load; structure problems are one line each. No
simulator here: tests/test_sensor_plugin.py runs a plugin's sensor through a real episode."""

from __future__ import annotations

import math
import re
import types
from pathlib import Path

import numpy as np
import pytest

from benchbot.core import observations
from benchbot.core.hookspecs import hookimpl
from benchbot.core.observations import (
    BUILT_IN, RESERVED_TOPICS, Channel, GymEntry, ObservationKind, RecordContext, problems,
)
from benchbot.core.registry import Registry
from benchbot.core.ros_messages import MSGDEFS, MessageType, definition, header

ROOT = Path(__file__).resolve().parents[1]


def _kind(name: str, topic: str = "/thing", **fields) -> ObservationKind:
    """A small recorded kind: a (2,) float64 vector on a channel and a message type of its own."""
    vector = MessageType("benchbot_test/msg/Vector2", definition("float64 x\nfloat64 y\n", []),
                         "RIHS01_" + "0" * 64)
    defaults = dict(
        check=lambda v, obs: [], channels=(Channel(name, topic, vector.datatype),), message_types=(vector,),
        to_messages=lambda v, ctx: {name: {"x": float(v[0]), "y": float(v[1])}},
        from_messages=lambda message, meta: np.array([message(name).x, message(name).y]))
    return ObservationKind(name, "(2,) float64 m", **{**defaults, **fields})


def _synthetic() -> dict:
    """One observation of every built-in kind, in docs/observations.md's structures (8 × 6 images), with the
    conventions a recording changes on the wire: depth 0.0 (no hit), a range at range_max (no return)."""
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.5, 4.0, (6, 8)).astype(np.float32)
    depth[0, :3] = 0.0
    K = np.array([[4.0, 0.0, 3.5], [0.0, 4.0, 2.5], [0.0, 0.0, 1.0]])
    info = {"frame_id": "camera", "height": 6, "width": 8, "matrix_intrinsics": K,
            "matrix_projection": np.hstack([K, np.zeros((3, 1))])}
    angles = -math.pi + 2 * math.pi / 16 * np.arange(16)
    ranges = rng.uniform(0.2, 5.0, 16)
    ranges[3] = 20.0
    pose = {"parent_frame": "map", "translation_xyz": np.array([1.0, 2.0, 0.2]),
            "rotation_rpy": np.array([0.0, 0.0, 0.5]), "rotation_xyzw": np.array([0.0, 0.0, 0.247404, 0.968912])}
    return {
        "image_rgb": rng.integers(0, 256, (6, 8, 3), dtype=np.uint8),
        "image_depth": depth,
        "image_rgb_info": dict(info),
        "image_depth_info": {**info, "frame_id": "depth_optical"},  # another frame: kept in the metadata
        "laser": {"scans": np.stack([ranges, angles], axis=1), "range_min": 0.1, "range_max": 20.0},
        "poses": {"robot": pose, "camera": dict(pose)},
        "image_segment": {"class_segment_img": rng.integers(0, 5, (6, 8), dtype=np.uint8),
                          "instance_segment_img": rng.integers(0, 5000, (6, 8)).astype(np.int32),
                          "class_ids": {"chair": 1, "table": 2}},
    }


def test_the_core_declares_the_seven_observations_of_the_docs_once_each():
    doc = (ROOT / "docs" / "observations.md").read_text()
    table = doc.split("| key | structure |", 1)[1].split("\n\n", 1)[0]
    documented = [n for row in table.splitlines()[2:] for n in re.findall(r"`(\w+)`", row.split("|")[1])]
    assert list(BUILT_IN) == ["image_rgb", "image_depth", "image_rgb_info", "image_depth_info", "laser", "poses",
                              "image_segment"]
    assert set(documented) == set(BUILT_IN) | {"scene_number"}  # scene_number: the episode's, no kind
    assert [k.name for k in BUILT_IN.values() if not k.sensor] == ["poses"]
    channels = [(c.key, c.topic, c.datatype) for k in BUILT_IN.values() for c in k.channels]
    assert channels == [  # the recordings' topics and types, as they have always been
        ("image_rgb", "/camera/color/image_raw", "sensor_msgs/msg/Image"),
        ("image_depth", "/camera/depth/image_raw", "sensor_msgs/msg/Image"),
        ("image_rgb_info", "/camera/color/camera_info", "sensor_msgs/msg/CameraInfo"),
        ("image_depth_info", "/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo"),
        ("laser", "/scan", "sensor_msgs/msg/LaserScan"),
        ("segment_class", "/camera/segment/class", "sensor_msgs/msg/Image"),
        ("segment_instance", "/camera/segment/instance", "sensor_msgs/msg/Image"),
    ]
    assert {k: e.key for k, kind in BUILT_IN.items() if (e := kind.gym)} == \
        {"image_rgb": "image_rgb", "image_depth": "image_depth", "laser": "laser", "poses": "pose"}
    where = doc.split("| kind | recorded on", 1)[1].split("\n\n", 1)[0].splitlines()[2:]
    rows = {re.findall(r"`(\w+)`", row.split("|")[1])[0]: row.split("|")[2:5] for row in where}
    assert list(rows) == list(BUILT_IN)  # the doc's second table says where each kind goes
    for name, (recorded, gym, views) in rows.items():
        kind = BUILT_IN[name]
        assert all(f"`{c.topic}`" in recorded for c in kind.channels), name
        assert (f"`{kind.gym.key}`" in gym) if kind.gym else gym.strip() == "none", name
        assert all(f"`{v.name}`" in views for v in kind.views) and (kind.views or views.strip() == "none"), name


def test_the_recorders_own_topics_are_reserved():
    from benchbot.plugins.recorder import TF_STATIC, TOPICS

    assert {topic for topic, _ in TOPICS.values()} | {TF_STATIC[0]} == RESERVED_TOPICS


def test_every_built_in_kind_goes_to_ros_2_messages_and_back():
    """to_messages → CDR bytes (mcap_ros2's encoder, the recorder's) → decoded → from_messages gives the observation
    back: exactly, but for the laser's float32 ranges; 0.0 depth and range_max ranges go through NaN and +Inf."""
    from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

    obs = _synthetic()
    frames = {"map": "map", "robot": "robot", "camera": "camera", "lidar": "lidar"}
    metadata: dict = {"step": 0, "time_ns": 5, "scene_number": 0, "names": sorted(obs)}
    context = RecordContext(1_700_000_000_123_456_789, frames, metadata)
    decoded = {}
    for name, kind in BUILT_IN.items():
        if not kind.channels:
            continue
        messages = kind.to_messages(obs[name], context)
        assert set(messages) == {c.key for c in kind.channels}
        for channel in kind.channels:
            encode = serialize_dynamic(channel.datatype, MSGDEFS[channel.datatype])[channel.datatype]
            decode = generate_dynamic(channel.datatype, MSGDEFS[channel.datatype])[channel.datatype]
            decoded[channel.key] = decode(encode(messages[channel.key]))
    wire_depth = np.frombuffer(bytes(decoded["image_depth"].data), np.float32).reshape(6, 8)
    assert np.isnan(wire_depth[0, :3]).all() and math.isinf(decoded["laser"].ranges[3])  # REP 118, REP 117
    assert decoded["image_rgb"].header.frame_id == "camera" and decoded["laser"].header.frame_id == "lidar"
    assert decoded["image_rgb"].header.stamp.nanosec == 123_456_789
    assert metadata["info_frame_ids"] == {"image_depth_info": "depth_optical"}
    assert metadata["class_ids"] == {"chair": 1, "table": 2}
    for name, kind in BUILT_IN.items():
        if not kind.channels:
            continue
        back = kind.from_messages(lambda key: decoded[key], metadata)
        if name == "laser":
            np.testing.assert_allclose(back["scans"], obs[name]["scans"], rtol=1e-6, atol=1e-6)
            assert back["scans"].dtype == np.float64 and back["range_max"] == 20.0
        else:
            assert not problems({name: back}, [name]) and _same(back, obs[name]), name


def _same(a, b) -> bool:
    if isinstance(a, dict):
        return set(a) == set(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray):
        return a.dtype == np.asarray(b).dtype and np.array_equal(a, b)
    return a == b


def test_structure_problems_are_one_line_each_and_a_raising_check_is_one_too():
    obs = _synthetic()
    assert problems(obs, list(obs)) == []
    bad = dict(obs, image_rgb=obs["image_rgb"][..., 0], image_depth=-obs["image_depth"],
               image_depth_info={**obs["image_depth_info"], "height": 5},
               laser={"scans": obs["laser"]["scans"].astype(np.float32), "range_min": 0.1, "range_max": 20.0})
    del bad["poses"]["camera"]["rotation_xyzw"]
    assert problems(bad, [*obs, "imu"]) == [
        "imu: missing",
        "image_rgb: expected (H, W, 3) uint8, got (6, 8) uint8",
        "image_depth: values must be finite and >= 0 (0 where nothing is hit)",
        "image_depth_info: height/width 5x8 differ from the image (6, 8)",
        "laser.scans: expected (N, 2) float64 [range m, angle rad], got (16, 2) float32",
        "poses['camera']: expected keys parent_frame, translation_xyz, rotation_rpy, rotation_xyzw",
    ]
    broken = _kind("thing", check=lambda v, o: 1 / 0)
    assert problems({"thing": 1}, ["thing"], {"thing": broken}) == \
        ["thing: its check raised ZeroDivisionError('division by zero')"]


def test_a_malformed_declaration_is_refused_in_one_line():
    with pytest.raises(ValueError, match="recorded channels need both to_messages and from_messages"):
        ObservationKind("x", "s", lambda v, o: [], channels=(Channel("x", "/x", "std_msgs/msg/Bool"),))
    with pytest.raises(ValueError, match="channel .*a topic /a/b"):
        _kind("x", topic="no_slash")
    with pytest.raises(ValueError, match="name 'a b'"):
        ObservationKind("a b", "s", lambda v, o: [])
    with pytest.raises(ValueError, match="gym must be a GymEntry"):
        _kind("x", gym=("x", None, None))


def test_a_plugins_kinds_join_and_clashing_ones_are_left_out_with_a_problem():
    """Left out, each with one line: a built-in's name, a taken topic, the recorder's topic, a type without a
    definition, an episode-built kind, a result that is no kind; a hook that raises offers nothing. What is left
    joins after the built-ins, and ``benchbot plugins`` shows what each plugin registers."""
    good = _kind("thing", gym=GymEntry("thing", lambda spaces, v: None, np.asarray))
    plain = ObservationKind("bumper", "bool: pressed", lambda v, o: [] if isinstance(v, bool) else ["bumper: bool"])
    untyped = ObservationKind("untyped", "s", lambda v, o: [], channels=(Channel("u", "/u", "std_msgs/msg/Bool"),),
                              to_messages=lambda v, c: {}, from_messages=lambda m, d: None)

    class Sensors:
        @hookimpl
        def benchbot_observations(self):
            return [good, plain, _kind("image_rgb", topic="/x"), _kind("other", topic="/thing"),
                    _kind("tf_thing", topic="/tf"), untyped, ObservationKind("p", "s", lambda v, o: [], sensor=False),
                    "laser"]

    broken = types.ModuleType("broken_sensors")

    def benchbot_observations():
        raise RuntimeError("no IMU driver")

    broken.benchbot_observations = hookimpl(benchbot_observations)
    reg = Registry(extra_plugins={"sensors": Sensors(), "broken": broken})
    assert list(reg.observations) == [*BUILT_IN, "thing", "bumper"] and reg.observations["thing"] is good
    info = {p.name: p for p in reg.plugins}
    assert info["sensors"].registers == {"observations": ["thing", "bumper"]}
    assert info["sensors"].problems == [
        "plugin sensors: observation 'image_rgb' left out: the name is taken by a built-in observation",
        "plugin sensors: observation 'other' left out: topic /thing belongs to observation 'thing'",
        "plugin sensors: observation 'tf_thing' left out: topic /tf belongs to the recorder",
        "plugin sensors: observation 'untyped' left out: /u's type std_msgs/msg/Bool has no definition: give it in "
        "message_types",
        "plugin sensors: observation 'p' left out: only the core declares observations that the episode builds "
        "(sensor=False)",
        "plugin sensors: benchbot_observations() returned a str, not a benchbot.core.observations.ObservationKind",
    ]
    assert info["broken"].problems == ["plugin broken: benchbot_observations() raised RuntimeError('no IMU driver')"]
    assert reg.problems[("observations", "broken")] == info["broken"].problems[0]
    assert "carter" in reg.names("robots") and "sim_taichi" in reg.backend_factories  # the rest still loads
    assert list(Registry().observations) == list(BUILT_IN)  # the first-party plugins add none


def test_message_types_add_a_kinds_own_definition_to_the_standard_ones():
    kind = _kind("thing")
    types_ = observations.message_types({**BUILT_IN, "thing": kind})
    assert set(types_) == set(MSGDEFS) | {"benchbot_test/msg/Vector2"}
    assert types_["benchbot_test/msg/Vector2"].definition == "float64 x\nfloat64 y\n"
    assert header(1_500_000_000, "robot") == {"stamp": {"sec": 1, "nanosec": 500_000_000}, "frame_id": "robot"}


def test_the_plugin_guides_bumper_is_a_kind_that_joins_and_goes_to_its_message_and_back():
    """The example of docs/plugin-guide.md, "Adding a sensor", run as it is written: its kind joins the registry,
    checks, records as a std_msgs/msg/Bool (its own definition and type hash) and reads back, and has a Gym entry."""
    import gymnasium
    from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

    guide = (ROOT / "docs" / "plugin-guide.md").read_text().split("## 3. Adding a sensor", 1)[1]
    code = guide.split("```python\n", 1)[1].split("```", 1)[0]
    example = types.ModuleType("bumper_plugin")
    exec(compile(code, "plugin-guide.md", "exec"), example.__dict__)
    reg = Registry(extra_plugins={"bumper": example})
    kind = reg.observations["bumper"]
    assert kind is example.BUMPER and next(p for p in reg.plugins if p.name == "bumper").problems == []
    assert problems({"bumper": True}, ["bumper"], reg.observations) == []
    assert problems({"bumper": 1}, ["bumper"], reg.observations) == ["bumper: expected a bool, got int"]
    (channel,) = kind.channels
    text = observations.message_types(reg.observations)[channel.datatype].definition
    wire = serialize_dynamic(channel.datatype, text)[channel.datatype](kind.to_messages(True, None)["bumper"])
    decoded = generate_dynamic(channel.datatype, text)[channel.datatype](wire)
    assert kind.from_messages(lambda key: decoded, {}) is True
    space = kind.gym.space(gymnasium.spaces, True)
    assert space.contains(kind.gym.value(True)) and space.contains(kind.gym.value(False))
