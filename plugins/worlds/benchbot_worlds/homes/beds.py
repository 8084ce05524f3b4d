"""A bed's model clear of the nightstand that stands inside its cuboid (pure NumPy).

BEAR's minirooms box their bed (2.30 x 1.85 x 0.90 m) with its headboard, which is wider than its mattress: the
nightstand beside it stands 0.2 m inside the bed's cuboid, and the laptop on the nightstand 0.26 m. A model that
filled the cuboid buried a third of the nightstand and two thirds of the laptop (docs/realism.md, 29 Nov 2026). So a
bed's model, still chosen for its whole cuboid, is drawn back from such a side (:func:`clear_of_neighbours`): it
spans its cuboid but for that strip, and nothing of it stands inside another object. The ground truth is not
changed. (A headboard wing made in code over the strip, to span the cuboid again, stood apart from the model's
headboard, which is narrower than its cover: docs/history/realism-2026-11.md, *A bed clear of its nightstand*.)
"""

from __future__ import annotations

import numpy as np

from benchbot_worlds.homes.furnish_space import Space

__all__ = ["CLEARED_CLASSES", "CLEARED_MIN_FRACTION", "NEIGHBOUR_BELOW_FRACTION", "clear_of_neighbours"]

#: Classes whose model is drawn back from a side of its cuboid where a lower GT object beside it reaches in.
CLEARED_CLASSES = frozenset(("bed",))

#: A neighbour counts when its bottom is lower than this fraction of the bed's height over the bed's bottom (a
#: nightstand, a laptop on it; not what stands on a shelf over the bed's edge) ...
NEIGHBOUR_BELOW_FRACTION = 0.5

#: ... and the model keeps at least this fraction of its cuboid's width or length, else that axis is left whole.
CLEARED_MIN_FRACTION = 0.7


def clear_of_neighbours(lo: np.ndarray, hi: np.ndarray, space: Space) -> tuple[np.ndarray, np.ndarray]:
    """The box a bed's model fills: its cuboid, drawn back on each side that a neighbour reaches in across, to the
    neighbour's edge.

    Args:
        lo, hi: (3,) the bed's cuboid corners, metres, in the frame of ``space`` (the home frame that
            :func:`~benchbot_worlds.homes.furnish.furnish_home` works in); positive extents.
        space: the home's :class:`~benchbot_worlds.homes.furnish_space.Space`; its GT boxes (``gt_lo``/``gt_hi``,
            ``gt_classes``) are the candidate neighbours.

    A neighbour is a GT box that overlaps the cuboid, comes in from outside it across one side (crossing two, the one
    it reaches in less across) and whose bottom is lower than :data:`NEIGHBOUR_BELOW_FRACTION` of the cuboid's
    height; people are left out. An axis that would keep less than :data:`CLEARED_MIN_FRACTION` of its extent is
    left whole.

    Returns:
        (lo, hi): (3,) float64 new arrays, the same frame and units; z is never changed. Raises nothing.
    """
    lo, hi = np.asarray(lo, dtype=np.float64).copy(), np.asarray(hi, dtype=np.float64).copy()
    new_lo, new_hi = lo.copy(), hi.copy()
    for olo, ohi in _neighbours(lo, hi, space):
        cuts = []  # (depth reached in, axis, side)
        for ax in (0, 1):  # it overlaps the cuboid: across a side is beyond that side and short of the other
            if olo[ax] > lo[ax] and ohi[ax] > hi[ax]:
                cuts.append((hi[ax] - olo[ax], ax, 1))
            elif olo[ax] < lo[ax] and ohi[ax] < hi[ax]:
                cuts.append((ohi[ax] - lo[ax], ax, 0))
        if cuts:
            _, ax, side = min(cuts)
            if side:
                new_hi[ax] = min(new_hi[ax], olo[ax])
            else:
                new_lo[ax] = max(new_lo[ax], ohi[ax])
    for ax in (0, 1):
        if new_hi[ax] - new_lo[ax] >= CLEARED_MIN_FRACTION * (hi[ax] - lo[ax]):
            lo[ax], hi[ax] = new_lo[ax], new_hi[ax]
    return lo, hi


def _neighbours(lo: np.ndarray, hi: np.ndarray, space: Space) -> list[tuple[np.ndarray, np.ndarray]]:
    """The GT boxes of ``space`` that overlap the cuboid ``lo``..``hi`` without lying inside it, lower than
    :data:`NEIGHBOUR_BELOW_FRACTION` of its height, people left out (:func:`clear_of_neighbours`)."""
    below = lo[2] + NEIGHBOUR_BELOW_FRACTION * (hi[2] - lo[2])
    out = []
    for olo, ohi, cls in zip(space.gt_lo, space.gt_hi, space.gt_classes):
        inside = np.all(olo >= lo - 1e-9) and np.all(ohi <= hi + 1e-9)
        overlaps = np.all(np.minimum(hi, ohi) - np.maximum(lo, olo) > 1e-6)
        if cls != "person" and olo[2] < below and not inside and overlaps:
            out.append((olo, ohi))
    return out
