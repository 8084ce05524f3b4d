"""The home frame: the orientation a furnished home is derived in, so that a turned or mirrored layout gives the same
world turned or mirrored (pure NumPy).

Why: the floor plan (:mod:`benchbot_worlds.homes.floorplan`) splits a home with axis-aligned walls, tries the
x axis before the y axis, draws its seeded jitter in that order, breaks ties towards smaller coordinates and sorts
rooms by y then x; the furnishing walks the plan's rooms, walls and windows in that order, and the sun shines from a
fixed direction. Derived in the map frame, a layout turned by 90° or mirrored got another house (other walls, other
rooms, other furniture, the sun from elsewhere), and other scores.

How: the ground-truth cuboids of a BEAR layout are axis-aligned, so the turns of a layout that keep it a BEAR layout
are the eight symmetries of the square (quarter turns and mirrors about the axes and diagonals). :func:`home_frame`
picks among them the one under which the layout looks a fixed way (:data:`ORIENTATION_RULES`), with no regard to the
orientation it came in: every turned or mirrored copy of a layout is brought to the same home-frame layout, bit for
bit (the symmetries of the square only swap and negate coordinates). The plan, the furnishing, the structure's
texture coordinates and the sun's direction are derived there, then every placement, wall box, lamp and the sun are
carried to the map frame (:class:`HomeFrame`); so are the procedural models of objects drawn with primitives (in
either style: a chair's back, a bed's headboard are placed by the object's longer side and a seeded flip). The rules
are such that the ten BEAR layouts are in their home orientation already (their frame turns nothing).

A moved layout: a furnished home's frame also has an origin of its own (:func:`home_frame` with ``own_origin``, as
:func:`~benchbot_worlds.homes.floorplan.home_plan` asks): the lowest corner, in the home frame, of the layout's
bounding box. The objects and paths are carried there and their xy rounded to :data:`HOME_GRID_M`, so a layout
moved by any translation (and turned) reaches the same home-frame layout bit for bit: the last bits in which
``(p + t) - (o + t)`` differs from ``p - o`` are rounded away, and with them every decision they could tip at BEAR's
exact contacts (objects flush on others, sides touching). (Only a coordinate within those last bits of a half
micrometre could round either way: about one coordinate in 10⁹.) The plan, the furnishing and the structure's texture
coordinates (metres from the home's origin) are therefore the same, and the world differs from the moved original
only by the rounding of carrying it back (about 1e-15 m; float32 triangles: their own resolution). The primitives
style keeps the map's origin (:func:`home_frame` without ``own_origin``): its models are made per object, with no
decision a shift could tip.

What it does not cover: a turn by another angle than a quarter turn changes what a BEAR cuboid is (its axis-aligned
extent), so no such layout is the same objects turned. A layout symmetric under a turn or mirror in every rule (to
:data:`TIE_M`) keeps its own orientation. A fitted model fills its cuboid as carried to the home frame, so to
:data:`HOME_GRID_M`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace

import numpy as np

#: Two rule values closer than this (metres) are a tie, decided by the next rule.
TIE_M = 1e-6
#: The grid (metres) that home-frame coordinates are rounded to in a frame with an origin of the home's own
#: (:func:`home_frame` with ``own_origin``): a moved copy of a layout differs from it in the last bits of every
#: coordinate, rounded away here, so that every decision of the plan and the furnishing is the same bit for bit.
#: Below float32's resolution of a triangle's vertex a few metres from the origin (0.5-1 µm).
HOME_GRID_M = 1e-6
HOME_GRID_DECIMALS = 6
#: The eight symmetries of the square as home ← map matrices (p_home = R @ p_map), the identity first: a layout
#: symmetric in every rule keeps its orientation.
SQUARE_SYMMETRIES = tuple(np.array(m, dtype=np.float64) for m in (
    [[1, 0], [0, 1]], [[-1, 0], [0, 1]], [[1, 0], [0, -1]], [[-1, 0], [0, -1]],
    [[0, 1], [1, 0]], [[0, -1], [1, 0]], [[0, 1], [-1, 0]], [[0, -1], [-1, 0]]))
#: How the home frame is chosen, rule by rule (each maximised, ties by the next): the layout's bounding box is at
#: least as long along y as along x; the mean of its objects' centres lies at x ≤ and y ≥ the box's centre; then the
#: mean of its robot paths' points, then the objects' centres weighted by their footprint, likewise.
ORIENTATION_RULES = ("box longer along y", "object centres toward -x", "object centres toward +y",
                     "path points toward -x", "path points toward +y", "object footprints toward -x",
                     "object footprints toward +y")


@dataclass(frozen=True)
class HomeFrame:
    """A home's frame: ``p_home = R @ (p_map - origin)`` in xy (z unchanged), rounded to :data:`HOME_GRID_M` when the
    frame has an origin of its own.

    Attributes:
        R: (2, 2) float64 home ← map rotation or reflection, one of :data:`SQUARE_SYMMETRIES` (entries 0 and ±1,
            so every coordinate carried either way is exact).
        origin: (2,) float64 map-frame xy (metres) of the home frame's origin (:func:`home_frame` with
            ``own_origin``: the corner of the layout's bounding box that the home frame puts lowest in x and y), or
            None: the map's origin (a turn only, nothing rounded).
    """

    R: np.ndarray
    origin: np.ndarray | None = None

    @property
    def is_identity(self) -> bool:
        """Whether the home frame is the map frame (then nothing is carried anywhere)."""
        return self.origin is None and bool(np.array_equal(self.R, np.eye(2)))

    @property
    def T_map_home(self) -> np.ndarray:
        """(4, 4) float64 transform taking home-frame points to the map frame."""
        T = np.eye(4)
        T[:2, :2] = self.R.T
        if self.origin is not None:
            T[:2, 3] = self.origin
        return T

    def _home_xy(self, xy: np.ndarray) -> np.ndarray:
        """(M, 2) map-frame xy → home frame, on the :data:`HOME_GRID_M` grid when the frame has an origin."""
        if self.origin is None:
            return xy @ self.R.T
        return np.round((xy - self.origin) @ self.R.T, HOME_GRID_DECIMALS) + 0.0  # + 0.0: no negative zeros

    def points_to_home(self, xy) -> np.ndarray:
        """(M, 2) float64 map-frame xy points (metres) in the home frame."""
        return self._home_xy(np.asarray(xy, dtype=np.float64).reshape(-1, 2))

    def objects_to_home(self, objects: list[dict]) -> list[dict]:
        """Ground-truth objects (``centroid``, ``extent``: axis-aligned cuboids, metres) in the home frame: copies
        with the centroid carried (its xy on the :data:`HOME_GRID_M` grid when the frame has an origin) and the
        horizontal extents swapped where the frame swaps x and y; every other key kept. The identity returns
        ``objects`` itself."""
        if self.is_identity:
            return objects
        out = []
        for o in objects:
            c = np.asarray(o["centroid"], dtype=np.float64).reshape(3)
            e = np.asarray(o["extent"], dtype=np.float64).reshape(3)
            c2, e2 = c.copy(), e.copy()
            c2[:2] = self._home_xy(c[None, :2])[0]
            e2[:2] = np.abs(self.R) @ e[:2]
            out.append({**o, "centroid": c2.tolist(), "extent": e2.tolist()})
        return out

    def layout_to_home(self, layout: dict | None) -> dict | None:
        """A procedural home's layout (its JSON form, :func:`benchbot_worlds.procedural.layout.layout_to_dict`: map
        frame, metres) in the home frame: ``outer`` and each room's ``lo``/``hi`` carried as boxes, each cut
        [axis, pos, lo, hi] carried by its two end points (the axis swapped where the frame swaps x and y, the ends
        ordered), every coordinate by the same rounding as :meth:`points_to_home`, so cut lines and room sides that
        are equal in the map frame stay equal bit for bit; each door's [axis, pos, lo, hi] as a cut's; other keys are
        kept; None and the identity return ``layout`` itself.

        Raises:
            KeyError, TypeError, ValueError: a malformed layout.
        """
        if layout is None or self.is_identity:
            return layout

        def box(lo, hi):
            a = self._home_xy(np.asarray([lo, hi], dtype=np.float64).reshape(2, 2))
            return np.minimum(a[0], a[1]).tolist(), np.maximum(a[0], a[1]).tolist()

        def line(ax, pos, lo, hi) -> tuple[int, float, float, float]:
            ends = np.zeros((2, 2))
            ends[:, int(ax)] = float(pos)
            ends[:, 1 - int(ax)] = (float(lo), float(hi))
            e = self._home_xy(ends)
            ax2 = int(ax) if self.R[0, 0] != 0 else 1 - int(ax)
            return ax2, float(e[0, ax2]), float(e[:, 1 - ax2].min()), float(e[:, 1 - ax2].max())

        cuts = [list(line(*c)) for c in layout["cuts"]]
        rooms = [{**r, **dict(zip(("lo", "hi"), box(r["lo"], r["hi"])))} for r in layout.get("rooms", [])]
        out = {**layout, "outer": list(box(*layout["outer"])), "cuts": cuts, "rooms": rooms}
        if "doors" in layout:
            out["doors"] = [{**d, **dict(zip(("axis", "pos", "lo", "hi"), line(d["axis"], d["pos"], d["lo"], d["hi"])))}
                            for d in layout["doors"]]
        return out

    def box_to_map(self, lo, hi) -> tuple[np.ndarray, np.ndarray]:
        """The map-frame (lo, hi) of a home-frame axis-aligned box (2 or 3 coordinates; z unchanged)."""
        lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        if self.is_identity:
            return lo, hi
        a, b = self.point_to_map(lo), self.point_to_map(hi)
        return np.minimum(a, b), np.maximum(a, b)

    def point_to_map(self, p) -> np.ndarray:
        """A home-frame point (2 or 3 coordinates, metres; z unchanged) in the map frame."""
        out = self.vector_to_map(p)
        if self.origin is not None:
            out = out.copy()
            out[:2] = out[:2] + self.origin
        return out

    def vector_to_map(self, v) -> np.ndarray:
        """A home-frame direction (2 or 3 coordinates; z unchanged) in the map frame (turned, never moved)."""
        v = np.asarray(v, dtype=np.float64)
        if np.array_equal(self.R, np.eye(2)):
            return v
        out = v.copy()
        out[:2] = self.R.T @ v[:2]
        return out

    def axis_to_map(self, axis: int) -> int:
        """The map-frame axis (0, 1, 2) of a home-frame axis."""
        if axis == 2 or self.R[0, 0] != 0:
            return axis
        return 1 - axis

    def plan_to_map(self, plan):
        """A home-frame :class:`~benchbot_worlds.homes.floorplan.FloorPlan` in the map frame: rooms, walls,
        openings (their ``outward`` normals turned), lamps, wall spans (ends carried, ``inward`` normals turned), the
        outer boundary and the robot corridor carried; indices and order kept. The identity returns ``plan``
        itself."""
        if self.is_identity:
            return plan
        outer_lo, outer_hi = self.box_to_map(plan.outer_lo, plan.outer_hi)
        return replace(
            plan, outer_lo=outer_lo, outer_hi=outer_hi,
            rooms=[replace(r, lo=lo, hi=hi) for r in plan.rooms for lo, hi in [self.box_to_map(r.lo, r.hi)]],
            walls=[replace(w, lo=lo, hi=hi) for w in plan.walls for lo, hi in [self.box_to_map(w.lo, w.hi)]],
            openings=[replace(o, lo=lo, hi=hi, outward=self.vector_to_map(o.outward)) for o in plan.openings
                      for lo, hi in [self.box_to_map(o.lo, o.hi)]],
            lights=[self.point_to_map(p) for p in plan.lights],
            wall_spans=[replace(s, a=self.point_to_map(s.a), b=self.point_to_map(s.b),
                                inward=self.vector_to_map(s.inward)) for s in plan.wall_spans],
            corridor=type(plan.corridor)(self.points_to_map(plan.corridor.p0), self.points_to_map(plan.corridor.p1),
                                         plan.corridor.radius))

    def points_to_map(self, xy) -> np.ndarray:
        """(M, 2) float64 home-frame xy points (metres) in the map frame."""
        out = np.asarray(xy, dtype=np.float64).reshape(-1, 2) @ self.R
        return out if self.origin is None else out + self.origin


def _layout_box(objects: list[dict], paths: list) -> tuple[np.ndarray, np.ndarray] | None:
    """(lo, hi) (2,) float64 xy bounds (map frame, metres) of a layout: its objects' cuboids, else its path points;
    None for an empty layout."""
    if objects:
        c = np.array([np.asarray(o["centroid"], dtype=np.float64).reshape(3)[:2] for o in objects])
        e = np.abs(np.array([np.asarray(o["extent"], dtype=np.float64).reshape(3)[:2] for o in objects]))
        return (c - e / 2).min(axis=0), (c + e / 2).max(axis=0)
    pts = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in paths]
    pts = np.concatenate(pts) if pts else np.zeros((0, 2))
    if not len(pts):
        return None
    return pts.min(axis=0), pts.max(axis=0)


def _rule_values(objects: list[dict], paths: list) -> np.ndarray:
    """(8, len(ORIENTATION_RULES)) the rules' values (metres) of the layout under each of
    :data:`SQUARE_SYMMETRIES` (higher is preferred)."""
    pts = np.concatenate([np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in paths]) if paths else \
        np.zeros((0, 2))
    if objects:
        c = np.array([np.asarray(o["centroid"], dtype=np.float64).reshape(3)[:2] for o in objects])
        e = np.abs(np.array([np.asarray(o["extent"], dtype=np.float64).reshape(3)[:2] for o in objects]))
        lo, hi = (c - e / 2).min(axis=0), (c + e / 2).max(axis=0)
        area = e[:, 0] * e[:, 1]
        footprint = (c * area[:, None]).sum(axis=0) / area.sum() if area.sum() > 0 else c.mean(axis=0)
        centres = c.mean(axis=0)
    elif len(pts):
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        centres = footprint = (lo + hi) / 2
    else:
        return np.zeros((len(SQUARE_SYMMETRIES), len(ORIENTATION_RULES)))
    mid = (lo + hi) / 2
    offsets = [centres - mid, (pts.mean(axis=0) if len(pts) else mid) - mid, footprint - mid]
    rows = []
    for R in SQUARE_SYMMETRIES:
        size = np.abs(R) @ (hi - lo)
        row = [size[1] - size[0]]
        for d in offsets:
            d2 = R @ d
            row += [-d2[0], d2[1]]
        rows.append(row)
    return np.asarray(rows)


def home_frame(objects: list[dict], paths: list, *, own_origin: bool = False) -> HomeFrame:
    """The frame a home is derived in (module docstring): the symmetry of the square under which the layout best
    follows :data:`ORIENTATION_RULES`, rule by rule (values within :data:`TIE_M` tie), the identity first among
    equals.

    Args:
        objects: the home's ground-truth objects (``centroid``, ``extent``; map frame, metres).
        paths: (M, 2) xy robot paths (map frame, metres).
        own_origin: give the frame an origin of the home's own: the corner of the layout's bounding box (its
            objects' cuboids, else its path points) that is lowest in x and y once turned, so that a moved copy of
            the layout has the same home-frame coordinates (to :data:`HOME_GRID_M`). False: the map's origin.

    Returns:
        A :class:`HomeFrame`; with ``own_origin`` and an empty layout, one at the map's origin.
    """
    values = _rule_values(objects, paths)
    keep = np.arange(len(SQUARE_SYMMETRIES))
    for k in range(values.shape[1]):
        best = values[keep, k].max()
        keep = keep[values[keep, k] >= best - TIE_M]
    R = SQUARE_SYMMETRIES[int(keep[0])]
    box = _layout_box(objects, paths) if own_origin else None
    if box is None:
        return HomeFrame(R)
    corner = np.minimum(R @ box[0], R @ box[1])  # the box's lowest corner in the home frame
    return HomeFrame(R, R.T @ corner)


def turned_layout(data: dict, M, offset=(0.0, 0.0)) -> dict:
    """A copy of a BEAR ground-truth dict ``{environment, format, ground_truth}`` carried by the 2 × 2 matrix ``M``
    (one of :data:`SQUARE_SYMMETRIES`, map → turned map), then moved by ``offset`` ((2,) xy, metres): every object's
    centroid, its horizontal extents (swapped where ``M`` swaps x and y, so the cuboids stay axis-aligned), the start
    pose and every trajectory pose (written as unit quaternions about z: the start pose's yaw is the one the original
    placed the robot at, :func:`benchbot.core.geometry.start_pose_to_se2`): ``p' = M @ p + offset``. For tests and
    ``benchmarks/turned_homes.py``.

    Raises:
        ValueError: ``M`` is not a symmetry of the square, ``offset`` is not 2 finite numbers; a pose is malformed.
    """
    from benchbot.core.geometry import pose7_to_se2, start_pose_to_se2

    M = np.asarray(M, dtype=np.float64)
    if not any(np.array_equal(M, S) for S in SQUARE_SYMMETRIES):
        raise ValueError(f"{M.tolist()} is not a symmetry of the square (entries 0 and ±1, one non-zero per row)")
    t = np.asarray(offset, dtype=np.float64)
    if t.shape != (2,) or not np.all(np.isfinite(t)):
        raise ValueError(f"offset {offset!r} is not 2 finite numbers (x, y in metres)")

    def pose(se2, z: float) -> list[float]:
        p = M @ se2[:2] + t
        heading = M @ [math.cos(se2[2]), math.sin(se2[2])]
        yaw = math.atan2(heading[1], heading[0])
        return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2), float(p[0]), float(p[1]), float(z)]

    out = json.loads(json.dumps(data))
    for o in out["ground_truth"]["objects"]:
        c, e = np.asarray(o["centroid"], dtype=np.float64), np.asarray(o["extent"], dtype=np.float64)
        c[:2], e[:2] = M @ c[:2] + t, np.abs(M) @ e[:2]
        o["centroid"], o["extent"] = c.tolist(), e.tolist()
    env = out.get("environment") or {}
    if env.get("start_pose") is not None:
        env["start_pose"] = pose(start_pose_to_se2(env["start_pose"]), env["start_pose"][6])
    env["trajectory_poses"] = [pose(pose7_to_se2(p), p[6]) for p in env.get("trajectory_poses") or []]
    return out
