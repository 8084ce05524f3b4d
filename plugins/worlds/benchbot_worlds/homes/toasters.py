"""Pop-up toasters made in code for ``toaster`` cuboids (pure NumPy; the meshes are
:class:`~benchbot_worlds.scene.meshes.MeshData`).

A toaster is a two-slot pop-up toaster as most kitchens have one: a body whose cross-section is a rectangle with
rounded top edges, extruded along its width; two slots in its top running along the width, open onto a dark
inside; on the right-hand end the lever in its groove and the browning knob (dark plastic; white on a white
toaster); a plinth under it all. Three finishes (:data:`STYLES`): brushed stainless steel, the commonest, and white or
red paint; the finish is drawn per toaster (:data:`STYLE_SHARES`). No black finish and no end panels of black plastic:
drawn so (a first version), a toaster seen end-on from the robot's height read as a dark screen, and NanoDet took
toasters for TVs.

The renderer's fast mode has no specular term, so steel drawn as a grey diffuse colour reads as grey plastic. The
steel finish therefore carries what a camera sees on a toaster's polished sides from a person's or a robot's height
as a texture (:func:`steel_texture`): the room mirrored as a light upper band, a dark band where the counter's edge
and the cabinets below are mirrored, the counter's lighter top under it, and faint horizontal brushing. The texture is
the albedo in both modes; the material is a dielectric of roughness 0.35, not a metal, so quality mode adds only a
dielectric's faint highlights over it, not a second mirror image.

The model the asset pack has for the class (a rounded orange-and-white toaster with a black panel on its side) was
found in none of 104 views of the validation homes 0–59 by NanoDet, which took it for a chair, a vase, a bottle or
a cup (docs/history/realism-2026-11.md, *Toasters made in code*).

Meshes (:func:`toaster_mesh`) are unit toasters in a model's map frame (x across its width, the slots' direction,
and y across its depth in −0.5..0.5, z in 0..1, the user's side at −y, the model's front), stretched into the
cuboid by :func:`~benchbot_worlds.homes.fitting.fit_to_cuboid`. The ground truth is not changed: the lever and the
knob stay inside the cuboid.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from benchbot_worlds.homes.fitting import fit_to_cuboid, turns_along_longer_side
from benchbot_worlds.scene.meshes import Material, MeshData, _srgb_to_linear, quad_mesh

__all__ = ["STYLES", "STYLE_SHARES", "UNIT_BOUNDS", "ToasterStyle", "steel_texture", "toaster", "toaster_mesh"]

#: Bounds of the unit toaster of :func:`toaster_mesh` (its model frame).
UNIT_BOUNDS = np.array([[-0.5, -0.5, 0.0], [0.5, 0.5, 1.0]])

#: Height of the plinth (fractions of the toaster's height) and its inset from the body's sides (of the width/depth).
_PLINTH_TOP, _PLINTH_INSET = 0.05, 0.03
#: The body's extent across the width: its left end, its right end (the lever and knob stand out of it to x = 0.5).
_X_LEFT, _X_RIGHT = -0.5, 0.42
#: Radius of the rounded top edges (fractions of the depth across y and of the height across z) and their facets.
_ROUND_Y, _ROUND_Z, _ROUND_FACETS = 0.14, 0.12, 3
#: The slots: their extent along x, their y intervals (front slot, back slot) and the depth of their floor (z).
_SLOT_X = (-0.34, 0.28)
_SLOTS_Y = ((-0.27, -0.06), (0.06, 0.27))
_SLOT_FLOOR = 0.45
#: The lever (a box standing out of the right end, at its front half) and the knob (below it): x, y, z ranges.
_LEVER = ((_X_RIGHT, 0.5), (-0.2, 0.02), (0.6, 0.7))
_KNOB = ((_X_RIGHT, 0.47), (-0.14, -0.02), (0.22, 0.36))
#: The lever's groove: a dark strip on the right end's face, under and over the lever.
_GROOVE_Y, _GROOVE_Z = (-0.11, -0.07), (0.2, 0.9)


class ToasterStyle(NamedTuple):
    """A toaster's finish (sRGB, 0..1): its body (None for brushed steel, :func:`steel_texture`), its lever and
    knob, its plinth; and the body's roughness (0..1)."""

    body: tuple[float, float, float] | None
    controls: tuple[float, float, float]
    plinth: tuple[float, float, float]
    roughness: float


#: The finishes. Black plastic reflects about 4 % (sRGB ≈ 0.2).
STYLES = {
    "steel": ToasterStyle(None, (0.16, 0.16, 0.17), (0.10, 0.10, 0.10), 0.35),
    "white": ToasterStyle((0.86, 0.86, 0.85), (0.80, 0.80, 0.79), (0.30, 0.30, 0.30), 0.45),
    "red": ToasterStyle((0.62, 0.08, 0.07), (0.16, 0.16, 0.17), (0.10, 0.10, 0.10), 0.4),
}
#: Share of toasters in each finish (in :data:`STYLES`' order; they sum to 1).
STYLE_SHARES = {"steel": 0.7, "white": 0.2, "red": 0.1}
#: The slots' inside and the lever's groove (sRGB): cavities, which let little light out.
_CAVITY = (0.05, 0.05, 0.05)


@functools.lru_cache(maxsize=None)
def steel_texture(rows: int = 64, cols: int = 32) -> np.ndarray:
    """(rows, cols, 3) uint8 sRGB texture of a brushed steel side, row 0 at its top (``v`` = 1): what a polished
    vertical side mirrors to a camera at about its own height, from the top down — the room's walls and ceiling
    (light, 0.80 → 0.72), the counter's far edge and the dark cabinets under the wall units (a band of 0.28 from 45 %
    to 58 % down), the counter's top (0.55, to the plinth). Faint horizontal brushing (± 0.02, seeded, fixed).
    """
    v = np.linspace(1.0, 0.0, rows)  # the side's height, top row first
    level = np.where(v > 0.55, 0.72 + 0.08 * (v - 0.55) / 0.45, np.where(v > 0.42, 0.28, 0.55))
    brushing = np.random.default_rng(1).uniform(-0.02, 0.02, size=(rows, 1))
    img = np.repeat((level[:, None] + brushing)[:, :, None], 3, axis=2) * np.ones((1, cols, 3))
    img[..., 2] += 0.015  # steel is a little cool
    return np.clip(np.round(np.clip(img, 0.0, 1.0) * 255.0), 0, 255).astype(np.uint8)


def _profile() -> list[tuple[float, float]]:
    """The body's cross-section (y, z), front bottom to back bottom over the top: vertical sides, rounded top edges."""
    pts = [(-0.5, _PLINTH_TOP)]
    for k in range(_ROUND_FACETS + 1):  # front top edge, from the side up to the top
        a = np.pi / 2 * k / _ROUND_FACETS
        pts.append((-0.5 + _ROUND_Y * (1 - np.cos(a)), 1.0 - _ROUND_Z * (1 - np.sin(a))))
    for k in range(_ROUND_FACETS + 1):  # back top edge, from the top down to the side
        a = np.pi / 2 * k / _ROUND_FACETS
        pts.append((0.5 - _ROUND_Y * (1 - np.sin(a)), 1.0 - _ROUND_Z * (1 - np.cos(a))))
    pts.append((0.5, _PLINTH_TOP))
    return pts


def _uv_side(p) -> tuple[float, float]:
    """A corner's texture coordinates on the body: ``u`` across the width, ``v`` its height."""
    return p[0] + .5, p[2]


def _face(corners, normal, mat: int) -> tuple:
    """A quad for :func:`~benchbot_worlds.scene.meshes.quad_mesh` (corners, unit normal, material), its corners put
    counter-clockwise seen from the side ``normal`` points to."""
    c = np.asarray(corners, dtype=np.float64)
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    if np.dot(np.cross(c[1] - c[0], c[2] - c[0]) + np.cross(c[2] - c[0], c[3] - c[0]), n) < 0:
        c = c[::-1]
    return [tuple(p) for p in c], n, mat


def _box_faces(x, y, z, mat: int) -> list:
    """The five visible faces (not the bottom) of the box ``x`` × ``y`` × ``z`` ((lo, hi) each)."""
    (x0, x1), (y0, y1), (z0, z1) = x, y, z
    return [_face([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)], (0, 0, 1), mat),
            _face([(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)], (0, -1, 0), mat),
            _face([(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)], (0, 1, 0), mat),
            _face([(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)], (1, 0, 0), mat),
            _face([(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)], (-1, 0, 0), mat)]


def _facet_normal(ya: float, za: float, yb: float, zb: float) -> tuple[float, float, float]:
    """The outward normal of the profile's facet from (ya, za) to (yb, zb) (the profile runs from the front bottom
    over the top to the back bottom)."""
    return 0.0, -(zb - za), yb - ya


def _end_face(x: float, outward: float, mat: int) -> list:
    """An end of the body at ``x`` (facing ``outward``, ±1 along x): the profile's area, as a strip of quads from
    each facet down to the plinth's top."""
    prof = _profile()
    return [_face([(x, ya, _PLINTH_TOP), (x, yb, _PLINTH_TOP), (x, yb, zb), (x, ya, za)], (outward, 0, 0), mat)
            for (ya, za), (yb, zb) in zip(prof, prof[1:]) if abs(yb - ya) > 1e-9]


def _body(mat: int) -> list:
    """The body's sides and top: the profile's facets extruded from :data:`_X_LEFT` to :data:`_X_RIGHT`, the flat
    top left open over the slots."""
    x0, x1 = _X_LEFT, _X_RIGHT
    (sx0, sx1), (slot_f, slot_b) = _SLOT_X, _SLOTS_Y
    prof = _profile()
    faces = []
    for (ya, za), (yb, zb) in zip(prof, prof[1:]):
        if abs(za - 1.0) > 1e-9 or abs(zb - 1.0) > 1e-9:
            faces.append(_face([(x0, ya, za), (x1, ya, za), (x1, yb, zb), (x0, yb, zb)],
                               _facet_normal(ya, za, yb, zb), mat))
            continue
        ys = [ya, slot_f[0], slot_f[1], slot_b[0], slot_b[1], yb]  # the flat top: solid around the slots
        for k, (y0, y1) in enumerate(zip(ys, ys[1:])):
            spans = ((x0, sx0), (sx1, x1)) if k in (1, 3) else ((x0, x1),)
            faces += [_face([(a, y0, 1), (b, y0, 1), (b, y1, 1), (a, y1, 1)], (0, 0, 1), mat) for a, b in spans]
    return faces


def _slot_insides(mat: int) -> list:
    """Each slot's inside: four walls down to its floor (:data:`_SLOT_FLOOR`), facing in, and the floor."""
    (sx0, sx1), f = _SLOT_X, _SLOT_FLOOR
    faces = []
    for y0, y1 in _SLOTS_Y:
        faces += [_face([(sx0, y0, f), (sx1, y0, f), (sx1, y1, f), (sx0, y1, f)], (0, 0, 1), mat),
                  _face([(sx0, y1, f), (sx1, y1, f), (sx1, y1, 1), (sx0, y1, 1)], (0, -1, 0), mat),
                  _face([(sx0, y0, f), (sx1, y0, f), (sx1, y0, 1), (sx0, y0, 1)], (0, 1, 0), mat),
                  _face([(sx0, y0, f), (sx0, y1, f), (sx0, y1, 1), (sx0, y0, 1)], (1, 0, 0), mat),
                  _face([(sx1, y0, f), (sx1, y1, f), (sx1, y1, 1), (sx1, y0, 1)], (-1, 0, 0), mat)]
    return faces


@functools.lru_cache(maxsize=None)
def toaster_mesh(style: str) -> MeshData:
    """The unit toaster in ``style`` (:data:`STYLES`): x and y in −0.5..0.5, z in 0..1 (:data:`UNIT_BOUNDS`), the
    user's side at −y, the slots along x, the lever and knob on the +x end. Materials: the body (textured with
    :func:`steel_texture` for steel, ``u`` across the width and ``v`` up), the lever and knob, the plinth,
    the slots' inside. 112 triangles; flat normals; cached.

    Raises:
        KeyError: an unknown style.
    """
    s = STYLES[style]
    body, controls, plinth, cavity = 0, 1, 2, 3
    (gy0, gy1), (gz0, gz1), g = _GROOVE_Y, _GROOVE_Z, _X_RIGHT + 0.002
    i = _PLINTH_INSET
    faces = (_body(body) + _slot_insides(cavity)
             + _end_face(_X_LEFT, -1.0, body) + _end_face(_X_RIGHT, 1.0, body)
             + [_face([(g, gy0, gz0), (g, gy1, gz0), (g, gy1, gz1), (g, gy0, gz1)], (1, 0, 0), cavity)]
             + _box_faces(*_LEVER, controls) + _box_faces(*_KNOB, controls)
             + _box_faces((_X_LEFT + i, _X_RIGHT - i), (-0.5 + i, 0.5 - i), (0.0, _PLINTH_TOP), plinth)
             + [_face([(-.5, -.5, 0), (.5, -.5, 0), (.5, .5, 0), (-.5, .5, 0)], (0, 0, -1), plinth)])
    quads = [(c, n, m, _uv_side) for c, n, m in faces]
    materials = [Material(albedo=np.ones(3, np.float32), texture=steel_texture(), roughness=s.roughness,
                          name="toaster_body:steel", from_file=False) if s.body is None else
                 Material(albedo=_srgb_to_linear(s.body), roughness=s.roughness, name=f"toaster_body:{style}",
                          from_file=False),
                 Material(albedo=_srgb_to_linear(s.controls), roughness=0.5, name=f"toaster_controls:{style}",
                          from_file=False),
                 Material(albedo=_srgb_to_linear(s.plinth), roughness=0.6, name=f"toaster_plinth:{style}",
                          from_file=False),
                 Material(albedo=_srgb_to_linear(_CAVITY), roughness=1.0, name="toaster_slots", from_file=False)]
    return quad_mesh(quads, materials)


def toaster(lo: np.ndarray, hi: np.ndarray, *, prefer: np.ndarray | None,
            rng: np.random.Generator) -> tuple[MeshData, np.ndarray]:
    """The toaster that fills a toaster cuboid ``lo``..``hi`` (3,) metres exactly.

    Its width (the slots' direction) runs along the cuboid's longer horizontal side, its front toward ``prefer``
    (2,) (of the two sides across that, the nearer; a seeded one when None); its finish seeded
    (:data:`STYLE_SHARES`).

    Returns:
        ``(mesh, transform (4, 4) float64)``: the unit mesh (:func:`toaster_mesh`) and the transform that puts its
        :data:`UNIT_BOUNDS` exactly onto the cuboid.

    Raises:
        ValueError: the cuboid is flat or empty on an axis (:func:`~benchbot_worlds.homes.fitting.fit_to_cuboid`).
    """
    k = turns_along_longer_side(lo, hi, prefer, rng)
    style = str(rng.choice(list(STYLE_SHARES), p=list(STYLE_SHARES.values())))
    return toaster_mesh(style), fit_to_cuboid(None, lo, hi, k, bounds=UNIT_BOUNDS)
