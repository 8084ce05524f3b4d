"""Backends of one process that load the same world share one renderer (benchbot_sim_taichi.loaded_scenes), and
sharing changes no observation: with the real simulator at a tiny resolution, two robots placed in turn through one
shared scene see byte for byte what a robot alone sees at the same poses; the last backend to close frees it."""

from __future__ import annotations

import numpy as np

from benchbot_sim_taichi import loaded_scenes

ALL = ["image_rgb", "image_depth", "image_segment", "laser"]


def observations(backend) -> dict:
    obs = backend.observe(ALL)
    return {"rgb": obs["image_rgb"], "depth": obs["image_depth"],
            "class": obs["image_segment"]["class_segment_img"],
            "instance": obs["image_segment"]["instance_segment_img"], "scan": obs["laser"]["scans"]}


def test_two_backends_of_one_world_share_its_renderer_and_see_what_one_alone_sees(bear_envs, make_backend):
    env = bear_envs["miniroom:4"]
    poses = [np.asarray(p) for p in bear_envs_trajectory(make_backend, env)[:6]]

    before = loaded_scenes.loaded_count()  # other tests' backends may still hold theirs
    alone = make_backend(width=32, height=24)
    alone.load_scene(env, seed=0)
    expected = []
    for pose in poses:
        alone.set_pose(pose)
        expected.append(observations(alone))
    alone.close()
    assert loaded_scenes.loaded_count() == before

    a, b = make_backend(width=32, height=24), make_backend(width=32, height=24, seed=7)  # seed: the episode's noise
    a.load_scene(env, seed=0)
    b.load_scene(env, seed=0)
    assert a._renderer is b._renderer and a.scene is b.scene and loaded_scenes.loaded_count() == before + 1
    # the two robots at different poses, rendered in turn through the one renderer
    for k, pose in enumerate(poses):
        a.set_pose(pose)
        b.set_pose(poses[len(poses) - 1 - k])
        got_b = observations(b)
        got_a = observations(a)
        for name, image in got_a.items():
            assert np.array_equal(image, expected[k][name]), (k, name)
        for name, image in got_b.items():
            assert np.array_equal(image, expected[len(poses) - 1 - k][name]), (k, name)

    a.close()  # b keeps the scene
    assert loaded_scenes.loaded_count() == before + 1
    b.set_pose(poses[0])
    assert np.array_equal(observations(b)["rgb"], expected[0]["rgb"])
    b.close()
    assert loaded_scenes.loaded_count() == before


def test_another_world_seed_or_camera_model_loads_its_own(bear_envs, make_backend):
    env = bear_envs["miniroom:4"]
    before = loaded_scenes.loaded_count()
    a, b = make_backend(width=16, height=12), make_backend(width=16, height=12)
    c = make_backend(width=16, height=12, seed=0)
    c.sensors["camera"] = {**c.sensors["camera"], "exposure_ev": 0.5}
    try:
        a.load_scene(env, seed=0)
        b.load_scene(env, seed=1)
        c.load_scene(env, seed=0)
        assert a._renderer is not b._renderer and a._renderer is not c._renderer
        assert loaded_scenes.loaded_count() == before + 3
        b.load_scene(env, seed=0)  # another world for b: it lets go of its own and joins a's
        assert b._renderer is a._renderer and loaded_scenes.loaded_count() == before + 2
    finally:
        for backend in (a, b, c):
            backend.close()
    assert loaded_scenes.loaded_count() == before


def test_a_scene_whose_backends_are_dropped_without_closing_goes_with_them(bear_envs, make_backend):
    import gc

    before = loaded_scenes.loaded_count()
    backend = make_backend(width=16, height=12)
    backend.load_scene(bear_envs["miniroom:4"], seed=3)
    assert loaded_scenes.loaded_count() == before + 1
    del backend
    gc.collect()
    assert loaded_scenes.loaded_count() == before


def bear_envs_trajectory(make_backend, env) -> list:
    """The environment's trajectory poses (x, y, yaw) as the simulator builds them."""
    probe = make_backend(width=8, height=6)
    probe.load_scene(env, seed=0)
    try:
        return [np.asarray(p, dtype=np.float64) for p in probe.scene.trajectory_se2]
    finally:
        probe.close()


def test_a_resident_process_keeps_the_scenes_it_let_go_of_last_and_they_render_as_new(bear_envs, make_backend,
                                                                                      monkeypatch):
    """In the simulator service (resident) a world's scene outlives its episode: the next episode there renders
    through the same upload, byte for byte what a fresh one renders; past the limit the oldest is closed."""
    import benchbot.service as service

    env = bear_envs["miniroom:4"]
    fresh = make_backend(width=16, height=12)
    fresh.load_scene(env, seed=0)
    expected = observations(fresh)
    fresh.close()
    monkeypatch.setattr(service, "_RESIDENT", True)
    monkeypatch.setattr(loaded_scenes, "KEPT_WHEN_RESIDENT", 1)
    before = loaded_scenes.loaded_count()
    try:
        first = make_backend(width=16, height=12)
        first.load_scene(env, seed=0)
        kept_renderer = first._renderer
        first.close()
        assert loaded_scenes.kept_count() == 1 and loaded_scenes.loaded_count() == before
        again = make_backend(width=16, height=12)
        again.load_scene(env, seed=0)  # the next episode of that world: nothing loaded again
        assert again._renderer is kept_renderer and loaded_scenes.kept_count() == 0
        got = observations(again)
        assert all(np.array_equal(got[name], expected[name]) for name in expected)
        assert kept_renderer._buffers  # it holds its upload and outputs
        again.close()
        other = make_backend(width=16, height=12)
        other.load_scene(env, seed=1)  # another world seed: a scene of its own
        other.close()  # two let go of, one kept: the older is closed
        assert loaded_scenes.kept_count() == 1 and kept_renderer._buffers == {}
    finally:
        monkeypatch.setattr(service, "_RESIDENT", False)
        while loaded_scenes.kept_count():  # close what is kept, as a non-resident process would have
            loaded_scenes.release(_take_kept())


def _take_kept():
    key, scene = loaded_scenes._KEPT.popitem()
    scene.users = 1
    return scene
