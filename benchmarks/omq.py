"""OMQ speed: the vectorised evaluator against a straightforward per-pair Python implementation.

Scores 1,000 proposals against house:1's ground truth (56 objects) — half perturbed copies of ground-truth boxes
(centroid jitter 0–30 % of the extent, extents scaled 0.7–1.3, label distributions peaked on the true class), half
random boxes inside house:1's bounds with random (Dirichlet) label distributions — generated deterministically from
``--seed``. ``omq_ms`` is the median wall time of ``benchbot_eval_omq.omq.evaluate`` over ``--repeat`` runs;
``per_pair_ms`` the median of :func:`per_pair_omq` (loops over every (GT, proposal) pair: the two footprint
polygons intersected — by Sutherland–Hodgman clipping, where the original used shapely — times the z-overlap, then
the qualities; then the original's square n×n Hungarian assignment and a loop over the assigned pairs) on the same
input in the same run; ``per_pair_minmax_ms`` the same loops with a per-axis min/max overlap instead of polygons.
The script asserts that all three give the same scores.

    python benchmarks/omq.py [--proposals 1000] [--seed 0] [--repeat 7] [--json]
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import sys
import time

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def make_results(gt: dict, n: int, seed: int) -> dict:
    """A semantic SLAM results file of ``n`` proposals for ground-truth file ``gt`` (deterministic in ``seed``)."""
    rng = np.random.default_rng(seed)
    class_list = list(gt["ground_truth"]["class_list"])
    objects = gt["ground_truth"]["objects"]
    c = np.array([o["centroid"] for o in objects])
    e = np.array([o["extent"] for o in objects])
    lo, hi = (c - e / 2).min(axis=0), (c + e / 2).max(axis=0)
    out = []
    for k in range(n):
        probs = rng.dirichlet(np.full(len(class_list), 0.3))
        if k % 2 == 0:  # perturbed copy of a GT box
            i = int(rng.integers(len(objects)))
            centroid = c[i] + rng.uniform(-0.3, 0.3, 3) * e[i]
            extent = e[i] * rng.uniform(0.7, 1.3, 3)
            probs = 0.3 * probs
            probs[class_list.index(objects[i]["class"])] += rng.uniform(0.3, 0.7)
        else:  # random box in the bounds
            centroid = rng.uniform(lo, hi)
            extent = rng.uniform(0.05, 1.5, 3)
            probs = probs * rng.uniform(0.5, 1.0)
        out.append({"label_probs": probs.tolist(), "centroid": centroid.tolist(), "extent": extent.tolist()})
    return {
        "task_details": {"name": "semantic_slam:passive:ground_truth", "results_format": "object_map"},
        "environment_details": [dict(gt["environment"])],
        "results": {"objects": out, "class_list": class_list},
    }


def footprint(c, e):
    """The 4 corners (CCW) of a box's footprint: centroid ± extent/2 in x and y."""
    x0, x1, y0, y1 = c[0] - e[0] / 2, c[0] + e[0] / 2, c[1] - e[1] / 2, c[1] + e[1] / 2
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def clip(subject, clipper):
    """Sutherland–Hodgman: the part of convex polygon ``subject`` inside convex CCW polygon ``clipper``."""
    out = subject
    for k in range(len(clipper)):
        (ax, ay), (bx, by) = clipper[k], clipper[(k + 1) % len(clipper)]
        inp, out = out, []
        if not inp:
            break

        def side(p):
            return (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax)

        for i, cur in enumerate(inp):
            prev = inp[i - 1]
            sc, sp = side(cur), side(prev)
            if sc >= 0:
                if sp < 0:
                    t = sp / (sp - sc)
                    out.append((prev[0] + t * (cur[0] - prev[0]), prev[1] + t * (cur[1] - prev[1])))
                out.append(cur)
            elif sp >= 0:
                t = sp / (sp - sc)
                out.append((prev[0] + t * (cur[0] - prev[0]), prev[1] + t * (cur[1] - prev[1])))
    return out


def polygon_area(poly):
    """Shoelace area of a simple polygon (0 for fewer than 3 vertices)."""
    if len(poly) < 3:
        return 0.0
    return abs(sum(poly[i - 1][0] * poly[i][1] - poly[i][0] * poly[i - 1][1] for i in range(len(poly)))) / 2


def per_pair_omq(results: dict, gt: dict, polygons: bool = True) -> dict:
    """Semantic SLAM OMQ computed pair by pair in plain Python (the algorithm as docs/evaluation.md gives it), for comparison.

    With ``polygons`` (as the original, which intersected shapely polygons per pair) each pair's footprint
    intersection is a Sutherland–Hodgman polygon clip; without, the per-axis min/max overlap.

    Returns the scores dict (``OMQ, avg_pairwise, avg_label, avg_spatial, avg_fp_quality, TP, FP, FN``).
    """
    from scipy.optimize import linear_sum_assignment

    from benchbot_eval_omq.omq import build_class_list, build_synonyms, resolve_class

    class_list = build_class_list([gt])
    index = {name.lower(): k for k, name in enumerate(class_list)}
    synonyms = build_synonyms([gt])
    nc = len(class_list)
    gts = []
    for o in gt["ground_truth"]["objects"]:
        gts.append((resolve_class(o["class"], index, synonyms), o["centroid"], o["extent"], bool(o.get("isgroup"))))
    res_map = [resolve_class(name, index, synonyms) for name in results["results"]["class_list"]]
    props = []
    for o in results["results"]["objects"]:
        probs = [0.0] * nc
        for k, v in enumerate(o["label_probs"]):
            probs[nc - 1 if res_map[k] is None else res_map[k]] += float(v)
        total = sum(probs)
        if total > 1:
            probs = [v / total for v in probs]
        else:
            probs[-1] += 1.0 - total
        props.append((probs, o["centroid"], o["extent"]))

    def box_overlap_minmax(ca, ea, cb, eb):
        inter = 1.0
        for a in range(3):
            d = min(ea[a], eb[a], (ea[a] + eb[a]) / 2 - abs(ca[a] - cb[a]))
            inter *= max(d, 0.0)
        return inter

    def box_overlap_polygon(ca, ea, cb, eb):
        # as the original: footprint polygons (corners c ± e/2, yaw 0) intersected, times the z-overlap
        fa = footprint(ca, ea)
        area = polygon_area(clip(fa, footprint(cb, eb)))
        dz = min(ca[2] + ea[2] / 2, cb[2] + eb[2] / 2) - max(ca[2] - ea[2] / 2, cb[2] - eb[2] / 2)
        return area * max(dz, 0.0)

    box_overlap = box_overlap_polygon if polygons else box_overlap_minmax

    g, p = len(gts), len(props)
    overall = [[0.0] * p for _ in range(g)]
    label_q = [[0.0] * p for _ in range(g)]
    spatial = [[0.0] * p for _ in range(g)]
    inter = [[0.0] * p for _ in range(g)]
    for i, (cls, cg, eg, _) in enumerate(gts):
        vg = eg[0] * eg[1] * eg[2]
        for j, (probs, cp, ep) in enumerate(props):
            ov = box_overlap(cg, eg, cp, ep)
            union = vg + ep[0] * ep[1] * ep[2] - ov
            iou = min(max(ov / union, 0.0), 1.0) if union > 0 else 0.0
            inter[i][j], spatial[i][j], label_q[i][j] = ov, iou, probs[cls]
            overall[i][j] = math.sqrt(probs[cls] * iou)
    n = max(g, p)
    cost = np.ones((n, n), dtype=np.float32)
    for i in range(g):
        for j in range(p):
            cost[i, j] = 1.0 - overall[i][j]
    rows, cols = linear_sum_assignment(cost)
    tp = fp = fn = 0
    s_all = s_label = s_spatial = fp_cost = 0.0
    for r, c in zip(rows, cols):
        if r < g and c < p and overall[r][c] > 0:
            tp += 1
            s_all += overall[r][c]
            s_label += label_q[r][c]
            s_spatial += spatial[r][c]
            continue
        if r < g:
            fn += 1
        if c < p:
            column = [overall[i][c] for i in range(g)]
            if max(column) > 0:
                best = column.index(max(column))
                probs, _, ep = props[c]
                nonbg = probs[:-1]
                vol = ep[0] * ep[1] * ep[2]
                if (gts[best][3] and nonbg.index(max(nonbg)) == gts[best][0] and vol > 0
                        and inter[best][c] / vol >= 0.5):  # fmt: skip
                    continue
            fp += 1
            fp_cost += max(props[c][0][:-1])

    def ratio(a, b, default=0.0):
        return a / b if b else default

    return {
        "OMQ": ratio(s_all, tp + fp_cost + fn),
        "avg_pairwise": ratio(s_all, tp),
        "avg_label": ratio(s_label, tp),
        "avg_spatial": ratio(s_spatial, tp),
        "avg_fp_quality": ratio(fp - fp_cost, fp, 1.0),
        "TP": tp,
        "FP": fp,
        "FN": fn,
    }


def _median_ms(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1")
    ap.add_argument("--proposals", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=7, help="timed runs of the vectorised evaluator (median)")
    ap.add_argument("--repeat-per-pair", type=int, default=3, help="timed runs of the per-pair version (median)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, proposals=60, repeat=1, repeat_per_pair=1)

    from benchbot.core.registry import get_registry
    from benchbot_eval_omq import omq

    gt = get_registry().ground_truth(args.env)
    results = make_results(gt, args.proposals, args.seed)

    fast = omq.evaluate(results, [gt])["scores"]  # also the warm-up (scipy import)
    for polygons in (True, False):
        slow = per_pair_omq(results, gt, polygons=polygons)
        for name, value in slow.items():
            assert math.isclose(fast[name], value, rel_tol=1e-9, abs_tol=1e-9), (name, fast[name], value)

    omq_ms = _median_ms(lambda: omq.evaluate(results, [gt]), args.repeat)
    per_pair_ms = _median_ms(lambda: per_pair_omq(results, gt), args.repeat_per_pair)
    minmax_ms = _median_ms(lambda: per_pair_omq(results, gt, polygons=False), args.repeat_per_pair)
    report = {
        "env": args.env,
        "ground_truth_objects": len(gt["ground_truth"]["objects"]),
        "proposals": args.proposals,
        "seed": args.seed,
        "omq_ms": round(omq_ms, 3),
        "per_pair_ms": round(per_pair_ms, 3),
        "ratio": round(per_pair_ms / omq_ms, 1),
        "per_pair_minmax_ms": round(minmax_ms, 3),
        "ratio_minmax": round(minmax_ms / omq_ms, 1),
        "scores": fast,
        "same_scores": True,
        "python": platform.python_version(),
        "machine": platform.machine(),
    }
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{args.env}: {report['ground_truth_objects']} GT objects, {args.proposals} proposals (seed {args.seed})")
        print(f"omq_ms      {omq_ms:9.2f}  (vectorised benchbot_eval_omq.omq.evaluate, median of {args.repeat})")
        print(f"per_pair_ms {per_pair_ms:9.2f}  (per-pair Python loops + square Hungarian, median of "
              f"{args.repeat_per_pair})")  # fmt: skip
        print(f"per_pair_minmax_ms {minmax_ms:9.2f}  (the same loops with a per-axis min/max overlap)")
        print(f"ratio       {per_pair_ms / omq_ms:9.1f}x  (min/max: {minmax_ms / omq_ms:.1f}x)   same scores: yes "
              f"(OMQ {fast['OMQ']:.4f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
