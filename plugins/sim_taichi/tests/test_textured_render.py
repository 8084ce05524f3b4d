"""Rendering textured, smooth-shaded triangle meshes against NumPy references: bilinear texture sampling, mip-mapped
minification, interpolated vertex normals, depth and segmentation of a loaded GLB, the glTF orientation end to end,
and the quality mode with textures."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot.core.geometry import se2_to_matrix

sys.path.insert(0, str(Path(__file__).parents[2] / "worlds" / "tests"))  # the worlds' mesh tests' GLB writer
from test_meshes import write_textured_quad_glb  # noqa: E402

LUT = np.power(np.arange(256) / 255.0, 2.2)


def _cam(x, y, yaw, h=0.8):
    from benchbot_sim_taichi.backend import R_BODY_OPTICAL

    T = np.eye(4)
    T[:3, :3] = R_BODY_OPTICAL
    T[:3, 3] = (0.0, 0.0, h)
    return se2_to_matrix(x, y, yaw) @ T


def _bare_scene(n_objects=0, ambient=1.25, room=((-1.0, -20.0, 0.0), (40.0, 20.0, 3.0))):
    """A scene with no primitives: ``n_objects`` object boxes (class 0 'chair', instances 1, 2, …; their geometry is
    added by the test), the room shell, ambient light only (1.25 · (0.8 + 0.2·n_z) = 1 on vertical surfaces, so
    a vertical surface's pixels are its albedo)."""
    from benchbot_worlds.scene.model import Scene

    z = np.zeros((n_objects, 3), np.float32)
    return Scene(box_min=z, box_max=z, box_albedo=z, box_class=np.zeros(n_objects, np.int32),
                 box_instance=np.arange(1, n_objects + 1, dtype=np.int32), box_names=[f"o{i}" for i in range(n_objects)],
                 room_min=np.array(room[0], np.float32), room_max=np.array(room[1], np.float32),
                 shell_albedo=np.full((3, 3), 0.5, np.float32), background_class=2,
                 class_list=["chair", "table", "background"], ambient=np.full(3, ambient, np.float32),
                 light_kind=np.zeros(0, np.int32), light_vec=np.zeros((0, 3), np.float32),
                 light_colour=np.zeros((0, 3), np.float32), light_range=np.zeros(0, np.float32), lighting="base",
                 start_se2=np.zeros(3), trajectory_se2=np.zeros((0, 3)))


def _quad(x, half_w, z0, z1, u_max=1.0, v_max=1.0):
    """A vertical quad in the plane ``x`` facing −x (towards a camera looking +x), y from +half_w (u = 0, the
    camera's left) to −half_w (u = u_max), z from z0 (v = 0) to z1 (v = v_max)."""
    v = np.array([[x, half_w, z0], [x, -half_w, z0], [x, -half_w, z1], [x, half_w, z1]])
    uv = np.array([[0.0, 0.0], [u_max, 0.0], [u_max, v_max], [0.0, v_max]])
    return v, np.array([[0, 1, 2], [0, 2, 3]]), uv


def _rays(K, T, W, H):
    v, u = np.mgrid[0:H, 0:W]
    d = np.stack([(u.ravel() - K[0, 2]) / K[0, 0], (v.ravel() - K[1, 2]) / K[1, 1], np.ones(W * H)], axis=1)
    return T[:3, 3], d @ T[:3, :3].T


def _bilinear_repeat(tex_lin, u, v):
    """Bilinear sample (repeat) of an (H, W, 3) linear texture at uv (v = 0 the bottom row): the kernel's rule."""
    H, W = tex_lin.shape[:2]
    x = (u - np.floor(u)) * W - 0.5
    y = (1.0 - (v - np.floor(v))) * H - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0, y0 = x0 % W, y0 % H
    x1, y1 = (x0 + 1) % W, (y0 + 1) % H
    return ((tex_lin[y0, x0] * (1 - fx) + tex_lin[y0, x1] * fx) * (1 - fy)
            + (tex_lin[y1, x0] * (1 - fx) + tex_lin[y1, x1] * fx) * fy)


def _srgb8(lin):
    return np.floor(np.power(np.clip(lin, 0.0, 1.0), 1 / 2.2) * 255.0 + 0.5)


def test_textured_quad_head_on_matches_a_numpy_bilinear_reference():
    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances, make_mesh
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    rng = np.random.default_rng(5)
    tex = rng.integers(0, 256, (8, 8, 3), dtype=np.uint8)  # no symmetry: a flip or a shift would show
    factor = np.array([1.0, 0.8, 0.6], np.float32)
    scene = _bare_scene(1)
    v, f, uv = _quad(2.0, 0.5, 0.3, 1.3)
    add_mesh_instances(scene, [MeshInstance(make_mesh(v, f, uv=uv, materials=[Material(factor, texture=tex)]),
                                            np.eye(4), 0)])
    W, H = 64, 48
    K = intrinsics(W, H, 60.0)
    T = _cam(0.0, 0.0, 0.0)
    r = Renderer("cpu")
    r.set_scene(scene)
    out = r.render(K, T, W, H)
    o, d = _rays(K, T, W, H)
    p = o + 2.0 * d  # the plane x = 2 at z-depth 2
    inside = (np.abs(p[:, 1]) < 0.5 - 1e-3) & (np.abs(p[:, 2] - 0.8) < 0.5 - 1e-3)
    assert inside.sum() > 400
    ref = _srgb8(_bilinear_repeat(LUT[tex], 0.5 - p[inside, 1], p[inside, 2] - 0.3) * factor)
    got = out["rgb"].reshape(-1, 3)[inside].astype(float)
    assert np.abs(got - ref).max() <= 2, np.abs(got - ref).max()
    assert np.all(out["instance"].reshape(-1)[inside] == 1) and np.all(out["class"].reshape(-1)[inside] == 0)
    np.testing.assert_allclose(out["depth"].reshape(-1)[inside], 2.0, atol=1e-5)


@pytest.mark.parametrize("distance", [4.0, 30.0])
def test_a_far_high_frequency_checker_is_filtered_to_its_average(distance):
    """A 1-texel black/white checker repeated many times: minified, each pixel must show the average (linear 0.5,
    sRGB 186), not a sample of black or white (aliasing). Seen close (magnified), the checker stays sharp."""
    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances, make_mesh
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    checker = np.zeros((64, 64, 3), np.uint8)
    checker[(np.arange(64)[:, None] + np.arange(64)[None, :]) % 2 == 1] = 255
    scene = _bare_scene(room=((-1.0, -20.0, -10.0), (40.0, 20.0, 10.0)))
    half = 0.2 * distance  # the quad covers the same part of the image at either distance
    v, f, uv = _quad(distance, half, 0.8 - half, 0.8 + half, u_max=16.0, v_max=16.0)  # 1024 texels across
    add_mesh_instances(scene, [MeshInstance(make_mesh(v, f, uv=uv, materials=[
        Material(np.ones(3, np.float32), texture=checker)]), np.eye(4), -1)])
    W, H = 64, 48
    K = intrinsics(W, H, 60.0)
    r = Renderer("cpu")
    r.set_scene(scene)
    out = r.render(K, _cam(0.0, 0.0, 0.0), W, H)
    quad = np.abs(out["depth"] - distance) < 1e-3 * distance
    quad[:, :1] = quad[:, -1:] = False
    assert quad.sum() > 200
    px = out["rgb"][quad].astype(float)
    assert np.all(out["instance"][quad] == 0) and np.all(out["class"][quad] == 2)  # not an object: background
    # ~22 texels per pixel: a mip level of the checker's average; without mip-maps pixels are 0 or 255
    assert np.abs(px - 186).max() <= 2, (px.min(), px.max())
    # the same checker, 16 texels over 1 m at 1 m (magnified, ~3.5 pixels per texel): both colours are seen
    scene2 = _bare_scene()
    v, f, uv = _quad(1.0, 0.5, 0.3, 1.3, u_max=0.25, v_max=0.25)
    add_mesh_instances(scene2, [MeshInstance(make_mesh(v, f, uv=uv, materials=[
        Material(np.ones(3, np.float32), texture=checker)]), np.eye(4), -1)])
    r.set_scene(scene2)
    near = r.render(K, _cam(0.0, 0.0, 0.0), W, H)["rgb"]
    assert near.min() < 60 and near.max() > 220


def _sphere_scene(smooth: bool):
    """A low-poly sphere (80 faces, radius 0.5 at (2.5, 0, 0.8)), albedo 0.8, lit by one directional light from
    the camera's side; vertex normals analytic (smooth) or the faces' (flat)."""
    import trimesh

    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances, make_mesh
    from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL

    s = trimesh.creation.icosphere(subdivisions=1, radius=0.5)
    mat = [Material(np.full(3, 0.8, np.float32))]
    if smooth:
        mesh = make_mesh(s.vertices, s.faces, n=s.vertices, materials=mat)
    else:  # unshared vertices carrying their face's normal
        v = s.vertices[s.faces].reshape(-1, 3)
        n = np.repeat(s.face_normals, 3, axis=0)
        mesh = make_mesh(v, np.arange(len(v)).reshape(-1, 3), n=n, materials=mat)
    scene = _bare_scene(1, ambient=0.0)
    M = np.eye(4)
    M[:3, 3] = (2.5, 0.0, 0.8)
    add_mesh_instances(scene, [MeshInstance(mesh, M, 0)])
    light = np.array([-1.0, 0.6, 0.4])
    scene.light_kind = np.array([LIGHT_DIRECTIONAL], np.int32)
    scene.light_vec = (light / np.linalg.norm(light)).astype(np.float32)[None]
    scene.light_colour = np.ones((1, 3), np.float32)
    scene.light_range = np.zeros(1, np.float32)
    return scene


def test_smooth_vertex_normals_shade_a_low_poly_sphere_like_the_true_sphere():
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    W, H = 96, 72
    K = intrinsics(W, H, 40.0)
    T = _cam(0.0, 0.0, 0.0)
    o, d = _rays(K, T, W, H)
    r = Renderer("cpu")
    errors, jumps = {}, {}
    for smooth in (True, False):
        scene = _sphere_scene(smooth)
        r.set_scene(scene)
        out = r.render(K, T, W, H)
        on = out["instance"].reshape(-1) == 1
        p = o + out["depth"].reshape(-1)[:, None] * d
        n_true = p - (2.5, 0.0, 0.8)
        n_true /= np.linalg.norm(n_true, axis=1, keepdims=True)
        ref = 0.8 * np.maximum(n_true @ scene.light_vec[0].astype(float), 0.0)
        got = LUT[out["rgb"].reshape(-1, 3)[:, 0]]
        core = on & (np.linalg.norm(p[:, 1:] - (0.0, 0.8), axis=1) < 0.45)  # away from the silhouette
        errors[smooth] = np.abs(got - ref)[core]
        img = np.where(core, got - ref, np.nan).reshape(H, W)
        jumps[smooth] = np.nanmax(np.abs(np.diff(img, axis=1)))  # steps between neighbours beyond the true sphere's
    assert errors[True].max() < 0.06 and errors[True].mean() < 0.015, (errors[True].max(), errors[True].mean())
    assert errors[False].max() > 0.15  # faceted: the test can tell
    assert jumps[True] < 0.04 < 0.15 < jumps[False], jumps


def _ray_triangles(o, d, tris, chunk=256):
    """Closest hit t (R,) (inf: none) of rays o (3,) / d (R, 3) with triangles (T, 3, 3), float64 Möller–Trumbore
    (vectorised over chunks of triangles)."""
    best = np.full(d.shape[0], np.inf)
    tris = np.asarray(tris, dtype=np.float64)
    for c in range(0, len(tris), chunk):
        v0, e1, e2 = tris[c:c + chunk, 0], tris[c:c + chunk, 1] - tris[c:c + chunk, 0], tris[c:c + chunk, 2] - tris[c:c + chunk, 0]
        p = np.cross(d[:, None, :], e2[None])  # (R, C, 3)
        det = np.einsum("rck,ck->rc", p, e1)
        ok = np.abs(det) > 1e-15
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - v0  # (C, 3)
        u = np.einsum("rck,ck->rc", p, s) * inv
        q = np.cross(s, e1)  # (C, 3)
        w = (d @ q.T) * inv
        t = (q * e2).sum(axis=1)[None, :] * inv
        t = np.where(ok & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 1e-4), t, np.inf)
        best = np.minimum(best, t.min(axis=1))
    return best


def test_depth_and_segmentation_of_a_loaded_glb_match_a_numpy_ray_cast(synthetic_env, tmp_path):
    """A user environment's GLB (two nodes with their own transforms, placed with a yaw and a non-uniform scale):
    depth and instance ids equal a float64 ray cast at the same triangles, computed from trimesh's reading of the
    file with the conversion and placement written out here."""
    import trimesh

    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    sc = trimesh.Scene()
    sc.add_geometry(trimesh.creation.box(extents=(0.6, 0.3, 0.4)), node_name="box",
                    transform=trimesh.transformations.rotation_matrix(0.4, [0, 1, 0]))
    sc.add_geometry(trimesh.creation.icosphere(subdivisions=1, radius=0.25), node_name="ball",
                    transform=trimesh.transformations.translation_matrix([0.0, 0.45, 0.0]))
    sc.export(str(tmp_path / "thing.glb"))
    env = synthetic_env([])
    env["style"] = "primitives"  # the objects in one room shell
    env["objects"] = [{"mesh": "thing.glb", "class": "chair", "pose": [2.0, 0.1, 0.5, 30.0], "scale": [1.0, 1.5, 0.8]},
                      {"mesh": "thing.glb", "class": "table", "pose": [2.6, -0.6, 0.3, -50.0]}]
    env["_file_path"] = str(tmp_path / "env.yaml")
    scene = build_scene(env)
    W, H = 64, 48
    K = intrinsics(W, H, 60.0)
    T = _cam(0.0, 0.0, 0.0)
    r = Renderer("cpu")
    r.set_scene(scene)
    out = r.render(K, T, W, H)
    # the reference: trimesh's triangles (nodes applied), glTF → map, then scale, yaw, translation
    base = trimesh.load(str(tmp_path / "thing.glb"), force="mesh").triangles.reshape(-1, 3) @ np.array(
        [[1, 0, 0], [0, 0, -1], [0, 1, 0]], float).T
    o, d = _rays(K, T, W, H)
    best = np.full(W * H, np.inf)
    inst = np.zeros(W * H, np.int32)
    for k, (x, y, z, yaw, s) in enumerate([(2.0, 0.1, 0.5, 30.0, (1.0, 1.5, 0.8)), (2.6, -0.6, 0.3, -50.0, (1, 1, 1))]):
        c, sn = np.cos(np.radians(yaw)), np.sin(np.radians(yaw))
        R = np.array([[c, -sn, 0], [sn, c, 0], [0, 0, 1]])
        t = _ray_triangles(o, d, ((base * s) @ R.T + (x, y, z)).reshape(-1, 3, 3))
        closer = t < best
        best[closer], inst[closer] = t[closer], scene.box_instance[k]
    hit = np.isfinite(best)
    assert hit.sum() > 150 and len(np.unique(inst[hit])) == 2
    assert (out["instance"].reshape(-1) != inst).sum() <= 4
    agree = hit & (out["instance"].reshape(-1) == inst)
    np.testing.assert_allclose(out["depth"].reshape(-1)[agree], best[agree], rtol=1e-5, atol=1e-5)
    # and the laser at the objects' height sees the same surfaces (ranges against the same ray cast)
    lidar = se2_to_matrix(0.0, 0.0, 0.0, z=0.5)
    angles = np.radians(np.linspace(-30, 30, 61))
    ranges = r.scan(lidar, angles)
    dl = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    ref = np.full(len(angles), np.inf)
    for k, (x, y, z, yaw, s) in enumerate([(2.0, 0.1, 0.5, 30.0, (1.0, 1.5, 0.8)), (2.6, -0.6, 0.3, -50.0, (1, 1, 1))]):
        c, sn = np.cos(np.radians(yaw)), np.sin(np.radians(yaw))
        R = np.array([[c, -sn, 0], [sn, c, 0], [0, 0, 1]])
        ref = np.minimum(ref, _ray_triangles(np.array([0.0, 0.0, 0.5]), dl, ((base * s) @ R.T + (x, y, z)).reshape(-1, 3, 3)))
    seen = np.isfinite(ref)
    assert seen.sum() > 10
    np.testing.assert_allclose(ranges[seen], ref[seen], rtol=1e-5, atol=1e-5)


def test_glb_front_faces_minus_y_and_its_texture_reads_upright(synthetic_env, tmp_path):
    """A glTF quad facing +Z with a quadrant texture, placed in a user environment as is: seen from −y (its front
    in the map frame) the image shows red top-left, green top-right, blue bottom-left, white bottom-right; the
    material factor multiplies the texture (the file's colours are kept, not the class colour)."""
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    write_textured_quad_glb(tmp_path / "quad.glb", factor=(255, 255, 128, 255))
    env = synthetic_env([])
    env["style"] = "primitives"  # the objects in one room shell
    env["objects"] = [{"mesh": "quad.glb", "class": "chair", "pose": [0.0, 0.0, 0.3, 0.0]}]
    env["_file_path"] = str(tmp_path / "env.yaml")
    scene = build_scene(env)
    assert scene.tex_info.shape == (1, 4) and list(scene.mat_texture) == [0]
    scene.ambient[:] = 1.25
    scene.light_kind = np.zeros(0, np.int32)
    r = Renderer("cpu")
    r.set_scene(scene)
    W, H = 48, 48
    K = intrinsics(W, H, 30.0)
    rgb = r.render(K, _cam(0.0, -2.0, np.pi / 2, h=0.8), W, H)["rgb"]  # looking along +y at the quad's centre
    tl, tr, bl, br = rgb[12, 12], rgb[12, 36], rgb[36, 12], rgb[36, 36]
    half = round(0.5 ** (1 / 2.2) * 255)  # the blue factor 128/255 ≈ linear 0.5
    np.testing.assert_allclose(tl, [255, 0, 0], atol=2)
    np.testing.assert_allclose(tr, [0, 255, 0], atol=2)
    np.testing.assert_allclose(bl, [0, 0, half], atol=2)
    np.testing.assert_allclose(br, [255, 255, half], atol=2)
    # from behind (+y) the same quad is seen mirrored: red top-right
    back = r.render(K, _cam(0.0, 2.0, -np.pi / 2, h=0.8), W, H)["rgb"]
    np.testing.assert_allclose(back[12, 36], [255, 0, 0], atol=2)


def test_quality_mode_draws_the_texture(synthetic_env, tmp_path):
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    write_textured_quad_glb(tmp_path / "quad.glb")
    env = synthetic_env([])
    env["style"] = "primitives"  # the objects in one room shell
    env["objects"] = [{"mesh": "quad.glb", "class": "chair", "pose": [0.0, 0.0, 0.3, 0.0]}]
    env["_file_path"] = str(tmp_path / "env.yaml")
    r = Renderer("cpu")
    r.set_scene(build_scene(env))
    W, H = 32, 32
    K = intrinsics(W, H, 30.0)
    T = _cam(0.0, -2.0, np.pi / 2, h=0.8)
    fast = r.render(K, T, W, H)
    q = r.render(K, T, W, H, mode="quality", spp=8, denoise=False)
    on = fast["instance"] == 1
    assert on.sum() > 300
    a, b = fast["rgb"][on].astype(float), q["rgb"][on].astype(float)
    for c in range(3):
        assert np.corrcoef(a[:, c], b[:, c])[0, 1] > 0.9
    for c in range(3):  # each pure-colour quadrant of the fast image keeps its dominant channel in quality mode
        others = [k for k in range(3) if k != c]
        quadrant = (a[:, c] > a[:, others[0]] + 20) & (a[:, c] > a[:, others[1]] + 20)
        assert quadrant.sum() > 30
        assert np.all(b[quadrant][:, c].mean() > b[quadrant][:, others].mean(axis=0) + 10)


def test_closest_hits_in_a_large_triangle_scene_match_a_numpy_ray_cast():
    """Depth, instance ids and laser ranges of overlapping ellipsoids of 1280 triangles each (a BVH of thousands of
    nodes, triangles packed in its order) equal a float64 ray cast."""
    import trimesh

    from benchbot_worlds.scene.meshes import MeshInstance, add_mesh_instances, make_mesh
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    s = trimesh.creation.icosphere(subdivisions=3, radius=0.4)
    mesh = make_mesh(s.vertices, s.faces, n=s.vertices)
    centres = [(2.0, 0.3, 0.8), (2.4, -0.2, 0.9), (2.9, 0.1, 0.6), (1.7, -0.5, 0.5)]
    scene = _bare_scene(len(centres))
    instances = []
    for k, c in enumerate(centres):
        M = np.diag([1.0, 1.3, 0.9, 1.0])
        M[:3, 3] = c
        instances.append(MeshInstance(mesh, M, k))
    add_mesh_instances(scene, instances)
    assert scene.prim_type.shape[0] == 4 * 1280
    W, H = 48, 36
    K = intrinsics(W, H, 70.0)
    T = _cam(0.0, 0.0, 0.0)
    r = Renderer("cpu")
    r.set_scene(scene)
    out = r.render(K, T, W, H)
    o, d = _rays(K, T, W, H)
    best = np.full(W * H, np.inf)
    inst = np.zeros(W * H, np.int32)
    tv = scene.tri_v.astype(np.float64)
    per = len(s.faces)
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    for k, c in enumerate(centres):
        near = np.linalg.norm(np.cross(dn, np.asarray(c) - o), axis=1) < 0.6  # rays passing the bounding sphere
        t = np.full(W * H, np.inf)
        t[near] = _ray_triangles(o, d[near], tv[k * per:(k + 1) * per])
        closer = t < best
        best[closer], inst[closer] = t[closer], k + 1
    hit = np.isfinite(best)
    assert hit.sum() > 300 and len(np.unique(inst[hit])) == 4
    assert (out["instance"].reshape(-1) != inst).sum() <= 3
    agree = hit & (out["instance"].reshape(-1) == inst)
    np.testing.assert_allclose(out["depth"].reshape(-1)[agree], best[agree], rtol=1e-5, atol=1e-5)
    angles = np.radians(np.linspace(-40, 40, 81))
    ranges = r.scan(se2_to_matrix(0.0, 0.0, 0.0, z=0.7), angles)
    dl = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    ref = _ray_triangles(np.array([0.0, 0.0, 0.7]), dl, tv)
    seen = np.isfinite(ref)
    assert seen.sum() > 20
    np.testing.assert_allclose(ranges[seen], ref[seen], rtol=1e-5, atol=1e-5)


def test_a_floor_lying_on_the_shell_floor_wins_every_pixel():
    """Geometry on a face of the room shell (a furnished home's floor at z = 0) is drawn, not the shell: at equal
    distance float32 rounding used to pick the shell in whole rows of pixels."""
    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances, make_mesh
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    scene = _bare_scene(1, room=((-1.0, -6.0, 0.0), (12.0, 6.0, 3.0)))
    v = np.array([[-1.0, -6.0, 0.0], [12.0, -6.0, 0.0], [12.0, 6.0, 0.0], [-1.0, 6.0, 0.0]])
    add_mesh_instances(scene, [MeshInstance(make_mesh(v, [[0, 1, 2], [0, 2, 3]], materials=[
        Material(np.array([0.9, 0.1, 0.1], np.float32))]), np.eye(4), 0)])
    W, H = 64, 48
    r = Renderer("cpu")
    r.set_scene(scene)
    K, T = intrinsics(W, H, 90.0), _cam(0.0, 0.0, 0.0, h=1.2)
    out = r.render(K, T, W, H)
    o, d = _rays(K, T, W, H)
    t = np.where(d[:, 2] < 0, -o[2] / np.minimum(d[:, 2], -1e-12), np.inf)
    p = o + t[:, None] * d
    on_floor = (d[:, 2] < 0) & (p[:, 0] < 12.0 - 0.05) & (np.abs(p[:, 1]) < 6.0 - 0.05)  # not at the far walls
    assert on_floor.sum() > 1000
    assert np.all(out["instance"].reshape(-1)[on_floor] == 1), (out["instance"].reshape(-1)[on_floor] != 1).sum()
