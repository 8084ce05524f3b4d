"""Procedural surface textures for the furnished homes' floors, walls and ceilings (pure NumPy, seeded).

Each texture is an (H, W, 3) uint8 sRGB image that tiles seamlessly (every noise term is periodic over the image) and
covers :data:`TILE_SIZE_M` metres of surface per repeat. Room kinds choose the materials (:func:`room_materials`):
wood planks or carpet in living rooms, bedrooms and offices, ceramic tiles in kitchens and bathrooms, painted plaster
on walls (a colour per room), white plaster on ceilings, white painted skirting.

The images are made here rather than shipped because they are cheap to make and add nothing to the package.
"""

from __future__ import annotations

import functools

import numpy as np

#: Texture side in pixels (square, a power of two so every mip level halves exactly).
TEXTURE_PX = 256

#: Metres of surface covered by one repeat of each texture.
TILE_SIZE_M = {"wood": 1.6, "tile": 0.9, "carpet": 1.2, "plaster": 2.0, "ceiling": 2.0, "skirting": 1.0,
               "exterior": 2.0}

#: Surface kinds :func:`surface_texture` knows.
SURFACE_KINDS = tuple(TILE_SIZE_M)

# sRGB base colours (0..255).
_WOOD = ((150, 104, 64), (122, 84, 52), (172, 128, 84))
_TILE = ((226, 224, 218), (200, 206, 210), (214, 204, 186))
_CARPET = ((120, 110, 100), (92, 104, 122), (140, 126, 108))
_PAINT = ((232, 228, 216), (222, 216, 198), (206, 214, 212), (230, 222, 210), (214, 210, 222))


def _periodic_noise(rng: np.random.Generator, size: int, cells: int, cells_x: int | None = None) -> np.ndarray:
    """(size, size) float64 value noise in [0, 1] that tiles: random values on a periodic grid of ``cells`` rows ×
    ``cells_x`` (default ``cells``) columns, interpolated with smoothstep weights across the image."""
    cx = cells if cells_x is None else cells_x

    def axis(c):
        t = np.arange(size) * c / size
        i0 = np.floor(t).astype(int)
        f = t - i0
        return i0, (i0 + 1) % c, f * f * (3 - 2 * f)

    grid = rng.random((cells, cx))
    r0, r1, fy = axis(cells)
    c0, c1, fx = axis(cx)
    a = grid[np.ix_(r0, c0)] * (1 - fx)[None, :] + grid[np.ix_(r0, c1)] * fx[None, :]
    b = grid[np.ix_(r1, c0)] * (1 - fx)[None, :] + grid[np.ix_(r1, c1)] * fx[None, :]
    return a * (1 - fy)[:, None] + b * fy[:, None]


def _fbm(rng: np.random.Generator, size: int, octaves=(4, 8, 16, 32, 64)) -> np.ndarray:
    """(size, size) float64 fractal noise (sum of periodic octaves, halving amplitude), normalised to [0, 1]."""
    out = np.zeros((size, size))
    amp = 1.0
    for cells in octaves:
        out += amp * _periodic_noise(rng, size, cells)
        amp *= 0.5
    return (out - out.min()) / max(out.max() - out.min(), 1e-9)


def _wood(rng, n):
    base = np.asarray(_WOOD[int(rng.integers(len(_WOOD)))], float)
    planks = 5  # planks across one repeat (along v); each has its own tone and grain offset
    v = np.arange(n)[:, None] * planks / n
    plank = np.floor(v).astype(int) % planks
    tone = rng.uniform(0.82, 1.12, planks)[plank]
    grain = _periodic_noise(rng, n, 64)
    stretched = _periodic_noise(rng, n, 64, 4)  # grain runs along the planks (u), varies fast across them (v)
    rings = 0.5 + 0.5 * np.sin(2 * np.pi * (np.arange(n)[None, :] / n * 3 + 6 * stretched + plank * 0.37))
    shade = tone * (0.88 + 0.10 * rings + 0.06 * (grain - 0.5))
    # Joints between planks and staggered butt joints.
    seam = (np.abs(v - np.round(v)) * n / planks < 0.9)
    offs = rng.random(planks)[plank]
    u = (np.arange(n)[None, :] / n + offs) % 1.0
    butt = (np.minimum(u, 1 - u) * n < 0.9)
    shade = np.where(seam | butt, shade * 0.55, shade)
    return base[None, None, :] * shade[..., None]


def _tile(rng, n):
    base = np.asarray(_TILE[int(rng.integers(len(_TILE)))], float)
    tiles = 3
    x = np.arange(n) * tiles / n
    frac = x - np.floor(x)
    grout1 = np.minimum(frac, 1 - frac) * n / tiles < 1.6
    grout = grout1[:, None] | grout1[None, :]
    ti = np.floor(x).astype(int)
    tone = rng.uniform(0.95, 1.04, (tiles, tiles))[np.ix_(ti, ti)]
    speckle = 0.97 + 0.05 * _fbm(rng, n, (16, 32, 64))
    img = base[None, None, :] * (tone * speckle)[..., None]
    return np.where(grout[..., None], np.asarray([150, 148, 142], float)[None, None, :], img)


def _carpet(rng, n):
    base = np.asarray(_CARPET[int(rng.integers(len(_CARPET)))], float)
    fibre = rng.random((n, n))
    shade = 0.86 + 0.12 * _fbm(rng, n, (8, 16, 32)) + 0.10 * (fibre - 0.5)
    return base[None, None, :] * shade[..., None]


def _plaster(rng, n, colour):
    shade = 0.975 + 0.035 * _fbm(rng, n, (4, 8, 16, 32, 64))
    return np.asarray(colour, float)[None, None, :] * shade[..., None]


@functools.lru_cache(maxsize=64)
def surface_texture(kind: str, seed: int = 0) -> np.ndarray:
    """A seamless (TEXTURE_PX, TEXTURE_PX, 3) uint8 sRGB texture of a surface kind (cached: do not modify).

    Args:
        kind: one of :data:`SURFACE_KINDS`.
        seed: picks the colour variant and the noise; the same (kind, seed) gives the same image.

    Raises:
        ValueError: unknown ``kind``.
    """
    if kind not in TILE_SIZE_M:
        raise ValueError(f"unknown surface kind {kind!r}; known: {', '.join(SURFACE_KINDS)}")
    rng = np.random.default_rng([seed, SURFACE_KINDS.index(kind)])
    n = TEXTURE_PX
    if kind == "wood":
        img = _wood(rng, n)
    elif kind == "tile":
        img = _tile(rng, n)
    elif kind == "carpet":
        img = _carpet(rng, n)
    elif kind == "plaster":
        img = _plaster(rng, n, _PAINT[int(rng.integers(len(_PAINT)))])
    elif kind == "ceiling":
        img = _plaster(rng, n, (240, 240, 236))
    elif kind == "exterior":
        img = _plaster(rng, n, (196, 190, 180))
    else:  # skirting: white gloss paint
        img = _plaster(rng, n, (236, 234, 228))
    out = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    out.setflags(write=False)
    return out


#: Floor surface per room kind (first choice, alternative); see :func:`room_materials`.
_FLOOR = {"kitchen": ("tile", "tile"), "bathroom": ("tile", "tile"), "bedroom": ("carpet", "wood"),
          "living_room": ("wood", "carpet"), "office": ("carpet", "wood"), "hall": ("wood", "tile")}


def room_materials(room_kind: str, seed: int = 0) -> dict[str, tuple[str, int]]:
    """The surfaces of a room: ``{"floor": (kind, texture seed), "wall": …, "ceiling": …, "skirting": …}``.

    Kitchens and bathrooms get tiles; bedrooms and offices carpet or wood; living rooms and halls wood (or carpet /
    tile); walls a painted plaster whose colour varies per room (through the texture seed). Unknown room kinds are
    treated as halls. Deterministic in (room_kind, seed).
    """
    rng = np.random.default_rng([seed, sum(map(ord, room_kind))])
    first, alt = _FLOOR.get(room_kind, _FLOOR["hall"])
    floor = first if rng.random() < 0.7 else alt
    return {"floor": (floor, int(rng.integers(1 << 16))), "wall": ("plaster", int(rng.integers(1 << 16))),
            "ceiling": ("ceiling", 0), "skirting": ("skirting", 0)}
