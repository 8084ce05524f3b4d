"""Computer keyboards made in code for ``keyboard`` cuboids (pure NumPy; the meshes are
:class:`~benchbot_worlds.scene.meshes.MeshData`).

A keyboard is a low case whose top slopes up toward its back (as a keyboard on its feet does) and carries the keys:
a texture of key caps on a standard layout, in rows of 1-unit keys (a unit, ``u``, is a key's pitch) with the wider
keys of a real keyboard (tab, caps lock, shift, enter, backspace, the space bar), the function row apart at the back,
and, where the cuboid is wide enough for them, the navigation keys and the numeric keypad (:data:`LAYOUTS`; the one
whose width-to-depth ratio is nearest the cuboid's is drawn, so keys stay near square). Each cap is lit on its top,
with its front face (toward the typist, which the robot's camera sees from 1.05 m) in shadow and dark gaps between
the caps; letter keys carry a small legend. Two styles of real keyboards (:data:`STYLES`): black plastic, and white
or silver with light keys; the style is drawn per keyboard.

The model the asset pack has for the class (a desktop computer's keyboard, its keys geometry a few millimetres
apart) was drawn at one sample a pixel as an irregular pattern of black blots, which no COCO detector of
``benchmarks/realism.py`` took for a keyboard in the procedural homes (0 of 10 views; docs/realism.md, 29 Nov 2026).
A texture's mip levels keep the keys a regular grid at any distance.

Meshes (:func:`keyboard_mesh`) are unit keyboards in a model's map frame (x across its width and y across its depth
in −0.5..0.5, z in 0..1, the typist's side at −y, the model's front), stretched into the cuboid by
:func:`~benchbot_worlds.homes.fitting.fit_to_cuboid`. The ground truth is not changed.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from benchbot_worlds.homes.fitting import fit_to_cuboid, front_of
from benchbot_worlds.scene.meshes import Material, MeshData, _srgb_to_linear, quad_mesh

__all__ = ["BLACK_SHARE", "FRONT_HEIGHT", "LAYOUTS", "STYLES", "UNIT_BOUNDS", "KeyboardStyle", "key_texture",
           "keyboard", "keyboard_mesh", "layout_keys"]

#: Bounds of the unit keyboard of :func:`keyboard_mesh` (its model frame).
UNIT_BOUNDS = np.array([[-0.5, -0.5, 0.0], [0.5, 0.5, 1.0]])
#: Height of the top's front edge, a fraction of the back's: the top slopes up toward the back.
FRONT_HEIGHT = 0.6
#: Texture pixels per key unit.
_PX_PER_U = 16
#: Margin of case around the keys (key units).
_MARGIN_U = 0.5

#: Rows of the main block, front row last: (width in key units, has a legend) per key; every row is 15 units.
_MAIN_ROWS = (
    [(1.0, True)] * 13 + [(2.0, False)],
    [(1.5, False)] + [(1.0, True)] * 12 + [(1.5, False)],
    [(1.75, False)] + [(1.0, True)] * 11 + [(2.25, False)],
    [(2.25, False)] + [(1.0, True)] * 10 + [(2.75, False)],
    [(1.25, False)] * 3 + [(6.25, False)] + [(1.25, False)] * 4,
)
#: The layouts (name → width in key units, navigation keys, numeric keypad): compact (the main block), tenkeyless,
#: full size. Depth is always 7.5 units (the function row, half a unit apart, five rows, margins).
LAYOUTS = {"compact": (16.0, False, False), "tenkeyless": (19.5, True, False), "full": (24.0, True, True)}
_DEPTH_U = 7.5


class KeyboardStyle(NamedTuple):
    """A keyboard's colours (sRGB, 0..1): its case, the gaps between caps, the cap tops, the caps' shadowed fronts,
    the legends; and its roughness (0..1)."""

    case: tuple[float, float, float]
    gap: tuple[float, float, float]
    cap: tuple[float, float, float]
    front: tuple[float, float, float]
    legend: tuple[float, float, float]
    roughness: float


#: The styles. Black plastic reflects about 4 % (sRGB ≈ 0.2); the gaps are cavities.
STYLES = {
    "black": KeyboardStyle((0.20, 0.20, 0.21), (0.07, 0.07, 0.07), (0.25, 0.25, 0.26), (0.13, 0.13, 0.14),
                           (0.72, 0.72, 0.72), 0.55),
    "white": KeyboardStyle((0.82, 0.82, 0.84), (0.45, 0.45, 0.47), (0.93, 0.93, 0.93), (0.66, 0.66, 0.68),
                           (0.30, 0.30, 0.32), 0.5),
}
#: Share of keyboards drawn in the black style (the rest white).
BLACK_SHARE = 0.7


def layout_keys(layout: str) -> list[tuple[float, float, float, float, bool]]:
    """The keys of ``layout`` (a key of :data:`LAYOUTS`): ``(x, y, width, depth, legend)`` in key units from the
    keyboard's back-left corner (y grows toward the typist), the margin included.

    Raises:
        KeyError: an unknown layout.
    """
    _width, nav, pad = LAYOUTS[layout]
    m = _MARGIN_U
    keys = [(m, m, 1.0, 1.0, False)]  # Esc, then F1-F12 in three groups of four
    for g in range(3):
        for j in range(4):
            keys.append((m + 2.0 + g * 4.5 + j, m, 1.0, 1.0, True))
    y = m + 1.5
    for row in _MAIN_ROWS:
        x = m
        for w, legend in row:
            keys.append((x, y, w, 1.0, legend))
            x += w
        y += 1.0
    if nav:
        nx = m + 15.5
        keys += [(nx + j, m, 1.0, 1.0, False) for j in range(3)]
        keys += [(nx + j, m + 1.5 + r, 1.0, 1.0, False) for r in range(2) for j in range(3)]
        keys += [(nx + 1, m + 4.5, 1.0, 1.0, False)] + [(nx + j, m + 5.5, 1.0, 1.0, False) for j in range(3)]
    if pad:
        px = m + 19.0
        keys += [(px + j, m + 1.5 + r, 1.0, 1.0, True) for r in range(4) for j in range(3)]
        keys += [(px + 3, m + 1.5, 1.0, 1.0, False), (px + 3, m + 2.5, 1.0, 2.0, False),
                 (px, m + 5.5, 2.0, 1.0, True), (px + 2, m + 5.5, 1.0, 1.0, True), (px + 3, m + 4.5, 1.0, 2.0, False)]
    return keys


@functools.lru_cache(maxsize=None)
def key_texture(layout: str, style: str) -> np.ndarray:
    """(rows, cols, 3) uint8 sRGB texture of the keyboard's top: rows across its depth (row 0 at its back, ``v`` =
    1), columns across its width; :data:`_PX_PER_U` pixels a key unit. The case colour around the keys, dark gaps
    between them, each cap's top (a little lighter toward its back edge, which faces the light) with its front face
    a shadowed strip, a small legend near the top-left of a letter key.

    Raises:
        KeyError: an unknown layout or style.
    """
    s = STYLES[style]
    case, gap, cap, front, legend = (np.asarray(c, dtype=np.float64) for c in (s.case, s.gap, s.cap, s.front, s.legend))
    width_u = LAYOUTS[layout][0]
    rows, cols = int(round(_DEPTH_U * _PX_PER_U)), int(round(width_u * _PX_PER_U))
    img = np.tile(case, (rows, cols, 1))
    p = _PX_PER_U
    inner = slice(int(0.4 * p), rows - int(0.4 * p)), slice(int(0.4 * p), cols - int(0.4 * p))
    img[inner] = gap
    for x, y, w, d, has_legend in layout_keys(layout):
        x0, x1 = int(round((x + 0.08) * p)), int(round((x + w - 0.08) * p))
        y0, y1 = int(round((y + 0.06) * p)), int(round((y + d - 0.1) * p))
        skirt = max(1, int(round(0.18 * p)))
        img[y0:y1, x0:x1] = cap * np.linspace(1.05, 0.97, y1 - y0)[:, None, None]
        img[y1 - skirt:y1, x0:x1] = front
        if has_legend:
            ly, lx = y0 + int(0.2 * p), x0 + int(0.25 * p)
            img[ly:ly + max(2, p // 5), lx:lx + max(2, p // 4)] = legend
    return np.clip(np.round(np.clip(img, 0.0, 1.0) * 255.0), 0, 255).astype(np.uint8)


def _across_and_back(p) -> tuple[float, float]:
    """A unit keyboard corner's texture coordinates: ``u`` across the width, ``v`` toward the back."""
    return p[0] + .5, p[1] + .5


@functools.lru_cache(maxsize=None)
def keyboard_mesh(layout: str, style: str) -> MeshData:
    """The unit keyboard of ``layout`` (:data:`LAYOUTS`) in ``style`` (:data:`STYLES`): x and y in −0.5..0.5, z in
    0..1 (:data:`UNIT_BOUNDS`), the typist's side at −y. Its top, textured with :func:`key_texture` (``u`` across
    the width, ``v`` toward the back), rises from :data:`FRONT_HEIGHT` at the front to 1 at the back; the four sides
    and the bottom are the case's plain colour. 24 vertices, 12 triangles, 2 materials, flat normals; cached.

    Raises:
        KeyError: an unknown layout or style.
    """
    case, roughness = STYLES[style].case, STYLES[style].roughness
    f = FRONT_HEIGHT
    top, body = 0, 1
    faces = [  # corners counter-clockwise seen from outside, outward normal, material
        ([(-.5, -.5, f), (.5, -.5, f), (.5, .5, 1), (-.5, .5, 1)], (0, 0, 1), top),
        ([(-.5, -.5, 0), (.5, -.5, 0), (.5, -.5, f), (-.5, -.5, f)], (0, -1, 0), body),
        ([(.5, .5, 0), (-.5, .5, 0), (-.5, .5, 1), (.5, .5, 1)], (0, 1, 0), body),
        ([(.5, -.5, 0), (.5, .5, 0), (.5, .5, 1), (.5, -.5, f)], (1, 0, 0), body),
        ([(-.5, .5, 0), (-.5, -.5, 0), (-.5, -.5, f), (-.5, .5, 1)], (-1, 0, 0), body),
        ([(-.5, .5, 0), (.5, .5, 0), (.5, -.5, 0), (-.5, -.5, 0)], (0, 0, -1), body),
    ]
    white = np.ones(3, np.float32)
    materials = [Material(albedo=white, texture=key_texture(layout, style), roughness=roughness,
                          name=f"keyboard_keys:{layout}:{style}", from_file=False),
                 Material(albedo=_srgb_to_linear(case), roughness=roughness, name=f"keyboard_case:{style}",
                          from_file=False)]
    return quad_mesh([(corners, normal, mat, _across_and_back) for corners, normal, mat in faces], materials)


def keyboard(lo: np.ndarray, hi: np.ndarray, *, prefer: np.ndarray | None,
             rng: np.random.Generator) -> tuple[MeshData, np.ndarray]:
    """The keyboard that fills a keyboard cuboid ``lo``..``hi`` (3,) metres exactly.

    Its width runs along the cuboid's longer horizontal side, its typist's side toward ``prefer`` (2,) (of the two
    sides across that, the nearer; a seeded one when None); its layout is the one of :data:`LAYOUTS` whose ratio of
    width to depth is nearest the cuboid's, its style seeded (:data:`BLACK_SHARE`).

    Returns:
        ``(mesh, transform (4, 4) float64)``: the unit mesh (:func:`keyboard_mesh`) and the transform that puts its
        :data:`UNIT_BOUNDS` exactly onto the cuboid.

    Raises:
        ValueError: the cuboid is flat or empty on an axis (:func:`~benchbot_worlds.homes.fitting.fit_to_cuboid`).
    """
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    ext = hi - lo
    across = 0 if ext[0] >= ext[1] else 1  # the axis the keyboard's width runs along
    turns = (0, 2) if across == 0 else (1, 3)  # fit_to_cuboid: k even keeps the model's x along the map's x
    if prefer is None:
        k = turns[int(rng.integers(2))]
    else:
        k = max(turns, key=lambda kk: float(front_of(kk) @ np.asarray(prefer, dtype=np.float64)[:2]))
    ratio = max(ext[0], ext[1]) / max(min(ext[0], ext[1]), 1e-9)
    layout = min(LAYOUTS, key=lambda name: abs(np.log(LAYOUTS[name][0] / _DEPTH_U / ratio)))
    style = "black" if rng.random() < BLACK_SHARE else "white"
    return keyboard_mesh(layout, style), fit_to_cuboid(None, lo, hi, k, bounds=UNIT_BOUNDS)

