"""The layout of a procedural home: rectangular rooms made by guillotine cuts of the outer rectangle, and the doors
between them (pure Python and NumPy; metres, ``map`` frame, z up, floor at z = 0).

The rooms tile the outer rectangle ``outer_lo``..``outer_hi`` (the inner faces of the exterior walls); a cut is a wall
line across one cell of the partition. Room boxes are measured between wall centre lines (a room's clear floor is
its box less half a wall thickness on every interior side), as :class:`benchbot_worlds.homes.floorplan.Room`'s
cells are before the walls are cut.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The room types of a procedural home.
ROOM_TYPES = ("bedroom", "bathroom", "kitchen", "living_room", "dining_room", "office", "hall")


@dataclass(frozen=True)
class Cut:
    """One guillotine cut: the wall line ``axis`` = ``pos`` (axis 0: the line x = pos, a wall running along y;
    axis 1: y = pos) from ``lo`` to ``hi`` along the other axis (metres), splitting one cell into two."""

    axis: int
    pos: float
    lo: float
    hi: float


@dataclass(frozen=True)
class RoomBox:
    """A room: ``index`` into :attr:`Layout.rooms`, ``kind`` (one of :data:`ROOM_TYPES`), ``lo``/``hi`` (2,) float64
    xy corners between wall centre lines (the outer rectangle's faces on exterior sides)."""

    index: int
    kind: str
    lo: np.ndarray
    hi: np.ndarray


@dataclass(frozen=True)
class Door:
    """A doorway between rooms ``rooms`` = (a, b) in the wall line ``axis`` = ``pos`` (as :class:`Cut`), spanning
    ``lo``..``hi`` along the wall (metres, the clear opening). ``centre`` (2,) is the doorway's middle on the wall
    line; a robot passes through it along ``axis``."""

    rooms: tuple[int, int]
    axis: int
    pos: float
    lo: float
    hi: float

    @property
    def centre(self) -> np.ndarray:
        c = np.zeros(2)
        c[self.axis] = self.pos
        c[1 - self.axis] = (self.lo + self.hi) / 2
        return c

    @property
    def width(self) -> float:
        return self.hi - self.lo


@dataclass(frozen=True)
class Layout:
    """A home's rooms and doors: ``outer_lo``/``outer_hi`` (2,) the inner faces of the exterior walls, ``cuts`` in
    the order they were made, ``rooms``, ``doors`` (every room reachable from every other through them) and the
    ``wall_thickness`` (m)."""

    outer_lo: np.ndarray
    outer_hi: np.ndarray
    cuts: list[Cut]
    rooms: list[RoomBox]
    doors: list[Door]
    wall_thickness: float = 0.12


def _r6(v: float) -> float:
    return round(float(v), 6) + 0.0  # + 0.0: no negative zeros


def layout_to_dict(layout: Layout) -> dict:
    """The JSON form of ``layout`` stored in each variant's ``environment.layout`` (metres, map frame, coordinates
    rounded to a micrometre): ``outer`` [[x0, y0], [x1, y1]], ``cuts`` [[axis, pos, lo, hi], ...] in the order made,
    ``rooms`` [{"kind", "lo": [x, y], "hi": [x, y]}, ...] (boxes between wall centre lines), ``room_kinds`` (the
    rooms' kinds, in order), ``doors`` [{"rooms": [a, b], "axis", "pos", "lo", "hi"}, ...] and ``wall_thickness``.
    :func:`benchbot_worlds.homes.floorplan.derive_floor_plan` reads ``outer``, ``cuts`` and the rooms' kinds."""
    return {
        "outer": [[_r6(v) for v in layout.outer_lo], [_r6(v) for v in layout.outer_hi]],
        "cuts": [[int(c.axis), _r6(c.pos), _r6(c.lo), _r6(c.hi)] for c in layout.cuts],
        "rooms": [{"kind": r.kind, "lo": [_r6(v) for v in r.lo], "hi": [_r6(v) for v in r.hi]} for r in layout.rooms],
        "room_kinds": [r.kind for r in layout.rooms],
        "doors": [{"rooms": [int(d.rooms[0]), int(d.rooms[1])], "axis": int(d.axis), "pos": _r6(d.pos),
                   "lo": _r6(d.lo), "hi": _r6(d.hi)} for d in layout.doors],
        "wall_thickness": _r6(layout.wall_thickness),
    }


def layout_from_dict(data: dict) -> Layout:
    """The :class:`Layout` of its JSON form (:func:`layout_to_dict`).

    Raises:
        ValueError: a field is missing or malformed.
    """
    try:
        outer = np.asarray(data["outer"], dtype=np.float64).reshape(2, 2)
        cuts = [Cut(int(a), float(p), float(lo), float(hi)) for a, p, lo, hi in data["cuts"]]
        rooms = [RoomBox(i, str(r["kind"]), np.asarray(r["lo"], dtype=np.float64).reshape(2),
                         np.asarray(r["hi"], dtype=np.float64).reshape(2)) for i, r in enumerate(data["rooms"])]
        doors = [Door((int(d["rooms"][0]), int(d["rooms"][1])), int(d["axis"]), float(d["pos"]), float(d["lo"]),
                      float(d["hi"])) for d in data.get("doors", [])]
        return Layout(outer[0].copy(), outer[1].copy(), cuts, rooms, doors, float(data.get("wall_thickness", 0.12)))
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"malformed layout ({e!r})") from e
