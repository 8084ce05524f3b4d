"""Detections fused across views into 3D cuboids with class probabilities: the mapper of ``semslam_detector``.

Frames and units (as ``semslam_geometric``'s ``mapping.py``): ``map`` is the world frame (z up, metres, the floor at
z = 0). The camera frame is the OPTICAL frame (z forward, x right, y down in the image): a pixel (u, v) with depth d
(metres along z) is the point ``d · K⁻¹ [u, v, 1]ᵀ``, and ``T_map_camera`` (4, 4) carries it into ``map``.

Per frame, each detection (a 2D box, a score, a COCO class; kept when its BEAR name is in the task's class list)
becomes a 3D observation: the depths inside the box's central part give the object's depth (their median); the
box's pixels whose depth lies within a band around it (the band scales with the box's width in metres at that
depth) are back-projected into ``map``, floor points (z < :data:`FLOOR_Z`) dropped, and the points' 5th–95th
percentiles per axis make the observation's axis-aligned box. Observations are associated, class-agnostically (the
detector often calls one object by two names across views), to the track whose box overlaps theirs most (3D IoU ≥
``associate_iou`` of the two boxes grown by ``associate_margin``: views from two sides see two faces, thin boxes
that only touch); a track keeps a bounded sample of its points and the summed score of every class. At the end a
track's cuboid is its points' ``box_percentile``–(100 − ``box_percentile``) range, and its label probabilities are
the class score shares scaled by the noisy-or confidence ``1 − Π(1 − sᵢ)`` of its observations (the rest goes to
``background``); tracks seen fewer than ``min_views`` times with no score ≥ ``single_view_score`` are dropped, and
overlapping tracks (3D IoU ≥ ``merge_iou``) merged. A cuboid whose bottom is less than ``floor_snap`` above the floor
reaches down to it: the object stands there, and the depth pixels of its legs are few, thin and cut at
:data:`FLOOR_Z`.

The defaults were chosen on the ten BEAR homes' passive trajectories (the example's README, *Parameters*):
``min_score`` 0.3, the operating point at which a COCO detector's boxes are usually taken (and where
``benchmarks/realism.py`` counts an object as found), ``box_percentile`` 1 and ``floor_snap`` 0.3 m.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

#: Points below this height (metres, map frame) are floor, not object.
FLOOR_Z = 0.03
#: A track's cuboid whose bottom is less than this (metres) above the floor is extended down to it (the default of
#: ``DetectionMapper(floor_snap=...)``).
FLOOR_SNAP_M = 0.3
#: Points kept per track (a uniform sample beyond that), and per observation.
TRACK_POINTS = 4000
OBSERVATION_POINTS = 800


def box_iou_3d(lo_a: np.ndarray, hi_a: np.ndarray, lo_b: np.ndarray, hi_b: np.ndarray) -> float:
    """IoU of two axis-aligned boxes given by corners ``lo``, ``hi`` ((3,) metres); 0 when they do not overlap."""
    inter = np.prod(np.clip(np.minimum(hi_a, hi_b) - np.maximum(lo_a, lo_b), 0.0, None))
    union = np.prod(hi_a - lo_a) + np.prod(hi_b - lo_b) - inter
    return float(inter / union) if union > 0 else 0.0


@dataclass
class Observation:
    """One detection back-projected: ``points`` (N, 3) float64 map frame (metres), its box ``lo``/``hi`` (3,),
    ``label`` (BEAR class name), ``score`` (0..1)."""

    points: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    label: str
    score: float


@dataclass
class Track:
    """An object hypothesis: its points (a sample of at most :data:`TRACK_POINTS`), summed scores per class, the
    scores of its observations."""

    points: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    class_scores: dict[str, float] = field(default_factory=dict)
    scores: list[float] = field(default_factory=list)

    def add(self, obs: Observation, rng: np.random.Generator) -> None:
        """Fold ``obs`` in: its points join the sample, its score the class evidence."""
        self._add_points(obs.points, obs.lo, obs.hi, rng)
        self.class_scores[obs.label] = self.class_scores.get(obs.label, 0.0) + obs.score
        self.scores.append(obs.score)

    def merge(self, other: Track, rng: np.random.Generator) -> None:
        """Fold another track in (points, class evidence, observation scores)."""
        self._add_points(other.points, other.lo, other.hi, rng)
        for k, v in other.class_scores.items():
            self.class_scores[k] = self.class_scores.get(k, 0.0) + v
        self.scores.extend(other.scores)

    def _add_points(self, points: np.ndarray, lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator) -> None:
        pts = np.concatenate([self.points, points])
        if len(pts) > TRACK_POINTS:
            pts = pts[rng.choice(len(pts), TRACK_POINTS, replace=False)]
        self.points = pts
        self.lo, self.hi = np.minimum(self.lo, lo), np.maximum(self.hi, hi)


class DetectionMapper:
    """Fuses 2D detections with depth into an object map (see the module docstring).

    Args:
        detect: ``rgb (H, W, 3) uint8 -> rows [x1, y1, x2, y2, score, coco_class]`` (pixels), e.g.
            ``CocoDetector.detect``; only :meth:`integrate` needs it.
        label_of: COCO class index → BEAR class name (``benchbot_task_semslam.coco.bear_name``).
        min_score: detections below it are ignored. associate_iou, merge_iou: 3D IoU to join a track (of the boxes
            grown by ``associate_margin`` metres on every side), to merge two tracks.
        min_views, single_view_score: a track needs ``min_views`` observations or one of score ≥
            ``single_view_score``. box_percentile: the cuboid's lower percentile of the points per axis.
        floor_snap: a cuboid whose bottom is less than this (metres) above the floor (z = 0) reaches down to it;
            0: never.
        stride: pixel step inside a box. seed: the point sampling's random seed.
        allowed: BEAR class names whose detections are fused (default: all).
    """

    def __init__(self, detect: Callable | None = None, label_of: Callable[[int], str] | None = None,
                 min_score: float = 0.3, associate_iou: float = 0.15, merge_iou: float = 0.3, min_views: int = 2,
                 single_view_score: float = 0.4, box_percentile: float = 1.0, stride: int = 2, seed: int = 0,
                 allowed: Sequence[str] | None = None, associate_margin: float = 0.15,
                 floor_snap: float = FLOOR_SNAP_M):
        if label_of is None:
            from benchbot_task_semslam.coco import bear_name as label_of
        self.detect, self.label_of = detect, label_of
        self.min_score, self.associate_iou, self.merge_iou = min_score, associate_iou, merge_iou
        self.associate_margin = associate_margin
        self.min_views, self.single_view_score, self.box_percentile = min_views, single_view_score, box_percentile
        self.stride, self.floor_snap = stride, floor_snap
        self.rng = np.random.default_rng(seed)
        self.tracks: list[Track] = []
        self.allowed = None if allowed is None else set(allowed) - {"background"}

    # ---------------------------------------------------------------------------------------------------- per frame
    def integrate(self, rgb: np.ndarray, depth: np.ndarray, K: np.ndarray, T_map_camera: np.ndarray) -> int:
        """Detect objects in ``rgb`` and fuse them; returns the number of observations made. Shapes as in
        :meth:`integrate_detections`."""
        if self.detect is None:
            raise RuntimeError("DetectionMapper has no detector: pass detect=, or call integrate_detections")
        return self.integrate_detections(self.detect(rgb), depth, K, T_map_camera)

    def integrate_detections(self, detections: Sequence, depth: np.ndarray, K: np.ndarray,
                             T_map_camera: np.ndarray) -> int:
        """Fuse one frame's ``detections`` (rows ``[x1, y1, x2, y2, score, coco_class]``, pixels) with its ``depth``
        ((H, W) float32 metres along the optical axis, 0 or non-finite where nothing was hit), intrinsics ``K``
        (3, 3) and camera pose ``T_map_camera`` (4, 4, optical frame); returns the number of observations made."""
        made = 0
        for det in sorted(detections, key=lambda d: -d[4]):
            if det[4] < self.min_score:
                continue
            label = self.label_of(int(det[5]))
            if self.allowed is not None and label not in self.allowed:
                continue
            obs = self.observe(det[:4], float(det[4]), label, depth, K, T_map_camera)
            if obs is not None:
                self._associate(obs)
                made += 1
        return made

    def observe(self, box, score: float, label: str, depth: np.ndarray, K: np.ndarray,
                T_map_camera: np.ndarray) -> Observation | None:
        """The 3D observation of one 2D ``box`` ``[x1, y1, x2, y2]`` (pixels), or None when too few depth pixels
        belong to it."""
        H, W = depth.shape
        x1, y1 = max(int(np.floor(box[0])), 0), max(int(np.floor(box[1])), 0)
        x2, y2 = min(int(np.ceil(box[2])), W), min(int(np.ceil(box[3])), H)
        if x2 - x1 < 4 or y2 - y1 < 4:
            return None
        d = np.asarray(depth[y1:y2:self.stride, x1:x2:self.stride], dtype=np.float64)
        vs, us = np.mgrid[y1:y2:self.stride, x1:x2:self.stride]
        valid = np.isfinite(d) & (d > 0)
        h, w = d.shape
        core = np.zeros_like(valid)
        core[int(0.3 * h):max(int(0.7 * h), int(0.3 * h) + 1), int(0.3 * w):max(int(0.7 * w), int(0.3 * w) + 1)] = True
        if (valid & core).sum() < 4:
            return None
        d_obj = float(np.median(d[valid & core]))
        width_m = (x2 - x1) * d_obj / float(K[0, 0])
        band = float(np.clip(0.6 * width_m, 0.1, 1.0))
        keep = valid & (np.abs(d - d_obj) <= band)
        if keep.sum() < 10:
            return None
        z = d[keep]
        cam = np.stack([(us[keep] - K[0, 2]) * z / K[0, 0], (vs[keep] - K[1, 2]) * z / K[1, 1], z], axis=1)
        pts = cam @ T_map_camera[:3, :3].T + T_map_camera[:3, 3]
        above = pts[:, 2] >= FLOOR_Z
        if above.sum() < 10:
            return None
        pts = pts[above]
        if len(pts) > OBSERVATION_POINTS:
            pts = pts[self.rng.choice(len(pts), OBSERVATION_POINTS, replace=False)]
        lo, hi = np.percentile(pts, 5, axis=0), np.percentile(pts, 95, axis=0)
        hi = np.maximum(hi, lo + 0.02)
        return Observation(pts, lo, hi, label, score)

    def _associate(self, obs: Observation) -> None:
        best, best_iou = None, self.associate_iou
        m = self.associate_margin  # views of one object see different faces: thin boxes that only touch
        for t in self.tracks:
            iou = box_iou_3d(t.lo - m, t.hi + m, obs.lo - m, obs.hi + m)
            if iou >= best_iou:
                best, best_iou = t, iou
        if best is None:
            t = Track(np.empty((0, 3)), obs.lo.copy(), obs.hi.copy())
            t.add(obs, self.rng)
            self.tracks.append(t)
        else:
            best.add(obs, self.rng)

    # --------------------------------------------------------------------------------------------------- at the end
    def _box(self, t: Track) -> tuple[np.ndarray, np.ndarray]:
        lo = np.percentile(t.points, self.box_percentile, axis=0)
        hi = np.percentile(t.points, 100.0 - self.box_percentile, axis=0)
        if lo[2] < self.floor_snap:  # it stands on the floor
            lo[2] = 0.0
        return lo, np.maximum(hi, lo + 0.02)

    def final_tracks(self) -> list[tuple[Track, np.ndarray, np.ndarray]]:
        """The kept tracks with their cuboids ``(track, lo (3,), hi (3,))``, overlapping ones merged."""
        tracks = [t for t in self.tracks
                  if len(t.scores) >= self.min_views or max(t.scores) >= self.single_view_score]
        merged = True
        while merged:
            merged = False
            boxes = [self._box(t) for t in tracks]
            for i in range(len(tracks)):
                for j in range(i + 1, len(tracks)):
                    if box_iou_3d(*boxes[i], *boxes[j]) >= self.merge_iou:
                        tracks[i].merge(tracks.pop(j), self.rng)
                        merged = True
                        break
                if merged:
                    break
        return [(t, *self._box(t)) for t in tracks]

    def build_map(self, class_list: Sequence[str]) -> list[dict]:
        """The object map: one dict per kept track, ``{'label_probs': list[float] (len(class_list)), 'centroid':
        [x, y, z], 'extent': [dx, dy, dz]}`` (metres, ``map`` frame, full side lengths of an axis-aligned box); the
        probability mass not given to a class goes to ``background`` when the list has it."""
        index = {c: i for i, c in enumerate(class_list)}
        objects = []
        for t, lo, hi in self.final_tracks():
            evidence = {c: s for c, s in t.class_scores.items() if c in index and c != "background"}
            total = sum(evidence.values())
            if total <= 0:
                continue
            confidence = 1.0 - float(np.prod([1.0 - s for s in t.scores]))
            probs = [0.0] * len(class_list)
            for c, s in evidence.items():
                probs[index[c]] = confidence * s / total
            if "background" in index:
                probs[index["background"]] = max(0.0, 1.0 - sum(probs))
            objects.append({"label_probs": probs, "centroid": [float(v) for v in (lo + hi) / 2],
                            "extent": [float(v) for v in hi - lo]})
        return objects
