"""The original protocol (docs/protocol.md) served to the original client's request sequence
(tests/legacy_client.py), and the in-process client against the HTTP one."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import jsonpickle
import numpy as np
import pytest
import requests

from benchbot.api import ActionResult, Agent, BenchBot, InProcessBenchBot
from benchbot.core.evaluation import evaluate
sys.path.insert(0, str(Path(__file__).parent))
from legacy_client import ActionResult as LegacyResult  # noqa: E402
from legacy_client import LegacyBenchBot  # noqa: E402

PASSIVE = "semantic_slam:passive:ground_truth"
ACTIVE = "semantic_slam:active:ground_truth"


class HelloPassive(Agent):
    """The hello_passive pattern of the original examples: move_next until done, save one detected object."""

    def __init__(self):
        self.steps = 0
        self.shapes = set()

    def is_done(self, action_result):
        return action_result != LegacyResult.SUCCESS

    def pick_action(self, observations, action_list):
        self.shapes.add((observations["image_rgb"].shape, observations["image_rgb"].dtype.str,
                         observations["image_depth"].shape, observations["laser"]["scans"].shape[1]))
        assert observations["poses"]["camera"]["translation_xyz"].shape == (3,)
        self.steps += 1
        return "move_next", {}

    def save_result(self, filename, empty_results, results_format_fns):
        obj = results_format_fns["create_object"]()
        obj["centroid"], obj["extent"] = [1.0, 1.0, 0.5], [0.2, 0.2, 0.2]
        empty_results["results"]["objects"].append(obj)
        with open(filename, "w") as f:
            json.dump(empty_results, f)


@pytest.mark.slow
def test_original_client_runs_a_passive_episode_and_its_results_score(served, registry, tmp_path):
    _, server = served(PASSIVE, "miniroom:4")
    target = tmp_path / "result.json"
    agent = HelloPassive()
    bot = LegacyBenchBot(agent, supervisor_address=server.address, result_location=str(target), poll_s=0.1)
    bot.run()
    assert agent.steps == 33
    assert agent.shapes == {((48, 64, 3), "|u1", (48, 64), 2)}
    evaluation = evaluate([target], "omq", registry)
    assert len(evaluation.per_result) == 1 and evaluation.per_result[0][1]
    # a second original client is served a fresh episode (start's is_running handshake resets it)
    second = LegacyBenchBot(supervisor_address=server.address, result_location=str(target), poll_s=0.1)
    assert second.actions == ["move_next"]
    obs, result = second.step("move_next")
    assert result is LegacyResult.SUCCESS and obs["scene_number"] == 0
    # a native client names itself (X-BenchBot-Client): the episode is still the original clients', so it is refused
    with pytest.raises(ValueError, match="the episode belongs to another client"):
        BenchBot(supervisor_address=server.address)  # its start resets the episode: refused
    # until the original clients' episode is released (original clients of one host are one anonymous client)
    assert requests.post(server.address + "robot/release").json() == {"release_success": True}
    native = BenchBot(supervisor_address=server.address)
    assert native.step("move_next")[1] is ActionResult.SUCCESS
    native.close()
    # close() released it: an original client may start again at once
    third = LegacyBenchBot(supervisor_address=server.address, result_location=str(target), poll_s=0.1)
    assert third.step("move_next")[1] is LegacyResult.SUCCESS


def test_original_client_active_pattern_and_refusals(served, tmp_path):
    _, server = served(ACTIVE, "miniroom:1")
    bot = LegacyBenchBot(supervisor_address=server.address, result_location=str(tmp_path / "r.json"), poll_s=0.1)
    assert sorted(bot.actions) == ["move_angle", "move_distance"]
    obs, result = bot.step("move_angle", angle=90)
    assert result is LegacyResult.SUCCESS and obs["poses"]["initial_pose"]["translation_xyz"].shape == (3,)
    obs, result = bot.step("move_distance", distance=0.3)
    assert result is LegacyResult.SUCCESS
    with pytest.raises(ValueError, match="WRONG_ACTUATION_MODE"):
        bot.step("move_next")
    assert bot.next_scene() is False


def test_original_wire_format(served):
    service, server = served(PASSIVE, "miniroom:1")
    base = server.address
    # GET with a JSON body, as the original client sends every query
    assert requests.get(base + "robot/is_collided", json={}).json() == {"is_collided": False}
    assert requests.get(base + "/", json={}).json() == "Hello, I am the BenchBot supervisor"  # '//' merged
    assert requests.get(base + "results_functions//", json={}).json() == ["create", "create_object", "validate"]
    robot = requests.get(base + "config/robot", json={}).json()
    assert robot["connections"]["image_rgb"]["callback_api"] == "api_callbacks.convert_to_rgb"
    raw = requests.get(base + "connections/image_rgb", json={})
    assert raw.status_code == 200 and raw.text.lstrip().startswith("{")
    rgb = jsonpickle.decode(raw.content)
    assert rgb["encoding"] == "rgb8" and rgb["data"].shape == (48, 64, 3) and rgb["data"].dtype == np.uint8
    laser = jsonpickle.decode(requests.get(base + "connections/laser", json={}).content)
    assert laser["scans"].dtype == np.float64 and laser["scans"].shape[1] == 2
    # the same instant as the native protocol
    requests.post(base + "robot/release")  # the anonymous original client lets a named one use the episode
    native = BenchBot(supervisor_address=base, auto_start=False)
    obs, _ = native.step(None)
    assert np.array_equal(obs["image_rgb"], rgb["data"])
    native.close()  # and gives it back
    # errors: unknown connection 404, refused action 409, bad body 400; GT never served
    assert requests.get(base + "connections/nothing", json={}).status_code == 404
    assert requests.get(base + "connections/move_angle", json={"angle": 3}).status_code == 409
    assert requests.get(base + "connections/move_next", data=b"{bad").status_code == 400
    assert requests.get(base + "connections/image_segment", json={}).status_code == 404  # not observed by the task
    moved = requests.get(base + "connections/move_next", json={})
    assert moved.status_code == 200 and jsonpickle.decode(moved.content) is None
    assert requests.get(base + "robot/state", json={}).json()["step"] == 1
    config_text = requests.get(base + "config/", json={}).text
    assert "ground_truth\": {" not in config_text and "\"objects\"" not in config_text


def test_pose_arrays_are_one_type_in_process_natively_and_over_the_original_routes(served):
    """Every pose's ``translation_xyz``, ``rotation_rpy`` and ``rotation_xyzw`` is a float64 ndarray, as the original
    API documented, whichever way the observation travels (``rotation_rpy`` was a tuple in process, a list over the
    native protocol)."""
    service, server = served(PASSIVE, "miniroom:1")

    def check(poses):
        assert set(poses) == {"camera", "lidar", "robot", "initial_pose"}
        for pose in poses.values():
            for key, shape in (("translation_xyz", (3,)), ("rotation_rpy", (3,)), ("rotation_xyzw", (4,))):
                assert isinstance(pose[key], np.ndarray) and pose[key].dtype == np.float64, (key, type(pose[key]))
                assert pose[key].shape == shape

    in_process = InProcessBenchBot(service)
    check(in_process.step(None)[0]["poses"])
    in_process.close()
    native = BenchBot(supervisor_address=server.address, auto_start=False)
    check(native.step(None)[0]["poses"])
    native.close()
    check(jsonpickle.decode(requests.get(server.address + "connections/poses", json={}).content))


def _normalise(value):
    if isinstance(value, dict):
        return {k: _normalise(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_normalise(v) for v in value]
    if isinstance(value, np.ndarray):
        return ("ndarray", value.dtype.str, value.shape, value.tobytes())
    return value


def test_in_process_and_http_give_identical_results(make_service):
    from benchbot.server import ServerThread, build_app

    runs = []
    for mode in ("inprocess", "http"):
        service = make_service(ACTIVE, "miniroom:1", seed=7)
        server = None
        if mode == "http":
            server = ServerThread(build_app(service)).start()
            bot = BenchBot(supervisor_address=server.address)
        else:
            bot = InProcessBenchBot(service)
        trace = [_normalise(bot.reset())]
        for action, kwargs in [("move_angle", {"angle": 90}), ("move_distance", {"distance": 0.4}),
                               ("move_angle", {"angle": -30}), ("move_distance", {"distance": 0.2})]:
            obs, result = bot.step(action, **kwargs)
            trace.append((_normalise(obs), result))
        with pytest.raises(ValueError, match="not allowed"):
            bot.step("move_next")
        trace.append(_normalise(bot.empty_results()))
        trace.append(bot.results_functions()["create_object"]())
        runs.append(trace)
        bot.close()
        if server:
            server.stop()
    assert runs[0] == runs[1]
