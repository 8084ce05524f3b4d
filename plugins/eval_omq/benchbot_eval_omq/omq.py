"""Object Map Quality (OMQ): the evaluation method of BenchBot's semantic SLAM and scene change detection tasks.

Formula: D. Hall et al., "The Robotic Vision Scene Understanding Challenge", arXiv:2009.05246 (2020), and QUT's
``benchbot_eval`` OMQ add-on (``eval_omq``), re-implemented as described in the BenchBot reference §7.2, with the
bugs listed there fixed (see the package README):

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
    "pairwise_iou",
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
def _number_array(value: Any, length: int, path: str, what: str, non_negative: bool = False) -> np.ndarray:
    if not isinstance(value, (list, tuple)):
        raise ResultsError(f"{path}: expected a list of {length} {what}, got {type(value).__name__}", _RESULTS_HINT)
    if len(value) != length:
        raise ResultsError(f"{path}: expected {length} {what}, got {len(value)}", _RESULTS_HINT)
    for k, v in enumerate(value):
        if not isinstance(v, Real) or isinstance(v, bool) or not math.isfinite(v):
            raise ResultsError(f"{path}[{k}]: expected a finite number, got {v!r}", _RESULTS_HINT)
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


def _boxes(objects: Sequence[dict], prefix: str, err: type) -> tuple[np.ndarray, np.ndarray]:
    hint = _RESULTS_HINT if err is ResultsError else _GT_HINT
    centroids = np.zeros((len(objects), 3))
    extents = np.zeros((len(objects), 3))
    for i, obj in enumerate(objects):
        for key, out, non_neg in (("centroid", centroids, False), ("extent", extents, True)):
            try:
                out[i] = _number_array(obj.get(key), 3, f"{prefix}[{i}].{key}", "numbers (metres)", non_neg)
            except ResultsError as e:
                raise err(e.message, hint) from None
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
    gt_centroids: np.ndarray, gt_extents: np.ndarray, prop_centroids: np.ndarray, prop_extents: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned 3D IoU of every GT box with every proposal box (vectorised by broadcasting).

    Args:
        gt_centroids, gt_extents: ``(g, 3)`` float64, metres (map frame); extents are full side lengths.
        prop_centroids, prop_extents: ``(p, 3)`` float64, metres.

    Returns:
        ``(iou, intersection)``, both ``(g, p)`` float64: IoU = inter / (vol_gt + vol_prop - inter), 0 where the
        union is 0; ``intersection`` is the overlap volume in m³. Volumes are the products of the extents.
    """
    # Overlap of [cg - eg/2, cg + eg/2] and [cp - ep/2, cp + ep/2] per axis, written as
    # min(eg, ep, (eg + ep)/2 - |cg - cp|): the same value as min(hi) - max(lo), but without the rounding of c ± e/2,
    # so that identical boxes give an IoU of exactly 1.
    ge, pe = gt_extents[:, None, :], prop_extents[None, :, :]
    distance = np.abs(gt_centroids[:, None, :] - prop_centroids[None, :, :])
    overlap = np.minimum(np.minimum(ge, pe), (ge + pe) / 2 - distance)
    inter = np.prod(np.clip(overlap, 0.0, None), axis=2)
    union = np.prod(gt_extents, axis=1)[:, None] + np.prod(prop_extents, axis=1)[None, :] - inter
    with np.errstate(divide="ignore", invalid="ignore"):
        iou = np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)
    return np.clip(iou, 0.0, 1.0), inter


def _geometric_mean(*qualities: np.ndarray) -> np.ndarray:
    """Element-wise geometric mean (as scipy.stats.gmean over the stacked qualities); any zero gives 0."""
    stacked = np.stack(qualities)
    return np.prod(stacked, axis=0) ** (1.0 / len(qualities))


# --------------------------------------------------------------------------------------------------------------------
# evaluate / combine
# --------------------------------------------------------------------------------------------------------------------
def evaluate(results: dict, ground_truths: list[dict]) -> dict:
    """Score one submitted results file with OMQ (Hall et al. 2020, arXiv:2009.05246; benchbot_eval's OMQ add-on).

    Args:
        results: a whole results file ``{task_details: {name, results_format, ...}, environment_details: [...],
            results: {objects: [{label_probs, centroid, extent[, state_probs]}], class_list[, state_list]}}``.
            Centroids/extents in metres, map frame (extents = full side lengths of axis-aligned boxes).
            Mode: scene change detection (SCD) iff ``task_details.results_format == "object_map_with_states"``.
        ground_truths: one ground-truth file per scene, ``{environment, format, ground_truth: {class_list,
            synonyms, objects: [{class, ID_name, centroid, extent, isgroup}]}}`` as in the BEAR JSON files:
            exactly 1 for semantic SLAM, exactly 2 (scene A, scene B) for SCD.

    Returns:
        ``{"task_details", "environment_details", "scores": {"OMQ", "avg_pairwise", "avg_label", "avg_spatial",
        "avg_fp_quality", ["avg_state_quality" (SCD only)], "TP", "FP", "FN"}}``; qualities are floats in [0, 1],
        counts are ints.

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
    raw_labels = np.zeros((len(objects), len(res_classes)))
    for j, obj in enumerate(objects):
        if "label_probs" not in obj:
            raise ResultsError(f"results.objects[{j}].label_probs: missing", _RESULTS_HINT)
        raw_labels[j] = _number_array(
            obj["label_probs"], len(res_classes), f"results.objects[{j}].label_probs",
            "probabilities (len(class_list))", non_negative=True,
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
        raw_states = np.zeros((len(objects), len(res_states)))
        for j, obj in enumerate(objects):
            if "state_probs" not in obj:
                raise ResultsError(f"results.objects[{j}].state_probs: missing", _RESULTS_HINT)
            raw_states[j] = _number_array(
                obj["state_probs"], len(res_states), f"results.objects[{j}].state_probs",
                "probabilities (len(state_list))", non_negative=True,
            )  # fmt: skip
        states = _sanitise(raw_states, state_map, len(SCD_STATE_LIST))  # (p, 3)

    scores = _score(gt_class, gt_group, gt_c, gt_e, gt_states, labels, states, prop_c, prop_e)
    return {
        "task_details": results.get("task_details"),
        "environment_details": results.get("environment_details"),
        "scores": scores,
    }


def _fp_cost(labels: np.ndarray, states: Optional[np.ndarray], j: int, label_only: bool = False) -> float:
    label = float(labels[j, :-1].max()) if labels.shape[1] > 1 else 0.0
    if states is None or label_only:
        return label
    state = float(max(states[j, STATE_ADDED], states[j, STATE_REMOVED]))
    return float(np.sqrt(label * state))


def _score(gt_class, gt_group, gt_c, gt_e, gt_states, labels, states, prop_c, prop_e) -> dict:
    from scipy.optimize import linear_sum_assignment

    scd = states is not None
    g, p = len(gt_class), labels.shape[0]
    tp = fp = fn = 0
    fp_cost = 0.0
    sum_overall = sum_label = sum_spatial = sum_state = 0.0

    if g == 0 or p == 0:  # special case: nothing to match
        fp, fn = p, g
        fp_cost = float(sum(_fp_cost(labels, states, j, label_only=True) for j in range(p)))
    else:
        spatial, inter = pairwise_iou(gt_c, gt_e, prop_c, prop_e)  # (g, p)
        label_q = labels[:, gt_class].T  # (g, p): P_j(class of GT i)
        if scd:
            state_q = states[:, gt_states].T  # (g, p): P_j(state of GT i)
            overall = _geometric_mean(label_q, spatial, state_q)
        else:
            state_q = None
            overall = _geometric_mean(label_q, spatial)
        n = max(g, p)
        cost = np.ones((n, n), dtype=np.float32)
        cost[:g, :p] = 1.0 - overall
        rows, cols = linear_sum_assignment(cost)
        prop_vol = np.prod(prop_e, axis=1)
        for r, c in zip(rows, cols):
            if r < g and c < p and overall[r, c] > 0:
                tp += 1
                sum_overall += overall[r, c]
                sum_label += label_q[r, c]
                sum_spatial += spatial[r, c]
                if scd:
                    sum_state += state_q[r, c]
                continue
            if r < g:
                fn += 1
            if c < p:
                if _group_exempt(c, overall, inter, prop_vol, gt_group, gt_class, labels):
                    continue
                fp += 1
                fp_cost += _fp_cost(labels, states, c)

    def ratio(num: float, den: float, default: float = 0.0) -> float:
        return float(num / den) if den else default

    scores = {
        "OMQ": ratio(sum_overall, tp + fp_cost + fn),
        "avg_pairwise": ratio(sum_overall, tp),
        "avg_label": ratio(sum_label, tp),
        "avg_spatial": ratio(sum_spatial, tp),
        "avg_fp_quality": ratio(fp - fp_cost, fp, default=1.0),
    }
    if scd:
        scores["avg_state_quality"] = ratio(sum_state, tp)
    scores.update({"TP": int(tp), "FP": int(fp), "FN": int(fn)})
    return scores


def _group_exempt(c, overall, inter, prop_vol, gt_group, gt_class, labels) -> bool:
    """True when unassigned proposal ``c`` lies in a group GT box: its column has a non-zero quality, its best GT
    is a group, its argmax non-background label is that GT's class, and >= 50 % of its volume is inside that box."""
    column = overall[:, c]
    if not np.any(column > 0):
        return False
    best = int(np.argmax(column))
    if not gt_group[best] or labels.shape[1] < 2:
        return False
    if int(np.argmax(labels[c, :-1])) != int(gt_class[best]):
        return False
    return bool(prop_vol[c] > 0 and inter[best, c] / prop_vol[c] >= 0.5)


def _zero_scores(score_names: Sequence[str]) -> dict:
    return {"task_details": None, "environment_details": [], "scores": {k: 0.0 for k in score_names}}


def combine(scores: list[dict]) -> dict:
    """Combine per-result OMQ score dicts into one, as the original ``combine``.

    Args:
        scores: the :func:`evaluate` outputs, padded by the caller with ``{}`` for every required environment that
            has no result.

    Returns:
        ``{"task_details": <of the first real entry, else None>, "environment_details": [<each entry's>],
        "scores": {name: arithmetic mean over the entries}}``. An empty list is treated as ``[{}]``; every ``{}`` entry
        counts as all-zero scores (so missing environments pull the means down). The score names are those found in
        the entries (the original five when none has scores); the counts ``TP``/``FP``/``FN`` are averaged too.
    """
    entries = list(scores) if scores else [{}]
    names: list[str] = []
    for entry in entries:
        for name in (entry.get("scores") or {}) if isinstance(entry, dict) else ():
            if name not in names:
                names.append(name)
    if not names:
        names = list(SCORE_NAMES)
    filled = [e if isinstance(e, dict) and e else _zero_scores(names) for e in entries]
    first = next((e for e in filled if e.get("task_details") is not None), filled[0])
    return {
        "task_details": first.get("task_details"),
        "environment_details": [e.get("environment_details", []) for e in filled],
        "scores": {
            name: float(np.mean([float((e.get("scores") or {}).get(name, 0.0)) for e in filled])) for name in names
        },
    }
