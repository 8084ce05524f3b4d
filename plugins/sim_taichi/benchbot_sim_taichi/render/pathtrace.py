"""The path tracer of ``quality`` mode: :func:`quality_kernel` (launched by ``Renderer.render(mode='quality')``).

Per pixel, ``spp`` paths (jittered in the pixel) of up to ``bounces`` scattering events each, with:

- **the BSDF** of :mod:`benchbot_sim_taichi.render.bsdf` (Lambertian + GGX, glTF metallic–roughness; each primitive's
  roughness and metallic in ``pf`` columns 9–10, see ``renderer.pack_scene``), textures and shading normals as in
  ``fast`` mode (``kernels._shade_hit``);
- **the lights as emitters of finite size**: the sun a disc of angular radius ``params[P_SUN_RADIUS]`` and radiance
  ``π · colour / Ω`` (Ω its solid angle), each lamp a sphere of radius ``params[P_LAMP_RADIUS]`` and radiance
  ``colour / radius²``, falling off as 1/d² (no range cut-off) — the same light as ``fast`` mode's
  ``colour · n·l`` (sun) and ``colour · n·l / d²`` (lamp) on a Lambertian surface, and as the reference renders of
  ``docs/realism.md``; the sky, ``ambient · (0.8 + 0.3 ω_z)`` (the direction's z component), is what a path that
  leaves the scene sees;
- **the room shell** seen by camera rays only (as in the reference renders): a path that reaches it after a bounce
  has left the scene;
- **next-event estimation**: at each vertex one light, chosen with probability proportional to its unshadowed
  contribution (luminance of its colour over the squared distance, zero when it lies wholly below the surface), is
  sampled uniformly in the cone it subtends and tested with one shadow ray as long as its centre's distance.
  Unlike ``fast`` mode (``kernels.LAMP_FIXTURE_M``), a lamp's own fixture does occlude it, as in the reference
  renderer: light that bounces off the walls lights the ceiling above a shade, which ``fast`` mode has no other
  way to do. (With the fixture let through, quality mode was 9–12 % brighter than Cycles and about 1 dB further
  from it: ``docs/realism.md``.)
- **multiple importance sampling** (Veach 1997, power heuristic, β = 2) between that light sample and the BSDF sample
  that hits the same sun or lamp (at a path's last vertex, where no BSDF sample follows, the light sample counts
  fully);
- **window panes** (``kernels.GLASS``): at each face a path reflects with probability F (Schlick, index 1.5) or goes
  straight on with 1 − F, with its throughput unchanged (what it estimates is F · reflected + (1 − F) · transmitted
  light); a face is not a bounce (a path ends at the face after ``kernels.MAX_GLASS_LAYERS``),
  has no next-event estimation (a specular event), and a light reached after a reflection counts fully. Shadow rays
  go through panes weighted by their 1 − F. The camera's view through panes sees the room shell and writes the
  denoiser's guides, like a camera hit;
- **Russian roulette** from bounce ``params[P_ROULETTE_FROM]`` on: a path continues with probability
  ``min(0.95, max(throughput))`` and is reweighted by its inverse.

Random numbers come from a hash of (pixel, sample, seed) advanced per draw (:func:`_rng`), so an image is a pure
function of the scene, the camera and the seed (deterministic per seed, on any arch and thread count).
"""

import contextlib
import sys

with contextlib.redirect_stdout(sys.stderr):
    import taichi as ti

from benchbot_sim_taichi.render import bsdf  # noqa: E402 - after Taichi's banner is redirected
from benchbot_sim_taichi.render.camera_model import GAMMA, METER_OFFSET, METER_STRIDE  # noqa: E402
from benchbot_sim_taichi.render.layouts import (  # noqa: E402
    CAM_FX, CAM_LEN, P_BOUNCES, P_LAMP_RADIUS, P_ROULETTE_FROM, P_SEED, P_SPP, P_SUN_RADIUS, PARAMS_LEN, WORLD_AMBIENT,
)
from benchbot_sim_taichi.render.kernels import (  # noqa: E402
    GLASS, MAX_GLASS_LAYERS, PANES_SEEN, SHADOW_OFFSET, _frame, _glass_reflectance, _hash, _ray, _shade_hit, _trace,
)

#: Spread (rad) of the ray cone of a diffuse bounce, for its texture level of detail.
BOUNCE_SPREAD = 0.1
#: Highest continuation probability of Russian roulette.
RR_MAX = 0.95
TWO_PI = 6.283185307179586


@ti.func
def _rng(state):
    """(next state, uniform float in [0, 1)) from a u32 state (24 bits of a hash)."""
    s = _hash(state + ti.u32(0x9E3779B9))
    return s, ti.cast(s >> ti.u32(8), ti.f32) * (1.0 / 16777216.0)


@ti.func
def _sky(world: ti.template(), d):
    """Linear radiance of the sky in unit direction d."""
    a = WORLD_AMBIENT
    return ti.Vector([world[a], world[a + 1], world[a + 2]]) * (0.8 + 0.3 * d[2])


@ti.func
def _one_minus_cos_cone(sin2):
    """1 − cos θ for sin²θ = ``sin2`` (accurate for small cones)."""
    s2 = ti.min(ti.max(sin2, 0.0), 1.0)
    return s2 / (1.0 + ti.sqrt(1.0 - s2))


@ti.func
def _light_geometry(lights: ti.template(), j, p, params):
    """Of light j seen from p: (unit direction to its centre, distance (1e30 for the sun), 1 − cos of the half-angle
    of the cone it subtends (0: p is inside a lamp), its radiance (RGB))."""
    col = ti.Vector([lights[j, 4], lights[j, 5], lights[j, 6]])
    axis = ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]])
    dist = 1e30
    omc = 0.0
    radiance = ti.Vector([0.0, 0.0, 0.0])
    if lights[j, 0] > 0.5:  # lamp: a sphere of radius params[P_LAMP_RADIUS]
        r = params[P_LAMP_RADIUS]
        axis -= p
        dist = axis.norm()
        if dist > r:
            axis /= dist
            omc = _one_minus_cos_cone(r * r / (dist * dist))
            radiance = col / (r * r)
    else:  # sun: a disc of angular radius params[P_SUN_RADIUS]
        axis = axis.normalized()
        sh = ti.sin(0.5 * params[P_SUN_RADIUS])
        omc = 2.0 * sh * sh
        radiance = col * (bsdf.PI / (TWO_PI * omc))
    return axis, dist, omc, radiance


@ti.func
def _light_weight(lights: ti.template(), j, p, ns, params):
    """Unnormalised probability of choosing light j at p (shading normal ns) for next-event estimation: the
    luminance of its colour over the squared distance (lamps), zero when it lies wholly below the surface."""
    axis, dist, omc, radiance = _light_geometry(lights, j, p, params)
    w = 0.0
    if omc > 0.0:
        sin_half = ti.sqrt(ti.max(0.0, omc * (2.0 - omc)))  # sin of the cone's half-angle
        reach = ns.dot(axis) + sin_half
        if reach > 0.0:
            col = bsdf.luminance(ti.Vector([lights[j, 4], lights[j, 5], lights[j, 6]]))
            if lights[j, 0] > 0.5:
                col /= dist * dist
            w = col * ti.min(reach, 1.0)
    return w


@ti.func
def _cone_hit(lights: ti.template(), j, o, d, tmax, params):
    """1 when the unit ray (o, d), whose first surface is at tmax (1e30: none), reaches light j, else 0. A lamp: the
    ray meets its sphere and no surface lies nearer than its centre (the rule of the shadow rays of next-event
    estimation, so that both estimators see the same light). The sun: the ray escapes within its disc."""
    hit = 0
    if lights[j, 0] > 0.5:
        c = ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]]) - o
        r = params[P_LAMP_RADIUS]
        b = c.dot(d)
        cc = c.dot(c)
        if b > 0.0 and b * b - (cc - r * r) >= 0.0 and tmax >= ti.sqrt(cc):
            hit = 1
    elif tmax >= 1e29:
        axis = ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]]).normalized()
        sh = ti.sin(0.5 * params[P_SUN_RADIUS])
        if 1.0 - d.dot(axis) <= 2.0 * sh * sh:
            hit = 1
    return hit


@ti.kernel
def quality_kernel(
    cam: ti.types.vector(CAM_LEN, ti.f32),
    nodes: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (I, 16) f32 SceneArrays.nodes
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 11) f32 SceneArrays.pf
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 4) i32 SceneArrays.pi
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 9) f32 SceneArrays.tris
    shade: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 17) f32 SceneArrays.shade
    texels: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (N,) i32 SceneArrays.texels
    tex_info: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (X, 4) i32 SceneArrays.tex_info
    tex_lut: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (256,) f32 SceneArrays.tex_lut
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (L, 17) f32 SceneArrays.lights
    n_lights: ti.i32,
    world: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (19,) f32 SceneArrays.world
    params: ti.types.vector(PARAMS_LEN, ti.f32),
    out: ti.types.ndarray(dtype=ti.f32, ndim=4),  # (B, H, W, 3) f32 linear radiance (B = 1)
    aux: ti.types.ndarray(dtype=ti.f32, ndim=4),  # (B, H, W, 6) f32 the denoiser's guides: albedo rgb, normal xyz
):
    """Path-traced linear radiance into ``out`` (B, H, W, 3) float32 (B = 1) for camera ``cam``
    (``renderer.camera_params``: optical frame in ``map``, pixels), as the module docstring describes.
    ``params`` is ``renderer.render_params``: [1] the sun's angular radius (rad), [2] the lamps' radius (m), [3] the
    seed, [4] samples per pixel, [5] the most bounces of a path, [6] the bounce from which Russian roulette applies.
    ``aux`` (B, H, W, 6) float32 receives the denoiser's guides averaged over the samples: the albedo at the camera's
    hit (0..1) and its shading normal (``map`` frame, unit before averaging); zero where a sample hits nothing."""
    B = out.shape[0]
    H = out.shape[1]
    W = out.shape[2]
    spp = ti.cast(params[P_SPP], ti.i32)
    max_bounces = ti.cast(params[P_BOUNCES], ti.i32)
    rr_start = ti.cast(params[P_ROULETTE_FROM], ti.i32)
    seed_hash = _hash(ti.cast(params[P_SEED], ti.i32) * 7919 + 17)
    for b, v, u in ti.ndrange(B, H, W):
        acc = ti.Vector([0.0, 0.0, 0.0])
        guide_albedo = ti.Vector([0.0, 0.0, 0.0])
        guide_normal = ti.Vector([0.0, 0.0, 0.0])
        pixel = ti.cast((b * H + v) * W + u, ti.u32)
        for s in range(spp):
            state = _hash(pixel * ti.u32(0x27D4EB2F) ^ _hash(seed_hash + ti.cast(s, ti.u32) * ti.u32(0x165667B1)))
            state, jx = _rng(state)
            state, jy = _rng(state)
            o, d = _ray(cam, ti.cast(u, ti.f32) + jx - 0.5, ti.cast(v, ti.f32) + jy - 0.5)
            spread = 1.0 / cam[CAM_FX]
            d = d.normalized()
            throughput = ti.Vector([1.0, 1.0, 1.0])
            # the previous vertex, for the MIS weight of a BSDF sample that reaches a light
            prev_p = o
            prev_ns = d
            prev_pdf = 0.0
            prev_total = 0.0
            prev_delta = 0  # the last event was a pane's reflection: no light sample could reach what follows
            camera_view = 1  # still the camera's ray (through panes): it sees the shell and writes the guides
            panes = 0
            bounce = 0
            for _event in range(max_bounces + 1 + MAX_GLASS_LAYERS):
                hit, t, n, ns, albedo, c_id, i_id, p, k, _pane, _tp = _shade_hit(o, d, spread, nodes,
                                                                            pf, pi, tris, shade, texels, tex_info,
                                                                            tex_lut, world, PANES_SEEN)
                escaped = hit == 0 or (k < 0 and camera_view == 0)  # the shell is seen by camera rays only
                if camera_view == 0:  # lights reached by the BSDF sample, weighted against next-event estimation
                    t_lim = 1e30
                    if not escaped:
                        t_lim = t
                    for j in range(n_lights):
                        if _cone_hit(lights, j, o, d, t_lim, params) == 1:
                            axis, dist, omc, radiance = _light_geometry(lights, j, prev_p, params)
                            p_light = 0.0
                            if prev_delta == 0 and prev_total > 0.0 and omc > 0.0:
                                p_light = (_light_weight(lights, j, prev_p, prev_ns, params) / prev_total
                                           / (TWO_PI * omc))
                            mis = 1.0  # after a pane's reflection (a delta event) no light sample competes
                            if p_light > 0.0:
                                mis = prev_pdf * prev_pdf / (prev_pdf * prev_pdf + p_light * p_light)
                            acc += throughput * radiance * mis
                    if escaped:
                        acc += throughput * _sky(world, d)
                if escaped:
                    break
                pane = 0
                if k >= 0:
                    if pi[k, 0] == GLASS:
                        pane = 1
                if pane == 1:  # reflect with probability F, else straight on; not a bounce
                    if panes == MAX_GLASS_LAYERS:
                        break
                    panes += 1
                    state, u_f = _rng(state)
                    if u_f < _glass_reflectance(ti.abs(n.dot(d))):
                        d = d - 2.0 * n.dot(d) * n
                        o = p + n * SHADOW_OFFSET
                        prev_delta = 1
                        camera_view = 0
                    else:
                        o = p
                    continue
                if camera_view == 1:
                    guide_albedo += albedo
                    guide_normal += ns
                rough = 1.0
                metal = 0.0
                if k >= 0:
                    rough = pf[k, 9]
                    metal = pf[k, 10]
                t1, t2 = _frame(ns)
                wo = ti.Vector([-d.dot(t1), -d.dot(t2), -d.dot(ns)])
                po = p + n * SHADOW_OFFSET
                # next-event estimation: one light, chosen in proportion to its unshadowed contribution
                total = 0.0
                for j in range(n_lights):
                    total += _light_weight(lights, j, p, ns, params)
                state, u_pick = _rng(state)
                state, u1 = _rng(state)
                state, u2 = _rng(state)
                if total > 0.0:
                    target = u_pick * total
                    chosen = -1
                    w_chosen = 0.0
                    for j in range(n_lights):
                        if chosen < 0:
                            w = _light_weight(lights, j, p, ns, params)
                            if w > 0.0 and (target < w or j == n_lights - 1):
                                chosen = j
                                w_chosen = w
                            target -= w
                    if chosen >= 0 and w_chosen > 0.0:
                        axis, dist, omc, radiance = _light_geometry(lights, chosen, p, params)
                        a1, a2 = _frame(axis)
                        cos_t = 1.0 - u1 * omc
                        sin_t = ti.sqrt(ti.max(0.0, 1.0 - cos_t * cos_t))
                        wl = (sin_t * ti.cos(TWO_PI * u2)) * a1 + (sin_t * ti.sin(TWO_PI * u2)) * a2 + cos_t * axis
                        if wl.dot(n) > 0.0:
                            f, p_bsdf = bsdf.evaluate(albedo, rough, metal, wo,
                                                      ti.Vector([wl.dot(t1), wl.dot(t2), wl.dot(ns)]))
                            if p_bsdf > 0.0:
                                _t, k_sh, _n, tr, _pt, _pk = _trace(po, wl, dist, nodes, pf, pi,
                                                                    tris, True, PANES_SEEN)
                                if k_sh < 0:
                                    p_light = w_chosen / total / (TWO_PI * omc)
                                    mis = 1.0  # the path ends here: no BSDF sample will reach the light
                                    if bounce < max_bounces:
                                        mis = p_light * p_light / (p_light * p_light + p_bsdf * p_bsdf)
                                    acc += throughput * f * radiance * (tr * wl.dot(ns) * mis / p_light)
                if bounce == max_bounces:
                    break
                # the BSDF sample that continues the path
                state, u0 = _rng(state)
                state, u1 = _rng(state)
                state, u2 = _rng(state)
                wi, f, pdf = bsdf.sample(albedo, rough, metal, wo, u0, u1, u2)
                d_new = wi[0] * t1 + wi[1] * t2 + wi[2] * ns
                if pdf <= 0.0 or d_new.dot(n) <= 0.0:
                    break
                throughput *= f * (wi[2] / pdf)
                if bounce + 1 >= rr_start:
                    q = ti.min(RR_MAX, ti.max(throughput[0], ti.max(throughput[1], throughput[2])))
                    state, u_rr = _rng(state)
                    if u_rr >= q:
                        break
                    throughput /= q
                prev_p = p
                prev_ns = ns
                prev_pdf = pdf
                prev_total = total
                prev_delta = 0
                camera_view = 0
                o = po
                d = d_new.normalized()
                spread = ti.max(BOUNCE_SPREAD * rough, spread)
                bounce += 1
        acc /= ti.cast(spp, ti.f32)
        for k in ti.static(range(3)):
            out[b, v, u, k] = acc[k]
            aux[b, v, u, k] = guide_albedo[k] / ti.cast(spp, ti.f32)
            aux[b, v, u, 3 + k] = guide_normal[k] / ti.cast(spp, ti.f32)


@ti.kernel
def prepare_denoiser_inputs(
    out: ti.types.ndarray(dtype=ti.f32, ndim=4),  # (B, H, W, 3) f32 linear radiance (B = 1)
    aux: ti.types.ndarray(dtype=ti.f32, ndim=4),  # (B, H, W, 6) f32 the denoiser's guides: albedo rgb, normal xyz
):
    """Clamp :func:`quality_kernel`'s outputs in place to the ranges the denoiser reads (what
    ``denoiser.Denoiser`` does to its copies): radiance ``out`` (B, H, W, 3) ≥ 0, the albedo guide (``aux`` channels
    0–2) to 0..1 and the normal guide (channels 3–5) to −1..1."""
    for b, v, u in ti.ndrange(out.shape[0], out.shape[1], out.shape[2]):
        for k in ti.static(range(3)):
            out[b, v, u, k] = ti.max(out[b, v, u, k], 0.0)
            aux[b, v, u, k] = ti.min(ti.max(aux[b, v, u, k], 0.0), 1.0)
            aux[b, v, u, 3 + k] = ti.min(ti.max(aux[b, v, u, 3 + k], -1.0), 1.0)


@ti.kernel
def encode_kernel(
    radiance: ti.types.ndarray(dtype=ti.f32, ndim=4),  # (B, H, W, 3) f32 linear radiance
    camera: ti.types.vector(8, ti.f64),
    rgb: ti.types.ndarray(dtype=ti.u8, ndim=4),  # (B, H, W, 3) u8 out: sRGB
):
    """The camera model (``camera_model.CameraModel.encode``'s steps 1–4, in float64 as there) of linear radiance
    (B, H, W, 3) float32 into ``rgb`` (B, H, W, 3) uint8 sRGB, where the images are (on the GPU: no copy to the
    host first). ``camera`` is ``CameraModel.kernel_params``: [2^EV, 1 for the filmic curve else 0, vignetting,
    fx, fy, cx, cy, 0]."""
    for b, v, u in ti.ndrange(radiance.shape[0], radiance.shape[1], radiance.shape[2]):
        xn = (ti.cast(u, ti.f64) - camera[5]) / camera[3]
        yn = (ti.cast(v, ti.f64) - camera[6]) / camera[4]
        cos2 = 1.0 / (1.0 + xn * xn + yn * yn)
        vignette = 1.0 - camera[2] * (1.0 - cos2 * cos2)
        for k in ti.static(range(3)):
            x = ti.max(ti.cast(radiance[b, v, u, k], ti.f64) * vignette, 0.0) * camera[0]
            y = ti.min(x, 1.0)
            if camera[1] > 0.5:  # Narkowicz's ACES fit, clamped to 0..1 (camera_model.aces_filmic)
                y = ti.min(ti.max(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0), 1.0)
            rgb[b, v, u, k] = ti.cast(ti.floor(ti.pow(y, ti.cast(GAMMA, ti.f64)) * 255.0 + 0.5), ti.u8)


@ti.kernel
def meter_sample_kernel(
    radiance: ti.types.ndarray(dtype=ti.f32, ndim=4),  # (B, H, W, 3) f32 linear radiance
    sample: ti.types.ndarray(dtype=ti.f32, ndim=4),  # (B, h, w, 3) f32 out: the meter's pixels (camera_model.METER_*)
):
    """The auto-exposure meter's pixels of linear radiance (B, H, W, 3) float32 into ``sample`` (B, h, w, 3),
    ``sample[b, i, j] = radiance[b, METER_OFFSET + METER_STRIDE i, METER_OFFSET + METER_STRIDE j]``: what
    ``camera_model.CameraModel.meter_sample`` takes on the host, gathered where the images are (a copy, so the
    same values)."""
    for b, i, j in ti.ndrange(sample.shape[0], sample.shape[1], sample.shape[2]):
        for k in ti.static(range(3)):
            sample[b, i, j, k] = radiance[b, METER_OFFSET + METER_STRIDE * i, METER_OFFSET + METER_STRIDE * j, k]
