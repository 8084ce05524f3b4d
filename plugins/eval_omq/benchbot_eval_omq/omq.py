"""Object Map Quality (OMQ): the evaluation method of BenchBot's semantic SLAM and scene change detection tasks.

Formula: D. Hall et al., "The Robotic Vision Scene Understanding Challenge", arXiv:2009.05246 (2020), and QUT's
``benchbot_eval`` OMQ add-on (``eval_omq``), re-implemented as described in docs/original-benchbot.md (section 8.2)
and docs/evaluation.md, with the bugs listed there fixed (see the package README):

1. Class list = sorted unique union of the ground truths' class lists, ``background`` moved (or appended) last.
2. Synonyms = the merged synonyms of ALL ground truths plus ``none``/``bg``/``__background__`` → ``background``;
   lookups are lower-case and follow synonym chains to the end (cycle-safe), so ``diningtable`` → ``dining table``
   → ``table`` works.
3. Each proposal's ``label_probs`` are re-binned into the ground-truth class order (unresolvable names → background,
   duplicates add up), then divided by their sum if it is > 1, else the remainder ``1 - sum`` goes to background.
   ``state_probs`` (SCD) likewise, remainder to the last state (``unchanged``).
4. Pairwise (g GT × p proposals) qualities: spatial = axis-aligned 3D IoU, label = probability of the GT class,
   state (SCD) = probability of the GT state; overall = their geometric mean (any zero → 0).
5. Optimal assignment (Hungarian, ``scipy.optimize.linear_sum_assignment``) on a float32 ``n×n`` cost matrix,
   ``n = max(g, p)``, filled with 1 and ``1 - overall`` in the ``g×p`` corner; TP / FP / FN with the group exemption.
6. OMQ = Σ overall(TP) / (TP + Σ FP cost + FN).

Units: centroids and extents in metres, ``map`` frame; extents are full side lengths of axis-aligned boxes.
"""

from __future__ import annotations

import itertools
import math
from numbers import Real
from typing import Any, Optional, Sequence

import numpy as np

from benchbot.core.errors import ResultsError, SpecError

__all__ = [
    "BACKGROUND",
    "BACKGROUND_ALIASES",
    "SCD_STATE_LIST",
    "SCORE_NAMES",
    "evaluate",
    "combine",
    "COMBINE_MODES",
    "scores_from_totals",
    "pairwise_iou",
    "footprint_intersection",
    "scd_ground_truth",
    "build_class_list",
    "build_synonyms",
    "resolve_class",
]

BACKGROUND = "background"
BACKGROUND_ALIASES: dict[str, str] = {"none": BACKGROUND, "bg": BACKGROUND, "__background__": BACKGROUND}
"""The original's built-in background alias table (merged with the ground truths' synonyms)."""

SCD_STATE_LIST: tuple[str, ...] = ("added", "removed", "unchanged")
"""Canonical SCD states; ground-truth state ids are added 0, removed 1 (``unchanged`` is never in the GT)."""
STATE_ADDED, STATE_REMOVED = 0, 1
_STATE_ALIASES = {"constant": "unchanged"}

SCORE_NAMES: tuple[str, ...] = ("OMQ", "avg_pairwise", "avg_label", "avg_spatial", "avg_fp_quality")
"""The original's reported scores (unchanged names)."""
COUNT_NAMES: tuple[str, ...] = ("TP", "FP", "FN")
SCD_MATCH_TOLERANCE = 1e-6
"""Tolerance (metres) on centroid/extent when matching scene A and scene B objects for the SCD ground truth."""

_RESULTS_HINT = "check the results file against its format (benchbot_task_semslam/formats/*.yaml)"
_GT_HINT = "check the ground-truth file (an object_map_ground_truth instance)"


# --------------------------------------------------------------------------------------------------------------------
# Class list and synonyms
# --------------------------------------------------------------------------------------------------------------------
def _gt_label(gt: dict, i: int) -> str:
    env = gt.get("environment") if isinstance(gt, dict) else None
    if isinstance(env, dict) and "name" in env:
        return f"ground truth of {env.get('name')}:{env.get('variant')}"
    return f"ground_truths[{i}]"


def build_class_list(ground_truths: Sequence[dict]) -> list[str]:
    """Return the evaluation class list: the sorted unique union of every ground truth's
    ``ground_truth.class_list`` (or, when missing, ``environment.object_labels``), with ``background`` moved to the
    end (appended when absent). Background aliases (``none``, ``bg``, ``__background__``) are folded into it.

    Raises:
        benchbot.core.errors.SpecError: a ground truth has neither a class list nor object labels (the original
            raised NameError).
    """
    names: set[str] = set()
    for i, gt in enumerate(ground_truths):
        inner = gt.get("ground_truth") or {}
        classes = inner.get("class_list") or (gt.get("environment") or {}).get("object_labels")
        if not classes:
            raise SpecError(
                f"{_gt_label(gt, i)}: has neither ground_truth.class_list nor environment.object_labels", _GT_HINT
            )
        names.update(str(c) for c in classes)
    ordered = [c for c in sorted(names) if c.lower() != BACKGROUND and c.lower() not in BACKGROUND_ALIASES]
    return ordered + [BACKGROUND]


def build_synonyms(ground_truths: Sequence[dict]) -> dict[str, str]:
    """Return the merged synonym table ``{lower-case alias: target}``: the background aliases, then every ground
    truth's ``ground_truth.synonyms`` in order (a later one overrides an earlier one on conflict). The original used
    the first ground truth's table only (and raised KeyError when it had none)."""
    table = dict(BACKGROUND_ALIASES)
    for gt in ground_truths:
        for alias, target in ((gt.get("ground_truth") or {}).get("synonyms") or {}).items():
            table[str(alias).lower()] = str(target)
    return table


def resolve_class(name: Any, class_index: dict[str, int], synonyms: dict[str, str]) -> Optional[int]:
    """Return the index of class ``name`` or None when it cannot be resolved.

    Lookup is case-insensitive: the exact class first, then synonym hops until a class is reached (chains of any
    length; a cycle stops the search). ``class_index`` maps lower-case class names to indices.
    """
    if not isinstance(name, str):
        return None
    query = name.lower()
    seen: set[str] = set()
    while query not in class_index:
        if query in seen or query not in synonyms:
            return None
        seen.add(query)
        query = synonyms[query].lower()
    return class_index[query]


# --------------------------------------------------------------------------------------------------------------------
# Input checking / sanitising
# --------------------------------------------------------------------------------------------------------------------
def _finite(value: Any) -> bool:
    """A real number (not a bool) that is finite as a float: a JSON integer beyond a float's range (400 digits) is
    not, and never raises ``OverflowError``."""
    if not isinstance(value, Real) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _shown(value: Any) -> str:
    """``repr(value)``, except an integer beyond a float's range, told by its digit count (one short line)."""
    if isinstance(value, int) and not isinstance(value, bool) and not _finite(value):
        return f"an integer of {len(str(abs(value)))} digits (beyond a float's range)"
    return repr(value)


def _as_floats(values: Any) -> Optional[np.ndarray]:
    """``np.asarray(values, float64)``, or None when an integer does not fit a float (the slow path names it)."""
    try:
        return np.asarray(values, dtype=np.float64)
    except OverflowError:
        return None


def _number_array(value: Any, length: int, path: str, what: str, non_negative: bool = False) -> np.ndarray:
    # Fast path (the common case: a list of JSON ints/floats): one type pass, then vectorised checks.
    if type(value) is list and len(value) == length and all(type(v) is float or type(v) is int for v in value):
        arr = _as_floats(value)
        if arr is not None and np.isfinite(arr).all() and not (non_negative and (arr < 0).any()):
            return arr
    if not isinstance(value, (list, tuple)):
        raise ResultsError(f"{path}: expected a list of {length} {what}, got {type(value).__name__}", _RESULTS_HINT)
    if len(value) != length:
        raise ResultsError(f"{path}: expected {length} {what}, got {len(value)}", _RESULTS_HINT)
    for k, v in enumerate(value):
        if not _finite(v):
            raise ResultsError(f"{path}[{k}]: expected a finite number, got {_shown(v)}", _RESULTS_HINT)
        if non_negative and v < 0:
            raise ResultsError(f"{path}[{k}]: expected a number >= 0, got {v!r}", _RESULTS_HINT)
    return np.asarray(value, dtype=np.float64)


def _sanitise(probs: np.ndarray, mapping: np.ndarray, n_out: int) -> np.ndarray:
    """Re-bin ``probs`` (p, k) into ``n_out`` bins via ``mapping`` (k,) → bin, then normalise if the sum > 1, else put
    the remainder into the last bin."""
    out = np.zeros((probs.shape[0], n_out), dtype=np.float64)
    if probs.shape[0] and probs.shape[1]:
        np.add.at(out, (slice(None), mapping), probs)
    total = out.sum(axis=1)
    over = total > 1
    out[over] /= total[over, None]
    out[~over, -1] += 1.0 - total[~over]
    return out


def _number_matrix(
    objects: Sequence[dict], key: str, length: int, prefix: str, what: str, non_negative: bool, err: type
) -> np.ndarray:
    """``objects[i][key]`` for every object as an ``(n, length)`` float64 array.

    Fast path: one C-level pass over the element types (JSON ints/floats only) and one ``np.array``; otherwise
    (or when a value is non-finite/negative) each object is checked in turn so that the error names the first bad
    one (``{prefix}[i].{key}...``), raised as ``err`` (ResultsError or SpecError).
    """
    values = [obj.get(key) for obj in objects]
    if all(type(v) is list and len(v) == length for v in values) and set(
        map(type, itertools.chain.from_iterable(values))
    ) <= {float, int}:
        arr = _as_floats(values)
        if arr is not None and np.isfinite(arr).all() and not (non_negative and (arr < 0).any()):
            return arr.reshape(len(values), length)
    out = np.zeros((len(values), length))
    hint = _GT_HINT if err is SpecError else _RESULTS_HINT
    for i, (obj, value) in enumerate(zip(objects, values)):
        if key not in obj:
            raise err(f"{prefix}[{i}].{key}: missing", hint)
        try:
            out[i] = _number_array(value, length, f"{prefix}[{i}].{key}", what, non_negative)
        except ResultsError as e:
            raise err(e.message, hint) from None
    return out


def _boxes(objects: Sequence[dict], prefix: str, err: type) -> tuple[np.ndarray, np.ndarray]:
    """Centroids and extents ``(n, 3)`` float64 (metres) of ``objects``; extents must be >= 0."""
    centroids = _number_matrix(objects, "centroid", 3, prefix, "numbers (metres)", False, err)
    extents = _number_matrix(objects, "extent", 3, prefix, "numbers (metres)", True, err)
    return centroids, extents


def _results_instance(results: Any) -> tuple[dict, dict, list]:
    if not isinstance(results, dict):
        raise ResultsError(f"results file: expected a JSON object, got {type(results).__name__}", _RESULTS_HINT)
    task = results.get("task_details")
    if not isinstance(task, dict) or "results_format" not in task:
        raise ResultsError("task_details.results_format: missing", "a results file names its task and format")
    inner = results.get("results")
    if not isinstance(inner, dict):
        raise ResultsError("results: missing or not a JSON object (the format instance)", _RESULTS_HINT)
    objects = inner.get("objects")
    if not isinstance(objects, list):
        raise ResultsError(f"results.objects: expected a list, got {type(objects).__name__}", _RESULTS_HINT)
    for i, obj in enumerate(objects):
        if not isinstance(obj, dict):
            raise ResultsError(f"results.objects[{i}]: expected an object, got {type(obj).__name__}", _RESULTS_HINT)
    class_list = inner.get("class_list")
    if not isinstance(class_list, list) or not class_list:
        raise ResultsError("results.class_list: expected a non-empty list of class names", _RESULTS_HINT)
    return task, inner, objects


def _gt_objects(gt: Any, i: int) -> list[dict]:
    if not isinstance(gt, dict) or not isinstance(gt.get("ground_truth"), dict):
        raise SpecError(f"ground_truths[{i}]: expected {{environment, format, ground_truth}}", _GT_HINT)
    objects = gt["ground_truth"].get("objects")
    if not isinstance(objects, list) or not all(isinstance(o, dict) for o in objects):
        raise SpecError(f"{_gt_label(gt, i)}: ground_truth.objects must be a list of objects", _GT_HINT)
    return objects


# --------------------------------------------------------------------------------------------------------------------
# SCD ground truth
# --------------------------------------------------------------------------------------------------------------------
def _same_object(a: dict, b: dict, tol: float) -> bool:
    if a.get("ID_name") != b.get("ID_name") or a.get("class") != b.get("class"):
        return False
    for key in ("centroid", "extent"):
        va, vb = a.get(key), b.get(key)
        if va is None or vb is None or len(va) != len(vb):
            return False
        if any(abs(float(x) - float(y)) > tol for x, y in zip(va, vb)):
            return False
    return True


def scd_ground_truth(
    objects_a: Sequence[dict], objects_b: Sequence[dict], tol: float = SCD_MATCH_TOLERANCE
) -> list[tuple[dict, int]]:
    """Return the changed objects between scene A and scene B as ``[(gt_object, state_id), ...]``.

    ``removed`` (state id 1) = objects of A not present in B, listed first; ``added`` (state id 0) = objects of B not
    present in A. An object is "present" when the other scene has one with the same ``ID_name`` and ``class`` and a
    ``centroid``/``extent`` equal within ``tol`` metres per coordinate (the original used exact dict equality). A
    moved object therefore counts as both removed and added, as in the original.
    """
    removed = [o for o in objects_a if not any(_same_object(o, b, tol) for b in objects_b)]
    added = [o for o in objects_b if not any(_same_object(o, a, tol) for a in objects_a)]
    return [(o, STATE_REMOVED) for o in removed] + [(o, STATE_ADDED) for o in added]


# --------------------------------------------------------------------------------------------------------------------
# Pairwise qualities
# --------------------------------------------------------------------------------------------------------------------
def pairwise_iou(
    gt_centroids: np.ndarray,
    gt_extents: np.ndarray,
    prop_centroids: np.ndarray,
    prop_extents: np.ndarray,
    gt_yaw: Optional[np.ndarray] = None,
    prop_yaw: Optional[np.ndarray] = None,
) -> tuple[np.ndarray, np.ndarray]:
    """3D IoU of every GT box with every proposal box (vectorised by broadcasting).

    Without yaws (the default, and the original's behaviour) the boxes are axis-aligned. With yaws (the opt-in
    oriented-cuboid extension), each box's footprint is its x/y extent rotated by its yaw about +z (radians,
    counter-clockwise seen from above, ``map`` frame) around its centroid; the intersection volume is then the
    exact area of the intersection of the two rotated rectangles (:func:`footprint_intersection`) times the
    z-overlap. Pairs whose two yaws are both exactly 0 use the axis-aligned formula, so ``yaw = 0`` reproduces the
    axis-aligned scores bit for bit.

    Args:
        gt_centroids, gt_extents: ``(g, 3)`` float64, metres (map frame); extents are full side lengths.
        prop_centroids, prop_extents: ``(p, 3)`` float64, metres.
        gt_yaw: ``(g,)`` float64 radians, or None (axis-aligned).
        prop_yaw: ``(p,)`` float64 radians, or None (axis-aligned).

    Returns:
        ``(iou, intersection)``, both ``(g, p)`` float64: IoU = inter / (vol_gt + vol_prop - inter), 0 where the
        union is 0; ``intersection`` is the overlap volume in m³. Volumes are the products of the extents (a
        rotation does not change them).
    """
    # Overlap of [cg - eg/2, cg + eg/2] and [cp - ep/2, cp + ep/2] per axis, written as
    # min(eg, ep, (eg + ep)/2 - |cg - cp|): the same value as min(hi) - max(lo), but without the rounding of c ± e/2,
    # so that identical boxes give an IoU of exactly 1.
    # Sparse in practice: the x-overlap is computed for every pair, y and z only where x overlaps, then z where
    # y overlaps (most pairs of a real map are far apart).
    g, p = len(gt_centroids), len(prop_centroids)

    def axis_overlap(axis: int, rows: Any, cols: Any) -> np.ndarray:
        eg, ep = gt_extents[:, axis][rows], prop_extents[:, axis][cols]
        cg, cp = gt_centroids[:, axis][rows], prop_centroids[:, axis][cols]
        return np.minimum(np.minimum(eg, ep), (eg + ep) * 0.5 - np.abs(cg - cp))

    ox = axis_overlap(0, (slice(None), None), (None, slice(None)))  # (g, p)
    rows, cols = np.nonzero(ox > 0)
    oy = axis_overlap(1, rows, cols)
    keep = oy > 0
    rows, cols, oxy = rows[keep], cols[keep], ox[rows[keep], cols[keep]] * oy[keep]
    oz = np.maximum(axis_overlap(2, rows, cols), 0.0)
    inter = np.zeros((g, p))
    inter[rows, cols] = oxy * oz
    gy = np.zeros(g) if gt_yaw is None else np.asarray(gt_yaw, dtype=np.float64)
    py = np.zeros(p) if prop_yaw is None else np.asarray(prop_yaw, dtype=np.float64)
    rotated = (gy[:, None] != 0) | (py[None, :] != 0)
    if rotated.any():
        rows, cols = np.nonzero(rotated)
        oz = np.maximum(axis_overlap(2, rows, cols), 0.0)
        area = footprint_intersection(
            gt_centroids[rows, :2], gt_extents[rows, :2], gy[rows],
            prop_centroids[cols, :2], prop_extents[cols, :2], py[cols],
        )  # fmt: skip
        inter[rows, cols] = area * oz
    rows, cols = np.nonzero(inter > 0)
    union = np.prod(gt_extents[rows], axis=1) + np.prod(prop_extents[cols], axis=1) - inter[rows, cols]
    iou = np.zeros((g, p))
    iou[rows, cols] = np.minimum(inter[rows, cols] / union, 1.0)  # union >= inter > 0
    return iou, inter


def _rectangles(centres: np.ndarray, extents: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Corners ``(n, 4, 2)`` of rectangles (centre ``(n, 2)``, full sides ``(n, 2)``, yaw ``(n,)`` rad), CCW."""
    local = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])[None] * extents[:, None, :]
    cos, sin = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    x = cos * local[..., 0] - sin * local[..., 1]
    y = sin * local[..., 0] + cos * local[..., 1]
    return np.stack([x, y], axis=-1) + centres[:, None, :]


def _inside_boundary_area(poly: np.ndarray, clip: np.ndarray, keep_same_direction: bool) -> np.ndarray:
    """Σ over the edges of convex CCW ``poly`` of the shoelace term of the part of the edge inside convex CCW
    ``clip`` (Cyrus–Beck clipping), both ``(n, 4, 2)``. Edges lying on a clip edge's line count when they run
    the opposite way, and when they run the same way only if ``keep_same_direction`` (so that a shared boundary
    is counted once)."""
    start = poly[:, :, None, :]  # (n, 4 edges, 1, 2)
    d = (np.roll(poly, -1, axis=1) - poly)[:, :, None, :]
    q0 = clip[:, None, :, :]  # (n, 1, 4 half-planes, 2)
    qd = (np.roll(clip, -1, axis=1) - clip)[:, None, :, :]
    # inside(x) <=> cross(qd, x - q0) >= 0; along the edge x = start + t d: num + t den
    num = qd[..., 0] * (start[..., 1] - q0[..., 1]) - qd[..., 1] * (start[..., 0] - q0[..., 0])
    den = qd[..., 0] * d[..., 1] - qd[..., 1] * d[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(den != 0, -num / np.where(den != 0, den, 1.0), 0.0)
    lo = np.max(np.where(den > 0, t, 0.0), axis=2, initial=0.0)
    hi = np.min(np.where(den < 0, t, 1.0), axis=2, initial=1.0)
    same_dir = (qd[..., 0] * d[..., 0] + qd[..., 1] * d[..., 1]) > 0
    parallel_out = (den == 0) & ((num < 0) | ((num == 0) & same_dir & (not keep_same_direction)))
    keep = (hi > lo) & ~parallel_out.any(axis=2)
    a = poly + lo[..., None] * (np.roll(poly, -1, axis=1) - poly)
    b = poly + hi[..., None] * (np.roll(poly, -1, axis=1) - poly)
    return np.where(keep, a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0], 0.0).sum(axis=1)


def footprint_intersection(
    centres_a: np.ndarray, extents_a: np.ndarray, yaw_a: np.ndarray,
    centres_b: np.ndarray, extents_b: np.ndarray, yaw_b: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """Exact area of the intersection of rotated rectangles A[k] and B[k] (element-wise, numpy only).

    Green's theorem: the intersection of two convex polygons is bounded by the parts of A's edges inside B and the
    parts of B's edges inside A, so its area is half the sum of the shoelace terms ``x0*y1 - x1*y0`` of those
    parts (each edge clipped to the other polygon by Cyrus–Beck). Coordinates are taken relative to A's centre.

    Args:
        centres_a, extents_a, yaw_a: ``(n, 2)`` metres, ``(n, 2)`` full side lengths in metres, ``(n,)`` radians
            about +z (counter-clockwise seen from above); likewise for B.

    Returns:
        ``(n,)`` float64 areas in m², >= 0.
    """
    origin = np.asarray(centres_a, dtype=np.float64)
    rect_a = _rectangles(np.zeros_like(origin), np.asarray(extents_a, float), np.asarray(yaw_a, float))
    rect_b = _rectangles(np.asarray(centres_b, float) - origin, np.asarray(extents_b, float), np.asarray(yaw_b, float))
    area = 0.5 * (
        _inside_boundary_area(rect_a, rect_b, keep_same_direction=True)
        + _inside_boundary_area(rect_b, rect_a, keep_same_direction=False)
    )
    smaller = np.minimum(np.prod(extents_a, axis=1), np.prod(extents_b, axis=1))
    area = np.where(area > 1e-12 * smaller, area, 0.0)  # rounding residue of boxes that only touch
    return np.minimum(area, smaller)


def _geometric_mean(*qualities: np.ndarray) -> np.ndarray:
    """Element-wise geometric mean (as scipy.stats.gmean over the stacked qualities); any zero gives 0."""
    product = qualities[0]
    for q in qualities[1:]:
        product = product * q
    if len(qualities) == 2:
        return np.sqrt(product)
    return product ** (1.0 / len(qualities))


# --------------------------------------------------------------------------------------------------------------------
# evaluate / combine
# --------------------------------------------------------------------------------------------------------------------
def evaluate(
    results: dict, ground_truths: list[dict], *, per_class: bool = False, oriented: bool = False,
    matches: bool = False,
) -> dict:  # fmt: skip
    """Score one submitted results file with OMQ (Hall et al. 2020, arXiv:2009.05246; benchbot_eval's OMQ add-on).

    Args:
        results: a whole results file ``{task_details: {name, results_format, ...}, environment_details: [...],
            results: {objects: [{label_probs, centroid, extent[, state_probs]}], class_list[, state_list]}}``.
            Centroids/extents in metres, map frame (extents = full side lengths of axis-aligned boxes).
            Mode: scene change detection (SCD) iff ``task_details.results_format == "object_map_with_states"``.
        ground_truths: one ground-truth file per scene, ``{environment, format, ground_truth: {class_list,
            synonyms, objects: [{class, ID_name, centroid, extent, isgroup}]}}`` as in the BEAR JSON files:
            exactly 1 for semantic SLAM, exactly 2 (scene A, scene B) for SCD.

        per_class: also return the scores per class (key ``per_class``, see below).
        oriented: the oriented-cuboid extension: a proposal's optional ``yaw`` (radians about +z, map frame; also
            read on ground-truth objects, default 0) rotates its footprint in the IoU (:func:`pairwise_iou`). Off
            (the default, as the original), ``yaw`` is ignored.
        matches: also return the assignment object by object (key ``matches``, see below). It only reports what
            the scoring decided; no score changes.

    Returns:
        ``{"task_details", "environment_details", "scores": {"OMQ", "avg_pairwise", "avg_label", "avg_spatial",
        "avg_fp_quality", ["avg_state_quality" (SCD only)], "TP", "FP", "FN"}, "totals": {...}[, "per_class"]}``;
        qualities are floats in [0, 1], counts are ints. ``totals`` holds the sums the scores are ratios of
        (``TP, FP, FN, sum_overall, sum_label, sum_spatial, sum_state, sum_fp_cost``; used by the pooled
        :func:`combine`). ``per_class`` = ``{class name: {"scores": {...}, "totals": {...}}}`` for every class
        that has a ground-truth object or a false positive: TP pairs and FNs count for their GT object's class,
        an FP for its argmax non-background class (``background`` when all those are 0); per-class counts and sums
        add up to the totals.
        ``matches`` = ``{"class_list": [...], "ground_truth": [...], "proposals": [...]}``: one entry per scored
        ground-truth object (for SCD, per changed object, removed ones first, with its ``state``) ``{index, class,
        ID_name, centroid, extent, status: "TP" | "FN", proposal: index or None, quality, label, spatial}`` and one
        per proposal ``{index, class (argmax non-background, or "background"), centroid, extent, status: "TP" |
        "FP" | "group" (inside a group GT box: neither TP nor FP), ground_truth: index or None, quality, label,
        spatial, fp_cost}``; indices are positions in ``results.objects`` and in the ``ground_truth`` list,
        qualities are those of the pair (None when unmatched), ``fp_cost`` is 0 unless the status is ``FP``.

    Raises:
        benchbot.core.errors.ResultsError: the results cannot be scored (missing parts, ``label_probs`` /
            ``state_probs`` of the wrong length, non-finite or negative numbers...), naming the object index.
        benchbot.core.errors.SpecError: a ground truth is malformed (no class list, unresolvable class, wrong
            number of ground truths for the mode).
    """
    task, inner, objects = _results_instance(results)
    scd = task.get("results_format") == "object_map_with_states"
    if not isinstance(ground_truths, (list, tuple)):
        raise SpecError("ground_truths: expected a list (one ground truth per scene)", _GT_HINT)
    gt_lists = [_gt_objects(gt, i) for i, gt in enumerate(ground_truths)]
    if scd and len(gt_lists) != 2:
        raise SpecError(
            f"scene change detection needs exactly 2 ground truths (scene A, scene B), got {len(gt_lists)}", _GT_HINT
        )
    if not scd and len(gt_lists) != 1:
        raise SpecError(f"semantic SLAM needs exactly 1 ground truth, got {len(gt_lists)}", _GT_HINT)

    # --- class list, synonyms, GT objects --------------------------------------------------------------------------
    class_list = build_class_list(ground_truths)
    class_index = {c.lower(): k for k, c in enumerate(class_list)}
    synonyms = build_synonyms(ground_truths)
    n_classes, bg = len(class_list), len(class_list) - 1

    if scd:
        gt_pairs = scd_ground_truth(gt_lists[0], gt_lists[1])
    else:
        gt_pairs = [(o, None) for o in gt_lists[0]]
    gt_objects = [o for o, _ in gt_pairs]
    gt_states = np.array([s for _, s in gt_pairs], dtype=np.int64) if scd else None
    gt_class = np.zeros(len(gt_objects), dtype=np.int64)
    for i, obj in enumerate(gt_objects):
        cid = resolve_class(obj.get("class"), class_index, synonyms)
        if cid is None:
            raise SpecError(f"ground truth objects[{i}].class: {obj.get('class')!r} cannot be resolved", _GT_HINT)
        gt_class[i] = cid
    gt_group = np.array([bool(o.get("isgroup", False)) for o in gt_objects], dtype=bool)
    gt_c, gt_e = _boxes(gt_objects, "ground truth objects", SpecError)

    # --- proposals -----------------------------------------------------------------------------------------------
    res_classes = inner["class_list"]
    class_map = np.array(
        [bg if (k := resolve_class(c, class_index, synonyms)) is None else k for c in res_classes], dtype=np.int64
    )
    raw_labels = _number_matrix(
        objects, "label_probs", len(res_classes), "results.objects", "probabilities (len(class_list))", True,
        ResultsError,
    )  # fmt: skip
    labels = _sanitise(raw_labels, class_map, n_classes)  # (p, n_classes)
    prop_c, prop_e = _boxes(objects, "results.objects", ResultsError)

    states = None
    if scd:
        res_states = inner.get("state_list", list(SCD_STATE_LIST))
        if not isinstance(res_states, list) or not res_states:
            raise ResultsError("results.state_list: expected a non-empty list of state names", _RESULTS_HINT)
        state_index = {s: k for k, s in enumerate(SCD_STATE_LIST)}
        state_map = np.array(
            [state_index.get(_STATE_ALIASES.get(str(s).lower(), str(s).lower()), len(SCD_STATE_LIST) - 1)
             for s in res_states], dtype=np.int64,
        )  # fmt: skip
        raw_states = _number_matrix(
            objects, "state_probs", len(res_states), "results.objects", "probabilities (len(state_list))", True,
            ResultsError,
        )  # fmt: skip
        states = _sanitise(raw_states, state_map, len(SCD_STATE_LIST))  # (p, 3)

    gt_yaw = prop_yaw = None
    if oriented:
        gt_yaw = _yaws(gt_objects, "ground truth objects", SpecError)
        prop_yaw = _yaws(objects, "results.objects", ResultsError)
    detail: Optional[dict] = {} if matches else None
    totals, by_class = _score(
        gt_class, gt_group, gt_c, gt_e, gt_states, labels, states, prop_c, prop_e, gt_yaw, prop_yaw, per_class,
        detail,
    )
    out = {
        "task_details": results.get("task_details"),
        "environment_details": results.get("environment_details"),
        "scores": scores_from_totals(totals, scd),
        "totals": totals,
    }
    if per_class:
        out["per_class"] = {
            class_list[k]: {"scores": scores_from_totals(t, scd), "totals": t} for k, t in sorted(by_class.items())
        }
    if detail is not None:
        out["matches"] = _matches(detail, class_list, gt_objects, gt_class, gt_states, gt_c, gt_e, labels, prop_c,
                                  prop_e)  # fmt: skip
    return out


def _matches(detail, class_list, gt_objects, gt_class, gt_states, gt_c, gt_e, labels, prop_c, prop_e) -> dict:
    """The ``matches`` entry of :func:`evaluate` from the assignment ``_score`` recorded in ``detail``."""
    bg = len(class_list) - 1
    pairs = detail["pairs"]  # {gt row: (proposal column, overall, label, spatial)}
    by_col = {c: (r, q, lab, sp) for r, (c, q, lab, sp) in pairs.items()}
    fp_cost = detail["fp_cost"]  # {proposal column: cost}
    gt_out = []
    for i, obj in enumerate(gt_objects):
        c, q, lab, sp = pairs.get(i, (None, None, None, None))
        entry = {"index": i, "class": class_list[int(gt_class[i])], "ID_name": obj.get("ID_name"),
                 "centroid": gt_c[i].tolist(), "extent": gt_e[i].tolist(), "status": "TP" if c is not None else "FN",
                 "proposal": c, "quality": q, "label": lab, "spatial": sp}  # fmt: skip
        if gt_states is not None:
            entry["state"] = SCD_STATE_LIST[int(gt_states[i])]
        gt_out.append(entry)
    prop_out = []
    for j in range(labels.shape[0]):
        r, q, lab, sp = by_col.get(j, (None, None, None, None))
        status = "TP" if r is not None else ("FP" if j in fp_cost else "group")
        prop_out.append({"index": j, "class": class_list[_fp_class(labels, j, bg)], "centroid": prop_c[j].tolist(),
                         "extent": prop_e[j].tolist(), "status": status, "ground_truth": r, "quality": q,
                         "label": lab, "spatial": sp, "fp_cost": fp_cost.get(j, 0.0)})  # fmt: skip
    return {"class_list": list(class_list), "ground_truth": gt_out, "proposals": prop_out}


def _yaws(objects: Sequence[dict], prefix: str, err: type) -> np.ndarray:
    """The objects' ``yaw`` (radians, 0 when absent) as ``(n,)`` float64."""
    out = np.zeros(len(objects))
    for i, obj in enumerate(objects):
        yaw = obj.get("yaw", 0.0)
        if not _finite(yaw):
            raise err(f"{prefix}[{i}].yaw: expected a finite number (radians about +z), got {_shown(yaw)}",
                      _RESULTS_HINT if err is ResultsError else _GT_HINT)  # fmt: skip
        out[i] = float(yaw)
    return out


TOTAL_NAMES: tuple[str, ...] = (
    "TP", "FP", "FN", "sum_overall", "sum_label", "sum_spatial", "sum_state", "sum_fp_cost",
)  # fmt: skip
"""Keys of an evaluation's ``totals``: the counts and the sums that every score is a ratio of."""


def _new_totals() -> dict:
    return {k: (0 if k in COUNT_NAMES else 0.0) for k in TOTAL_NAMES}


def scores_from_totals(totals: dict, scd: bool) -> dict:
    """The OMQ scores from counts and sums (docs/evaluation.md):
    ``OMQ = Σoverall / (TP + ΣFPcost + FN)`` (0 if the denominator is 0); ``avg_pairwise/label/spatial
    [/state_quality] = Σ/TP`` (0 if TP = 0); ``avg_fp_quality = (FP − ΣFPcost)/FP`` (1.0 if FP = 0).

    Args:
        totals: ``{TP, FP, FN, sum_overall, sum_label, sum_spatial, sum_state, sum_fp_cost}``.
        scd: include ``avg_state_quality``.
    """

    def ratio(num: float, den: float, default: float = 0.0) -> float:
        return float(num / den) if den else default

    tp, fp, fn, fp_cost = totals["TP"], totals["FP"], totals["FN"], totals["sum_fp_cost"]
    scores = {
        "OMQ": ratio(totals["sum_overall"], tp + fp_cost + fn),
        "avg_pairwise": ratio(totals["sum_overall"], tp),
        "avg_label": ratio(totals["sum_label"], tp),
        "avg_spatial": ratio(totals["sum_spatial"], tp),
        "avg_fp_quality": ratio(fp - fp_cost, fp, default=1.0),
    }
    if scd:
        scores["avg_state_quality"] = ratio(totals["sum_state"], tp)
    scores.update({"TP": int(tp), "FP": int(fp), "FN": int(fn)})
    return scores


def _fp_label_cost(labels: np.ndarray, j: int) -> float:
    """Proposal ``j``'s largest non-background label probability (the FP cost when nothing can be matched)."""
    return float(labels[j, :-1].max()) if labels.shape[1] > 1 else 0.0


def _fp_class(labels: np.ndarray, j: int, bg: int) -> int:
    """The class an FP is attributed to in the per-class breakdown: argmax non-background, else background."""
    if labels.shape[1] < 2 or labels[j, :-1].max() <= 0:
        return bg
    return int(np.argmax(labels[j, :-1]))


def _score(
    gt_class, gt_group, gt_c, gt_e, gt_states, labels, states, prop_c, prop_e, gt_yaw=None, prop_yaw=None,
    per_class=False, detail=None,
) -> tuple[dict, dict]:  # fmt: skip
    """Assignment and sums. Returns ``(totals, {class id: totals})`` (the second empty unless ``per_class``).

    ``detail`` (a dict, or None) receives what was decided, for :func:`_matches`: ``pairs`` ``{gt row: (proposal
    column, overall, label, spatial)}`` of the TPs and ``fp_cost`` ``{proposal column: cost}`` of the FPs."""
    from benchbot_eval_omq.assignment import linear_sum_assignment

    scd = states is not None
    g, p = len(gt_class), labels.shape[0]
    bg = labels.shape[1] - 1
    totals = _new_totals()
    by_class: dict[int, dict] = {}

    def add(cls: int, **values: float) -> None:
        for target in (totals, by_class.setdefault(cls, _new_totals()) if per_class else None):
            if target is not None:
                for k, v in values.items():
                    target[k] += v

    if detail is not None:
        detail.update(pairs={}, fp_cost={})
    if g == 0 or p == 0:  # special case: nothing to match
        for i in range(g):
            add(int(gt_class[i]), FN=1)
        for j in range(p):
            add(_fp_class(labels, j, bg), FP=1, sum_fp_cost=_fp_label_cost(labels, j))
            if detail is not None:
                detail["fp_cost"][j] = _fp_label_cost(labels, j)
        return totals, by_class

    spatial, inter = pairwise_iou(gt_c, gt_e, prop_c, prop_e, gt_yaw, prop_yaw)  # (g, p)
    label_q = labels[:, gt_class].T  # (g, p): P_j(class of GT i)
    if scd:
        state_q = states[:, gt_states].T  # (g, p): P_j(state of GT i)
        overall = _geometric_mean(label_q, spatial, state_q)
    else:
        state_q = None
        overall = _geometric_mean(label_q, spatial)
    # The original solves a square n×n float32 matrix (n = max(g, p)) of ones with 1 − overall in the g×p corner.
    # The padding rows/columns cost 1 whatever they are paired with, so that problem has the same optimal pairs as
    # the rectangular g×p one solved here (scipy supports rectangular matrices; 40× faster at g=56, p=1000).
    # Only pairs with overall > 0 become TPs; every other real row is an FN and every other real column an FP.
    cost = (1.0 - overall).astype(np.float32)
    rows, cols = linear_sum_assignment()(cost)
    matched = overall[rows, cols] > 0
    tp_rows, tp_cols = rows[matched], cols[matched]
    for r, c in zip(tp_rows, tp_cols):
        add(
            int(gt_class[r]), TP=1, sum_overall=float(overall[r, c]), sum_label=float(label_q[r, c]),
            sum_spatial=float(spatial[r, c]), sum_state=float(state_q[r, c]) if scd else 0.0,
        )  # fmt: skip
    fn_rows = np.setdiff1d(np.arange(g), tp_rows)
    for r in fn_rows:
        add(int(gt_class[r]), FN=1)
    # False positives, vectorised over the unmatched columns (same rules as _fp_class).
    unmatched = np.ones(p, dtype=bool)
    unmatched[tp_cols] = False
    cols_fp = np.nonzero(unmatched)[0]
    exempt = _group_exempt_all(cols_fp, overall, inter, np.prod(prop_e, axis=1), gt_group, gt_class, labels)
    cols_fp = cols_fp[~exempt]
    nonbg = labels[cols_fp, :-1] if labels.shape[1] > 1 else np.zeros((len(cols_fp), 1))
    label_cost = nonbg.max(axis=1) if len(cols_fp) else np.zeros(0)
    if scd:
        fp_costs = np.sqrt(label_cost * np.maximum(states[cols_fp, STATE_ADDED], states[cols_fp, STATE_REMOVED]))
    else:
        fp_costs = label_cost
    totals["FP"] += int(len(cols_fp))
    totals["sum_fp_cost"] += float(fp_costs.sum())
    if detail is not None:
        detail["pairs"] = {int(r): (int(c), float(overall[r, c]), float(label_q[r, c]), float(spatial[r, c]))
                           for r, c in zip(tp_rows, tp_cols)}  # fmt: skip
        detail["fp_cost"] = {int(c): float(cost) for c, cost in zip(cols_fp, fp_costs)}
    if per_class:
        fp_cls = np.where(label_cost > 0, np.argmax(nonbg, axis=1) if len(cols_fp) else 0, bg)
        for k in np.unique(fp_cls):
            t = by_class.setdefault(int(k), _new_totals())
            t["FP"] += int(np.count_nonzero(fp_cls == k))
            t["sum_fp_cost"] += float(fp_costs[fp_cls == k].sum())
    return totals, by_class


def _group_exempt_all(cols, overall, inter, prop_vol, gt_group, gt_class, labels) -> np.ndarray:
    """Which unassigned proposals ``cols`` lie in a group GT box → ``(len(cols),)`` bool: a proposal's column has a
    non-zero quality, its best GT is a group, its argmax non-background label is that GT's class, and >= 50 % of its
    volume is inside that box."""
    if len(cols) == 0 or labels.shape[1] < 2:
        return np.zeros(len(cols), dtype=bool)
    column = overall[:, cols]
    best = np.argmax(column, axis=0)
    vol = prop_vol[cols]
    with np.errstate(divide="ignore", invalid="ignore"):
        inside = np.where(vol > 0, inter[best, cols] / np.where(vol > 0, vol, 1.0), 0.0)
    return (
        (column > 0).any(axis=0)
        & gt_group[best]
        & (np.argmax(labels[cols, :-1], axis=1) == gt_class[best])
        & (vol > 0)
        & (inside >= 0.5)
    )


def _zero_scores(score_names: Sequence[str]) -> dict:
    return {"task_details": None, "environment_details": [], "scores": {k: 0.0 for k in score_names}}


COMBINE_MODES: tuple[str, ...] = ("mean", "pooled")


def combine(scores: list[dict], mode: str = "mean") -> dict:
    """Combine per-result OMQ score dicts into one.

    ``mode="mean"`` (the default) is the original ``combine``: every score is the arithmetic mean over the entries,
    and a ``{}`` entry (a required environment without results, padded in by the caller) counts as all zeros.
    ``mode="pooled"`` adds up the entries' ``totals`` (TP, FP, FN and the quality sums) and computes the scores
    from those sums (:func:`scores_from_totals`), so that a scene with many objects weighs more than one with few;
    ``{}`` entries contribute nothing (the core pads missing environments with the evaluation of an empty map,
    whose ground-truth objects all count as FN).

    Args:
        scores: the :func:`evaluate` outputs, padded by the caller for every required environment without results.
        mode: ``"mean"`` or ``"pooled"``.

    Returns:
        ``{"task_details": <of the first real entry, else None>, "environment_details": [<each entry's>],
        "combine": mode, "scores": {...}[, "totals": {...}][, "per_class": {...}]}``. Mean: the score names are
        those found in the entries (the original five when none has scores); the counts ``TP``/``FP``/``FN`` are
        averaged too. Pooled: the scores of the summed totals (counts are the sums). ``per_class`` (when the
        entries have one) is always pooled: per class, the totals of every entry that has the class.

    Raises:
        ValueError: unknown ``mode``.
    """
    if mode not in COMBINE_MODES:
        raise ValueError(f"combine mode must be one of {', '.join(COMBINE_MODES)}, got {mode!r}")
    entries = list(scores) if scores else [{}]
    names: list[str] = []
    for entry in entries:
        for name in (entry.get("scores") or {}) if isinstance(entry, dict) else ():
            if name not in names:
                names.append(name)
    if not names:
        names = list(SCORE_NAMES)
    scd = "avg_state_quality" in names
    filled = [e if isinstance(e, dict) and e else _zero_scores(names) for e in entries]
    first = next((e for e in filled if e.get("task_details") is not None), filled[0])
    out = {
        "task_details": first.get("task_details"),
        "environment_details": [e.get("environment_details", []) for e in filled],
        "combine": mode,
    }
    if mode == "mean":
        out["scores"] = {
            name: float(np.mean([float((e.get("scores") or {}).get(name, 0.0)) for e in filled])) for name in names
        }
    else:
        pooled = _new_totals()
        for e in filled:
            for k, v in (e.get("totals") or {}).items():
                if k in pooled:
                    pooled[k] += v
        out["scores"] = scores_from_totals(pooled, scd)
        out["totals"] = pooled
    if any("per_class" in e for e in filled):
        per_class: dict[str, dict] = {}
        for e in filled:
            for cls, entry in (e.get("per_class") or {}).items():
                t = per_class.setdefault(cls, _new_totals())
                for k, v in (entry.get("totals") or {}).items():
                    if k in t:
                        t[k] += v
        out["per_class"] = {
            cls: {"scores": scores_from_totals(t, scd), "totals": t} for cls, t in sorted(per_class.items())
        }
    return out
