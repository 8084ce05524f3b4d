"""The camera model: how the renderer's linear radiance becomes an 8-bit sRGB image.

A pixel's linear radiance ``L`` (per channel, the renderer's units: 1 is a white surface under the reference light)
goes through, in order:

1. **vignetting** — ``L · (1 − v · (1 − cos⁴ θ))``, θ the angle between the pixel's ray and the optical axis,
   ``cos² θ = 1 / (1 + ((u − cx)/fx)² + ((v − cy)/fy)²)`` (the natural cos⁴ fall-off of a lens; ``v`` in 0..1 scales
   it, 0: none, 1: the whole fall-off);
2. **exposure** — ``× 2^exposure_ev`` (stops; +1 doubles the light);
3. **tone curve** — ``clip``: ``min(x, 1)``, highlights saturate (the renderer's original look); ``filmic``: the
   ACES filmic curve as fitted by K. Narkowicz ("ACES Filmic Tone Mapping Curve", 2016),
   ``x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)``, which rolls highlights off instead of clipping them;
4. **encoding** — ``round(255 · y^(1/2.2))``.

The default (no vignetting, 0 EV, ``clip``) is the renderer's image as it always was, bit for bit. The kernels apply
steps 1–4 through :func:`tone_table` (a lookup table indexed by ``sqrt(L' / radiance_max)``) and two frame constants
(:meth:`CameraModel.frame_constants`); :meth:`CameraModel.encode` is the same model in NumPy (quality mode, tests).
Shot and read noise are the noise presets' (``benchbot.core.noise``), applied to the encoded image by the backend.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

#: Tone curves (see the module doc).
TONE_CURVES = ("clip", "filmic")
#: Exposure-scaled radiance at which the filmic curve is taken as 1 (its value there is above 0.999 … 1.02).
FILMIC_WHITE = 16.0
#: Entries of the tone table (it is indexed by the square root of the radiance, so dark values get most entries).
TABLE_STEPS = 4096
GAMMA = 1.0 / 2.2


def aces_filmic(x: np.ndarray) -> np.ndarray:
    """Narkowicz's fit of the ACES filmic curve, clamped to 0..1 (float64 array of ``x``'s shape; ``x`` ≥ 0)."""
    x = np.asarray(x, dtype=np.float64)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


@dataclass(frozen=True)
class CameraModel:
    """Exposure, tone curve and vignetting of a simulated camera (the robot spec's ``sensors.camera.exposure_ev``,
    ``tone_curve`` and ``vignetting``).

    Attributes:
        exposure_ev: exposure in stops, finite (0: as rendered).
        tone_curve: one of :data:`TONE_CURVES`.
        vignetting: 0..1, the share of the cos⁴ fall-off applied.

    Raises:
        ValueError: a value outside those ranges (the backend's schema refuses them first, naming the field).
    """

    exposure_ev: float = 0.0
    tone_curve: str = "clip"
    vignetting: float = 0.0

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

    def kernel_params(self, K: np.ndarray) -> np.ndarray:
        """(8,) float64 ``[2^exposure_ev, 1 if filmic else 0, vignetting, fx, fy, cx, cy, 0]`` for the intrinsics
        ``K`` (3, 3, pixels): the arguments of ``pathtrace.encode_kernel``, this model on the GPU."""
        K = np.asarray(K, dtype=np.float64)
        return np.array([2.0 ** self.exposure_ev, 1.0 if self.tone_curve == "filmic" else 0.0, self.vignetting,
                         K[0, 0], K[1, 1], K[0, 2], K[1, 2], 0.0])

    def vignette(self, K: np.ndarray, width: int, height: int) -> np.ndarray:
        """(height, width) float64 factor of step 1 for the pinhole intrinsics ``K`` (3, 3, pixels; integer pixel
        centres)."""
        v, u = np.mgrid[0:height, 0:width].astype(np.float64)
        cos2 = 1.0 / (1.0 + ((u - K[0, 2]) / K[0, 0]) ** 2 + ((v - K[1, 2]) / K[1, 1]) ** 2)
        return 1.0 - self.vignetting * (1.0 - cos2 * cos2)

    def encode(self, radiance: np.ndarray, K: np.ndarray) -> np.ndarray:
        """Steps 1–4 in NumPy, exactly (no table).

        Args:
            radiance: (H, W, 3) linear radiance, any float dtype.
            K: (3, 3) intrinsics of the image (for the vignetting).

        Returns:
            (H, W, 3) uint8 sRGB (gamma 2.2).
        """
        lin = np.asarray(radiance, dtype=np.float64)
        if self.vignetting > 0.0:
            lin = lin * self.vignette(K, lin.shape[1], lin.shape[0])[..., None]
        x = np.maximum(lin, 0.0) * 2.0 ** self.exposure_ev
        y = np.minimum(x, 1.0) if self.tone_curve == "clip" else aces_filmic(x)
        return np.floor(np.power(y, GAMMA) * 255.0 + 0.5).astype(np.uint8)


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
