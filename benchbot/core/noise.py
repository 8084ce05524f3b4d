"""Noise presets for a robot's sensors and motion (``benchbot batch --noise PRESET``), and the noise models they
parameterise. docs/noise.md has the table of every preset's numbers with their sources.

The models (all zero-mean where stated, all drawn from a ``numpy.random.Generator`` the caller seeds, so the same
seed gives bit-identical output):

* **Depth** (structured-light / stereo camera): each valid z-depth ``z`` (metres, 0 = no hit) becomes
  ``z + n``, ``n ~ Normal(0, σ(z)²)`` with ``σ(z) = σ₀ + k·z²`` — the random error of triangulation grows with
  the square of the distance (Khoshelham & Elberink 2012, Sensors 12(2):1437: a few millimetres near the Kinect v1,
  about 4 cm at its 5 m maximum range; ``k = 1.425·10⁻³`` m⁻¹ gives 3.6 cm at 5 m); then the pixel is dropped (set to 0, "no data") with a range-dependent probability ``p(z)``: 1
  nearer than ``z_min``, ``p₀`` up to ``fade_start``, rising linearly to 1 at ``fade_end`` and 1 beyond.
* **RGB** (photon shot noise + read noise, the Poisson-Gaussian model of Foi et al. 2008, IEEE TIP 17(10):1737, as
  in the EMVA 1288 photon-transfer standard): a pixel's 8-bit sRGB level is decoded to linear intensity
  ``L ∈ [0, 1]`` (the simulator's 2.2 gamma), turned into ``N = L·full_well`` electrons, replaced by
  ``Poisson(N) + Normal(0, read²)`` electrons (mean ``N``, variance ``N + read²``: signal-dependent; the Poisson
  draw is its normal approximation above 100 electrons), and encoded back (clipped to [0, 1], rounded to 8 bits).
* **Laser**: every beam that returned (range < ``range_max``) gets ``Normal(0, σ²)`` metres; beams with no return
  stay at ``range_max``.
* **Actuation** (the motion executed differs from the one commanded): the odometry motion model of Thrun, Burgard &
  Fox, *Probabilistic Robotics* (2005), table 5.6: a commanded SE(2) increment is split into a rotation
  ``δ_rot1``, a translation ``δ_trans`` and a rotation ``δ_rot2``; each gets zero-mean Gaussian noise of variance
  ``α₁·δ_rot1² + α₂·δ_trans²``, ``α₃·δ_trans² + α₄·(δ_rot1² + δ_rot2²)``, ``α₁·δ_rot2² + α₂·δ_trans²``.
* **Odometry** (dead-reckoning tasks only): :class:`benchbot.core.episode.OdometryNoise` with the preset's
  ``sigma_linear``/``sigma_angular`` instead of the task's default 0.1; ``none`` keeps the task's own model.

``none`` changes nothing: no draw is made and every observation and motion is what it was without presets. Ground
truth (poses served in ground-truth localisation, segmentation, the evaluated ground truth) never gets noise.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from benchbot.core.errors import UsageError

#: The simulator's sRGB encoding: a plain 2.2 gamma (``benchbot_worlds.scene.model.srgb_to_linear``).
GAMMA = 2.2

#: Every preset, by name: ``depth``, ``rgb``, ``laser``, ``actuation``, ``odometry`` (None: the task's own).
#: Units: metres, radians, electrons. docs/noise.md gives the source or reason of every number.
PRESETS: dict[str, dict[str, Any]] = {
    "none": {
        "depth": {"sigma0_m": 0.0, "k_per_m": 0.0, "z_min_m": 0.0, "dropout_p0": 0.0,
                  "fade_start_m": None, "fade_end_m": None},
        "rgb": None,
        "laser": {"sigma_m": 0.0},
        "actuation": {"alpha1": 0.0, "alpha2": 0.0, "alpha3": 0.0, "alpha4": 0.0},
        "odometry": None,
    },
    "low": {
        "depth": {"sigma0_m": 0.0005, "k_per_m": 0.0005, "z_min_m": 0.2, "dropout_p0": 0.002,
                  "fade_start_m": 8.0, "fade_end_m": 10.0},
        "rgb": {"full_well_e": 20000.0, "read_noise_e": 2.0},
        "laser": {"sigma_m": 0.005},
        "actuation": {"alpha1": 0.02 ** 2, "alpha2": 0.01 ** 2, "alpha3": 0.02 ** 2, "alpha4": 0.01 ** 2},
        "odometry": {"sigma_linear": 0.02, "sigma_angular": 0.02},
    },
    "realistic": {
        "depth": {"sigma0_m": 0.0, "k_per_m": 1.425e-3, "z_min_m": 0.5, "dropout_p0": 0.01,
                  "fade_start_m": 4.0, "fade_end_m": 5.0},
        "rgb": {"full_well_e": 5000.0, "read_noise_e": 3.0},
        "laser": {"sigma_m": 0.015},
        "actuation": {"alpha1": 0.05 ** 2, "alpha2": 0.02 ** 2, "alpha3": 0.05 ** 2, "alpha4": 0.02 ** 2},
        "odometry": {"sigma_linear": 0.05, "sigma_angular": 0.05},
    },
    "high": {
        "depth": {"sigma0_m": 0.0, "k_per_m": 0.01, "z_min_m": 0.6, "dropout_p0": 0.05,
                  "fade_start_m": 2.5, "fade_end_m": 4.0},
        "rgb": {"full_well_e": 1000.0, "read_noise_e": 6.0},
        "laser": {"sigma_m": 0.03},
        "actuation": {"alpha1": 0.1 ** 2, "alpha2": 0.04 ** 2, "alpha3": 0.1 ** 2, "alpha4": 0.04 ** 2},
        "odometry": {"sigma_linear": 0.1, "sigma_angular": 0.1},
    },
}

#: Streams of ``numpy.random.default_rng([seed, frame, stream])`` per sensor (distinct from the robot spec's own
#: ``sensors.noise`` streams 1-3, so the two never share draws).
STREAM_RGB, STREAM_DEPTH, STREAM_LASER, STREAM_ACTUATION = 11, 12, 13, 14


def preset_names() -> list[str]:
    """The preset names, from least to most noise: ``['none', 'low', 'realistic', 'high']``."""
    return list(PRESETS)


def get_preset(name: str, flag: str = "--noise") -> dict[str, Any]:
    """The parameters of preset ``name`` (a deep copy of :data:`PRESETS` ``[name]``).

    Raises:
        UsageError: an unknown name, in one line naming ``flag`` and the presets.
    """
    if name not in PRESETS:
        raise UsageError(f"{flag} '{name}' is not a noise preset", f"use one of {', '.join(PRESETS)} (docs/noise.md)")
    import copy

    return copy.deepcopy(PRESETS[name])


def is_none(name: str) -> bool:
    """True for the preset that changes nothing (``none``, or an empty name)."""
    return not name or name == "none"


# ------------------------------------------------------------------------------------------------------------ depth
def depth_sigma(z: np.ndarray, depth: dict) -> np.ndarray:
    """``σ(z) = σ₀ + k·z²`` (metres) of z-depths ``z`` (metres, any shape), with ``depth`` a preset's ``depth``."""
    z = np.asarray(z, dtype=np.float64)
    return depth["sigma0_m"] + depth["k_per_m"] * z * z


def depth_dropout_probability(z: np.ndarray, depth: dict) -> np.ndarray:
    """Probability (same shape as ``z``) that a pixel of z-depth ``z`` (metres) reads 0: 1 below ``z_min_m``,
    ``dropout_p0`` up to ``fade_start_m``, linear up to 1 at ``fade_end_m``, 1 beyond (no fade when
    ``fade_start_m`` is None)."""
    z = np.asarray(z, dtype=np.float64)
    p0, z0, z1 = depth["dropout_p0"], depth["fade_start_m"], depth["fade_end_m"]
    p = np.full(z.shape, float(p0))
    if z0 is not None:
        ramp = np.clip((z - z0) / max(z1 - z0, 1e-12), 0.0, 1.0)
        p = p0 + (1.0 - p0) * ramp
    return np.where(z < depth["z_min_m"], 1.0, p)


def add_depth_noise(depth_m: np.ndarray, depth: dict, rng: np.random.Generator) -> np.ndarray:
    """``depth_m`` (H, W) z-depths in metres (0: no hit) with range-dependent Gaussian error and dropout.

    Returns a new float32 array: pixels with no hit stay 0, dropped pixels are 0, the others are
    ``z + Normal(0, σ(z)²)`` (:func:`depth_sigma`), never below 0. Two draws per pixel (normal, then uniform), in
    that order, whatever the pixel.
    """
    z = np.asarray(depth_m, dtype=np.float64)
    valid = z > 0
    noisy = z + rng.standard_normal(z.shape) * depth_sigma(z, depth)
    drop = rng.random(z.shape) < depth_dropout_probability(z, depth)
    noisy = np.where(valid & ~drop, np.maximum(noisy, 0.0), 0.0)
    return noisy.astype(np.float32)


# ------------------------------------------------------------------------------------------------------------ RGB
def srgb_to_linear(rgb: np.ndarray) -> np.ndarray:
    """8-bit sRGB levels (any shape, 0..255) → linear intensity in [0, 1] (float64, :data:`GAMMA`)."""
    return (np.asarray(rgb, dtype=np.float64) / 255.0) ** GAMMA


def linear_to_srgb8(linear: np.ndarray) -> np.ndarray:
    """Linear intensity (clipped to [0, 1]) → 8-bit sRGB levels (uint8, rounded)."""
    return np.round(np.clip(linear, 0.0, 1.0) ** (1.0 / GAMMA) * 255.0).astype(np.uint8)


#: Electrons below which the shot noise is drawn from the Poisson distribution itself; from there up it is
#: ``Normal(N, N)`` (the normal approximation: same mean and variance, skewness 1/√N ≤ 0.1), ~10× faster.
POISSON_EXACT_BELOW_E = 100.0


def photon_noise(linear: np.ndarray, rgb: dict, rng: np.random.Generator) -> np.ndarray:
    """Poisson-Gaussian sensor noise on linear intensities ``linear`` (any shape, [0, 1]): ``N = linear ·
    full_well_e`` electrons become ``Poisson(N) + Normal(0, read_noise_e²)`` (Poisson drawn exactly below
    :data:`POISSON_EXACT_BELOW_E` electrons, as ``Normal(N, N)`` above), returned as intensity (float64, not
    clipped): mean ``linear``, variance ``(linear·full_well_e + read_noise_e²) / full_well_e²``."""
    fw, read = rgb["full_well_e"], rgb["read_noise_e"]
    electrons = np.clip(np.asarray(linear, dtype=np.float64), 0.0, None) * fw
    noisy = electrons + rng.standard_normal(electrons.shape) * np.sqrt(electrons + read * read)
    small = electrons < POISSON_EXACT_BELOW_E
    if small.any():
        few = electrons[small]
        noisy[small] = rng.poisson(few) + rng.standard_normal(few.shape) * read
    return noisy / fw


def add_rgb_noise(image: np.ndarray, rgb: dict | None, rng: np.random.Generator) -> np.ndarray:
    """``image`` (H, W, 3) uint8 sRGB with :func:`photon_noise` applied in linear light; a new uint8 array (the
    image itself when ``rgb`` is None)."""
    if rgb is None:
        return image
    return linear_to_srgb8(photon_noise(srgb_to_linear(image), rgb, rng))


# ------------------------------------------------------------------------------------------------------------ laser
def add_laser_noise(ranges: np.ndarray, laser: dict, range_max: float, rng: np.random.Generator) -> np.ndarray:
    """``ranges`` (N,) metres with ``Normal(0, sigma_m²)`` on every beam that returned (``< range_max``), clipped
    to [0, range_max]; beams at ``range_max`` (no return) are kept. A new float64 array."""
    r = np.asarray(ranges, dtype=np.float64)
    noisy = r + rng.standard_normal(r.shape) * laser["sigma_m"]
    return np.where(r < range_max, np.clip(noisy, 0.0, range_max), r)


# ------------------------------------------------------------------------------------------------------------ motion
def split_motion(increment: np.ndarray) -> tuple[float, float, float]:
    """``(δ_rot1, δ_trans, δ_rot2)`` of an SE(2) increment ``[dx m, dy m, dyaw rad]`` (in the frame of the start
    pose): turn towards the end point, drive straight, turn to the end heading. A pure rotation (no
    translation) is ``(0, 0, dyaw)``."""
    dx, dy, dyaw = (float(v) for v in increment)
    trans = math.hypot(dx, dy)
    rot1 = math.atan2(dy, dx) if trans > 1e-9 else 0.0
    return rot1, trans, _wrap(dyaw - rot1)


def join_motion(rot1: float, trans: float, rot2: float) -> np.ndarray:
    """The SE(2) increment ``[dx, dy, dyaw]`` of ``(δ_rot1, δ_trans, δ_rot2)`` (inverse of :func:`split_motion`)."""
    return np.array([trans * math.cos(rot1), trans * math.sin(rot1), _wrap(rot1 + rot2)])


def actuation_sigmas(rot1: float, trans: float, rot2: float, actuation: dict) -> tuple[float, float, float]:
    """Standard deviations (rad, m, rad) of the noise on ``(δ_rot1, δ_trans, δ_rot2)`` (Thrun et al. 2005,
    table 5.6)."""
    a1, a2, a3, a4 = (actuation[k] for k in ("alpha1", "alpha2", "alpha3", "alpha4"))
    return (math.sqrt(a1 * rot1 ** 2 + a2 * trans ** 2), math.sqrt(a3 * trans ** 2 + a4 * (rot1 ** 2 + rot2 ** 2)),
            math.sqrt(a1 * rot2 ** 2 + a2 * trans ** 2))


def sample_actuation(increment: np.ndarray, actuation: dict, rng: np.random.Generator) -> np.ndarray:
    """The increment (3,) ``[dx m, dy m, dyaw rad]`` a robot executes when commanded ``increment``: each of
    ``(δ_rot1, δ_trans, δ_rot2)`` plus zero-mean Gaussian noise of :func:`actuation_sigmas`. Three normal draws,
    always."""
    rot1, trans, rot2 = split_motion(increment)
    s1, st, s2 = actuation_sigmas(rot1, trans, rot2, actuation)
    n = rng.standard_normal(3)
    return join_motion(rot1 + s1 * n[0], trans + st * n[1], rot2 + s2 * n[2])


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi
