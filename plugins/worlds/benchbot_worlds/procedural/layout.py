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
