"""OMQ beyond the reference cases: per-class scores, pooled combine, the oriented-cuboid extension, SCD details,
and hypothesis properties (bounds, perfect map, permutation, false positives, synonyms)."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchbot.core.errors import ResultsError
from benchbot_eval_omq import omq

DATA = Path(__file__).parent / "data"
GT1 = json.loads((DATA / "miniroom_1.json").read_text())
GT2 = json.loads((DATA / "miniroom_2.json").read_text())
CL = GT1["ground_truth"]["class_list"]
GT_OBJECTS = GT1["ground_truth"]["objects"]


def obj(gt_obj: dict, conf: float = 1.0, cls: str | None = None, shift=(0.0, 0.0, 0.0), states=None, **extra) -> dict:
    lp = [0.0] * len(CL)
    lp[CL.index(cls or gt_obj["class"])] = conf
    out = {
        "label_probs": lp,
        "centroid": [c + s * e for c, s, e in zip(gt_obj["centroid"], shift, gt_obj["extent"])],
        "extent": list(gt_obj["extent"]),
        **extra,
    }
    if states is not None:
        out["state_probs"] = list(states)
    return out


def results(objects, scd: bool = False, class_list=CL) -> dict:
    inner = {"objects": objects, "class_list": list(class_list)}
    if scd:
        inner["state_list"] = ["added", "removed", "unchanged"]
    return {
        "task_details": {"name": "scd:passive:ground_truth" if scd else "semantic_slam:passive:ground_truth",
                         "results_format": "object_map_with_states" if scd else "object_map"},
        "environment_details": [{"name": "miniroom", "variant": 1}] + ([{"name": "miniroom", "variant": 2}] if scd else []),
        "results": inner,
    }  # fmt: skip


def far_fp(conf: float = 0.8, cls: int = 0, states=None) -> dict:
    lp = [0.0] * len(CL)
    lp[cls] = conf
    out = {"label_probs": lp, "centroid": [50.0, 50.0, 50.0], "extent": [1.0, 1.0, 1.0]}
    if states is not None:
        out["state_probs"] = list(states)
    return out


def unit_gt(yaw: float | None = None) -> dict:
    o = {"class": "table", "ID_name": "t0", "centroid": [0.0, 0.0, 0.5], "extent": [1.0, 1.0, 1.0], "isgroup": False}
    if yaw is not None:
        o["yaw"] = yaw
    gt = copy.deepcopy(GT1)
    gt["ground_truth"]["objects"] = [o]
    return gt


# ---------------------------------------------------------------------------------------------------------------------
# per-class
# ---------------------------------------------------------------------------------------------------------------------
def test_per_class_perfect_and_counts_add_up():
    objs = [obj(o) for o in GT_OBJECTS] + [far_fp(0.8, CL.index("cup")), far_fp(0.0)]
    out = omq.evaluate(results(objs), [GT1], per_class=True)
    pc = out["per_class"]
    assert set(pc) == {o["class"] for o in GT_OBJECTS} | {"background"}
    for name in ("TP", "FP", "FN", "sum_overall", "sum_fp_cost"):
        assert sum(c["totals"][name] for c in pc.values()) == pytest.approx(out["totals"][name]), name
    assert pc["cup"]["totals"]["FP"] == 1 and pc["cup"]["scores"]["avg_fp_quality"] == pytest.approx(0.2)
    n_cup = sum(o["class"] == "cup" for o in GT_OBJECTS)
    assert pc["cup"]["scores"]["OMQ"] == pytest.approx(n_cup / (n_cup + 0.8))
    assert pc["background"]["totals"]["FP"] == 1 and pc["background"]["scores"]["OMQ"] == 0.0  # zero-cost FP
    assert pc["chair"]["scores"]["OMQ"] == 1.0
    assert "per_class" not in omq.evaluate(results(objs), [GT1])


def test_per_class_misses_and_scd():
    objs = [obj(o) for o in GT_OBJECTS if o["class"] != "table"]
    pc = omq.evaluate(results(objs), [GT1], per_class=True)["per_class"]
    assert pc["table"]["scores"]["OMQ"] == 0.0 and pc["table"]["totals"]["FN"] == 3
    changes = omq.scd_ground_truth(GT1["ground_truth"]["objects"], GT2["ground_truth"]["objects"])
    scd = results([obj(o, states=[1.0 if s == k else 0.0 for k in range(3)]) for o, s in changes], scd=True)
    out = omq.evaluate(scd, [GT1, GT2], per_class=True)
    assert out["scores"]["OMQ"] == pytest.approx(1.0) and out["scores"]["avg_state_quality"] == pytest.approx(1.0)
    assert all("avg_state_quality" in c["scores"] for c in out["per_class"].values())
    assert sum(c["totals"]["TP"] for c in out["per_class"].values()) == len(changes)


# ---------------------------------------------------------------------------------------------------------------------
# combine
# ---------------------------------------------------------------------------------------------------------------------
def test_pooled_combine_divides_pooled_sums():
    a = omq.evaluate(results([obj(o) for o in GT_OBJECTS]), [GT1])  # 18 TP, OMQ 1
    b = omq.evaluate(results([obj(o, shift=(0.5, 0, 0)) for o in GT_OBJECTS[:2]]), [GT1])  # 2 TP, 16 FN
    mean = omq.combine([a, b])
    pooled = omq.combine([a, b], mode="pooled")
    assert mean["combine"] == "mean" and pooled["combine"] == "pooled"
    assert mean["scores"]["OMQ"] == pytest.approx((1.0 + b["scores"]["OMQ"]) / 2)
    expected = (18 + b["totals"]["sum_overall"]) / (18 + 2 + 16)
    assert pooled["scores"]["OMQ"] == pytest.approx(expected)
    assert (pooled["scores"]["TP"], pooled["scores"]["FP"], pooled["scores"]["FN"]) == (20, 0, 16)
    assert pooled["scores"]["avg_spatial"] == pytest.approx((18 + 2 / 3) / 20)
    assert omq.combine([a], mode="pooled")["scores"] == a["scores"]
    # {} (a missing environment) pulls the mean down, contributes nothing to the pool
    assert omq.combine([a, {}])["scores"]["OMQ"] == pytest.approx(0.5)
    assert omq.combine([a, {}], mode="pooled")["scores"]["OMQ"] == 1.0
    with pytest.raises(ValueError, match="combine mode"):
        omq.combine([a], mode="median")


def test_combine_pools_per_class():
    a = omq.evaluate(results([obj(o) for o in GT_OBJECTS]), [GT1], per_class=True)
    b = omq.evaluate(results([]), [GT1], per_class=True)
    pc = omq.combine([a, b])["per_class"]
    assert pc["chair"]["totals"]["TP"] == pc["chair"]["totals"]["FN"] > 0
    assert pc["chair"]["scores"]["OMQ"] == pytest.approx(0.5)


# ---------------------------------------------------------------------------------------------------------------------
# oriented-cuboid extension
# ---------------------------------------------------------------------------------------------------------------------
def test_oriented_yaw_zero_equals_axis_aligned():
    rng = np.random.default_rng(3)
    objs = [obj(o, conf=0.9, shift=tuple(rng.uniform(-0.4, 0.4, 3)), yaw=0.0) for o in GT_OBJECTS]
    objs.append(far_fp())
    assert omq.evaluate(results(objs), [GT1], oriented=True) == omq.evaluate(results(objs), [GT1])


def test_oriented_45_degree_square_known_iou():
    gt = unit_gt()
    rotated = results([obj(gt["ground_truth"]["objects"][0], yaw=math.pi / 4)])
    # intersection of a unit square and the same square turned 45°: a regular octagon of area 2√2 − 2;
    # IoU = (2√2 − 2) / (2 − (2√2 − 2)) = 1/√2 (same height, so the 3D IoU equals the 2D one)
    s = omq.evaluate(rotated, [gt], oriented=True)["scores"]
    assert s["avg_spatial"] == pytest.approx(1 / math.sqrt(2), rel=1e-12)
    assert omq.evaluate(rotated, [gt])["scores"]["avg_spatial"] == 1.0  # off: yaw ignored, as the original
    iou, inter = omq.pairwise_iou(np.array([[0.0, 0, 0]]), np.ones((1, 3)), np.array([[0.0, 0, 0.5]]),
                                  np.ones((1, 3)), np.zeros(1), np.array([math.pi / 4]))  # fmt: skip
    assert inter[0, 0] == pytest.approx((2 * math.sqrt(2) - 2) * 0.5)
    assert iou[0, 0] == pytest.approx(inter[0, 0] / (2 - inter[0, 0]))


def test_oriented_ground_truth_yaw_and_symmetries():
    gt = unit_gt(yaw=0.3)
    o = gt["ground_truth"]["objects"][0]
    for yaw in (0.3, 0.3 + math.pi / 2, 0.3 - math.pi):  # same footprint
        assert omq.evaluate(results([obj(o, yaw=yaw)]), [gt], oriented=True)["scores"]["OMQ"] == pytest.approx(1.0)
    with pytest.raises(ResultsError, match=r"results\.objects\[0\]\.yaw"):
        omq.evaluate(results([obj(o, yaw="north")]), [gt], oriented=True)
    assert omq.evaluate(results([obj(o, yaw="north")]), [gt])["scores"]["OMQ"] == 1.0  # ignored when off


def test_footprint_intersection_matches_grid():
    rng = np.random.default_rng(7)
    n = 12
    ca, cb = rng.uniform(-0.6, 0.6, (n, 2)), rng.uniform(-0.6, 0.6, (n, 2))
    ea, eb = rng.uniform(0.2, 1.5, (n, 2)), rng.uniform(0.2, 1.5, (n, 2))
    ya, yb = rng.uniform(-3, 3, n), rng.uniform(-3, 3, n)
    area = omq.footprint_intersection(ca, ea, ya, cb, eb, yb)
    g = np.linspace(-2, 2, 801)
    x, y = np.meshgrid(g, g)

    def inside(c, e, yaw):
        dx, dy = x - c[0], y - c[1]
        u, v = math.cos(yaw) * dx + math.sin(yaw) * dy, -math.sin(yaw) * dx + math.cos(yaw) * dy
        return (np.abs(u) <= e[0] / 2) & (np.abs(v) <= e[1] / 2)

    cell = (g[1] - g[0]) ** 2
    for k in range(n):
        est = (inside(ca[k], ea[k], ya[k]) & inside(cb[k], eb[k], yb[k])).sum() * cell
        assert area[k] == pytest.approx(est, abs=0.01)
    far = omq.footprint_intersection(np.zeros((1, 2)), np.ones((1, 2)), [0.4], np.array([[5.0, 0]]), np.ones((1, 2)), [0.1])
    assert far[0] == 0.0


# ---------------------------------------------------------------------------------------------------------------------
# SCD
# ---------------------------------------------------------------------------------------------------------------------
def _scd_changes():
    return omq.scd_ground_truth(GT1["ground_truth"]["objects"], GT2["ground_truth"]["objects"])


def test_scd_wrong_state_lowers_omq():
    changes = _scd_changes()
    right = results([obj(o, states=[1.0 if s == k else 0.0 for k in range(3)]) for o, s in changes], scd=True)
    wrong = copy.deepcopy(right)
    wrong["results"]["objects"][0]["state_probs"] = [0.0, 0.0, 1.0]  # "unchanged": state quality 0
    s_right = omq.evaluate(right, [GT1, GT2])["scores"]
    s_wrong = omq.evaluate(wrong, [GT1, GT2])["scores"]
    assert s_right["OMQ"] == pytest.approx(1.0)
    assert s_wrong["OMQ"] < s_right["OMQ"] and s_wrong["TP"] == len(changes) - 1


def test_scd_state_probs_sanitised_and_fp_cost():
    changes = _scd_changes()
    objs = [obj(o, states=[0.4 if s == k else 0.0 for k in range(3)]) for o, s in changes]
    s = omq.evaluate(results(objs, scd=True), [GT1, GT2])["scores"]
    assert s["avg_state_quality"] == pytest.approx(0.4)  # the remainder 0.6 went to "unchanged"
    objs = [obj(o, states=[2.0 if s == k else 0.0 for k in range(3)] + [0.0]) for o, s in changes]
    res = results(objs, scd=True)
    res["results"]["state_list"] = ["added", "removed", "unchanged", "moved"]  # unknown name → unchanged
    assert omq.evaluate(res, [GT1, GT2])["scores"]["avg_state_quality"] == pytest.approx(1.0)  # sum > 1: divided


# ---------------------------------------------------------------------------------------------------------------------
# properties
# ---------------------------------------------------------------------------------------------------------------------
_prop = st.tuples(
    st.integers(0, len(GT_OBJECTS) - 1),
    st.lists(st.floats(-0.6, 0.6), min_size=3, max_size=3),
    st.floats(0.05, 1.0),
    st.integers(0, len(CL) - 1),
)


def _build(spec) -> dict:
    k, shift, conf, cls = spec
    o = obj(GT_OBJECTS[k], conf=conf, shift=tuple(shift))
    o["label_probs"][cls] += (1.0 - conf) / 2
    return o


SETTINGS = settings(max_examples=30, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(st.lists(_prop, max_size=20), st.floats(0.0, 1.0))
def test_property_bounds_and_extra_fp_never_raises(specs, fp_conf):
    objs = [_build(s) for s in specs]
    out = omq.evaluate(results(objs), [GT1], per_class=True)
    for name, value in out["scores"].items():
        if name not in omq.COUNT_NAMES:
            assert 0.0 <= value <= 1.0, name
    for entry in out["per_class"].values():
        assert all(0.0 <= v <= 1.0 for k, v in entry["scores"].items() if k not in omq.COUNT_NAMES)
    worse = omq.evaluate(results(objs + [far_fp(fp_conf, cls=1)]), [GT1])["scores"]
    assert worse["OMQ"] <= out["scores"]["OMQ"] + 1e-12


@SETTINGS
@given(st.lists(st.integers(0, len(GT_OBJECTS) - 1), min_size=1, max_size=len(GT_OBJECTS), unique=True),
       st.randoms(use_true_random=False))  # fmt: skip
def test_property_perfect_map_scores_one_in_any_order(indices, rnd):
    gt = copy.deepcopy(GT1)
    gt["ground_truth"]["objects"] = [GT_OBJECTS[i] for i in indices]
    objs = [obj(o) for o in gt["ground_truth"]["objects"]]
    rnd.shuffle(objs)
    s = omq.evaluate(results(objs), [gt])["scores"]
    assert all(s[name] == 1.0 for name in omq.SCORE_NAMES)
    assert (s["TP"], s["FP"], s["FN"]) == (len(indices), 0, 0)


@SETTINGS
@given(st.lists(_prop, max_size=15), st.randoms(use_true_random=False))
def test_property_permutation_and_synonyms_change_nothing(specs, rnd):
    objs = [_build(s) for s in specs]
    base = omq.evaluate(results(objs), [GT1])["scores"]
    shuffled = list(objs)
    rnd.shuffle(shuffled)
    assert omq.evaluate(results(shuffled), [GT1])["scores"] == pytest.approx(base, abs=1e-9)
    synonyms = {"table": "dining table", "couch": "sofa", "tv": "tvmonitor", "potted plant": "plant",
                "chair": "stool", "background": "bg"}  # fmt: skip
    renamed = [synonyms.get(c, c) if rnd.random() < 0.7 else c.upper() for c in CL]
    assert omq.evaluate(results(objs, class_list=renamed), [GT1])["scores"] == pytest.approx(base, abs=1e-9)


# ---------------------------------------------------------------------------------------------------------------------
# matches: the assignment object by object (for the report's top-down maps)
# ---------------------------------------------------------------------------------------------------------------------
def _check_matches(out: dict, n_gt: int, n_prop: int) -> None:
    """``matches`` agrees with the totals it explains: counts, quality sums, FP costs, both directions of a pair."""
    m, t = out["matches"], out["totals"]
    gt, props = m["ground_truth"], m["proposals"]
    assert len(gt) == n_gt and len(props) == n_prop
    assert sum(e["status"] == "TP" for e in gt) == sum(e["status"] == "TP" for e in props) == t["TP"]
    assert sum(e["status"] == "FN" for e in gt) == t["FN"]
    assert sum(e["status"] == "FP" for e in props) == t["FP"]
    assert math.fsum(e["quality"] for e in gt if e["status"] == "TP") == pytest.approx(t["sum_overall"], abs=1e-12)
    assert math.fsum(e["spatial"] for e in props if e["status"] == "TP") == pytest.approx(t["sum_spatial"], abs=1e-12)
    assert math.fsum(e["fp_cost"] for e in props) == pytest.approx(t["sum_fp_cost"], abs=1e-12)
    for e in gt:
        if e["status"] == "TP":
            assert props[e["proposal"]]["ground_truth"] == e["index"] and props[e["proposal"]]["quality"] == e["quality"]
        else:
            assert e["proposal"] is None and e["quality"] is None
    assert all(e["status"] in ("TP", "FP", "group") for e in props)


def test_matches_change_no_score_and_explain_the_totals():
    objs = [obj(o, shift=(0.25, 0.0, 0.0)) for o in GT_OBJECTS[:10]] + [obj(o, conf=0.5) for o in GT_OBJECTS[10:14]]
    objs += [far_fp(0.8, cls=2), far_fp(0.3, cls=0)]
    plain = omq.evaluate(results(objs), [GT1])
    out = omq.evaluate(results(objs), [GT1], matches=True, per_class=True)
    assert out["scores"] == plain["scores"] and out["totals"] == plain["totals"]  # bit for bit
    _check_matches(out, len(GT_OBJECTS), len(objs))
    fps = [e for e in out["matches"]["proposals"] if e["status"] == "FP"]
    assert [(e["index"], e["class"], e["fp_cost"]) for e in fps] == [(14, CL[2], 0.8), (15, CL[0], 0.3)]
    first = out["matches"]["ground_truth"][0]
    assert (first["class"], first["ID_name"], first["proposal"]) == (GT_OBJECTS[0]["class"], GT_OBJECTS[0]["ID_name"], 0)
    assert first["spatial"] == pytest.approx(0.75 / 1.25)  # a quarter-extent shift along x: IoU 0.75 / 1.25
    assert out["matches"]["ground_truth"][-1]["status"] == "FN"


def test_matches_group_exemption_empty_maps_and_scd():
    group = next(i for i, o in enumerate(GT_OBJECTS) if o.get("isgroup"))
    inside = obj(GT_OBJECTS[group], extent=[e / 4 for e in GT_OBJECTS[group]["extent"]])
    out = omq.evaluate(results([obj(o) for o in GT_OBJECTS] + [inside]), [GT1], matches=True)
    assert out["matches"]["proposals"][-1]["status"] == "group" and out["scores"]["FP"] == 0
    _check_matches(out, len(GT_OBJECTS), len(GT_OBJECTS) + 1)
    empty = omq.evaluate(results([]), [GT1], matches=True)
    assert {e["status"] for e in empty["matches"]["ground_truth"]} == {"FN"} and empty["matches"]["proposals"] == []
    no_gt = copy.deepcopy(GT1)
    no_gt["ground_truth"]["objects"] = []
    only_fp = omq.evaluate(results([far_fp(0.7, cls=1)]), [no_gt], matches=True)
    _check_matches(only_fp, 0, 1)
    changes = omq.scd_ground_truth(GT1["ground_truth"]["objects"], GT2["ground_truth"]["objects"])
    scd = results([obj(o, states=[1.0, 0.0, 0.0] if s == 0 else [0.0, 1.0, 0.0]) for o, s in changes], scd=True)
    out = omq.evaluate(scd, [GT1, GT2], matches=True)
    assert out["scores"] == omq.evaluate(scd, [GT1, GT2])["scores"]
    assert [e["state"] for e in out["matches"]["ground_truth"]] == ["removed" if s == 1 else "added" for _, s in changes]
    _check_matches(out, len(changes), len(changes))


@SETTINGS
@given(st.lists(_prop, max_size=20), st.floats(0.0, 1.0))
def test_property_matches_never_change_a_score(specs, fp_conf):
    objs = [_build(s) for s in specs] + [far_fp(fp_conf, cls=1)]
    out = omq.evaluate(results(objs), [GT1], matches=True)
    assert out["scores"] == omq.evaluate(results(objs), [GT1])["scores"]
    _check_matches(out, len(GT_OBJECTS), len(objs))
