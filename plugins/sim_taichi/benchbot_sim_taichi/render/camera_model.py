"""The camera model: how the renderer's linear radiance becomes an 8-bit sRGB image.

A pixel's linear radiance ``L`` (per channel, the renderer's units: 1 is a white surface under the reference light)
goes through, in order:

1. **vignetting** — ``L · (1 − v · (1 − cos⁴ θ))``, θ the angle between the pixel's ray and the optical axis,
   ``cos² θ = 1 / (1 + ((u − cx)/fx)² + ((v − cy)/fy)²)`` (the natural cos⁴ fall-off of a lens; ``v`` in 0..1 scales
   it, 0: none, 1: the whole fall-off);
2. **exposure** — ``× g · 2^exposure_ev`` (stops; +1 doubles the light). ``g`` is 1, except in quality mode with
   ``auto_exposure``: there the camera meters each frame, as a real camera's auto-exposure does, because the path
   tracer's light is physical and varies severalfold between homes (a daylit room without lamps, a room under its
   lamps at night), where fast mode's light has a fill that keeps its frames exposed. ``g = key / L̄``, ``L̄`` the
   log-average luminance ``exp(mean(log(δ + Y)))`` of the frame's radiance (before vignetting) on a grid of every
   :data:`METER_STRIDE`-th pixel, ``Y`` the Rec. 709 luminance, key :data:`METER_KEY` = 0.18 and ``δ`` =
   :data:`METER_DELTA` (E. Reinhard et al., "Photographic Tone Reproduction for Digital Images", SIGGRAPH 2002,
   eq. 1 and 2), clamped to ±:data:`METER_RANGE_EV` stops; ``exposure_ev`` then biases it (exposure
   compensation);
3. **tone curve** — ``clip``: ``min(x, 1)``, highlights saturate (the renderer's original look); ``filmic``: the
   ACES filmic curve as fitted by K. Narkowicz ("ACES Filmic Tone Mapping Curve", 2016),
   ``x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)``, which rolls highlights off instead of clipping them;
4. **encoding** — ``round(255 · y^(1/2.2))``.

The default (no vignetting, 0 EV, ``clip``, no auto-exposure) is the renderer's image as it always was, bit for
bit. The kernels apply steps 1–4 through :func:`tone_table` (a lookup table indexed by ``sqrt(L' / radiance_max)``)
and two frame constants (:meth:`CameraModel.frame_constants`); :meth:`CameraModel.encode` is the same model in NumPy
(quality mode, tests).
Shot and read noise are the noise presets' (``benchbot.core.noise``), applied to the encoded image by the backend.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from benchbot_worlds.scene.model import LUMA_709

#: Tone curves (see the module doc).
TONE_CURVES = ("clip", "filmic")
#: Exposure-scaled radiance at which the filmic curve is taken as 1 (its value there is above 0.999 … 1.02).
FILMIC_WHITE = 16.0
#: Entries of the tone table (it is indexed by the square root of the radiance, so dark values get most entries).
TABLE_STEPS = 4096
GAMMA = 1.0 / 2.2
#: Auto-exposure (quality mode): the log-average luminance maps to this value before the tone curve (Reinhard et
#: al. 2002's "key" of a normal scene, middle grey).
METER_KEY = 0.18
#: Auto-exposure: the meter reads every METER_STRIDE-th pixel of every METER_STRIDE-th row, from METER_OFFSET.
METER_STRIDE = 8
METER_OFFSET = METER_STRIDE // 2
#: Auto-exposure: added to the luminance before its logarithm, so that black pixels do not rule the mean.
METER_DELTA = 1e-4
#: Auto-exposure: the meter's gain stays within ±METER_RANGE_EV stops of 1.
METER_RANGE_EV = 8.0


def aces_filmic(x: np.ndarray) -> np.ndarray:
    """Narkowicz's fit of the ACES filmic curve, clamped to 0..1 (float64 array of ``x``'s shape; ``x`` ≥ 0)."""
    x = np.asarray(x, dtype=np.float64)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


@dataclass(frozen=True)
class CameraModel:
    """Exposure, tone curve, vignetting and auto-exposure of a simulated camera (the robot spec's
    ``sensors.camera.exposure_ev``, ``tone_curve``, ``vignetting`` and ``auto_exposure``).

    Attributes:
        exposure_ev: exposure in stops, finite (0: as rendered); with ``auto_exposure``, the compensation added to
            the metered exposure.
        tone_curve: one of :data:`TONE_CURVES`.
        vignetting: 0..1, the share of the cos⁴ fall-off applied.
        auto_exposure: quality mode meters each frame's exposure (the module doc, step 2); fast mode ignores it.

    Raises:
        ValueError: a value outside those ranges (the backend's schema refuses them first, naming the field).
    """

    exposure_ev: float = 0.0
    tone_curve: str = "clip"
    vignetting: float = 0.0
    auto_exposure: bool = False

    def __post_init__(self) -> None:
        if not np.isfinite(self.exposure_ev):
            raise ValueError(f"exposure_ev must be finite, got {self.exposure_ev}")
        if self.tone_curve not in TONE_CURVES:
            raise ValueError(f"tone_curve must be one of {TONE_CURVES}, got {self.tone_curve!r}")
        if not 0.0 <= self.vignetting <= 1.0:
            raise ValueError(f"vignetting must be within 0..1, got {self.vignetting}")

    @property
    def radiance_max(self) -> float:
        """The linear radiance (after vignetting, before exposure) that maps to 255: ``2^−EV`` (``clip``) or
        ``FILMIC_WHITE · 2^−EV`` (``filmic``)."""
        white = 1.0 if self.tone_curve == "clip" else FILMIC_WHITE
        return float(white * 2.0 ** -self.exposure_ev)

    def frame_constants(self) -> np.ndarray:
        """(2,) float64 ``[1 / radiance_max, vignetting]``: what the kernels read besides :func:`tone_table`."""
        return np.array([1.0 / self.radiance_max, self.vignetting])

    def kernel_params(self, K: np.ndarray, gain: float = 1.0) -> np.ndarray:
        """(8,) float64 ``[gain · 2^exposure_ev, 1 if filmic else 0, vignetting, fx, fy, cx, cy, 0]`` for the
        intrinsics ``K`` (3, 3, pixels) and the metered ``gain`` (:meth:`metered_gain`; 1: none): the arguments of
        ``pathtrace.encode_kernel``, this model on the GPU."""
        K = np.asarray(K, dtype=np.float64)
        return np.array([self._scale(gain), 1.0 if self.tone_curve == "filmic" else 0.0, self.vignetting,
                         K[0, 0], K[1, 1], K[0, 2], K[1, 2], 0.0])

    def _scale(self, gain: float) -> float:
        """The factor of step 2: ``gain · 2^exposure_ev`` (float64, computed the same way for both paths)."""
        return float(gain) * 2.0 ** self.exposure_ev

    @staticmethod
    def meter_sample(radiance: np.ndarray) -> np.ndarray:
        """The pixels the meter reads: ``radiance[METER_OFFSET::METER_STRIDE, METER_OFFSET::METER_STRIDE]`` of an
        (H, W, 3) linear radiance (a view). ``pathtrace.meter_sample_kernel`` gathers the same pixels on a device."""
        return radiance[METER_OFFSET::METER_STRIDE, METER_OFFSET::METER_STRIDE]

    @staticmethod
    def meter_shape(height: int, width: int) -> tuple[int, int]:
        """(rows, columns) of :meth:`meter_sample` for an image of ``height`` × ``width`` pixels (either may be 0,
        for an image too small to meter)."""
        return len(range(METER_OFFSET, height, METER_STRIDE)), len(range(METER_OFFSET, width, METER_STRIDE))

    def metered_gain(self, sample: np.ndarray) -> float:
        """The auto-exposure gain ``g`` of step 2 for the meter's pixels ``sample`` ((h, w, 3) linear radiance,
        :meth:`meter_sample`): ``METER_KEY / exp(mean(log(METER_DELTA + Y)))`` clamped to ±``METER_RANGE_EV`` stops,
        in float64 (the same on every device). 1.0 without ``auto_exposure`` or without pixels."""
        sample = np.asarray(sample, dtype=np.float64)
        if not self.auto_exposure or sample.size == 0:
            return 1.0
        luma = np.maximum(sample.reshape(-1, 3) @ np.asarray(LUMA_709, dtype=np.float64), 0.0)
        log_average = float(np.exp(np.mean(np.log(METER_DELTA + luma))))
        return float(np.clip(METER_KEY / log_average, 2.0 ** -METER_RANGE_EV, 2.0 ** METER_RANGE_EV))

    def vignette(self, K: np.ndarray, width: int, height: int) -> np.ndarray:
        """(height, width) float64 factor of step 1 for the pinhole intrinsics ``K`` (3, 3, pixels; integer pixel
        centres)."""
        v, u = np.mgrid[0:height, 0:width].astype(np.float64)
        cos2 = 1.0 / (1.0 + ((u - K[0, 2]) / K[0, 0]) ** 2 + ((v - K[1, 2]) / K[1, 1]) ** 2)
        return 1.0 - self.vignetting * (1.0 - cos2 * cos2)

    def encode(self, radiance: np.ndarray, K: np.ndarray, gain: float | None = None) -> np.ndarray:
        """Steps 1–4 in NumPy, exactly (no table).

        Args:
            radiance: (H, W, 3) linear radiance, any float dtype.
            K: (3, 3) intrinsics of the image (for the vignetting).
            gain: step 2's metered gain; None: metered from ``radiance`` itself (:meth:`metered_gain`, 1 without
                ``auto_exposure``).

        Returns:
            (H, W, 3) uint8 sRGB (gamma 2.2).
        """
        if gain is None:
            gain = self.metered_gain(self.meter_sample(np.asarray(radiance)))
        lin = np.asarray(radiance, dtype=np.float64)
        if self.vignetting > 0.0:
            lin = lin * self.vignette(K, lin.shape[1], lin.shape[0])[..., None]
        x = np.maximum(lin, 0.0) * self._scale(gain)
        y = np.minimum(x, 1.0) if self.tone_curve == "clip" else aces_filmic(x)
        return np.floor(np.power(y, GAMMA) * 255.0 + 0.5).astype(np.uint8)


    def decode(self, rgb: np.ndarray, gain: float = 1.0) -> np.ndarray:
        """The inverse of steps 2–4: the linear radiance (after vignetting) that :meth:`encode` maps to each 8-bit
        value of ``rgb``, so that ``encode(decode(v)) == v`` for every value (no vignetting, the same ``gain``).

        Args:
            rgb: (..., 3) uint8 sRGB (gamma 2.2) as this camera encoded it.
            gain: step 2's metered gain (1: fast mode, which does not meter).

        Returns:
            float64 array of ``rgb``'s shape. A saturated value (255) decodes to the least radiance that saturates.
        """
        y = np.power(np.asarray(rgb, dtype=np.float64) / 255.0, 1.0 / GAMMA)
        if self.tone_curve == "clip":
            x = y
        else:  # aces_filmic's fit solved for x: (2.43y − 2.51)x² + (0.59y − 0.03)x + 0.14y = 0, its root ≥ 0
            a, b, c = 2.43 * y - 2.51, 0.59 * y - 0.03, 0.14 * y
            x = (-b - np.sqrt(b * b - 4.0 * a * c)) / (2.0 * a)
        return x / self._scale(gain)


@functools.lru_cache(maxsize=16)
def tone_table(camera: CameraModel = CameraModel()) -> np.ndarray:
    """(TABLE_STEPS,) float64 (cached: do not modify): entry i is the 8-bit value of linear radiance
    ``s² · radiance_max`` with ``s = i / (TABLE_STEPS − 1)``, through the exposure and the tone curve (steps 2–4).
    Indexed by ``sqrt(L / radiance_max)``: nearly linear in the output, so the nearest entry is within one 8-bit
    level of :meth:`CameraModel.encode`; for the default camera it is ``round(255 · s^(2/2.2))`` exactly, the table
    the renderer always used."""
    s = np.linspace(0.0, 1.0, TABLE_STEPS)
    if camera.tone_curve == "clip":
        y = s * s  # radiance_max · 2^EV = 1
    else:
        y = aces_filmic(s * s * FILMIC_WHITE)
    return np.floor(np.power(y, GAMMA) * 255.0 + 0.5)
