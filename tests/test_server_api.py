"""The backend server on 127.0.0.1 driven by the real client API (benchbot.api / benchbot_api)."""

from __future__ import annotations

import json

import httpx
import numpy as np
import pytest

import benchbot_api
from benchbot.api import ActionResult, Agent, BenchBot, InProcessBenchBot

PASSIVE = "semantic_slam:passive:ground_truth"


def test_compatibility_module_exports_the_same_names():
    assert benchbot_api.BenchBot is BenchBot and benchbot_api.ActionResult is ActionResult
    assert benchbot_api.RESULT_LOCATION
    from benchbot_api.agent import Agent as CompatAgent
    assert CompatAgent is Agent


def test_client_steps_through_a_passive_episode(served):
    service, server = served(PASSIVE, "miniroom:4")
    bot = BenchBot(supervisor_address=server.address)
    assert bot.config["task"]["name"] == PASSIVE
    assert bot.actions == ["move_next"]
    assert "image_rgb" in bot.observations
    obs, result = bot.reset()
    assert result is ActionResult.SUCCESS and obs["image_rgb"].shape == (48, 64, 3)
    steps = 0
    while result is ActionResult.SUCCESS:
        obs, result = bot.step("move_next")
        steps += 1
    assert result is ActionResult.FINISHED and steps == 33 and bot.actions == []
    with pytest.raises(ValueError, match="FINISHED"):
        bot.step("move_next")
    assert bot.next_scene() is False
    empty = bot.empty_results()
    assert empty["results"]["objects"] == [] and empty["results"]["class_list"][-1] == "background"
    assert empty["environment_details"][0]["name"] == "miniroom"
    fns = bot.results_functions()
    assert {"create", "create_object", "validate"} <= set(fns)
    assert len(fns["create_object"]()["label_probs"]) == 31
    bot.close()


def test_agent_run_saves_results(served, tmp_path, monkeypatch):
    _, server = served(PASSIVE, "miniroom:4")
    target = tmp_path / "result.json"
    monkeypatch.setattr("benchbot.api.benchbot.RESULT_LOCATION", str(target))

    class Counter(Agent):
        steps = 0

        def is_done(self, result):
            return result is not ActionResult.SUCCESS

        def pick_action(self, observations, actions):
            self.steps += 1
            return "move_next", {}

        def save_result(self, filename, empty_results, fns):
            empty_results["results"]["objects"].append(fns["create_object"]())
            with open(filename, "w") as f:
                json.dump(empty_results, f)

    agent = Counter()
    BenchBot(agent=agent, supervisor_address=server.address).run()
    assert agent.steps == 33
    saved = json.loads(target.read_text())
    assert len(saved["results"]["objects"]) == 1


def test_original_routes_and_errors(served):
    _, server = served(PASSIVE, "miniroom:1")
    with httpx.Client(base_url=server.address, timeout=30) as http:
        assert http.get("/").json() == "Hello, I am the BenchBot supervisor"
        assert http.get("/config/task/actions").json() == ["move_next"]
        assert http.get("/config/task/nothing").status_code == 404
        assert http.get("/robot/selected_environment").json() == {"name": "miniroom", "variant": 1, "number": 0}
        assert http.get("/robot/is_collided").json() == {"is_collided": False}
        assert http.get("/robot/fly").status_code == 404
        assert http.get("/results_functions/").json() == ["create", "create_object", "validate"]
        bad = http.post("/results_functions/create", content=b"{not json")
        assert bad.status_code == 400 and "not valid JSON" in bad.json()["error"]
        assert http.post("/native/step", content=b"\xc1garbage").status_code == 400
        from benchbot.protocol import wire
        assert http.post("/native/step", content=wire.pack({"action": 3})).status_code == 400
        refused = http.post("/native/step", content=wire.pack({"action": "move_angle", "args": {"angle": 5}}))
        assert refused.status_code == 409 and "not an action of this task" in refused.json()["error"]
        ok = wire.unpack(http.post("/native/step", content=wire.pack({"action": "move_next"})).content)
        assert ok["result"] == "SUCCESS" and ok["state"]["step"] == 1
        assert isinstance(ok["observations"]["image_depth"], np.ndarray)


@pytest.mark.slow
def test_client_reports_missing_backend_clearly():
    with pytest.raises(ConnectionError, match="no BenchBot backend answered"):
        BenchBot(supervisor_address="http://127.0.0.1:9/", auto_start=False).start(wait_s=0.5)


def test_in_process_observations_are_read_only_views_like_the_native_ones(make_service):
    service = make_service("semantic_slam:active:ground_truth", "miniroom:1")
    bot = InProcessBenchBot(service)
    obs, _ = bot.step(None)
    assert not obs["image_rgb"].flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        obs["image_depth"][0, 0] = 1.0
    again, _ = bot.step(None)
    assert np.array_equal(again["image_depth"], obs["image_depth"])


def test_the_server_parses_http_with_httptools(served):
    """uvicorn picks httptools (a declared dependency, its C parser) over the pure-Python h11: the native step's
    request and reply legs are ~0.25 ms shorter after a render (benchmarks/api_step_stages.py --angle 10)."""
    _, server = served("semantic_slam:passive:ground_truth", "miniroom:1")
    assert server.server.config.http_protocol_class.__name__ == "HttpToolsProtocol"
    assert httpx.get(server.address, timeout=10).json() == "Hello, I am the BenchBot supervisor"


def test_native_steps_and_json_routes_over_https(make_service, tmp_path):
    """A backend served with a TLS certificate (``benchbot run --tls-cert``): the client trusts its authority through
    ``ca_file`` and both the JSON routes and the native step go over TLS; a client that does not trust it gets a
    ConnectionError."""
    import trustme

    from benchbot.api.benchbot import HttpTransport
    from benchbot.server import ServerThread, build_app

    authority = trustme.CA()
    server_pem, ca_pem = tmp_path / "server.pem", tmp_path / "ca.pem"
    authority.issue_cert("127.0.0.1").private_key_and_cert_chain_pem.write_to_path(str(server_pem))
    authority.cert_pem.write_to_path(str(ca_pem))
    service = make_service("semantic_slam:active:ground_truth", "miniroom:1")
    server = ServerThread(build_app(service), tls_cert=server_pem).start()
    try:
        assert server.address.startswith("https://127.0.0.1:")
        bot = BenchBot(transport=HttpTransport(server.address, ca_file=str(ca_pem)))
        observations, result = bot.step("move_angle", angle=10.0)
        assert result == ActionResult.SUCCESS and observations["image_rgb"].shape == (48, 64, 3)
        assert bot.config["task"]["name"] == "semantic_slam:active:ground_truth"
        bot.close()
        untrusting = HttpTransport(server.address, ca_file=None)
        with pytest.raises(ConnectionError, match="CERTIFICATE_VERIFY_FAILED|certificate verify failed"):
            untrusting.step(None, {}, None)
        untrusting.close()
        with pytest.raises(ValueError, match="must start with http:// or https://"):
            HttpTransport("ftp://127.0.0.1:1/")
    finally:
        server.stop()


def test_an_unusable_ca_file_is_a_one_line_error(tmp_path, monkeypatch):
    from benchbot.api.benchbot import HttpTransport

    (tmp_path / "empty.pem").write_text("no certificate here\n")
    with pytest.raises(ValueError, match=r"ca_file=.*missing\.pem cannot be used as certificate authorities "
                                         r"\(No such file or directory\)"):
        HttpTransport("https://127.0.0.1:1/", ca_file=str(tmp_path / "missing.pem"))
    monkeypatch.setenv("BENCHBOT_CA_FILE", str(tmp_path / "empty.pem"))
    with pytest.raises(ValueError, match=r"BENCHBOT_CA_FILE=.*empty\.pem cannot be used as certificate authorities"):
        HttpTransport("https://127.0.0.1:1/")
    assert HttpTransport("http://127.0.0.1:1/")._tls is None, "plain HTTP never reads it"
