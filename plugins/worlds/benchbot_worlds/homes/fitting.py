"""Fitting a model into an axis-aligned box, and choosing a model by its proportions (pure NumPy).

A model (an :class:`~benchbot.packs.assets.AssetInfo`) is described in its map frame: z up, front −y, origin at the
centre of the bottom of its bounds, bounds ``size_m = [w, d, h]``. :func:`fit_to_cuboid` gives the transform
``T = Translate(box bottom centre) · Rz(k·90°) · Scale(s) · Translate(−model bottom centre)`` that makes the model's
bounds EQUAL the box (k odd swaps the x and y extents; quarter turns only, so axis-aligned bounds stay exact).
:func:`choose_model` picks, seeded, among the models and turns that distort the least
(``Σ_axes |log(s_axis / geometric-mean(s))|``, 0 for a uniform scale), plus, with a ``size_weight``, a size term
``size_weight · |log(geometric-mean(s))|`` (0 when the model keeps its size; the packs' models have their real sizes,
so a 0.8 m cuboid takes an armchair rather than a 0.45 m stool of the same proportions blown up 1.8×), plus a facing
term ``weight · (1 − cos Δ) / 2`` (Δ: angle between the model's front after the turn and the wanted facing).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: Weight of a rule-given facing against the proportion distortion (see the module docstring): facing yields to
#: proportions once the facing it wants distorts by more than about this (0.6: a 1.8x aspect change).
FACING_WEIGHT = 0.6

#: The size term's weight for ground-truth objects (:mod:`~benchbot_worlds.homes.furnish`; see the module
#: docstring): a model of the right proportions at twice (or half) its size scores as one of the right size whose
#: proportions are off by a factor 2.2 on one axis. Chosen with ``benchmarks/realism.py`` (docs/realism.md, 24 Nov
#: 2026, late: 1.5 against 0 and 3).
SIZE_WEIGHT = 1.5

#: Weight of a seeded random facing (only breaks ties between turns that distort alike).
RANDOM_FACING_WEIGHT = 0.05

#: The model is drawn among at most this many best-scoring models ...
CHOICE_TOP = 3

#: ... whose score is within this of the best one.
CHOICE_MARGIN = 0.15

_FRONT = np.array([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])  # model front after k quarter turns
_COS = (1.0, 0.0, -1.0, 0.0)  # exact cos/sin of k quarter turns
_SIN = (0.0, 1.0, 0.0, -1.0)


def asset_bounds(asset: Any) -> np.ndarray:
    """(2, 3) float64 bounds of an asset in its map frame from its ``size_m``: ``[[−w/2, −d/2, 0], [w/2, d/2, h]]``.

    Raises:
        ValueError: a size is not positive and finite.
    """
    size = np.asarray(asset.size_m, dtype=np.float64).reshape(3)
    if not (np.all(np.isfinite(size)) and np.all(size > 0)):
        raise ValueError(f"asset {getattr(asset, 'id', '?')}: size_m {size.tolist()} must be 3 positive numbers")
    return np.array([[-size[0] / 2, -size[1] / 2, 0.0], [size[0] / 2, size[1] / 2, size[2]]])


def front_of(k: int) -> np.ndarray:
    """(2,) unit xy direction the model's front (−y in its frame) faces after ``k`` quarter turns about z."""
    return _FRONT[int(k) % 4].copy()


def turns_facing(direction: Sequence[float]) -> int:
    """The quarter turn ``k`` whose :func:`front_of` is closest to ``direction`` (2,)."""
    d = np.asarray(direction, dtype=np.float64)[:2]
    return int(np.argmax(_FRONT @ d))


def turns_along_longer_side(lo: Sequence[float], hi: Sequence[float], prefer: Sequence[float] | None,
                            rng: np.random.Generator) -> int:
    """The quarter turn ``k`` that lays a model's x (its width) along the longer horizontal side of the cuboid
    ``lo``..``hi`` (3,) metres, its front (:func:`front_of`) toward ``prefer`` (2,): of the two turns that do, the
    one whose front is nearer ``prefer``; a seeded one of the two (one draw from ``rng``) when ``prefer`` is None."""
    ext = np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64)
    turns = (0, 2) if ext[0] >= ext[1] else (1, 3)  # an even k keeps the model's x along the map's x
    if prefer is None:
        return turns[int(rng.integers(2))]
    return max(turns, key=lambda k: float(front_of(k) @ np.asarray(prefer, dtype=np.float64)[:2]))


def fit_to_cuboid(asset: Any, lo: Sequence[float], hi: Sequence[float], yaw_quarter_turns: int, *,
                  bounds: np.ndarray | None = None) -> np.ndarray:
    """The transform that puts ``asset`` exactly into the axis-aligned box ``lo``..``hi``.

    ``T = Translate(box bottom centre) · Rz(k·90°) · Scale(s) · Translate(−model bottom centre)`` with ``s`` such
    that the model's bounds map onto the box (to rounding): with ``k`` odd the model's x extent spans the box's y.

    Args:
        asset: an :class:`~benchbot.packs.assets.AssetInfo` (its ``size_m`` gives the bounds unless ``bounds``).
        lo, hi: (3,) box corners, map frame, metres; ``hi > lo`` on every axis.
        yaw_quarter_turns: k (any integer; taken mod 4); the model's front faces :func:`front_of` (k).
        bounds: (2, 3) the model's true bounds in its map frame (e.g. its mesh's), if they differ from ``size_m``.

    Returns:
        (4, 4) float64 model → map.

    Raises:
        ValueError: the box is empty or flat on an axis, or the model's bounds are.
    """
    lo = np.asarray(lo, dtype=np.float64).reshape(3)
    hi = np.asarray(hi, dtype=np.float64).reshape(3)
    b = asset_bounds(asset) if bounds is None else np.asarray(bounds, dtype=np.float64).reshape(2, 3)
    size = b[1] - b[0]
    ext = hi - lo
    if not (np.all(np.isfinite(ext)) and np.all(ext > 0)):
        raise ValueError(f"box {lo.tolist()}..{hi.tolist()} must have positive finite extents")
    if not (np.all(np.isfinite(size)) and np.all(size > 0)):
        raise ValueError(f"asset {getattr(asset, 'id', '?')}: bounds {b.tolist()} must have positive extents")
    k = int(yaw_quarter_turns) % 4
    s = np.empty(3)
    if k % 2 == 0:
        s[0], s[1] = ext[0] / size[0], ext[1] / size[1]
    else:
        s[0], s[1] = ext[1] / size[0], ext[0] / size[1]
    s[2] = ext[2] / size[2]
    c, sn = _COS[k], _SIN[k]
    pre = -np.array([(b[0, 0] + b[1, 0]) / 2, (b[0, 1] + b[1, 1]) / 2, b[0, 2]])
    post = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    R = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
    M = R * s[None, :]  # R · diag(s)
    T = np.eye(4)
    T[:3, :3] = M
    T[:3, 3] = M @ pre + post
    return T


def transformed_bounds(T: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """(2, 3) axis-aligned bounds of the 8 corners of ``bounds`` (2, 3) under ``T`` (4, 4)."""
    b = np.asarray(bounds, dtype=np.float64)
    corners = np.array([[b[i, 0], b[j, 1], b[l, 2]] for i in (0, 1) for j in (0, 1) for l in (0, 1)])
    p = corners @ T[:3, :3].T + T[:3, 3]
    return np.stack([p.min(axis=0), p.max(axis=0)])


def distortion(size: Sequence[float], ext: Sequence[float], k: int) -> float:
    """How non-uniform the scale fitting a model of ``size`` (3,) into a box of ``ext`` (3,) with ``k`` quarter
    turns is: ``Σ |log(s_i / geometric mean(s))|`` (0 for a uniform scale)."""
    size = np.asarray(size, dtype=np.float64)
    ext = np.asarray(ext, dtype=np.float64)
    if k % 2:
        size = size[[1, 0, 2]]
    ls = np.log(ext / size)
    return float(np.abs(ls - ls.mean()).sum())


def size_change(size: Sequence[float], ext: Sequence[float], k: int) -> float:
    """How much fitting a model of ``size`` (3,) into a box of ``ext`` (3,) with ``k`` quarter turns scales it
    overall: ``|log(geometric mean of the per-axis scales)|`` (0 when the model keeps its size; log 2 ≈ 0.69 at twice
    or half its size)."""
    size = np.asarray(size, dtype=np.float64)
    ext = np.asarray(ext, dtype=np.float64)
    if k % 2:
        size = size[[1, 0, 2]]
    return float(abs(np.log(ext / size).mean()))


def tall_stretch(size: Sequence[float], ext: Sequence[float]) -> float:
    """How much taller than wide fitting a model of ``size`` (3,) into a box of ``ext`` (3,) makes it (both extents in
    metres along x, y, z, z up; positive): the vertical scale over the larger horizontal one, ``s_z / max(s_x, s_y)``,
    with the quarter turn that distorts least (:func:`distortion`). 1: the model keeps its proportion of height to
    width; 1.4: a teacup fitted into a mug's box, which reads as a vase. A float; raises nothing (a zero extent gives
    0 or inf)."""
    size = np.asarray(size, dtype=np.float64)
    ext = np.asarray(ext, dtype=np.float64)
    s = size[[1, 0, 2]] if distortion(size, ext, 1) < distortion(size, ext, 0) else size
    return float(ext[2] / s[2] / max(ext[0] / s[0], ext[1] / s[1]))


def choose_model(assets: Sequence[Any], ext: Sequence[float], prefer: np.ndarray | None, weight: float,
                 rng: np.random.Generator, *, size_weight: float = 0.0) -> tuple[Any, int] | None:
    """Seeded choice of (asset, quarter turns) for a box of extents ``ext`` (3,), ``prefer`` the wanted facing (2,)
    or None, ``size_weight`` the size term's weight (0: proportions and facing only; see the module docstring for
    the score). ``None`` when ``assets`` is empty."""
    ext = np.asarray(ext, dtype=np.float64)
    rows = []
    for i, a in enumerate(assets):
        size = np.asarray(a.size_m, dtype=np.float64)
        best = None
        for k in range(4):
            sc = distortion(size, ext, k)
            if size_weight:
                sc += size_weight * size_change(size, ext, k)
            if prefer is not None:
                sc += weight * (1.0 - float(front_of(k) @ prefer)) / 2.0
            if best is None or sc < best[0] - 1e-12:
                best = (sc, k)
        rows.append((best[0], i, best[1]))
    if not rows:
        return None
    rows.sort()
    pool = [r for r in rows[:CHOICE_TOP] if r[0] <= rows[0][0] + CHOICE_MARGIN]
    _, i, k = pool[int(rng.integers(len(pool)))]
    return assets[i], k
