"""The physically based BSDF of ``quality`` mode (Taichi functions, called by :mod:`benchbot_sim_taichi.render.pathtrace`):
a Lambertian diffuse lobe plus a GGX (Trowbridge–Reitz) microfacet specular lobe in the glTF metallic–roughness
parametrisation, its importance sampling and its probability density.

Conventions: directions are unit vectors in a local shading frame whose z axis is the shading normal; ``v`` points
from the surface towards the viewer, ``l`` towards the light (both away from the surface). Radiance is linear.

Model (glTF 2.0 metallic–roughness, Appendix B, with Blender's Principled BSDF conventions where they differ):

- ``α = roughness²`` (clamped to ≥ :data:`MIN_ALPHA`); ``F0 = 0.04·(1 − metallic) + albedo·metallic`` (a dielectric
  of IOR 1.5); Schlick's Fresnel ``F = F0 + (1 − F0)(1 − v·h)⁵`` (Schlick 1994).
- Specular: ``F · D · G2 / (4 (n·l)(n·v))`` with the GGX normal distribution ``D`` (Walter et al. 2007,
  "Microfacet models for refraction through rough surfaces") and Smith's height-correlated masking–shadowing ``G2``
  (Heitz 2014, "Understanding the masking-shadowing function in microfacet-based BRDFs", eq. 99).
- Diffuse: ``(1 − metallic) · albedo / π · (1 − F_d(n·v))``, ``F_d`` the dielectric's Fresnel (F0 = 0.04): glTF's
  mix of a dielectric (specular layer over diffuse) and a metal by ``metallic``; the light the specular layer
  reflects does not reach the diffuse one, so a white surface reflects at most what it receives.
- A material with roughness ≥ 0.999 and metallic ≤ 1e-6 (the flat colours of primitives and of untextured assets) is
  purely Lambertian, ``albedo / π``, as in ``fast`` mode and in the reference renders of ``docs/realism.md``.
- Sampling: the specular lobe by GGX's distribution of visible normals (Heitz 2018, "Sampling the GGX distribution of
  visible normals", JCGT 7(4)), pdf ``G1(v) D(h) / (4 n·v)``; the diffuse lobe by cosine-weighted directions, pdf
  ``n·l / π``; one lobe chosen per sample with probability :func:`specular_probability`, and the pdf returned is the
  mixture's (one-sample multiple importance sampling between the lobes), so ``f · n·l / pdf`` is unbiased.
"""

import contextlib
import sys

from benchbot_worlds.scene.model import LUMA_709

with contextlib.redirect_stdout(sys.stderr):
    import taichi as ti

#: Smallest GGX α (= roughness²): below it a lobe is a mirror for every practical purpose, and float32 ``D`` overflows.
MIN_ALPHA = 1e-3
#: F0 of dielectrics (IOR 1.5: ((1.5 − 1)/(1.5 + 1))²).
DIELECTRIC_F0 = 0.04
PI = 3.14159265358979
INV_PI = 0.3183098861837907


#: The Rec. 709 weights (:data:`benchbot_worlds.scene.model.LUMA_709`) as scalars, which Taichi compiles in as
#: constants.
_LUMA_R, _LUMA_G, _LUMA_B = LUMA_709


@ti.func
def luminance(c):
    """Rec. 709 luminance of a linear RGB vector."""
    return _LUMA_R * c[0] + _LUMA_G * c[1] + _LUMA_B * c[2]


@ti.func
def is_lambertian(roughness, metallic):
    """1 when the material has no specular lobe (see the module docstring), else 0."""
    return 1 if (roughness >= 0.999 and metallic <= 1e-6) else 0


@ti.func
def base_reflectance(albedo, metallic):
    """F0 (RGB) of the glTF metallic–roughness model: the dielectric's 0.04 blended with the albedo by
    ``metallic``."""
    return DIELECTRIC_F0 * (1.0 - metallic) + albedo * metallic


@ti.func
def fresnel_schlick(f0, cos_theta):
    """Schlick's Fresnel reflectance at incidence cosine ``cos_theta`` for F0 ``f0`` (RGB vector or scalar)."""
    m = ti.max(0.0, 1.0 - cos_theta)
    m2 = m * m
    return f0 + (1.0 - f0) * (m2 * m2 * m)


@ti.func
def ggx_d(alpha, cos_h):
    """GGX normal distribution D(h) (sr⁻¹) for α and ``cos_h`` = n·h."""
    a2 = alpha * alpha
    c2 = cos_h * cos_h
    den = c2 * (a2 - 1.0) + 1.0
    return a2 / (PI * den * den)


@ti.func
def _lambda_term(alpha, cos_t):
    a2 = alpha * alpha
    return ti.sqrt(a2 + (1.0 - a2) * cos_t * cos_t)


@ti.func
def smith_g1(alpha, cos_v):
    """Smith masking G1 of GGX for a direction at cosine ``cos_v`` from the normal."""
    return 2.0 * cos_v / (cos_v + _lambda_term(alpha, cos_v))


@ti.func
def smith_g2(alpha, cos_v, cos_l):
    """Smith height-correlated masking–shadowing G2 of GGX."""
    return 2.0 * cos_v * cos_l / (cos_v * _lambda_term(alpha, cos_l) + cos_l * _lambda_term(alpha, cos_v))


@ti.func
def specular_probability(albedo, roughness, metallic, cos_v):
    """Probability (0..1) of sampling the specular lobe: its Fresnel weight against the diffuse albedo's, at least
    0.1 and at most 0.9 when both lobes exist (1 for a metal, 0 for a Lambertian material)."""
    p = 0.0
    if is_lambertian(roughness, metallic) == 0:
        ws = luminance(fresnel_schlick(base_reflectance(albedo, metallic), cos_v))
        wd = luminance(albedo) * (1.0 - metallic)
        p = 1.0
        if wd > 0.0:
            p = ti.min(ti.max(ws / (ws + wd), 0.1), 0.9)
    return p


@ti.func
def evaluate(albedo, roughness, metallic, v, l):
    """(f (RGB, sr⁻¹), pdf (sr⁻¹)) of the BSDF for local directions v (to the viewer) and l (to the light), the pdf
    being :func:`sample`'s; both zero when either direction is below the shading surface."""
    f = ti.Vector([0.0, 0.0, 0.0])
    pdf = 0.0
    if v[2] > 0.0 and l[2] > 0.0:
        if is_lambertian(roughness, metallic) == 1:
            f = albedo * INV_PI
            pdf = l[2] * INV_PI
        else:
            alpha = ti.max(roughness * roughness, MIN_ALPHA)
            h = (v + l).normalized()
            f0 = base_reflectance(albedo, metallic)
            d = ggx_d(alpha, h[2])
            spec = fresnel_schlick(f0, v.dot(h)) * (d * smith_g2(alpha, v[2], l[2]) / (4.0 * v[2] * l[2]))
            diff = albedo * ((1.0 - metallic) * INV_PI * (1.0 - fresnel_schlick(DIELECTRIC_F0, v[2])))
            f = spec + diff
            ps = specular_probability(albedo, roughness, metallic, v[2])
            pdf = ps * smith_g1(alpha, v[2]) * d / (4.0 * v[2]) + (1.0 - ps) * l[2] * INV_PI
    return f, pdf


@ti.func
def _sample_visible_normal(v, alpha, u1, u2):
    """A microfacet normal sampled from GGX's distribution of normals visible from v (Heitz 2018, listing 1)."""
    vh = ti.Vector([alpha * v[0], alpha * v[1], v[2]]).normalized()
    lensq = vh[0] * vh[0] + vh[1] * vh[1]
    t1 = ti.Vector([1.0, 0.0, 0.0])
    if lensq > 1e-12:
        t1 = ti.Vector([-vh[1], vh[0], 0.0]) / ti.sqrt(lensq)
    t2 = vh.cross(t1)
    r = ti.sqrt(u1)
    phi = 2.0 * PI * u2
    p1 = r * ti.cos(phi)
    p2 = r * ti.sin(phi)
    s = 0.5 * (1.0 + vh[2])
    p2 = (1.0 - s) * ti.sqrt(ti.max(0.0, 1.0 - p1 * p1)) + s * p2
    nh = p1 * t1 + p2 * t2 + ti.sqrt(ti.max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh
    return ti.Vector([alpha * nh[0], alpha * nh[1], ti.max(1e-6, nh[2])]).normalized()


@ti.func
def sample(albedo, roughness, metallic, v, u0, u1, u2):
    """A direction l sampled for local view direction v with uniform numbers u0 (lobe choice), u1, u2: (l, f, pdf)
    as :func:`evaluate` (pdf 0: no valid sample, e.g. a specular reflection below the surface)."""
    l = ti.Vector([0.0, 0.0, 1.0])
    ps = specular_probability(albedo, roughness, metallic, v[2])
    if u0 < ps:
        alpha = ti.max(roughness * roughness, MIN_ALPHA)
        h = _sample_visible_normal(v, alpha, u1, u2)
        l = 2.0 * v.dot(h) * h - v
    else:
        r = ti.sqrt(u1)
        phi = 2.0 * PI * u2
        l = ti.Vector([r * ti.cos(phi), r * ti.sin(phi), ti.sqrt(ti.max(0.0, 1.0 - u1))])
    f, pdf = evaluate(albedo, roughness, metallic, v, l)
    return l, f, pdf
