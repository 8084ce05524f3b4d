"""Building the simulator's scene (:class:`~benchbot_worlds.scene.model.Scene`) of an environment from its BEAR
ground-truth JSON (pure NumPy, no Taichi).

A scene is a set of axis-aligned boxes (one per ground-truth object, its AABB exactly the ground-truth
cuboid ``centroid ± extent / 2``), a room shell (floor at z = 0, four walls, a ceiling) enclosing every object and
every pose, and a list of lights. All coordinates are metres in the environment's ``map`` frame (z up).

The object → geometry step is :func:`object_geometry` (one box per object today; procedural models later).
"""

from __future__ import annotations

import json
import math
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchbot.core import settings
from benchbot.core.errors import BackendError
from benchbot.core.geometry import pose7_to_se2, quaternion_wxyz_to_matrix, start_pose_to_se2
from benchbot.core.seeding import home_seed
from benchbot.core.specs import first_error
from benchbot_worlds.bear import lighting_of_map_path
from benchbot_worlds.scene.meshes import MeshInstance, add_mesh_instances, instance_bounds, load_mesh, with_albedo
from benchbot_worlds.scene.model import (
    LIGHT_DIRECTIONAL, LIGHT_POINT, LUMA_709, PRIM_BOX, PRIM_CYLINDER, PRIM_ELLIPSOID, PRIM_TRIANGLE, Scene,
    srgb_to_linear,
)
from benchbot_worlds.settings import SIM_STYLE

#: Margin (metres) between the walls and every object / pose.
WALL_MARGIN_M = 0.5
#: Minimum ceiling height (metres) and clearance above the highest object.
CEILING_MIN_M = 2.6
CEILING_CLEARANCE_M = 0.3

# Plausible sRGB albedos (0..1) per class; a list means "pick one per instance".
_CLASS_COLOURS: dict[str, object] = {
    "bottle": [(0.20, 0.45, 0.25), (0.55, 0.35, 0.15), (0.75, 0.80, 0.82)],
    "cup": [(0.92, 0.92, 0.90), (0.75, 0.20, 0.18), (0.25, 0.40, 0.65)],
    "knife": (0.72, 0.73, 0.75),
    "bowl": [(0.93, 0.92, 0.88), (0.80, 0.70, 0.55), (0.35, 0.50, 0.60)],
    "wine glass": (0.82, 0.86, 0.88),
    "fork": (0.72, 0.73, 0.75),
    "spoon": (0.72, 0.73, 0.75),
    "banana": (0.95, 0.82, 0.25),
    "apple": (0.75, 0.12, 0.10),
    "orange": (0.95, 0.55, 0.10),
    "cake": (0.85, 0.70, 0.50),
    "potted plant": (0.22, 0.48, 0.18),
    "mouse": (0.12, 0.12, 0.13),
    "keyboard": (0.14, 0.14, 0.15),
    "laptop": (0.25, 0.26, 0.28),
    "cell phone": (0.08, 0.08, 0.09),
    "book": [
        (0.60, 0.12, 0.12), (0.15, 0.25, 0.55), (0.20, 0.45, 0.25), (0.85, 0.75, 0.45),
        (0.35, 0.20, 0.40), (0.90, 0.88, 0.82), (0.20, 0.20, 0.22), (0.80, 0.45, 0.15),
    ],
    "clock": (0.85, 0.85, 0.82),
    "chair": [(0.50, 0.33, 0.18), (0.42, 0.27, 0.15), (0.30, 0.30, 0.32)],
    "table": [(0.55, 0.37, 0.20), (0.45, 0.30, 0.16), (0.68, 0.52, 0.34)],
    "couch": [(0.45, 0.47, 0.50), (0.55, 0.40, 0.30), (0.25, 0.32, 0.45), (0.62, 0.58, 0.50)],
    "bed": (0.90, 0.88, 0.84),
    "toilet": (0.95, 0.95, 0.94),
    "tv": (0.07, 0.07, 0.08),
    "microwave": (0.80, 0.80, 0.80),
    "toaster": (0.75, 0.76, 0.78),
    "refrigerator": (0.88, 0.89, 0.90),
    "oven": (0.30, 0.30, 0.32),
    "sink": (0.94, 0.94, 0.93),
    "person": (0.80, 0.62, 0.50),
}
_DEFAULT_COLOUR = (0.6, 0.6, 0.6)
# Floor (wood), walls (off-white), ceiling (white).
_SHELL_COLOURS = ((0.62, 0.48, 0.33), (0.86, 0.84, 0.78), (0.95, 0.95, 0.94))

_LIGHTINGS = ("base", "day", "night", "day_extra", "night_extra")
#: The schema of the environment fields this package reads beyond ``schemas/`` (mesh ``objects``; package data).
ENVIRONMENT_SCHEMA = Path(__file__).resolve().parents[1] / "schemas" / "environment.schema.json"

#: The styles of :func:`build_scene` (environment field ``style``): ``furnished`` — a house with rooms, walls,
#: doors and windows, textured models fitted to the cuboids, supports and distractor furniture
#: (:mod:`benchbot_worlds.homes.furnished`); ``primitives`` — procedural primitives in one room shell.
STYLES = ("furnished", "primitives")
#: The style of an environment that names none, unless :data:`STYLE_VARIABLE` says otherwise.
DEFAULT_STYLE = SIM_STYLE.default
#: The environment variable that sets the style of environments naming none, for a whole run and the processes it
#: starts (e.g. ``BENCHBOT_SIM_STYLE=primitives benchbot batch …`` for speed; the test suite sets it).
STYLE_VARIABLE = SIM_STYLE.name
#: Furnished homes: the outdoors (ground, sky) lies this far (m) beyond the outer walls; sRGB ground, sky, sky.
OUTDOOR_MARGIN_M = 6.0
_OUTDOOR_COLOURS = ((0.36, 0.40, 0.26), (0.62, 0.74, 0.90), (0.70, 0.80, 0.94))
#: Furnished homes: ceiling lamps (one or more per room) are this much brighter than a lamp of the grid, and
#: light this far (m).
LAMP_GAIN = 0.8
#: Furnished homes: the ambient term stands in for the daylight that windows let in and walls bounce around.
INDOOR_AMBIENT_GAIN = 1.75
#: Furnished homes, lighting ``base``: the ceiling lamps' intensity (before :data:`LAMP_GAIN`).
BASE_LAMP_INTENSITY = 0.9
LAMP_RANGE_M = 6.0
#: Furnished homes lit by day alone (``day``): the sky seen through each window lights the room as a lamp in the
#: window's opening would, this far (m) inside it, with the sky's colour at a lamp's luminance and range; the ambient
#: term, which stood in for that light too, keeps :data:`DAY_WINDOW_AMBIENT_SHARE` of its level.
WINDOW_LIGHT_INSET_M = 0.3
DAY_WINDOW_AMBIENT_SHARE = 0.6


def load_ground_truth_json(path: "str | Path") -> dict:
    """Load and check a BEAR ground-truth JSON ``{environment, format, ground_truth}``.

    Raises:
        BackendError: the file is missing, unreadable, not JSON, or lacks ``ground_truth.objects`` /
            ``class_list`` or an object's ``class``/``centroid``/``extent``.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise BackendError(f"cannot read the scene file {p}: {e.strerror or e}",
                           "check the environment's map_path: it must name a BEAR ground-truth JSON file") from e
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise BackendError(f"the scene file {p} is not valid JSON (line {e.lineno}: {e.msg})",
                           "map_path must name a BEAR ground-truth JSON {environment, format, ground_truth}") from e
    gt = data.get("ground_truth") if isinstance(data, dict) else None
    if not isinstance(gt, dict) or not isinstance(gt.get("objects"), list) or not isinstance(gt.get("class_list"), list):
        raise BackendError(f"the scene file {p} has no ground_truth.objects / ground_truth.class_list",
                           "map_path must name a BEAR ground-truth JSON {environment, format, ground_truth}")
    for i, o in enumerate(gt["objects"]):
        try:
            c = np.asarray(o["centroid"], dtype=np.float64)
            x = np.asarray(o["extent"], dtype=np.float64)
            str(o["class"])
        except (KeyError, TypeError, ValueError) as e:
            raise BackendError(f"the scene file {p}: ground_truth.objects[{i}] is malformed ({e!r})",
                               "every object needs class, centroid [x,y,z] and extent [dx,dy,dz]") from e
        if c.shape != (3,) or x.shape != (3,) or not (np.all(np.isfinite(c)) and np.all(np.isfinite(x))) or np.any(x < 0):
            raise BackendError(f"the scene file {p}: ground_truth.objects[{i}] has a bad centroid/extent",
                               "centroid and extent must be 3 finite numbers, extents ≥ 0")
    return data


_KIND = {"box": PRIM_BOX, "ellipsoid": PRIM_ELLIPSOID, "cylinder": PRIM_CYLINDER}


@dataclass
class Part:
    """One primitive of an object: ``kind`` ('box', 'ellipsoid', 'cylinder' or 'mesh'), its AABB ``lo``/``hi``
    (3,) float64 (map frame, metres), the cylinder ``axis`` (0/1/2), ``colour`` (sRGB (3,) or None: the object's
    colour; a float: the object's colour times it) and, for 'mesh', ``tris`` (T, 3, 3) float64."""

    kind: str
    lo: np.ndarray
    hi: np.ndarray
    axis: int = 2
    colour: object = None
    tris: np.ndarray | None = None


# Procedural models: parts in the unit cube of the object's cuboid, (kind, axis, (u0, w0, z0), (u1, w1, z1), colour);
# u runs along the longer horizontal side, w along the shorter one (w = 1 is the "back"), z up; axis 'u'/'w'/'z'.
# Every model touches all six faces of the unit cube, so the union's AABB is exactly the ground-truth cuboid.
_WOOD_DARK = 0.65


def _legs(z1, inset=0.0, size=0.09, colour=_WOOD_DARK, kind="cylinder"):
    out = []
    for u0 in (inset, 1.0 - inset - size):
        for w0 in (inset, 1.0 - inset - size):
            out.append((kind, "z", (u0, w0, 0.0), (u0 + size, w0 + size, z1), colour))
    return out


_MODELS: dict[str, list] = {
    "chair": [("box", "z", (0, 0, 0.44), (1, 1, 0.52), None), ("box", "z", (0.02, 0.86, 0.52), (0.98, 1, 1), None)]
    + _legs(0.44, 0.02, 0.1, _WOOD_DARK, "box"),
    "table": [("box", "z", (0, 0, 0.93), (1, 1, 1), None)] + _legs(0.93, 0.04, 0.07),
    "bed": [("box", "z", (0, 0, 0), (0.94, 1, 0.3), _WOOD_DARK), ("box", "z", (0.94, 0, 0), (1, 1, 1), _WOOD_DARK),
            ("box", "z", (0.01, 0.01, 0.3), (0.94, 0.99, 0.52), None),
            ("box", "z", (0.0, 0.0, 0.44), (0.62, 1.0, 0.56), 0.93),
            ("ellipsoid", "z", (0.76, 0.06, 0.48), (0.93, 0.47, 0.66), (0.97, 0.97, 0.95)),
            ("ellipsoid", "z", (0.76, 0.53, 0.48), (0.93, 0.94, 0.66), (0.97, 0.97, 0.95))],
    "couch": [("box", "z", (0, 0, 0.08), (1, 1, 0.42), None), ("box", "z", (0.0, 0.72, 0.42), (1, 1, 1), 0.92),
              ("box", "z", (0, 0, 0.42), (0.1, 0.72, 0.66), 0.85), ("box", "z", (0.9, 0, 0.42), (1, 0.72, 0.66), 0.85),
              ("box", "z", (0.11, 0.02, 0.42), (0.495, 0.71, 0.55), 1.08),
              ("box", "z", (0.505, 0.02, 0.42), (0.89, 0.71, 0.55), 1.08)] + _legs(0.08, 0.03, 0.05, (0.2, 0.15, 0.1)),
    "toilet": [("box", "z", (0.72, 0, 0.45), (1, 1, 1), None), ("cylinder", "z", (0.3, 0.25, 0), (0.72, 0.75, 0.3), None),
               ("ellipsoid", "z", (0, 0.1, 0.2), (0.8, 0.9, 0.55), None),
               ("cylinder", "z", (0.0, 0.1, 0.5), (0.8, 0.9, 0.56), 0.93)],
    "sink": [("box", "z", (0, 0, 0.78), (1, 1, 1), None), ("cylinder", "z", (0.35, 0.3, 0), (0.65, 0.7, 0.78), None),
             ("ellipsoid", "z", (0.15, 0.1, 0.6), (0.85, 0.75, 0.9), 0.95)],
    "tv": [("box", "z", (0, 0.4, 0.14), (1, 0.6, 1), None), ("box", "z", (0.03, 0.38, 0.17), (0.97, 0.4, 0.97),
                                                                   (0.02, 0.03, 0.06)),
           ("cylinder", "z", (0.46, 0.42, 0.04), (0.54, 0.58, 0.14), None), ("box", "z", (0.3, 0, 0), (0.7, 1, 0.04), None)],
    "laptop": [("box", "z", (0, 0, 0), (1, 0.96, 0.12), None), ("box", "z", (0, 0.9, 0.12), (1, 1, 1), None),
               ("box", "z", (0.05, 0.12, 0.12), (0.95, 0.6, 0.14), (0.08, 0.08, 0.09)),
               ("box", "z", (0.05, 0.88, 0.2), (0.95, 0.9, 0.95), (0.1, 0.15, 0.3))],
    "keyboard": [("box", "z", (0, 0, 0), (1, 1, 0.55), None), ("box", "z", (0.03, 0.08, 0.55), (0.97, 0.92, 1), 1.6)],
    "mouse": [("ellipsoid", "z", (0, 0, -1), (1, 1, 1), None)],
    "bowl": [("cylinder", "z", (0, 0, 0.4), (1, 1, 1), None), ("ellipsoid", "z", (0.08, 0.08, 0.0), (0.92, 0.92, 0.8), None)],
    "cup": [("cylinder", "z", (0, 0.05, 0), (0.8, 0.95, 1), None), ("box", "z", (0.78, 0.42, 0.25), (1, 0.58, 0.75), None),
            ("cylinder", "z", (0, 0, 0.96), (0.8, 1, 1), None)],
    "bottle": [("cylinder", "z", (0, 0, 0), (1, 1, 0.6), None), ("ellipsoid", "z", (0, 0, 0.42), (1, 1, 0.8), None),
               ("cylinder", "z", (0.33, 0.33, 0.7), (0.67, 0.67, 1), (0.9, 0.9, 0.88))],
    "wine glass": [("cylinder", "z", (0.15, 0.15, 0), (0.85, 0.85, 0.04), None),
                   ("cylinder", "z", (0.45, 0.45, 0.04), (0.55, 0.55, 0.45), None),
                   ("ellipsoid", "z", (0, 0, 0.35), (1, 1, 1.1), None), ("cylinder", "z", (0, 0, 0.7), (1, 1, 1), None)],
    "potted plant": [("cylinder", "z", (0.22, 0.22, 0), (0.78, 0.78, 0.32), (0.72, 0.38, 0.22)),
                     ("ellipsoid", "z", (0, 0, 0.25), (1, 1, 1), None),
                     ("ellipsoid", "z", (0.05, 0.1, 0.5), (0.6, 0.6, 1), 1.25)],
    "clock": [("cylinder", "w", (0, 0, 0), (1, 1, 1), (0.2, 0.2, 0.22)),
              ("cylinder", "w", (0.06, -0.02, 0.06), (0.94, 0.02, 0.94), None),
              ("box", "z", (0.48, -0.04, 0.48), (0.52, 0.0, 0.85), (0.05, 0.05, 0.05)),
              ("box", "z", (0.48, -0.04, 0.47), (0.75, 0.0, 0.53), (0.05, 0.05, 0.05))],
    "apple": [("ellipsoid", "z", (0, 0, 0), (1, 1, 0.95), None), ("cylinder", "z", (0.47, 0.47, 0.9), (0.53, 0.53, 1),
                                                                    (0.3, 0.2, 0.1))],
    "orange": [("ellipsoid", "z", (0, 0, 0), (1, 1, 1), None)],
    "banana": [("ellipsoid", "z", (0, 0, 0), (1, 1, 1), None),
               ("cylinder", "u", (0.0, 0.4, 0.4), (0.08, 0.6, 0.6), (0.3, 0.25, 0.1))],
    "cake": [("cylinder", "z", (0, 0, 0), (1, 1, 0.85), None), ("cylinder", "z", (0.02, 0.02, 0.85), (0.98, 0.98, 1),
                                                                    (0.95, 0.93, 0.9))],
    "refrigerator": [("box", "z", (0, 0, 0), (1, 0.95, 1), None),
                     ("box", "z", (0.01, 0.95, 0.01), (0.99, 1, 0.62), 1.03), ("box", "z", (0.01, 0.95, 0.64), (0.99, 1, 0.99), 1.03),
                     ("box", "z", (0.85, 0.96, 0.35), (0.9, 1, 0.58), (0.35, 0.35, 0.37)),
                     ("box", "z", (0.85, 0.96, 0.68), (0.9, 1, 0.85), (0.35, 0.35, 0.37))],
    "toaster": [("box", "z", (0, 0.04, 0), (1, 0.96, 0.85), None),
                ("box", "z", (0.12, 0.25, 0.85), (0.88, 0.42, 1), (0.08, 0.08, 0.08)),
                ("box", "z", (0.12, 0.58, 0.85), (0.88, 0.75, 1), (0.08, 0.08, 0.08)),
                ("box", "z", (0.8, 0, 0.5), (0.9, 0.04, 0.65), (0.1, 0.1, 0.1)),
                ("box", "z", (0.1, 0.96, 0.1), (0.2, 1, 0.2), (0.1, 0.1, 0.1))],
    "microwave": [("box", "z", (0, 0, 0), (1, 0.94, 1), None), ("box", "z", (0.05, 0.94, 0.12), (0.68, 1, 0.88),
                                                                  (0.06, 0.06, 0.07)),
                  ("box", "z", (0.74, 0.94, 0.2), (0.94, 0.97, 0.8), 0.7)],
    "oven": [("box", "z", (0, 0, 0), (1, 0.94, 1), None), ("box", "z", (0.08, 0.94, 0.15), (0.92, 1, 0.75),
                                                             (0.05, 0.05, 0.06)),
             ("box", "z", (0.08, 0.95, 0.8), (0.92, 1, 0.86), (0.7, 0.7, 0.72))],
    "person": [("cylinder", "z", (0.3, 0.3, 0), (0.48, 0.7, 0.48), (0.2, 0.25, 0.4)),
               ("cylinder", "z", (0.52, 0.3, 0), (0.7, 0.7, 0.48), (0.2, 0.25, 0.4)),
               ("ellipsoid", "z", (0.18, 0.0, 0.4), (0.82, 1.0, 0.86), (0.35, 0.45, 0.6)),
               ("cylinder", "z", (0.0, 0.38, 0.46), (0.17, 0.62, 0.82), (0.35, 0.45, 0.6)),
               ("cylinder", "z", (0.83, 0.38, 0.46), (1.0, 0.62, 0.82), (0.35, 0.45, 0.6)),
               ("ellipsoid", "z", (0.38, 0.3, 0.84), (0.62, 0.7, 1), None)],
}
#: Book objects wider than this along their long side are drawn as a row of books (a shelf group).
BOOK_ROW_MIN_M = 0.12


def _book_row(obj: dict, rng: np.random.Generator) -> list:
    """A row of books along the long side of the unit cube (random widths, heights and colours, one full height)."""
    e = np.asarray(obj["extent"], dtype=np.float64)
    length = float(max(e[0], e[1]))
    n = int(np.clip(round(length / 0.035), 2, 40))
    widths = rng.uniform(0.7, 1.3, n)
    edges = np.concatenate([[0.0], np.cumsum(widths) / widths.sum()])
    heights = rng.uniform(0.72, 1.0, n)
    heights[int(rng.integers(n))] = 1.0
    pal = _CLASS_COLOURS["book"]
    parts = []
    for i in range(n):
        col = pal[int(rng.integers(len(pal)))]
        depth0 = 0.0 if i % 3 else 0.06  # a few books stick out a little less
        if i == 0:
            depth0 = 0.0
        parts.append(("box", "z", (edges[i], depth0, 0.0), (edges[i + 1] - 0.004 * (i < n - 1), 1.0, heights[i]), col))
    return parts


def _instantiate(parts: list, obj: dict, flip: bool) -> list[Part]:
    c = np.asarray(obj["centroid"], dtype=np.float64)
    e = np.asarray(obj["extent"], dtype=np.float64)
    lo, hi = c - e / 2.0, c + e / 2.0
    ua, wa = (0, 1) if e[0] >= e[1] else (1, 0)  # u along the longer horizontal side
    axis_of = {"u": ua, "w": wa, "z": 2}
    out = []
    for kind, ax, p0, p1, col in parts:
        a = np.clip(np.array(p0, dtype=np.float64), 0.0, 1.0)
        b = np.clip(np.array(p1, dtype=np.float64), 0.0, 1.0)
        if flip:  # mirror the back to the other side of the shorter axis
            a[1], b[1] = 1.0 - b[1], 1.0 - a[1]
        f0 = np.zeros(3)
        f1 = np.zeros(3)
        f0[ua], f1[ua] = a[0], b[0]
        f0[wa], f1[wa] = a[1], b[1]
        f0[2], f1[2] = a[2], b[2]
        plo, phi = lo + f0 * e, lo + f1 * e
        plo[f0 <= 0.0] = lo[f0 <= 0.0]  # exact bounds on the cuboid's faces
        phi[f1 >= 1.0] = hi[f1 >= 1.0]
        if np.any(phi - plo <= 0.0):
            continue
        out.append(Part(kind, plo, phi, axis_of[ax], col))
    return out


def object_geometry(obj: dict, *, procedural: bool = True) -> list[Part]:
    """Geometry of one ground-truth object as a list of :class:`Part` (map frame, metres), the single object →
    geometry step. With ``procedural`` a recognisable model of its class (chair: seat, legs, back; table: top and
    legs; bed; couch; toilet; sink; tv on a stand; laptop; keyboard; mouse; rows of books; bowl; cup; bottle; potted
    plant; clock; fruit; refrigerator; toaster; microwave; oven; person; …) fitted to the ground-truth cuboid so the
    union of its parts' AABBs is exactly ``centroid ± extent / 2``; other classes, degenerate cuboids or
    ``procedural=False``: one box equal to the cuboid. Objects with a ``_tris`` key (mesh objects of an
    environment's ``objects`` list, see :func:`load_mesh_objects`) return their triangles as one 'mesh' part.
    Deterministic (choices seeded by ``ID_name``)."""
    if obj.get("_tris") is not None:
        tris = np.asarray(obj["_tris"], dtype=np.float64)
        return [Part("mesh", tris.reshape(-1, 3).min(axis=0), tris.reshape(-1, 3).max(axis=0), 2, None, tris)]
    c = np.asarray(obj["centroid"], dtype=np.float64)
    e = np.asarray(obj["extent"], dtype=np.float64)
    cuboid = [Part("box", c - e / 2.0, c + e / 2.0)]
    cls = str(obj.get("class", ""))
    if not procedural or np.any(e <= 1e-6):
        return cuboid
    rng = np.random.default_rng(zlib.crc32(f"geom|{obj.get('ID_name', '')}".encode("utf-8")))
    flip = bool(rng.integers(2))
    if cls == "book":
        if max(e[0], e[1]) < BOOK_ROW_MIN_M:
            return cuboid
        return _instantiate(_book_row(obj, rng), obj, flip)
    if cls not in _MODELS:
        return cuboid
    return _instantiate(_MODELS[cls], obj, flip)


def object_colour(cls: str, id_name: str, seed: int) -> np.ndarray:
    """sRGB albedo (3,) float32 of one object: its class colour (or one of its palette, chosen per instance), with a
    small per-instance variation seeded by ``ID_name`` and ``seed``."""
    key = zlib.crc32(f"{id_name}|{seed}".encode("utf-8"))
    rng = np.random.default_rng(key)
    base = _CLASS_COLOURS.get(cls, _DEFAULT_COLOUR)
    if isinstance(base, list):
        base = base[int(rng.integers(len(base)))]
    jitter = rng.uniform(-0.04, 0.04, size=3) + rng.uniform(-0.04, 0.04)
    return np.clip(np.asarray(base, dtype=np.float64) + jitter, 0.02, 0.98).astype(np.float32)


def scene_lights(lighting: str, room_min: np.ndarray, room_max: np.ndarray, lamps: np.ndarray | None = None,
                 frame=None, windows: np.ndarray | None = None):
    """The lights of a lighting variant in a room, before :data:`INDOOR_AMBIENT_GAIN` (what :func:`build_scene`
    stores in :class:`~benchbot_worlds.scene.model.Scene`'s ``ambient`` and ``light_*`` fields).

    Args:
        lighting: ``base``, ``day``, ``day_extra``, ``night`` or ``night_extra`` (BEAR's variants; another name is
            lit as ``base``).
        room_min, room_max: (3,) the room's corners (metres, map frame); the ceiling is at ``room_max[2]``.
        lamps: (K, 3) the ceiling lights' positions (furnished homes), else a grid under the room's ceiling.
        frame: a furnished home's :class:`~benchbot_worlds.homes.home_frame.HomeFrame`, in which the sun's
            direction is fixed (else the map frame).
        windows: (W, 2, 3) a furnished home's windows (centre, inward unit normal; metres, map frame), each a point
            light :data:`WINDOW_LIGHT_INSET_M` inside it when the lighting is ``day``.

    Returns:
        ``(ambient, kind, vec, colour, range)``: (3,) float32 linear ambient radiance; (L,) int32 light kinds
        (``LIGHT_DIRECTIONAL``, ``LIGHT_POINT``); (L, 3) float32 the direction towards a directional light (unit) or
        a point light's position (metres, map frame); (L, 3) float32 linear radiance; (L,) float32 a point light's
        range in metres (0 for a directional light). Raises nothing.
    """
    h = float(room_max[2])
    sun_dir = np.array([0.45, 0.30, 0.84], dtype=np.float64)
    sun_dir /= np.linalg.norm(sun_dir)
    if frame is not None:
        sun_dir = frame.vector_to_map(sun_dir)
    kinds, vecs, cols, ranges = [], [], [], []

    def sun(intensity):
        kinds.append(LIGHT_DIRECTIONAL)
        vecs.append(sun_dir)
        cols.append(np.array([1.0, 0.93, 0.82]) * intensity)
        ranges.append(0.0)

    def ceiling(intensity, spacing):
        if lamps is not None:
            for p in np.asarray(lamps, dtype=np.float64).reshape(-1, 3):
                kinds.append(LIGHT_POINT)
                vecs.append(p)
                cols.append(np.array([1.0, 0.82, 0.60]) * intensity * LAMP_GAIN)
                ranges.append(LAMP_RANGE_M)
            return
        nx = max(1, int(math.ceil((room_max[0] - room_min[0]) / spacing)))
        ny = max(1, int(math.ceil((room_max[1] - room_min[1]) / spacing)))
        for i in range(nx):
            for j in range(ny):
                x = room_min[0] + (i + 0.5) * (room_max[0] - room_min[0]) / nx
                y = room_min[1] + (j + 0.5) * (room_max[1] - room_min[1]) / ny
                kinds.append(LIGHT_POINT)
                vecs.append(np.array([x, y, h - 0.15]))
                cols.append(np.array([1.0, 0.82, 0.60]) * intensity)
                ranges.append(spacing * 1.25)

    if lighting == "day":
        ambient = np.array([0.30, 0.31, 0.33])
        sun(0.95)
        if windows is not None and len(windows):  # a furnished home: the sky lights it through its windows
            ambient = ambient * DAY_WINDOW_AMBIENT_SHARE
            luma = np.asarray(LUMA_709, dtype=np.float64)
            sky = srgb_to_linear(np.asarray(_OUTDOOR_COLOURS[1], dtype=np.float32)).astype(np.float64)
            lamp = np.array([1.0, 0.82, 0.60]) * BASE_LAMP_INTENSITY * LAMP_GAIN
            colour = sky / (luma @ sky) * (luma @ lamp)
            for centre, inward in np.asarray(windows, dtype=np.float64).reshape(-1, 2, 3):
                kinds.append(LIGHT_POINT)
                vecs.append(centre + WINDOW_LIGHT_INSET_M * inward)
                cols.append(colour)
                ranges.append(LAMP_RANGE_M)
    elif lighting == "day_extra":
        ambient = np.array([0.34, 0.35, 0.37])
        sun(1.05)
        ceiling(1.2, 4.0)
    elif lighting == "night":
        ambient = np.array([0.05, 0.05, 0.07])
        ceiling(2.2, 4.0)
    elif lighting == "night_extra":
        ambient = np.array([0.08, 0.075, 0.08])
        ceiling(3.0, 3.0)
    else:  # base: warm interior light
        ambient = np.array([0.26, 0.24, 0.21])
        sun(0.75)
        if lamps is not None:  # a furnished home: the sun reaches in only through windows; the lamps are on
            ceiling(BASE_LAMP_INTENSITY, 4.0)
    return (
        ambient.astype(np.float32),
        np.asarray(kinds, dtype=np.int32),
        np.asarray(vecs, dtype=np.float32).reshape(-1, 3),
        np.asarray(cols, dtype=np.float32).reshape(-1, 3),
        np.asarray(ranges, dtype=np.float32),
    )


def default_style() -> str:
    """The style of environments whose spec names none: ``$BENCHBOT_SIM_STYLE`` (:data:`STYLE_VARIABLE`) when set,
    else :data:`DEFAULT_STYLE`.

    Raises:
        BackendError: the variable is set to a name not in :data:`STYLES`.
    """
    style = settings.get(SIM_STYLE)
    if style not in STYLES:
        raise BackendError(f"the environment variable {STYLE_VARIABLE}={style[:40]!r} names no style",
                           f"set it to one of: {', '.join(STYLES)} (or unset it for {DEFAULT_STYLE})")
    return style


def build_scene(environment: dict, *, seed: int = 0) -> Scene:
    """Build the :class:`Scene` of an environment spec.

    Args:
        environment: an environment spec; ``map_path`` names a BEAR ground-truth JSON (objects, class list);
            ``start_pose``/``trajectory_poses`` (``[qw,qx,qy,qz,x,y,z]``) are taken from the spec, else from the
            JSON; ``lighting`` from the spec, else from the JSON's original Unreal ``map_path``; ``style`` (one of
            :data:`STYLES`) from the spec, else :func:`default_style`.
        seed: the world seed: seeds the per-instance colour variation of objects drawn with primitives. A
            furnished home (plan, materials, furniture, the models of the objects) is seeded by the home alone
            (:func:`benchbot.core.seeding.home_seed` of the environment's ``name``), the same in all its variants.

    Raises:
        BackendError: ``map_path`` is missing, unreadable or malformed, a pose is malformed, or the style is
            unknown.
    """
    map_path = environment.get("map_path")
    mesh_objs = load_mesh_objects(environment)
    if not map_path and not environment.get("objects"):
        raise BackendError(f"environment {environment.get('name')}:{environment.get('variant')} has no map_path",
                           "set map_path to a BEAR ground-truth JSON file (or list mesh objects in 'objects')")
    if map_path:
        data = load_ground_truth_json(map_path)
    else:
        data = {"environment": {}, "ground_truth": {"class_list": list(BEAR_CLASS_LIST), "objects": []}}
    gt = dict(data["ground_truth"])
    gt["objects"] = list(gt["objects"]) + mesh_objs
    file_env = data.get("environment") or {}
    class_list = [str(c) for c in gt["class_list"]]
    class_ids = {c: i for i, c in enumerate(class_list)}
    background = class_ids.get("background", len(class_list) - 1)

    procedural = bool(environment.get("procedural", True))
    style = environment.get("style") or default_style()
    if style not in STYLES:
        raise BackendError(f"environment {environment.get('name')}:{environment.get('variant')}: unknown style "
                           f"{style!r}", f"style is one of: {', '.join(STYLES)}")
    home = None
    map_objects = gt["objects"][: len(gt["objects"]) - len(mesh_objs)]
    if style == "furnished" and map_objects:  # the plan is derived from the map's cuboids: without any, a room shell
        home = furnished_home(environment, file_env, map_objects, map_path)
    frame = home.frame if home is not None else _primitives_frame(environment, file_env, map_objects, map_path)
    modelled = set() if home is None else \
        {i.object_index for i in home.instances if i.object_index >= 0}
    mins, maxs, albedo, cls_ids, inst_ids, names = [], [], [], [], [], []
    p_type, p_axis, p_min, p_max, p_alb, p_obj, tris = [], [], [], [], [], [], []
    instances: list[MeshInstance] = []  # mesh objects: their triangles are added after the primitives
    counters: dict[int, int] = {}
    for obj in gt["objects"]:
        cname = str(obj["class"])
        cid = class_ids.get(cname)
        if cid is None:
            src = f"the scene file {map_path}" if obj.get("_tris") is None and obj.get("_mesh") is None else \
                f"environment {environment.get('name')}:{environment.get('variant')}: mesh object {obj.get('ID_name')}"
            raise BackendError(f"{src}: object class {cname!r} is not in class_list",
                               "every object's class must appear in ground_truth.class_list")
        counters[cid] = counters.get(cid, 0) + 1
        colour = object_colour(cname, str(obj.get("ID_name", "")), seed)
        k = len(mins)
        if obj.get("_mesh") is not None:  # a mesh object: its file's materials (the class colour where it has none)
            inst = MeshInstance(with_albedo(obj["_mesh"], srgb_to_linear(colour)), obj["_transform"], k)
            instances.append(inst)
            bounds = instance_bounds(inst)
            mins.append(bounds[0])
            maxs.append(bounds[1])
        elif k in modelled:  # furnished: its models are fitted exactly to the cuboid
            c, e = np.asarray(obj["centroid"], np.float64), np.asarray(obj["extent"], np.float64)
            mins.append(c - e / 2)
            maxs.append(c + e / 2)
        else:
            if frame is not None and k < len(map_objects) and not frame.is_identity:  # drawn in the home frame
                parts = _parts_in_map(frame, object_geometry(frame.objects_to_home([obj])[0], procedural=procedural))
            else:
                parts = object_geometry(obj, procedural=procedural)
            for part in parts:
                if part.colour is None:
                    col = colour
                elif isinstance(part.colour, float):
                    col = np.clip(colour * part.colour, 0.0, 1.0)
                else:
                    col = np.asarray(part.colour, dtype=np.float32)
                if part.kind == "mesh":
                    t = np.asarray(part.tris, dtype=np.float64).reshape(-1, 3, 3)
                    p_type.extend([PRIM_TRIANGLE] * len(t))
                    p_axis.extend(range(len(tris), len(tris) + len(t)))
                    tris.extend(t)
                    p_min.extend(t.min(axis=1))
                    p_max.extend(t.max(axis=1))
                    p_alb.extend([col] * len(t))
                    p_obj.extend([k] * len(t))
                else:
                    p_type.append(_KIND[part.kind])
                    p_axis.append(int(part.axis))
                    p_min.append(part.lo)
                    p_max.append(part.hi)
                    p_alb.append(col)
                    p_obj.append(k)
            mins.append(np.min([p.lo for p in parts], axis=0))
            maxs.append(np.max([p.hi for p in parts], axis=0))
        albedo.append(colour)
        cls_ids.append(cid)
        inst_ids.append(cid * 1000 + counters[cid])
        names.append(str(obj.get("ID_name", "")))

    def poses(key):
        v = environment.get(key)
        if v is None:
            v = file_env.get(key)
        return v

    try:
        sp = poses("start_pose")
        start = start_pose_to_se2(sp) if sp is not None else np.zeros(3)  # as the original placed the robot
        traj = np.array([pose7_to_se2(p) for p in (poses("trajectory_poses") or [])], dtype=np.float64).reshape(-1, 3)
    except (ValueError, TypeError) as e:
        raise BackendError(f"environment {environment.get('name')}:{environment.get('variant')}: bad pose ({e})",
                           "poses are [qw,qx,qy,qz,x,y,z] with a non-zero quaternion") from e

    box_min = np.asarray(mins, dtype=np.float32).reshape(-1, 3)
    box_max = np.asarray(maxs, dtype=np.float32).reshape(-1, 3)
    pts = np.concatenate([start[None, :2], traj[:, :2]], axis=0)
    lo = pts.min(axis=0)
    hi = pts.max(axis=0)
    if len(box_min):
        lo = np.minimum(lo, box_min[:, :2].min(axis=0))
        hi = np.maximum(hi, box_max[:, :2].max(axis=0))
    top = float(box_max[:, 2].max()) if len(box_max) else 0.0
    room_min = np.array([lo[0] - WALL_MARGIN_M, lo[1] - WALL_MARGIN_M, 0.0], dtype=np.float32)
    room_max = np.array([hi[0] + WALL_MARGIN_M, hi[1] + WALL_MARGIN_M,
                         max(CEILING_MIN_M, top + CEILING_CLEARANCE_M)], dtype=np.float32)

    lighting = environment.get("lighting") or lighting_of_map_path(file_env.get("map_path", ""))
    if lighting not in _LIGHTINGS:
        lighting = "base"
    shell = _SHELL_COLOURS
    if home is not None:  # the shell becomes the outdoors seen through the windows: ground and sky
        room_min = np.array([*(home.outer_lo - OUTDOOR_MARGIN_M), 0.0], dtype=np.float32)
        room_max = np.array([*(home.outer_hi + OUTDOOR_MARGIN_M), home.wall_height + OUTDOOR_MARGIN_M], np.float32)
        shell = _OUTDOOR_COLOURS
    ambient, kind, vec, col, rng = scene_lights(lighting, room_min, room_max,
                                                lamps=None if home is None else home.lamps, frame=frame,
                                                windows=None if home is None else home.windows)
    if home is not None:  # walls and ceilings keep the sun out but for the windows: light bounced indoors
        ambient = (ambient * INDOOR_AMBIENT_GAIN).astype(np.float32)
    obstacles = [] if home is None else home.obstacles
    scene = Scene(
        box_min=box_min,
        box_max=box_max,
        box_albedo=srgb_to_linear(np.asarray(albedo, dtype=np.float32).reshape(-1, 3)),
        box_class=np.asarray(cls_ids, dtype=np.int32),
        box_instance=np.asarray(inst_ids, dtype=np.int32),
        box_names=names,
        room_min=room_min,
        room_max=room_max,
        shell_albedo=srgb_to_linear(np.asarray(shell, dtype=np.float32)),
        background_class=int(background),
        class_list=class_list,
        class_ids=class_ids,
        ambient=ambient,
        light_kind=kind,
        light_vec=vec,
        light_colour=col,
        light_range=rng,
        lighting=lighting,
        start_se2=start,
        trajectory_se2=traj,
        prim_type=np.asarray(p_type, dtype=np.int32),
        prim_axis=np.asarray(p_axis, dtype=np.int32),
        prim_min=np.asarray(p_min, dtype=np.float32).reshape(-1, 3),
        prim_max=np.asarray(p_max, dtype=np.float32).reshape(-1, 3),
        prim_albedo=srgb_to_linear(np.asarray(p_alb, dtype=np.float32).reshape(-1, 3)),
        prim_object=np.asarray(p_obj, dtype=np.int32),
        tri_v=np.asarray(tris, dtype=np.float32).reshape(-1, 3, 3),
        style=style,
        obstacle_min=np.asarray([o[0] for o in obstacles], dtype=np.float64).reshape(-1, 2),
        obstacle_max=np.asarray([o[1] for o in obstacles], dtype=np.float64).reshape(-1, 2),
        obstacle_bottom=np.asarray([o[2] for o in obstacles], dtype=np.float64),
        obstacle_names=[o[3] for o in obstacles],
        plan=None if home is None else home.plan,
        box_models=_box_models(home, len(mins)),
    )
    if home is not None:
        instances = home.instances + instances
    if instances:
        add_mesh_instances(scene, instances)
    return scene


def _env_paths(environment: dict, file_env: dict) -> list[np.ndarray]:
    """The environment's robot path as [(M, 2) xy]: its start pose then its trajectory (spec, else map file); a bad
    pose is left out (build_scene reports it with its own message)."""
    paths = []
    for key in ("start_pose", "trajectory_poses"):
        v = environment.get(key, file_env.get(key))
        poses = [v] if key == "start_pose" and v is not None else (v or [])
        try:
            paths.append(np.array([pose7_to_se2(p)[:2] for p in poses], dtype=np.float64).reshape(-1, 2))
        except (ValueError, TypeError):
            continue
    return [np.concatenate(paths, axis=0)] if paths else []


def _primitives_frame(environment: dict, file_env: dict, objects: list, map_path):
    """The :class:`~benchbot_worlds.homes.home_frame.HomeFrame` of a scene without a furnished home: that of its
    home's ground-truth files (:func:`~benchbot_worlds.homes.floorplan.home_files`, as the furnished style's),
    else of its own objects and path; ``None`` without map objects. The objects' procedural models and the sun are
    made in it."""
    from benchbot_worlds.homes.floorplan import HOME_FILES_FIELD, home_files, home_inputs
    from benchbot_worlds.homes.home_frame import home_frame

    if not objects:
        return None
    if map_path:
        try:
            dicts = [load_ground_truth_json(f) for f in home_files(environment, _env_dir(environment))]
        except BackendError as e:
            if not environment.get(HOME_FILES_FIELD) or e.message.startswith("environment "):
                raise  # the map's own problem was reported by build_scene; home_files' names the field already
            raise BackendError(f"environment {environment.get('name')}:{environment.get('variant')}: "
                               f"{HOME_FILES_FIELD}: {e.message}", "list the ground-truth JSON files of the home's "
                               "variants {environment, format, ground_truth}") from e
        return home_frame(*home_inputs(dicts))
    return home_frame(objects, _env_paths(environment, file_env))


def _parts_in_map(frame, parts: list[Part]) -> list[Part]:
    """Home-frame :class:`Part` s of an object (boxes, ellipsoids, cylinders) carried to the map frame by a
    :class:`~benchbot_worlds.homes.home_frame.HomeFrame` (a symmetry of the square: boxes stay boxes)."""
    out = []
    for part in parts:
        lo, hi = frame.box_to_map(part.lo, part.hi)
        out.append(Part(part.kind, lo, hi, frame.axis_to_map(part.axis), part.colour, part.tris))
    return out


def _box_models(home, n_boxes: int) -> list[str]:
    """:attr:`Scene.box_models` of ``n_boxes`` objects furnished as ``home`` (None: the primitives style, [])."""
    if home is None:
        return []
    by_object = {p.object_index: p.asset_id for p in home.furnishing.placements if p.role == "object"}
    return [by_object.get(k, "") for k in range(n_boxes)]


def furnished_home(environment: dict, file_env: dict, objects: list, map_path):
    """The :class:`~benchbot_worlds.homes.furnished.FurnishedHome` of an environment (its home's plan is derived
    from the ground-truth files its ``home_files`` declares with its own map file,
    :func:`~benchbot_worlds.homes.floorplan.home_files`, or from this environment's own poses without a map file),
    seeded by the home alone (:func:`benchbot.core.seeding.home_seed` of the environment's ``name``): every variant of
    a home gets the same plan, materials and furniture, whatever the world seed.

    Raises:
        BackendError: ``home_files`` is malformed or names a missing file, or one of the files is not a ground-truth
            JSON (one line naming the environment and the field).
    """
    from benchbot_worlds.homes.floorplan import HOME_FILES_FIELD, home_files
    from benchbot_worlds.homes.furnished import furnish_environment

    paths = _env_paths(environment, file_env)
    files = home_files(environment, _env_dir(environment)) if map_path else None
    try:
        return furnish_environment(objects, files, paths, seed=home_seed(str(environment.get("name", ""))))
    except BackendError as e:
        if not environment.get(HOME_FILES_FIELD) or not e.message.startswith("floor plan: cannot read"):
            raise
        raise BackendError(f"environment {environment.get('name')}:{environment.get('variant')}: {HOME_FILES_FIELD}: "
                           f"{e.message.removeprefix('floor plan: ')}", e.hint) from e


#: The BEAR class list (30 classes, ``background`` last): the class list of environments without a map_path.
BEAR_CLASS_LIST = ("bottle", "cup", "knife", "bowl", "wine glass", "fork", "spoon", "banana", "apple", "orange", "cake",
                   "potted plant", "mouse", "keyboard", "laptop", "cell phone", "book", "clock", "chair", "table",
                   "couch", "bed", "toilet", "tv", "microwave", "toaster", "refrigerator", "oven", "sink", "person",
                   "background")


def _env_dir(environment: dict) -> Path:
    fp = environment.get("_file_path")
    return Path(fp).resolve().parent if fp else Path.cwd()


def _rotation(pose: list) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3), t (3,)) of ``[x, y, z, yaw_deg]`` or ``[qw, qx, qy, qz, x, y, z]``."""
    if len(pose) == 4:
        x, y, z, yaw = (float(v) for v in pose)
        c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array([x, y, z])
    p = np.asarray(pose, dtype=np.float64)
    return quaternion_wxyz_to_matrix(p[:4]), p[4:]


def load_mesh_objects(environment: dict) -> list[dict]:
    """The environment's mesh objects as ground-truth-like objects (``class``, ``ID_name``, ``centroid``,
    ``extent`` = the axis-aligned bounds of the placed mesh, ``isgroup: False``, ``_mesh`` the
    :class:`~benchbot_worlds.scene.meshes.MeshData` (with its file's materials and textures) and ``_transform``
    (4, 4) mesh → map).

    The environment field ``objects`` is a list of ``{mesh: PATH, class: NAME, pose: [x, y, z, yaw_deg] or
    [qw, qx, qy, qz, x, y, z] (default [0, 0, 0, 0]), scale: s or [sx, sy, sz] (default 1), name: ID (optional)}``;
    PATH (OBJ, GLB/glTF, PLY, STL, … — anything trimesh reads; every node of a scene file with its transform) is
    absolute or relative to the environment file. GLB/glTF files are converted from glTF's +Y up to the map's z up
    (:func:`~benchbot_worlds.scene.meshes.load_mesh`); other formats are taken as z up. The mesh's vertices are
    scaled, rotated, then translated: ``p_map = R · (s ⊙ p_mesh) + t``. A mesh whose file has no material takes
    its class colour.

    Raises:
        BackendError: one line naming the field: ``objects`` does not match :data:`ENVIRONMENT_SCHEMA` (not a list, an
            entry without ``mesh``/``class``, a ``pose`` not of 4 or 7 numbers, a ``scale`` not positive), a pose or
            scale is not finite or a quaternion is zero, a mesh file is missing, unreadable or has no triangles.
    """
    objs = environment.get("objects")
    if objs is None:
        return []
    where = f"environment {environment.get('name')}:{environment.get('variant')}"
    form = "objects: [{mesh: PATH, class: NAME, pose: [x, y, z, yaw_deg] | [qw,qx,qy,qz,x,y,z], scale: s | [sx,sy,sz]}]"
    error = first_error({"objects": objs}, ENVIRONMENT_SCHEMA)
    if error:
        raise BackendError(f"{where}: {error[0].removeprefix('$.')}: {error[1]}", form)
    out = []
    for i, o in enumerate(objs):
        # What JSON Schema cannot express: a finite pose with a non-zero quaternion, a finite scale (NaN passes every
        # bound); the mesh file's existence below.
        try:
            R, t = _rotation(list(o.get("pose", [0, 0, 0, 0])))
            sc = np.broadcast_to(np.asarray(o.get("scale", 1.0), dtype=np.float64), (3,)).copy()
            if not (np.all(np.isfinite(sc)) and np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
                raise ValueError("scale and pose must be finite")
        except ValueError as e:  # also a zero quaternion (quaternion_wxyz_to_matrix)
            raise BackendError(f"{where}: objects[{i}] has a bad pose or scale ({e})", form) from e
        path = Path(o["mesh"]).expanduser()
        if not path.is_absolute():
            path = _env_dir(environment) / path
        if not path.is_file():
            raise BackendError(f"{where}: objects[{i}].mesh {path} does not exist",
                               "mesh paths are absolute or relative to the environment file")
        try:
            mesh = load_mesh(path)
        except BackendError as e:
            raise BackendError(f"{where}: {e.message}", e.hint) from e
        transform = np.eye(4)
        transform[:3, :3] = R * sc[None, :]
        transform[:3, 3] = t
        lo, hi = instance_bounds(MeshInstance(mesh, transform))
        out.append({"class": o["class"], "ID_name": str(o.get("name") or f"{o['class']}_mesh_{i}"),
                    "centroid": ((lo + hi) / 2).tolist(), "extent": (hi - lo).tolist(), "isgroup": False,
                    "_mesh": mesh, "_transform": transform})
    return out


def derive_ground_truth(environment: dict, *, seed: int = 0) -> dict:
    """The ground truth ``{environment, format, ground_truth}`` of an environment, derived from its scene: one
    object per ground-truth object (the map_path's, then the mesh objects'), its cuboid the axis-aligned bounds of
    its geometry. For ``benchbot eval`` on environments with mesh objects."""
    scene = build_scene(environment, seed=seed)
    objects = []
    for i in range(scene.n_boxes):
        lo, hi = scene.box_min[i].astype(np.float64), scene.box_max[i].astype(np.float64)
        objects.append({"class": scene.class_list[int(scene.box_class[i])], "ID_name": scene.box_names[i],
                        "centroid": ((lo + hi) / 2).tolist(), "extent": (hi - lo).tolist(), "isgroup": False})
    env = {k: environment[k] for k in ("name", "variant", "start_pose", "trajectory_poses", "object_labels")
           if k in environment}
    return {"environment": env, "format": {"name": "object_map_ground_truth"},
            "ground_truth": {"class_list": list(scene.class_list), "objects": objects}}
