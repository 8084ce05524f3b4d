"""What ``benchmarks/realism.py`` counts in a rendered frame: which ground-truth objects are visible, their boxes,
and which of them a detector finds (docs/realism.md, *What is counted*).

- **Visible** (:func:`frame_truths`): an object whose instance mask has at least :data:`MIN_PIXELS` pixels and of
  whose cuboid at most :data:`MAX_TRUNCATION` lies outside the image or behind the camera
  (:func:`cuboid_truncation`); its box is its mask's bounding box. A sink's mask counts only within
  :data:`SINK_BASIN_M` under its cuboid's top (its basin, as COCO boxes sinks).
- **Found** (:func:`score_frame`): detections of score ≥ a threshold matched greedily, best first, to boxes of the same
  class at IoU ≥ :data:`MATCH_IOU`, one per object; a detection of an object that is not visible is ignored, any
  other unmatched one is a false positive.
- **COCO's crowd rule** (:func:`with_crowd_rule`, :func:`crowd_instances`): an object BEAR marks ``isgroup`` (a row
  of books) is neither found nor missed, and a detection mostly inside it (:func:`box_ioa`) is no false positive.

Frames: the camera's OPTICAL frame (x right, y down, z forward), poses ``T_map_camera`` (4, 4) in the map frame
(metres, z up); boxes ``[x1, y1, x2, y2]`` in pixels (x right, y down). Detections are rows
``[x1, y1, x2, y2, score, coco80_class]`` (``benchbot_task_semslam.coco``: COCO's names, BEAR's where they differ).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from benchbot_task_semslam.coco import bear_name, box_iou

#: IoU for a detection to match an object's box (``--iou``); the detector's own NMS is ``coco.NMS_IOU``.
MATCH_IOU = 0.5
#: A visible object: at least this many mask pixels (``--min-pixels``) and at most this fraction of its cuboid
#: outside the image (``--max-truncation``).
MIN_PIXELS = 400
MAX_TRUNCATION = 0.5
#: COCO's annotators box a sink as its basin and the tap over it, not the pedestal or cabinet under it (so do the
#: sinks of the real photos, ``benchmarks/realism/photos``), while BEAR's cuboid of a pedestal washbasin reaches the
#: floor. So a sink counts by its mask's pixels within this height under its cuboid's top (a basin's rim stands
#: 0.8-0.9 m high, its bowl about 0.2 m deep, its tap up to 0.15 m over the rim): :func:`frame_truths`.
SINK_BASIN_M = 0.35


def cuboid_truncation(lo, hi, K: np.ndarray, T_map_camera: np.ndarray, width: int, height: int,
                      samples: int = 5) -> float:
    """Fraction (0..1) of an axis-aligned cuboid (``lo``, ``hi`` (3,) metres, map frame) that falls outside the image
    or behind the camera, estimated on a ``samples``³ grid of points filling it (camera: OPTICAL frame pose,
    pinhole ``K``; pixels with integer centres, so the image spans [-0.5, W-0.5] × [-0.5, H-0.5])."""
    g = [np.linspace(lo[k], hi[k], samples) for k in range(3)]
    pts = np.stack(np.meshgrid(*g, indexing="ij"), axis=-1).reshape(-1, 3)
    T = np.asarray(T_map_camera, dtype=np.float64)
    pc = (pts - T[:3, 3]) @ T[:3, :3]
    front = pc[:, 2] > 1e-3
    z = np.where(front, pc[:, 2], 1.0)
    u = K[0, 0] * pc[:, 0] / z + K[0, 2]
    v = K[1, 1] * pc[:, 1] / z + K[1, 2]
    inside = front & (u >= -0.5) & (u <= width - 0.5) & (v >= -0.5) & (v <= height - 0.5)
    return float(1.0 - inside.mean())


@dataclass
class Truth:
    """One ground-truth object seen in a frame: ``instance`` id (class·1000 + n), BEAR ``cls``, mask ``box``
    ``[x1, y1, x2, y2]`` (pixels, exclusive max), mask ``pixels``, ``truncation`` (0..1), ``visible`` (counted) and
    the ``model`` that draws it (the scene's ``box_models``: an asset id, ``closed_book`` or ``computer_keyboard``
    for what is made in code, ``""`` for a primitive model or the primitives style) and ``crowd``: one cuboid for
    several instances (BEAR's ``isgroup``: a row or a stack of books; :func:`crowd_instances`)."""

    instance: int
    cls: str
    box: list
    pixels: int
    truncation: float
    visible: bool
    model: str = ""
    crowd: bool = False


def crowd_instances(scene, env: dict) -> frozenset[int]:
    """Instance ids (``class·1000 + n``) of the scene's ground-truth cuboids that BEAR marks ``isgroup`` (one box for
    a row or a stack of books) in the environment ``env``'s ground truth (its ``map_path``); matched by their
    bounds, which the scene keeps exactly (within 0.1 mm)."""
    data = json.loads(Path(env["map_path"]).read_text(encoding="utf-8"))
    objects = data["objects"] if "objects" in data else data["ground_truth"]["objects"]  # BEAR's or the original's
    objects = [o for o in objects if o.get("isgroup")]
    if not objects:
        return frozenset()
    lo = np.array([np.subtract(o["centroid"], np.divide(o["extent"], 2.0)) for o in objects])
    box_min, box_max = np.asarray(scene.box_min, np.float64), np.asarray(scene.box_max, np.float64)
    hi = lo + np.array([o["extent"] for o in objects], np.float64)
    same = (np.abs(box_min[:, None] - lo[None]).max(-1) < 1e-4) & (np.abs(box_max[:, None] - hi[None]).max(-1) < 1e-4)
    return frozenset(int(i) for i in np.asarray(scene.box_instance)[same.any(axis=1)])


def box_ioa(detection, region) -> float:
    """The share of a detection's box (``[x1, y1, x2, y2, ...]``, pixels) inside ``region`` (``[x1, y1, x2, y2]``):
    intersection over the detection's area, COCO's measure against a crowd region (0 for an empty box)."""
    w = min(detection[2], region[2]) - max(detection[0], region[0])
    h = min(detection[3], region[3]) - max(detection[1], region[1])
    area = (detection[2] - detection[0]) * (detection[3] - detection[1])
    return float(max(w, 0.0) * max(h, 0.0) / area) if area > 0 else 0.0


def with_crowd_rule(truths: list[Truth]) -> list[Truth]:
    """``truths`` under COCO's ``iscrowd`` rule (T.-Y. Lin et al., *Microsoft COCO: Common Objects in Context*, 2014,
    and its evaluation code): a crowd object is never visible, so it is neither found nor missed, and
    :func:`score_frame` does not count a detection inside it as a false positive."""
    return [dataclasses.replace(t, visible=False) if t.crowd else t for t in truths]


def pixel_heights(depth: np.ndarray, K: np.ndarray, T_map_camera: np.ndarray, ys: np.ndarray,
                  xs: np.ndarray) -> np.ndarray:
    """Map-frame heights (metres, (N,) float64) of the pixels at rows ``ys`` and columns ``xs`` ((N,) int) of a
    z-depth image ``depth`` ((H, W) metres, optical frame: x right, y down, z forward; integer pixel centres) seen
    with intrinsics ``K`` (3, 3) from ``T_map_camera`` (4, 4)."""
    z = np.asarray(depth, np.float64)[ys, xs]
    p = np.stack([(xs - K[0, 2]) / K[0, 0] * z, (ys - K[1, 2]) / K[1, 1] * z, z], axis=1)
    T = np.asarray(T_map_camera, np.float64)
    return p @ T[2, :3] + T[2, 3]


def frame_truths(instance_img: np.ndarray, scene, K: np.ndarray, T_map_camera: np.ndarray,
                 min_pixels: int = MIN_PIXELS, max_truncation: float = MAX_TRUNCATION,
                 crowd: frozenset[int] = frozenset(), depth: np.ndarray | None = None) -> list[Truth]:
    """The ground-truth objects with at least one pixel in ``instance_img`` ((H, W) int32 ``class*1000+n`` ids, 0 =
    background) of a frame rendered from ``T_map_camera``; ``scene`` gives each instance's class name
    (``class_list``), cuboid (``box_min``/``box_max``/``box_instance``) and, where it has them, model
    (``box_models``; a scene without them gives ``""``); ``crowd``: the instances of :func:`crowd_instances`.
    With the frame's z-depth ``depth`` ((H, W) float32 metres), a sink counts by its basin, as COCO boxes sinks:
    the pixels within :data:`SINK_BASIN_M` under its cuboid's top (:func:`pixel_heights`); a sink with none of them
    in view (only its pedestal or cabinet) keeps its whole mask but is never visible, so that a detection on it is
    ignored rather than counted as a false positive."""
    H, W = instance_img.shape
    ids, counts = np.unique(instance_img, return_counts=True)
    index = {int(i): k for k, i in enumerate(np.asarray(scene.box_instance).tolist())}
    models = list(getattr(scene, "box_models", None) or [])
    out = []
    for iid, n in zip(ids.tolist(), counts.tolist()):
        if iid <= 0 or iid not in index:
            continue
        k = index[iid]
        ys, xs = np.nonzero(instance_img == iid)
        cls = str(scene.class_list[iid // 1000])
        basin_in_view = True
        if cls == "sink" and depth is not None:
            basin = pixel_heights(depth, K, T_map_camera, ys, xs) >= float(scene.box_max[k][2]) - SINK_BASIN_M
            basin_in_view = bool(basin.any())
            if basin_in_view:
                ys, xs, n = ys[basin], xs[basin], int(basin.sum())
        box = [int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1]
        trunc = cuboid_truncation(scene.box_min[k], scene.box_max[k], K, T_map_camera, W, H)
        visible = basin_in_view and n >= min_pixels and trunc <= max_truncation
        out.append(Truth(iid, cls, box, int(n), trunc, visible, models[k] if k < len(models) else "", iid in crowd))
    return out


@dataclass
class FrameScore:
    """Matching of one frame's detections at one score threshold: ``hits`` instance → matched (visible objects
    only), ``localised`` instance → hit by a box of any class, ``false_positives`` detections matching nothing."""

    hits: dict = field(default_factory=dict)
    localised: dict = field(default_factory=dict)
    false_positives: list = field(default_factory=list)


def score_frame(truths: list[Truth], detections: list, threshold: float, iou: float = MATCH_IOU,
                crowd_rule: bool = False) -> FrameScore:
    """Greedy matching (best score first) of ``detections`` (rows ``[x1, y1, x2, y2, score, coco_class]``) of score
    ≥ ``threshold`` to ``truths`` of the same class (BEAR names) at IoU ≥ ``iou``, one detection per object; a
    detection on an object that is not visible (too small, truncated, or a crowd under :func:`with_crowd_rule`) is
    ignored, and with ``crowd_rule`` so is one lying mostly inside a crowd object of its class (:func:`box_ioa` ≥
    ``iou``: a single book of a row; pass the truths through :func:`with_crowd_rule` too); any other unmatched
    detection (a wrong class, a box on nothing, a second box on a matched object) is a false positive."""
    res = FrameScore()
    taken: set[int] = set()
    dets = [d for d in sorted(detections, key=lambda r: -r[4]) if d[4] >= threshold]
    for t in truths:
        if t.visible:
            res.hits[t.instance] = False
            res.localised[t.instance] = any(box_iou(d, t.box) >= iou for d in dets)
    for d in dets:
        name = bear_name(d[5])
        best, best_iou = None, iou
        for t in truths:
            if t.cls != name or t.instance in taken:
                continue
            o = box_iou(d, t.box)
            if o >= best_iou:
                best, best_iou = t, o
        if best is None:  # a duplicate, or a box on nothing of its class: false positive (unless on an ignored one)
            if not any(t.cls == name and not t.visible and (box_iou(d, t.box) >= iou
                                                            or (crowd_rule and t.crowd and box_ioa(d, t.box) >= iou))
                       for t in truths):
                res.false_positives.append(d)
            continue
        taken.add(best.instance)
        if best.visible:
            res.hits[best.instance] = True
    return res
