"""Window panes (``Material.glass``): the camera sees through them and in them (Fresnel reflection: of the ambient
sky in fast mode, of the scene in quality mode), shadow rays go through them (weighted by their transmittance in
quality mode), depth, segmentation and the laser see the surface beyond; each against a closed-form expectation,
and, where a pane changes the answer, a control that an opaque pane (or none) fails."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_textured_render import LUT, _bare_scene, _cam, _quad, _rays  # noqa: E402

F0 = 0.04
W, H = 64, 48


def _schlick(cos):
    return F0 + (1.0 - F0) * (1.0 - np.clip(cos, 0.0, 1.0)) ** 5


def _pane_faces(x, half_w, z0, z1, thickness=0.004):
    """Both faces of a vertical pane (a thin slab) across x = ``x`` .. ``x + thickness``: (vertices, faces)."""
    v0, f0, _ = _quad(x, half_w, z0, z1)
    v1, f1, _ = _quad(x + thickness, half_w, z0, z1)
    return np.concatenate([v0, v1]), np.concatenate([f0, f1 + 4])


def _mesh(v, f, material):
    from benchbot_worlds.scene.meshes import make_mesh

    return make_mesh(np.asarray(v, float), np.asarray(f), materials=[material])


def _scene_with_pane(pane_x, pane_half_w, pane_z, glass=True, ambient=1.25):
    """Ambient light only (vertical surfaces' radiance = their albedo): a coloured quad (object 0) at x = 3 facing
    the camera at the origin (looking +x, 0.8 m up), a pane in front of it, the shell wall behind the camera at
    x = −1 (albedo 0.5)."""
    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances

    scene = _bare_scene(1, ambient=ambient)
    v, f, _ = _quad(3.0, 2.0, 0.0, 2.6)
    quad = _mesh(v, f, Material(np.array([0.8, 0.4, 0.2], np.float32)))
    pv, pf = _pane_faces(pane_x, pane_half_w, *pane_z)
    pane = _mesh(pv, pf, Material(np.full(3, 0.64, np.float32), roughness=0.1, opacity=0.5, glass=glass))
    add_mesh_instances(scene, [MeshInstance(quad, np.eye(4), 0), MeshInstance(pane, np.eye(4), -1)])
    return scene


def test_panes_are_packed_as_glass_and_the_rest_as_triangles():
    from benchbot_sim_taichi.render.kernels import GLASS
    from benchbot_sim_taichi.render.renderer import pack_scene

    scene = _scene_with_pane(1.0, 0.3, (0.5, 1.1))
    assert scene.prim_glass().tolist() == [False] * 2 + [True] * 4
    kinds = sorted(pack_scene(scene)["pi"][:, 0].tolist())
    assert kinds == [3, 3, GLASS, GLASS, GLASS, GLASS]


def test_fast_mode_sees_through_a_pane_and_reflects_in_it():
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    K, T = intrinsics(W, H, 60.0), _cam(0.0, 0.0, 0.0)
    r = Renderer("cpu")
    r.set_scene(_scene_with_pane(1.0, 0.3, (0.5, 1.1)))
    out = r.render(K, T, W, H)
    o, d = _rays(K, T, W, H)
    p = o + 1.0 * d  # the pane's front face (z-depth 1)
    behind = (np.abs(p[:, 1]) < 0.3 - 0.02) & (np.abs(p[:, 2] - 0.8) < 0.2)  # (lower, the floor is nearer)
    assert behind.sum() > 200
    # depth and segmentation: the quad beyond the pane
    np.testing.assert_allclose(out["depth"].reshape(-1)[behind], 3.0, atol=1e-4)
    assert np.all(out["instance"].reshape(-1)[behind] == 1)
    # colour: (1 − F)² of the quad through both faces + F + (1 − F)² F of the ambient sky in the mirror direction
    dn = d[behind] / np.linalg.norm(d[behind], axis=1, keepdims=True)
    F = _schlick(np.abs(dn[:, 0]))[:, None]
    sky = 1.25 * (0.8 + 0.3 * dn[:, 2:3])  # the pane is vertical: the reflected ray keeps the camera ray's z
    expected = (1.0 - F) ** 2 * np.array([0.8, 0.4, 0.2]) + (F + (1.0 - F) ** 2 * F) * sky
    got = LUT[out["rgb"].reshape(-1, 3)[behind]]
    np.testing.assert_allclose(got, expected, rtol=0.02, atol=0.004)
    # beside the pane, the quad as it is
    beside = (np.abs(p[:, 1]) > 0.3 + 0.02) & (np.abs(p[:, 2] - 0.8) < 0.2)
    np.testing.assert_allclose(LUT[out["rgb"].reshape(-1, 3)[beside]], np.tile([0.8, 0.4, 0.2], (beside.sum(), 1)),
                               rtol=0.02, atol=0.004)
    # the laser, too, sees the quad through the pane
    lidar = np.eye(4)
    lidar[2, 3] = 0.8
    np.testing.assert_allclose(r.scan(lidar, np.array([0.0])), [3.0], atol=1e-4)
    # control: the same pane, opaque, hides the quad
    r.set_scene(_scene_with_pane(1.0, 0.3, (0.5, 1.1), glass=False))
    opaque = r.render(K, T, W, H)
    np.testing.assert_allclose(opaque["depth"].reshape(-1)[behind], 1.0, atol=1e-4)
    np.testing.assert_allclose(r.scan(lidar, np.array([0.0])), [1.0], atol=1e-4)


def test_shadow_rays_go_through_a_pane_weighted_by_its_transmittance_in_quality_mode():
    """The sun overhead lights a horizontal quad; a horizontal pane (out of the camera's view) covers the half y > 0.
    Quality mode: there the quad gets (1 − F0)² of the light (both faces at normal incidence). Fast mode: panes do not
    dim shadow rays (a cost decision, see kernels._trace). With an opaque pane, that half is dark in both."""
    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL

    def scene(glass):
        s = _bare_scene(1, ambient=0.0)
        s.light_kind = np.array([LIGHT_DIRECTIONAL], np.int32)
        s.light_vec = np.array([[0.0, 0.0, 1.0]], np.float32)
        s.light_colour = np.full((1, 3), 1.0, np.float32)
        s.light_range = np.array([1e9], np.float32)
        floor = np.array([[1.5, -1.0, 0.4], [4.0, -1.0, 0.4], [4.0, 1.0, 0.4], [1.5, 1.0, 0.4]])
        pane = np.array([[1.0, 0.0, 2.9], [4.2, 0.0, 2.9], [4.2, 1.2, 2.9], [1.0, 1.2, 2.9]])
        faces = np.array([[0, 1, 2], [0, 2, 3]])
        add_mesh_instances(s, [
            MeshInstance(_mesh(floor, faces, Material(np.full(3, 0.6, np.float32))), np.eye(4), 0),
            MeshInstance(_mesh(np.concatenate([pane, pane + [0, 0, 0.004]]), np.concatenate([faces, faces + 4]),
                               Material(np.ones(3, np.float32), opacity=0.4, glass=glass)), np.eye(4), -1)])
        return s

    K, T = intrinsics(W, H, 60.0), _cam(0.0, 0.0, 0.0)
    o, d = _rays(K, T, W, H)
    r = Renderer("cpu")
    lit = {}
    for glass in (True, False):
        r.set_scene(scene(glass))
        fast = r.render(K, T, W, H)
        quality = r.render(K, T, W, H, mode="quality", spp=16, denoise=False)["radiance"].reshape(-1, 3)[:, 0]
        on_quad = fast["instance"].reshape(-1) == 1
        y = (o + fast["depth"].reshape(-1, 1) * d)[:, 1]
        under, beside = on_quad & (y > 0.1), on_quad & (y < -0.1)  # (away from the soft shadow's edge)
        assert under.sum() > 100 and beside.sum() > 100
        rgb = LUT[fast["rgb"].reshape(-1, 3)][:, 0]
        lit[glass] = {"fast": (rgb[under].mean(), rgb[beside].mean()),
                      "quality": (quality[under].mean(), quality[beside].mean())}
    for mode, transmitted in (("quality", (1 - F0) ** 2), ("fast", 1.0)):
        under, beside = lit[True][mode]  # (quality mode's direct light is fast mode's within 3 %: test_pathtrace)
        assert beside == pytest.approx(0.6, rel=0.03) and under / beside == pytest.approx(transmitted, abs=0.01), lit
        under, beside = lit[False][mode]  # (quality: what the lit half sends back off the pane's underside)
        assert under < 0.05 and beside == pytest.approx(0.6, rel=0.03), lit


def test_quality_mode_transmits_and_reflects_at_a_pane():
    """A pane just in front of the camera: the path-traced image is (1 − F)² of the image without it plus the sky
    in reflection, F + (1 − F)² F (both faces) — averaged over the pixels that see the quad."""
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    K, T = intrinsics(W, H, 60.0), _cam(0.0, 0.0, 0.0)
    r = Renderer("cpu")
    images = {}
    for name, scene in (("pane", _scene_with_pane(0.2, 0.3, (0.5, 1.1))),
                        ("none", _scene_with_pane(0.2, 0.3, (-5.0, -4.0)))):  # the pane out of sight
        r.set_scene(scene)
        images[name] = r.render(K, T, W, H, mode="quality", spp=32, denoise=False)["radiance"].reshape(-1, 3)
    fast = r.render(K, T, W, H)
    o, d = _rays(K, T, W, H)
    on_quad = np.abs(fast["depth"].reshape(-1) - 3.0) < 1e-3
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    F = _schlick(np.abs(dn[:, 0]))[:, None]
    sky = 1.25 * (0.8 + 0.3 * dn[:, 2:3])  # the reflected ray keeps the camera ray's z
    expected = (1 - F) ** 2 * images["none"] + (F + (1 - F) ** 2 * F) * sky
    got, want = images["pane"][on_quad].mean(axis=0), expected[on_quad].mean(axis=0)
    np.testing.assert_allclose(got, want, rtol=0.02)
    # controls: no pane, or a pane without its reflection, would be far outside that tolerance (blue: the quad is
    # darkest there, so the sky's reflection weighs most)
    for alternative in (images["none"], (1 - F) ** 2 * images["none"]):
        assert abs(alternative[on_quad].mean(axis=0)[2] - want[2]) > 0.05 * want[2]


def test_quality_mode_shows_a_lamp_reflected_in_a_pane():
    """A lamp behind the camera, seen in the pane in front of it: a path that reflects off the pane and reaches the
    lamp counts fully (a delta event: no light sample competes with it) — finite and bright."""
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.model import LIGHT_POINT

    def scene(pane_z):
        s = _scene_with_pane(1.0, 0.6, pane_z, ambient=0.2)
        s.light_kind = np.array([LIGHT_POINT], np.int32)
        s.light_vec = np.array([[-0.5, 0.0, 0.8]], np.float32)  # behind the camera, at its height
        s.light_colour = np.full((1, 3), 1.0, np.float32)
        s.light_range = np.array([50.0], np.float32)
        return s

    K, T = intrinsics(W, H, 60.0), _cam(0.0, 0.0, 0.0)
    r = Renderer("cpu")
    centre = {}
    for name, pane_z in (("pane", (0.3, 1.3)), ("none", (-5.0, -4.0))):  # control: the pane out of sight
        r.set_scene(scene(pane_z))
        rad = r.render(K, T, W, H, mode="quality", spp=16, denoise=False)["radiance"]
        assert np.isfinite(rad).all()
        # the lamp's mirror image lies 2.5 m away straight ahead: a disc of about 0.15 / 2.5 · fx pixels
        centre[name] = rad[H // 2 - 2:H // 2 + 2, W // 2 - 2:W // 2 + 2].mean() / np.median(rad)
    assert centre["pane"] > 5.0 and centre["none"] < 2.0, centre


def test_a_pane_exports_as_a_glass_material_and_loads_back_as_glass(tmp_path):
    from benchbot_worlds.scene.export import GLASS_MATERIAL_PREFIX, export_scene
    from benchbot_worlds.scene.meshes import load_mesh, with_glass_panes

    export_scene(_scene_with_pane(1.0, 0.3, (0.5, 1.1)), tmp_path / "scene.glb")
    back = load_mesh(tmp_path / "scene.glb")
    panes = [m for m in back.materials if m.name.startswith(GLASS_MATERIAL_PREFIX)]
    assert len(panes) == 1 and panes[0].opacity < 0.2 and not any(
        m.opacity < 1.0 for m in back.materials if not m.name.startswith(GLASS_MATERIAL_PREFIX))
    glazed = with_glass_panes(back)  # what a furnished home does with a window's model
    assert [m.glass for m in glazed.materials] == [m.name.startswith(GLASS_MATERIAL_PREFIX) for m in back.materials]
    assert int(np.isin(back.f_material, [back.materials.index(panes[0])]).sum()) == 4
