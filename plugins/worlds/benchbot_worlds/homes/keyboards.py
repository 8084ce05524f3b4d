"""Computer keyboards made in code for ``keyboard`` cuboids (pure NumPy; the meshes are
:class:`~benchbot_worlds.scene.meshes.MeshData`).

A keyboard is a low case whose top, the plate, slopes up toward its back (as a keyboard on its feet does), and on
it a key cap for every key of a standard layout: rows of 1-unit keys (a unit, ``u``, is a key's pitch) with the wider
keys of a real keyboard (tab, caps lock, shift, enter, backspace, the space bar), the function row apart at the back,
and, where the cuboid is wide enough for them, the navigation keys and the numeric keypad (:data:`LAYOUTS`; the one
whose width-to-depth ratio is nearest the cuboid's is drawn, so keys stay near square). Each cap is a box standing
:data:`CAP_HEIGHT` over the plate, its sides the caps' shadowed colour and its top textured (:func:`key_texture`: lit
a little more toward its back, a small legend on letter keys). Two styles of real keyboards (:data:`STYLES`): black
plastic, and white or silver with light keys; the style is drawn per keyboard.

The model the asset pack has for the class (a desktop computer's keyboard, its keys geometry a few millimetres
apart) was drawn at one sample a pixel as an irregular pattern of black blots, which no COCO detector of
``benchmarks/realism.py`` took for a keyboard in the procedural homes (0 of 10 views; docs/realism.md, 29 Nov 2026).
Drawn instead as a texture of key caps on a flat sloping top (29 Nov), the keys vanished at the robot's view: the
camera meets a keyboard on a desk 10-15 degrees from grazing, where the renderer's texture filtering blurs a flat top
into its mean colour (docs/history/realism-2026-11.md, *Anisotropic texture filtering*). The caps as geometry keep
what a camera sees of a real keyboard from there: the rows of caps standing over the plate, their lit tops over their
shadowed fronts, the gaps between them (*Key caps as geometry*, 30 Nov 2026).

Meshes (:func:`keyboard_mesh`) are unit keyboards in a model's map frame (x across its width and y across its depth
in −0.5..0.5, z in 0..1, the typist's side at −y, the model's front), stretched into the cuboid by
:func:`~benchbot_worlds.homes.fitting.fit_to_cuboid`. The ground truth is not changed.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from benchbot_worlds.homes.fitting import fit_to_cuboid, turns_along_longer_side
from benchbot_worlds.scene.meshes import Material, MeshData, _srgb_to_linear, quad_mesh

__all__ = ["BLACK_SHARE", "CAP_HEIGHT", "LAYOUTS", "PLATE_BACK", "PLATE_FRONT", "STYLES", "UNIT_BOUNDS",
           "KeyboardStyle", "key_texture", "keyboard", "keyboard_mesh", "layout_keys"]

#: Bounds of the unit keyboard of :func:`keyboard_mesh` (its model frame).
UNIT_BOUNDS = np.array([[-0.5, -0.5, 0.0], [0.5, 0.5, 1.0]])
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


#: Height of the plate the caps stand on at the front and at the back of the case (fractions of its height).
PLATE_FRONT, PLATE_BACK = 0.35, 0.6
#: Space between a cap's top and its key's square of the layout, each side (key units).
_CAP_INSET_U = 0.06


def _plate(y: float) -> float:
    """The plate's height (unit model) at ``y`` (−0.5 front .. 0.5 back)."""
    return PLATE_FRONT + (PLATE_BACK - PLATE_FRONT) * (y + 0.5)


#: A cap's height over the plate (a fraction of the case's height): the back row's caps reach the top of the case.
CAP_HEIGHT = 1.0 - _plate(0.5 - (_MARGIN_U + _CAP_INSET_U) / _DEPTH_U)


@functools.lru_cache(maxsize=None)
def keyboard_mesh(layout: str, style: str) -> MeshData:
    """The unit keyboard of ``layout`` (:data:`LAYOUTS`) in ``style`` (:data:`STYLES`): x and y in −0.5..0.5, z in
    0..1 (:data:`UNIT_BOUNDS`), the typist's side at −y. A case whose top (the plate) rises from
    :data:`PLATE_FRONT` to :data:`PLATE_BACK` toward the back, and on it each key of the layout as a cap: a box
    :data:`CAP_HEIGHT` tall whose top, parallel to the plate, is textured with :func:`key_texture` (``u`` across the
    width, ``v`` toward the back) and whose sides are the caps' shadowed front colour. Three materials (the caps'
    tops, the case, the caps' sides); 10 triangles a key (its top and four sides) and 12 for the case (752 for the
    compact layout, 1,052 for full size); flat normals; cached.

    Raises:
        KeyError: an unknown layout or style.
    """
    s = STYLES[style]
    width_u = LAYOUTS[layout][0]
    top, body, side = 0, 1, 2
    quads = []

    def box(x0, x1, y0, y1, z0, z1f, z1b, top_mat, side_mat):
        # z1f, z1b: the top's height at the front (y0) and the back (y1)
        a, b, c, d = (x0, y0, z1f), (x1, y0, z1f), (x1, y1, z1b), (x0, y1, z1b)
        quads.append(([a, b, c, d], (0, -(z1b - z1f), y1 - y0), top_mat))
        quads.append(([(x0, y0, z0), (x1, y0, z0), b, a], (0, -1, 0), side_mat))
        quads.append(([(x1, y1, z0), (x0, y1, z0), d, c], (0, 1, 0), side_mat))
        quads.append(([(x1, y0, z0), (x1, y1, z0), c, b], (1, 0, 0), side_mat))
        quads.append(([(x0, y1, z0), (x0, y0, z0), a, d], (-1, 0, 0), side_mat))

    box(-.5, .5, -.5, .5, 0.0, _plate(-.5), _plate(.5), body, body)
    quads.append(([(-.5, .5, 0), (.5, .5, 0), (.5, -.5, 0), (-.5, -.5, 0)], (0, 0, -1), body))
    for x, y, w, d, _ in layout_keys(layout):
        x0, x1 = -.5 + (x + _CAP_INSET_U) / width_u, -.5 + (x + w - _CAP_INSET_U) / width_u
        y1, y0 = .5 - (y + _CAP_INSET_U) / _DEPTH_U, .5 - (y + d - _CAP_INSET_U) / _DEPTH_U
        box(x0, x1, y0, y1, _plate(y0) - 0.05, _plate(y0) + CAP_HEIGHT, _plate(y1) + CAP_HEIGHT, top, side)
    quads = [(c, np.asarray(n, float) / np.linalg.norm(n), m, _across_and_back) for c, n, m in quads]
    white = np.ones(3, np.float32)
    materials = [Material(albedo=white, texture=key_texture(layout, style), roughness=s.roughness,
                          name=f"keyboard_keys:{layout}:{style}", from_file=False),
                 Material(albedo=_srgb_to_linear(s.case), roughness=s.roughness, name=f"keyboard_case:{style}",
                          from_file=False),
                 Material(albedo=_srgb_to_linear(s.front), roughness=s.roughness, name=f"keyboard_cap_sides:{style}",
                          from_file=False)]
    return quad_mesh(quads, materials)


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
    k = turns_along_longer_side(lo, hi, prefer, rng)
    ratio = max(ext[0], ext[1]) / max(min(ext[0], ext[1]), 1e-9)
    layout = min(LAYOUTS, key=lambda name: abs(np.log(LAYOUTS[name][0] / _DEPTH_U / ratio)))
    style = "black" if rng.random() < BLACK_SHARE else "white"
    return keyboard_mesh(layout, style), fit_to_cuboid(None, lo, hi, k, bounds=UNIT_BOUNDS)

