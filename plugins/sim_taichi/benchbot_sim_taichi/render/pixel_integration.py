"""Pixel integration: a camera's pixel integrates the light that falls on its area, where a ray tracer that shades
one ray through each pixel's centre samples it at a point (aliasing: jagged edges, shimmering thin legs and fine
texture). The robot spec's ``sensors.camera.samples_per_pixel`` (1, 4, 9 or 16: an n × n grid of sub-pixels)
makes the simulated sensor integrate: fast mode renders the RGB image at n times the width and height, with the
intrinsics of :func:`subpixel_intrinsics` (the n × n sub-pixels of a block tile exactly the area of one pixel), and
:func:`integrate` averages each block in the camera's linear radiance before the camera's tone curve encodes it
again. Depth, segmentation and the laser stay those of each pixel's centre (one ray, as before). The averaging runs
in NumPy on the host, so a setting gives the same images whichever device rendered the sub-pixels.

1 (the default) is the image as it always was; 4 costs about four times the shading (docs/simulator.md,
*Pixel integration*).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from benchbot_sim_taichi.render.camera_model import CameraModel

#: The values ``samples_per_pixel`` may take: square grids of 1 to 4 sub-pixels a side.
SAMPLES_PER_PIXEL = (1, 4, 9, 16)


def grid_side(samples_per_pixel: int) -> int:
    """n for an n × n grid of ``samples_per_pixel`` sub-pixels.

    Raises:
        ValueError: ``samples_per_pixel`` is not one of :data:`SAMPLES_PER_PIXEL`.
    """
    if samples_per_pixel not in SAMPLES_PER_PIXEL:
        raise ValueError(f"samples_per_pixel must be one of {SAMPLES_PER_PIXEL}, got {samples_per_pixel!r}")
    return math.isqrt(samples_per_pixel)


def subpixel_intrinsics(K: np.ndarray, n: int) -> np.ndarray:
    """(3, 3) float64 pinhole intrinsics of the image n times as wide and as high as the one of ``K`` (3, 3,
    pixels, pixel centres on integers) covering the same view: ``fx, fy`` times n and the principal point at
    ``n · (c + 0.5) − 0.5``, so that the sub-pixels ``(n·u + i, n·v + j)``, i, j in 0..n−1, tile pixel (u, v)."""
    K = np.asarray(K, dtype=np.float64)
    out = K.copy()
    out[0, 0], out[1, 1] = n * K[0, 0], n * K[1, 1]
    out[0, 2], out[1, 2] = n * (K[0, 2] + 0.5) - 0.5, n * (K[1, 2] + 0.5) - 0.5
    return out


@functools.lru_cache(maxsize=16)
def decode_table(camera: CameraModel) -> np.ndarray:
    """(256,) float32, read-only: :meth:`CameraModel.decode` of every 8-bit value for ``camera`` (fast mode, gain 1)."""
    table = camera.decode(np.arange(256, dtype=np.uint8)).astype(np.float32)
    table.flags.writeable = False
    return table


def integrate(subpixels: np.ndarray, n: int, camera: CameraModel) -> np.ndarray:
    """Each pixel's n × n block of ``subpixels`` ((n·H, n·W, 3) uint8, encoded by ``camera`` in fast mode, with its
    vignetting already applied) averaged in linear radiance (:meth:`CameraModel.decode`) and encoded again by the
    same camera without vignetting (the sub-pixels carry it).

    Returns:
        (H, W, 3) uint8. A block of one value keeps that value.

    Raises:
        ValueError: the image does not split into n × n blocks.
    """
    if n < 1 or subpixels.ndim != 3 or subpixels.shape[0] % n or subpixels.shape[1] % n:
        raise ValueError(f"integrate: a {subpixels.shape} image does not split into {n} x {n} blocks")
    if n == 1:
        return np.array(subpixels, dtype=np.uint8)
    H, W = subpixels.shape[0] // n, subpixels.shape[1] // n
    # each of the 256 values decoded once per camera, then looked up (n²·H·W·3 powers and roots otherwise), in
    # float32 and summed in float64
    mean = decode_table(camera)[subpixels].reshape(H, n, W, n, 3).sum(axis=(1, 3), dtype=np.float64) / (n * n)
    flat = dataclasses.replace(camera, vignetting=0.0)
    return flat.encode(mean, np.eye(3), gain=1.0)
