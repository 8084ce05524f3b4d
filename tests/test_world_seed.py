"""A world is fixed by its name: an environment's scene depends on the run's seed and its name and variant, never on
its position in ``--envs``; repetitions of one world still get noise of their own (docs/noise.md, *Seeds*)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot.batch.plan import plan_episodes
from benchbot.core.seeding import environment_world_seed, world_seed
from benchbot.core.session import resolve_run, start_service

TASK = "semantic_slam:passive:ground_truth"
SMALL = {"width": 64, "height": 48}
SCENE_ARRAYS = ("box_min", "box_max", "box_albedo", "prim_min", "prim_max", "prim_albedo", "tri_v", "tri_material",
                "mat_albedo", "shell_albedo")


def plan(envs: list[str], seed: int, repeat: int = 1):
    return plan_episodes(task=TASK, robots=["carter"], envs=envs, repeat=repeat, seed=seed, argv=["x"], cwd=".",
                         options=SMALL, timeout_s=None)


def test_world_seed_is_a_stable_function_of_seed_name_and_variant():
    w = world_seed(0, "miniroom", 1)
    assert 0 <= w < 2 ** 32 and w == world_seed(0, "miniroom", "1")
    assert w == environment_world_seed(0, {"name": "miniroom", "variant": 1})
    assert len({world_seed(s, n, v) for s in range(4) for n in ("miniroom", "house") for v in (1, 2, 3)}) == 24
    # a subprocess (another hash salt) computes the same number: nothing depends on Python's hash()
    out = subprocess.run([sys.executable, "-c", "from benchbot.core.seeding import world_seed; "
                          "print(world_seed(0, 'miniroom', 1))"], capture_output=True, text=True, check=True,
                         env={"PYTHONHASHSEED": "123", "PATH": ""})
    assert int(out.stdout) == w


def test_the_plan_gives_every_episode_the_batch_seed_as_world_seed():
    a, b = plan(["miniroom:1", "house:1"], 7, repeat=2), plan(["house:1", "miniroom:1"], 7, repeat=2)
    assert [s.seed for s in a] == [7, 8, 9, 10]  # the episode seeds (noise) still follow the position
    assert {s.world_seed for s in a + b} == {7}


def _scene_and_view(registry, spec):
    service = start_service(registry, resolve_run(registry, TASK, "carter", spec.env), seed=spec.seed,
                            world_seed=spec.world_seed, options=SMALL)
    try:
        def grab(episode):
            scene = episode.backend.scene
            arrays = {k: np.array(getattr(scene, k)) for k in SCENE_ARRAYS}
            obs = episode.backend.observe(["image_rgb", "image_depth"])
            return episode.scene_seed(0), arrays, {k: np.array(v) for k, v in obs.items()}

        return service.call(grab, service.episode)
    finally:
        service.close()


def test_an_environment_builds_the_same_world_in_any_order_of_envs(registry):
    first = next(s for s in plan(["miniroom:1", "miniroom:2"], 7) if s.env == "miniroom:1")
    second = next(s for s in plan(["miniroom:2", "miniroom:1"], 7) if s.env == "miniroom:1")
    assert (first.index, second.index) == (0, 1) and first.seed != second.seed
    seed_a, scene_a, view_a = _scene_and_view(registry, first)
    seed_b, scene_b, view_b = _scene_and_view(registry, second)
    assert seed_a == seed_b == world_seed(7, "miniroom", 1)
    for key in SCENE_ARRAYS:
        assert np.array_equal(scene_a[key], scene_b[key]), key
    for key in ("image_rgb", "image_depth"):
        assert np.array_equal(view_a[key], view_b[key]), key
    # the seed second's position used to give it (7 + 1) is another world: its colours differ
    other = plan(["miniroom:1"], 8)[0]
    _, scene_c, view_c = _scene_and_view(registry, other)
    assert np.array_equal(scene_a["box_min"], scene_c["box_min"])  # geometry is the layout's
    assert not np.array_equal(scene_a["box_albedo"], scene_c["box_albedo"])
    assert not np.array_equal(view_a["image_rgb"], view_c["image_rgb"])


def test_repetitions_of_one_world_draw_their_own_sensor_noise(registry):
    """Same world seed, episode seeds 0 and 1, preset ``low``: the same scene, different noise; seed 0 twice: the
    same noise (bit-identical)."""
    from benchbot.core.geometry import pose7_to_se2
    from benchbot_sim_taichi.backend import TaichiSimBackend

    env = registry.scenes("miniroom:1")[0]
    robot = registry.get("robots", "carter")
    world = environment_world_seed(0, env)

    def observe(episode_seed):
        b = TaichiSimBackend(robot, {"arch": "cpu", **SMALL, "seed": episode_seed, "noise": "low"})
        try:
            b.load_scene(env, seed=world)
            b.move_to(pose7_to_se2(env["trajectory_poses"][2]))
            return b.observe(["image_rgb", "image_depth", "image_segment"])
        finally:
            b.close()

    a, again, b = observe(0), observe(0), observe(1)
    assert np.array_equal(a["image_depth"], again["image_depth"]) and np.array_equal(a["image_rgb"], again["image_rgb"])
    assert not np.array_equal(a["image_depth"], b["image_depth"])
    assert np.array_equal(a["image_segment"]["class_segment_img"], b["image_segment"]["class_segment_img"])


@pytest.mark.slow
def test_an_environment_scores_the_same_in_any_order_of_envs(tmp_path):
    """Two real batches of the geometric baseline, ``--envs miniroom:1,miniroom:3`` and the reverse: each
    environment's results file and OMQ are the same in both."""
    scores = []
    for order in ("miniroom:1,miniroom:3", "miniroom:3,miniroom:1"):
        proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--example", "semslam_geometric",
                               "--envs", order, "--seed", "3", "--camera-size", "64x48", "--output-dir",
                               str(tmp_path / order.replace(":", "_").replace(",", "-")), "--json"],
                              capture_output=True, text=True, timeout=900)
        assert proc.returncode == 0, proc.stderr
        run_dir = Path(json.loads(proc.stdout)["run_dir"])
        m = json.loads((run_dir / "manifest.json").read_text())
        per = json.loads((run_dir / "episode_scores.json").read_text())
        results = {p["env"]: json.loads((run_dir / p["results"]).read_text())["results"] for p in m["plan"]}
        scores.append(({e["env"]: e["scores"]["OMQ"] for e in per}, results,
                       {p["env"]: (p["seed"], p["world_seed"]) for p in m["plan"]}))
    (omq_a, res_a, seeds_a), (omq_b, res_b, seeds_b) = scores
    assert seeds_a["miniroom:1"] != seeds_b["miniroom:1"] and seeds_a["miniroom:1"][1] == seeds_b["miniroom:1"][1] == 3
    assert omq_a == omq_b and set(omq_a) == {"miniroom:1", "miniroom:3"}
    assert res_a == res_b
