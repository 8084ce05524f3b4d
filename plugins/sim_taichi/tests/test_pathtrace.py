"""The path tracer of quality mode (``pathtrace.py``) and its BSDF (``bsdf.py``) against analytic references: the
BSDF's sampling matches its pdf and conserves energy, a white diffuse sphere under the sky returns the sky's
radiance (white furnace), direct light from the sun and a lamp equals fast mode's, multiple importance sampling
neither loses nor adds light, and images are deterministic per seed."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_textured_render import _bare_scene, _cam, _rays  # noqa: E402


def _directional_albedo(albedo, roughness, metallic, cos_v, n=200_000):
    """Monte Carlo estimates for one view direction: (∫ f·cos dω by the BSDF's own sampling, the same by uniform
    hemisphere sampling, ∫ pdf dω by uniform hemisphere sampling), channel 0."""
    import taichi as ti

    from benchbot_sim_taichi.render import bsdf
    from benchbot_sim_taichi.render.kernels import _hash
    from benchbot_sim_taichi.render.pathtrace import _rng
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")

    @ti.kernel
    def estimate(a: ti.types.vector(3, ti.f32), rough: ti.f32, metal: ti.f32, c: ti.f32, count: ti.i32,
                 out: ti.types.ndarray(dtype=ti.f32, ndim=1)):
        v = ti.Vector([ti.sqrt(1.0 - c * c), 0.0, c])
        for i in range(count):
            state = _hash(i * 7919 + 13)
            state, u0 = _rng(state)
            state, u1 = _rng(state)
            state, u2 = _rng(state)
            l, f, pdf = bsdf.sample(a, rough, metal, v, u0, u1, u2)
            if pdf > 0.0:
                out[0] += f[0] * l[2] / pdf
            state, z = _rng(state)
            state, phi = _rng(state)
            r = ti.sqrt(ti.max(0.0, 1.0 - z * z))
            lu = ti.Vector([r * ti.cos(6.2831853 * phi), r * ti.sin(6.2831853 * phi), z])
            f2, pdf2 = bsdf.evaluate(a, rough, metal, v, lu)
            out[1] += f2[0] * lu[2] * 6.2831853
            out[2] += pdf2 * 6.2831853

    out = np.zeros(3, np.float32)
    estimate(ti.Vector(list(albedo)), roughness, metallic, cos_v, n, out)
    return out / n


@pytest.mark.parametrize("roughness,metallic,cos_v", [(0.3, 1.0, 1.0), (0.6, 1.0, 0.5), (0.5, 0.0, 0.9),
                                                      (0.2, 0.0, 0.3), (0.8, 0.5, 0.7)])
def test_the_bsdf_samples_its_own_pdf_and_conserves_energy(roughness, metallic, cos_v):
    by_sampling, by_uniform, pdf_integral = _directional_albedo((1.0, 1.0, 1.0), roughness, metallic, cos_v)
    # importance sampling with the returned pdf estimates the same integral as uniform sampling: the pdf is right
    assert by_sampling == pytest.approx(by_uniform, rel=0.03), (by_sampling, by_uniform)
    # a white surface reflects at most what it receives (white furnace), and GGX loses little of it
    assert 0.75 < by_sampling <= 1.01, by_sampling
    # the pdf integrates to 1 but for specular samples that would leave below the surface
    assert 0.8 < pdf_integral <= 1.01, pdf_integral


def test_a_lambertian_bsdf_reflects_its_albedo_exactly():
    by_sampling, by_uniform, pdf_integral = _directional_albedo((0.7, 0.7, 0.7), 1.0, 0.0, 0.6, n=50_000)
    assert by_sampling == pytest.approx(0.7, rel=1e-3)  # f·cos/pdf is the albedo for every sample (float32 sums)
    assert by_uniform == pytest.approx(0.7, rel=0.02) and pdf_integral == pytest.approx(1.0, rel=0.02)


def test_a_smooth_white_metal_reflects_everything_at_normal_incidence():
    by_sampling, _, _ = _directional_albedo((1.0, 1.0, 1.0), 0.05, 1.0, 1.0, n=20_000)
    assert by_sampling == pytest.approx(1.0, abs=0.01)


def _decode(rgb):
    return np.power(rgb.astype(np.float64) / 255.0, 2.2)


def _sphere_scene(centre, radius, albedo=1.0, ambient=1.0):
    scene = _bare_scene(ambient=ambient)
    lo, hi = np.array(centre) - radius, np.array(centre) + radius
    scene.prim_type = np.array([1], np.int32)  # PRIM_ELLIPSOID: inscribed in its box
    scene.prim_axis = np.zeros(1, np.int32)
    scene.prim_min, scene.prim_max = lo[None].astype(np.float32), hi[None].astype(np.float32)
    scene.prim_albedo = np.full((1, 3), albedo, np.float32)
    scene.prim_object = np.full(1, -1, np.int32)
    return scene


def test_white_furnace_a_white_diffuse_sphere_returns_the_skys_radiance():
    """A closed diffuse sphere of albedo 1 under the sky ``L(ω) = a·(0.8 + 0.3 ω_z)`` and no other light reflects
    exactly the irradiance it receives: its radiance is ``a·(0.8 + 0.2 n_z)`` at every point, whatever the number
    of bounces (a convex object never sees itself)."""
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    centre, radius = np.array([3.0, 0.0, 1.0]), 0.6
    scene = _sphere_scene(centre, radius)
    W, H = 48, 36
    K, T = intrinsics(W, H, 40.0), _cam(0.0, 0.0, 0.0, h=1.0)
    r = Renderer("cpu", seed=1)
    r.set_scene(scene)
    out = r.render(K, T, W, H, mode="quality", spp=32, denoise=False, bounces=6)
    o, d = _rays(K, T, W, H)
    p = o + out["depth"].reshape(-1, 1) * d
    normal = (p - centre) / radius
    on = np.abs(np.linalg.norm(normal, axis=1) - 1.0) < 1e-3
    on &= normal[:, 0] < -0.5  # away from the silhouette, where a pixel's samples also see the shell
    assert on.sum() > 200
    expected = 0.8 + 0.2 * normal[on, 2]
    got = out["radiance"].reshape(-1, 3)[on]
    for c in range(3):
        ratio = got[:, c] / expected
        assert np.mean(ratio) == pytest.approx(1.0, abs=0.005), np.mean(ratio)
        assert np.abs(ratio - 1.0).max() < 0.15, np.abs(ratio - 1.0).max()  # 32 samples of a ±30 % sky


def _lit_floor_scene(kind, roughness=1.0, metallic=0.0):
    """No sky; one light (the sun from 60° elevation, or a lamp 1.5 m above (2, 0, 0)); a mesh floor quad at
    z = 0.01 of the given material, seen by a camera looking down at it."""
    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances, make_mesh
    from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL, LIGHT_POINT

    scene = _bare_scene(ambient=0.0)
    if kind == "sun":
        el = np.radians(60.0)
        scene.light_kind = np.array([LIGHT_DIRECTIONAL], np.int32)
        scene.light_vec = np.array([[np.cos(el), 0.0, np.sin(el)]], np.float32)
        scene.light_colour = np.array([[0.9, 0.8, 0.7]], np.float32)
    else:
        scene.light_kind = np.array([LIGHT_POINT], np.int32)
        scene.light_vec = np.array([[2.0, 0.0, 1.5]], np.float32)
        scene.light_colour = np.array([[1.2, 1.0, 0.8]], np.float32)
    scene.light_range = np.array([1e6], np.float32)
    v = np.array([[0.0, -3.0, 0.01], [6.0, -3.0, 0.01], [6.0, 3.0, 0.01], [0.0, 3.0, 0.01]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    add_mesh_instances(scene, [MeshInstance(make_mesh(v, f, materials=[
        Material(np.full(3, 0.6, np.float32), roughness=roughness, metallic=metallic)]), np.eye(4), -1)])
    return scene


def _looking_down():
    from benchbot_sim_taichi.backend import R_BODY_OPTICAL

    T = np.eye(4)
    pitch = np.radians(-50.0)  # about the optical x axis (right), negative: the view turns down (y is down)
    Rx = np.array([[1, 0, 0], [0, np.cos(pitch), -np.sin(pitch)], [0, np.sin(pitch), np.cos(pitch)]])
    T[:3, :3] = R_BODY_OPTICAL @ Rx
    T[:3, 3] = (0.3, 0.0, 1.2)
    return T


@pytest.mark.parametrize("kind", ["sun", "lamp"])
def test_direct_light_equals_fast_modes(kind):
    """With no bounce, quality mode's next-event estimation of a Lambertian floor's light gives fast mode's
    ``albedo · colour · n·l`` (sun) and ``albedo · colour · n·l / d²`` (lamp; fast mode's range cut-off set far
    away), up to the light's finite size."""
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    scene = _lit_floor_scene(kind)
    W, H = 40, 30
    K, T = intrinsics(W, H, 60.0), _looking_down()
    r = Renderer("cpu", seed=2)
    r.set_scene(scene)
    q = r.render(K, T, W, H, mode="quality", spp=64, denoise=False, bounces=0)
    fast_out = r.render(K, T, W, H)
    fast = _decode(fast_out["rgb"])
    floor = np.abs(q["depth"] - fast_out["depth"]) < 1e-6
    floor &= q["depth"] > 0
    lin = q["radiance"][floor]
    ok = (lin > 0.05) & (lin < 0.95)  # fast mode's 8 bits: compare where they are not clipped
    assert ok.sum() > 1000
    ratio = np.clip(lin, 0.0, 1.0)[ok] / fast[floor][ok]
    assert np.median(ratio) == pytest.approx(1.0, abs=0.03), np.median(ratio)


@pytest.mark.parametrize("roughness,metallic", [(1.0, 0.0), (0.25, 0.0), (0.35, 1.0)])
def test_multiple_importance_sampling_neither_loses_nor_adds_light(roughness, metallic):
    """With one bounce and no sky, a path that bounces off the floor can only add light by reaching the lamp, which
    next-event estimation already counts; MIS splits that light between the two strategies, so the image's mean
    equals the no-bounce image's (next-event estimation alone) — on glossy floors too, where most of it comes from
    the BSDF's samples."""
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    scene = _lit_floor_scene("lamp", roughness, metallic)
    W, H = 40, 30
    K, T = intrinsics(W, H, 60.0), _looking_down()
    r = Renderer("cpu", seed=3)
    r.set_scene(scene)
    direct = r.render(K, T, W, H, mode="quality", spp=256, denoise=False, bounces=0)["radiance"]
    one = r.render(K, T, W, H, mode="quality", spp=256, denoise=False, bounces=1)["radiance"]
    assert direct.mean() > 0.01
    assert one.mean() == pytest.approx(direct.mean(), rel=0.03), (one.mean(), direct.mean())


def test_a_material_with_nan_factors_is_drawn_with_the_defaults():
    """A malformed asset's NaN roughness or metallic must not reach the kernels (NaN radiance): it reads as glTF's
    default of a flat colour, roughness 1 and metallic 0."""
    from benchbot_sim_taichi.render.renderer import pack_scene

    packed = pack_scene(_lit_floor_scene("lamp", roughness=float("nan"), metallic=float("nan")))
    tri = packed["pi"][:packed["n_prims"], 0] == 3
    assert tri.sum() == 2
    pf = packed["pf"][:packed["n_prims"]]
    assert np.all(pf[tri, 9] == 1.0) and np.all(pf[tri, 10] == 0.0)


def test_quality_images_are_deterministic_per_seed():
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    scene = _lit_floor_scene("lamp", 0.4, 0.0)
    W, H = 32, 24
    K, T = intrinsics(W, H, 60.0), _looking_down()
    images = []
    for seed in (5, 5, 6):
        r = Renderer("cpu", seed=seed)
        r.set_scene(scene)
        images.append(r.render(K, T, W, H, mode="quality", spp=4, denoise=False)["radiance"])
    assert np.array_equal(images[0], images[1])
    assert not np.array_equal(images[0], images[2])


@pytest.mark.slow
def test_the_quality_benchmark_runs_and_reports_its_figures():
    """``benchmarks/render_quality.py`` (the quality-mode fps of the docs) on a BEAR environment (in the tests'
    scene style), tiny and short."""
    import json
    import subprocess

    root = Path(__file__).resolve().parents[3]
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "render_quality.py"), "--env", "miniroom:1",
                           "--width", "32", "--height", "24", "--spp", "2", "--frames", "2", "--json",
                           "--compare-host-path"],
                          capture_output=True, text=True, timeout=600, cwd=root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout)
    assert out["arch"] == "cpu" and out["denoise_device"] == "cpu" and out["spp"] == 2 and out["bounces"] == 8
    assert out["fps"] > 0 and out["fps_no_denoise"] >= out["fps"] * 0.5 and out["prims"] > 10
    for kind in ("denoised", "plain"):  # on the CPU both renderers finish frames on NumPy arrays: the same images
        stats = out["host_path"][kind]
        assert set(stats) == {"rgb", "depth", "class", "instance", "radiance"}
        assert all(s["max_abs"] == 0.0 and s["differing"] == 0 and s["values"] > 0 for s in stats.values()), stats
