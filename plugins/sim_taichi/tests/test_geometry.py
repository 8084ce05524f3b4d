"""Procedural objects, analytic primitives, mesh objects, batched rendering, soft shadows and sensor noise."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchbot.core.errors import BackendError
from benchbot.core.geometry import se2_to_matrix


def _cam(x, y, yaw, h=0.8):
    from benchbot_sim_taichi.backend import R_BODY_OPTICAL

    T = np.eye(4)
    T[:3, :3] = R_BODY_OPTICAL
    T[:3, 3] = (0.0, 0.0, h)
    return se2_to_matrix(x, y, yaw) @ T


def test_procedural_models_fill_their_cuboid():
    from benchbot_worlds.scene.build import _MODELS, object_geometry

    rng = np.random.default_rng(0)
    for cls in list(_MODELS) + ["book", "unknown"]:
        for k in range(4):
            c, e = rng.uniform(-3, 3, 3), rng.uniform(0.05, 2.0, 3)
            parts = object_geometry({"class": cls, "ID_name": f"{cls}_{k}", "centroid": c, "extent": e})
            lo = np.min([p.lo for p in parts], axis=0)
            hi = np.max([p.hi for p in parts], axis=0)
            np.testing.assert_allclose(lo, c - e / 2, atol=1e-9, err_msg=cls)
            np.testing.assert_allclose(hi, c + e / 2, atol=1e-9, err_msg=cls)
            assert all(np.all(p.hi > p.lo) for p in parts)
            if cls in ("chair", "table", "bed", "couch", "tv", "potted plant", "person"):
                assert len(parts) >= 3, cls
    big_books = object_geometry({"class": "book", "ID_name": "b", "centroid": [0, 0, 1], "extent": [0.6, 0.2, 0.25]})
    assert len(big_books) >= 10  # a row of books


def _single(synthetic_env, kind):
    from benchbot_worlds.scene.build import build_scene

    env = synthetic_env([("chair", (2.5, 0.0, 0.8), (1.0, 1.0, 1.0))])
    env["procedural"] = False
    scene = build_scene(env)
    scene.prim_type[:] = kind
    scene.prim_axis[:] = 2
    return scene


@pytest.mark.parametrize("kind", [1, 2])
def test_depth_of_sphere_and_cylinder(synthetic_env, kind):
    from benchbot_sim_taichi.render.reference import render_reference
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    scene = _single(synthetic_env, kind)  # unit sphere / vertical cylinder of radius 0.5 centred at (2.5, 0, 0.8)
    r = Renderer("cpu")
    r.set_scene(scene)
    W, H = 48, 36
    K = intrinsics(W, H, 60.0)
    T = _cam(0.0, 0.0, 0.0)
    out = r.render(K, T, W, H)
    hit = out["instance"] == 1
    v, u = np.nonzero(hit)
    d = out["depth"][hit]
    pts = (T[:3, :3] @ ((np.linalg.inv(K) @ np.stack([u, v, np.ones_like(u)])) * d)) + T[:3, 3:4]
    q = pts - np.array([[2.5], [0.0], [0.8]])
    if kind == 1:
        np.testing.assert_allclose(np.linalg.norm(q, axis=0), 0.5, atol=2e-4)
    else:
        rad = np.hypot(q[0], q[1])
        assert np.all((np.abs(rad - 0.5) < 2e-4) | (np.abs(np.abs(q[2]) - 0.5) < 2e-4))
    ref = render_reference(scene, K, T, W, H)
    assert (ref["instance"] != out["instance"]).sum() <= 3
    np.testing.assert_allclose(out["depth"], ref["depth"], atol=1e-3)


def test_mesh_objects_and_derived_ground_truth(synthetic_env, tmp_path):
    import trimesh

    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene, derive_ground_truth

    trimesh.creation.icosphere(subdivisions=2, radius=0.5).export(tmp_path / "ball.obj")
    trimesh.creation.box(extents=(0.4, 0.4, 0.4)).export(tmp_path / "cube.ply")
    env = synthetic_env([])
    env["objects"] = [{"mesh": str(tmp_path / "ball.obj"), "class": "chair", "pose": [2.5, 0.0, 0.8, 0.0]},
                      {"mesh": "cube.ply", "class": "table", "pose": [1, 0, 0, 0, 0.0, 2.0, 0.2], "scale": [2, 1, 1]}]
    env["_file_path"] = str(tmp_path / "env.yaml")
    scene = build_scene(env)
    assert scene.n_boxes == 2 and scene.tri_v.shape[0] > 300
    gt = derive_ground_truth(env)["ground_truth"]
    np.testing.assert_allclose(gt["objects"][1]["extent"], [0.8, 0.4, 0.4], atol=1e-6)
    np.testing.assert_allclose(gt["objects"][1]["centroid"], [0.0, 2.0, 0.2], atol=1e-6)
    r = Renderer("cpu")
    r.set_scene(scene)
    out = r.render(intrinsics(32, 24, 60.0), _cam(0.0, 0.0, 0.0), 32, 24)
    assert out["instance"][12, 16] == 1 and out["depth"][12, 16] == pytest.approx(2.0, abs=0.02)
    # clear errors, one line naming the field (the schema benchbot_worlds/schemas/environment.schema.json, then
    # what it cannot express: finite poses, non-zero quaternions, existing files)
    for bad, msg in [({"mesh": "nope.obj", "class": "chair"}, r"objects\[0\]\.mesh .*nope.obj does not exist"),
                     ({"mesh": "ball.obj"}, r"objects\[0\]: 'class' is a required property"),
                     ({"mesh": "ball.obj", "class": "chair", "pose": [1, 2]},
                      r"objects\[0\]\.pose: \[1, 2\] .*expected \[x, y, z, yaw_deg\] or \[qw, qx, qy, qz, x, y, z\]"),
                     ({"mesh": "ball.obj", "class": "chair", "scale": -1}, r"objects\[0\]\.scale: -1 .*positive"),
                     ({"mesh": "ball.obj", "class": "chair", "pose": [0, 0, 0, 0, 1, 2, 3]},
                      r"objects\[0\] has a bad pose or scale \(quaternion has zero length\)"),
                     ({"mesh": "ball.obj", "class": "chair", "scale": float("nan")},
                      r"objects\[0\] has a bad pose or scale \(scale and pose must be finite\)")]:
        env["objects"] = [{**bad, "mesh": str(tmp_path / bad["mesh"])} if "mesh" in bad else bad]
        with pytest.raises(BackendError, match=msg) as e:
            build_scene(env)
        assert "\n" not in e.value.message and e.value.hint
    env["objects"] = {"mesh": "x"}
    with pytest.raises(BackendError, match=r"objects: .* is not of type 'array'"):
        build_scene(env)
    (tmp_path / "junk.obj").write_text("this is not a mesh\n")
    env["objects"] = [{"mesh": "junk.obj", "class": "chair"}]
    with pytest.raises(BackendError, match="junk.obj"):
        build_scene(env)


def test_batch_equals_single_and_soft_shadows_deterministic(bear_envs):
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    scene = build_scene(bear_envs["miniroom:1"])
    r = Renderer("cpu", shadow_samples=4, seed=3)
    r.set_scene(scene)
    K = intrinsics(40, 30, 90.0)
    Ts = np.stack([_cam(*scene.trajectory_se2[i]) for i in (0, 5, 10)])
    batch = r.render_batch(K, Ts, 40, 30)
    for b in range(3):
        one = r.render(K, Ts[b], 40, 30)
        for k in one:
            assert np.array_equal(one[k], batch[k][b]), k
    again = r.render_batch(K, Ts, 40, 30)
    assert all(np.array_equal(again[k], batch[k]) for k in batch)
    q = r.render(K, Ts[0], 40, 30, mode="quality", spp=4)
    assert q["rgb"].shape == (30, 40, 3) and np.array_equal(q["depth"], batch["depth"][0])


@pytest.mark.slow
def test_object_centres_hit_their_instance(bear_envs):
    """From trajectory poses that see it, the ray through the centre of an object's largest primitive hits that
    object's instance (visibility decided by the NumPy reference)."""
    from benchbot_sim_taichi.render.reference import trace_reference
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    r = Renderer("cpu")
    W, H = 64, 48
    K = intrinsics(W, H, 90.0)
    for key, env in bear_envs.items():
        scene = build_scene(env)
        r.set_scene(scene)
        vol = np.prod(scene.prim_max - scene.prim_min, axis=1)
        checked = 0
        for i in range(0, len(scene.trajectory_se2), max(1, len(scene.trajectory_se2) // 4)):
            T = _cam(*scene.trajectory_se2[i])
            inst = r.render(K, T, W, H)["instance"]
            for obj in range(scene.n_boxes):
                prims = np.nonzero(scene.prim_object == obj)[0]
                k = prims[np.argmax(vol[prims])]
                c = (scene.prim_min[k] + scene.prim_max[k]) / 2.0
                pc = T[:3, :3].T @ (c - T[:3, 3])
                if pc[2] < 0.3 or pc[2] > 8.0:
                    continue
                u, v = np.rint(K[0, 0] * pc[0] / pc[2] + K[0, 2]), np.rint(K[1, 1] * pc[1] / pc[2] + K[1, 2])
                if not (0 <= u < W and 0 <= v < H):
                    continue
                d = T[:3, :3] @ np.array([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], 1.0])
                _, hit, _ = trace_reference(scene, T[:3, 3], d[None])
                if hit[0] >= 0 and scene.prim_object[hit[0]] == obj:
                    assert inst[int(v), int(u)] == scene.box_instance[obj], (key, i, scene.box_names[obj])
                    checked += 1
        assert checked >= 3, key


def test_sensor_noise_seeded(bear_envs, make_backend, carter_spec):
    from benchbot_sim_taichi.backend import TaichiSimBackend

    spec = json.loads(json.dumps(carter_spec))
    spec["sensors"]["noise"] = {"rgb_sigma": 4.0, "depth_sigma": 0.01, "depth_dropout": 0.05, "laser_sigma": 0.02}
    names = ["image_rgb", "image_depth", "laser"]
    outs = []
    for _ in range(2):
        b = TaichiSimBackend(spec, {"arch": "cpu", "width": 32, "height": 24, "seed": 1})
        b.load_scene(bear_envs["miniroom:1"], seed=1)
        outs.append(b.observe(names))
    clean = make_backend(32, 24)
    clean.load_scene(bear_envs["miniroom:1"], seed=1)
    c = clean.observe(names)
    assert np.array_equal(outs[0]["image_rgb"], outs[1]["image_rgb"])
    assert np.array_equal(outs[0]["image_depth"], outs[1]["image_depth"])
    assert not np.array_equal(outs[0]["image_rgb"], c["image_rgb"])
    assert 0 < (outs[0]["image_depth"] == 0).mean() < 0.2 and (c["image_depth"] == 0).mean() == 0
    assert np.abs(outs[0]["laser"]["scans"][:, 0] - c["laser"]["scans"][:, 0]).max() > 0
    spec["sensors"]["noise"] = {"rgb_sigma": -1}
    with pytest.raises(BackendError, match="rgb_sigma"):
        TaichiSimBackend(spec, {})


def test_odometry_noise_models():
    from benchbot.core.episode import OdometryNoise, odometry_noise_model

    inc = np.array([1.0, 0.1, 0.2])
    orig = np.array([OdometryNoise(s, model="original").apply(inc) for s in range(400)])
    zero = np.array([OdometryNoise(s).apply(inc) for s in range(400)])
    assert abs(zero[:, 2].mean() - 0.2) < 0.01 and abs(orig[:, 2].mean() - 0.22) < 0.01  # mean +σ bias
    assert abs(orig[:, 2].std() - 0.02) < 0.004
    assert odometry_noise_model({}, {}) == "zero_mean"
    assert odometry_noise_model({"odometry_noise": "original"}, {}) == "original"
    with pytest.raises(ValueError):
        OdometryNoise(0, model="bogus")
