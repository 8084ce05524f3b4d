"""BENCHBOT_SIM_CHECK_RENDERS=1 (benchbot_sim_taichi.render_check): the backend renders every pose twice with the real
simulator; two equal renders say nothing, two that differ (one pixel changed in the second render, as a GPU that
rendered another image would) give one warning naming the environment, the frame and the region, and both renders
are kept; the episode's observation is the first render either way. Off (the default), each pose renders once."""

from __future__ import annotations

import logging

import numpy as np

from benchbot_sim_taichi.render_check import differences

NAMES = ["image_rgb", "image_depth"]


def test_differences_name_the_outputs_pixels_and_region_that_differ():
    rgb = np.zeros((6, 8, 3), np.uint8)
    depth = np.full((6, 8), np.nan, np.float32)
    a = {"rgb": rgb, "depth": depth, "ranges": np.ones(5)}
    assert differences(a, {k: v.copy() for k, v in a.items()}) == []  # NaN depth of the same bits is equal
    b = {k: v.copy() for k, v in a.items()}
    b["rgb"][2, 3, 1] = 7
    b["rgb"][4, 5, 0] = 1
    b["ranges"][2] = 2.0
    assert differences(a, b) == ["ranges: 1 of 5 elements",
                                 "rgb: 2 pixels in rows 2..4, columns 3..5; first (2, 3): [0, 0, 0] then [0, 7, 0]"]
    assert differences(a, {"rgb": rgb[:5], "depth": depth}) == [
        "ranges: only in the first render", "rgb: uint8[6, 8, 3] then uint8[5, 8, 3]"]


def _load(make_backend, bear_envs):
    backend = make_backend(width=32, height=24)
    backend.load_scene(bear_envs["miniroom:4"], seed=0)
    backend.set_pose(np.asarray(backend.scene.trajectory_se2[1], np.float64))
    return backend


def test_off_by_default_each_pose_renders_once(make_backend, bear_envs, monkeypatch):
    monkeypatch.delenv("BENCHBOT_SIM_CHECK_RENDERS", raising=False)
    backend = _load(make_backend, bear_envs)
    try:
        calls = []
        render = backend._renderer.render
        monkeypatch.setattr(backend._renderer, "render", lambda *a, **k: calls.append(1) or render(*a, **k))
        backend.observe(NAMES)
        assert len(calls) == 1
    finally:
        backend.close()


def test_two_renders_that_differ_are_said_and_kept_and_the_first_is_observed(make_backend, bear_envs, monkeypatch,
                                                                             tmp_path, caplog):
    monkeypatch.setenv("BENCHBOT_SIM_CHECK_RENDERS", "1")
    monkeypatch.setenv("BENCHBOT_CACHE_DIR", str(tmp_path))
    backend = _load(make_backend, bear_envs)
    try:
        expected = backend.observe(NAMES)  # the real simulator's two renders of this pose: equal, nothing said
        assert not [r for r in caplog.records if "render check" in r.getMessage()]
        assert not (tmp_path / "sim_taichi-render-checks").exists()

        calls = []
        render = backend._renderer.render

        def second_differs(*args, **kwargs):
            out = render(*args, **kwargs)
            calls.append(1)
            if len(calls) % 2 == 0:  # the second render of a pose: one pixel of its RGB changed
                out["rgb"] = out["rgb"].copy()
                out["rgb"][5, 7, 0] ^= 1
            return out

        monkeypatch.setattr(backend._renderer, "render", second_differs)
        backend.set_pose(np.asarray(backend.scene.trajectory_se2[0], np.float64))
        backend.set_pose(np.asarray(backend.scene.trajectory_se2[1], np.float64))  # the same pose, a new frame
        with caplog.at_level(logging.WARNING, logger="benchbot_sim_taichi.render_check"):
            got = backend.observe(NAMES)
        assert len(calls) == 2
        for name in NAMES:
            assert np.array_equal(got[name], expected[name])  # the first render, as without the check
        said = [r.getMessage() for r in caplog.records if "render check" in r.getMessage()]
        assert len(said) == 1
        assert "miniroom:4 frame 3 rendered twice gave two images: rgb: 1 pixels in rows 5..5, columns 7..7" in said[0]
        kept = list((tmp_path / "sim_taichi-render-checks").glob("*.npz"))
        assert len(kept) == 1 and str(kept[0]) in said[0]
        with np.load(kept[0]) as files:
            assert np.array_equal(files["first_rgb"], expected["image_rgb"])
            assert int(np.sum(files["first_rgb"] != files["second_rgb"])) == 1
            assert np.array_equal(files["first_depth"], files["second_depth"])
    finally:
        backend.close()
