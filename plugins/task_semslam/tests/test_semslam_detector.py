"""Tests of the ``semslam_detector`` example: its fusion of 2D detections with depth (``fusion.py``) on a synthetic
room ray-cast in NumPy (two boxes on a floor before a wall, seen from two poses, with the boxes' projections as
detections), and the whole example through ``benchbot batch`` on the furnished ``miniroom:1`` (slow)."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot_task_semslam.coco import COCO80

EXAMPLE_DIR = Path(__file__).resolve().parents[1] / "benchbot_task_semslam" / "examples" / "semslam_detector"
spec = importlib.util.spec_from_file_location("semslam_detector_fusion", EXAMPLE_DIR / "fusion.py")
fusion = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = fusion  # dataclasses look their module up
spec.loader.exec_module(fusion)

W, H = 320, 240
K = np.array([[160.0, 0.0, (W - 1) / 2], [0.0, 160.0, (H - 1) / 2], [0.0, 0.0, 1.0]])  # 90° horizontal field
#: The optical frame looking along map +x: its x is map −y, its y map −z, its z map +x.
R_LOOK_X = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
#: Two boxes (lo, hi) on the floor: a table and, to its left, a chair; a wall at x = 4.
TABLE = (np.array([2.0, -0.4, 0.0]), np.array([2.6, 0.4, 0.7]))
CHAIR = (np.array([2.2, 1.0, 0.0]), np.array([2.7, 1.5, 0.9]))
WALL_X = 4.0


#: The optical frame looking along map +y: its x is map +x, its y map −z, its z map +y.
R_LOOK_Y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def camera(y: float, x: float = 0.0, rotation: np.ndarray = R_LOOK_X) -> np.ndarray:
    """T_map_camera of a camera 0.8 m above the floor at (x, y) (optical frame)."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rotation, (x, y, 0.8)
    return T


def render_depth(T: np.ndarray) -> np.ndarray:
    """(H, W) float32 depth along the optical axis of the boxes, the floor (z = 0) and the wall."""
    vs, us = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(us - K[0, 2]) / K[0, 0], (vs - K[1, 2]) / K[1, 1], np.ones_like(us)], -1) @ T[:3, :3].T
    o = T[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        best = np.where(rays[..., 0] > 0, (WALL_X - o[0]) / rays[..., 0], np.inf)
        best = np.minimum(best, np.where(rays[..., 2] < 0, -o[2] / rays[..., 2], np.inf))
        for lo, hi in (TABLE, CHAIR):
            t1, t2 = (lo - o) / rays, (hi - o) / rays
            near = np.nanmax(np.minimum(t1, t2), axis=-1)
            far = np.nanmin(np.maximum(t1, t2), axis=-1)
            best = np.where((near <= far) & (near > 0) & (near < best), near, best)
    return np.where(np.isfinite(best), best, 0.0).astype(np.float32)  # depth = s for rays with optical z = 1


def project_box(lo, hi, T) -> list[float]:
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    cam = (corners - T[:3, 3]) @ T[:3, :3]
    uv = cam[:, :2] / cam[:, 2:] * K[0, 0] + K[:2, 2]
    return [max(uv[:, 0].min(), 0), max(uv[:, 1].min(), 0), min(uv[:, 0].max(), W), min(uv[:, 1].max(), H)]


def detections(T, table_score=0.5, chair_score=0.35, extra=()) -> list:
    return [project_box(*TABLE, T) + [table_score, COCO80.index("dining table")],
            project_box(*CHAIR, T) + [chair_score, COCO80.index("chair")], *extra]


CLASSES = ["chair", "table", "tv", "background"]


def fused(frames, **kwargs) -> list[dict]:
    m = fusion.DetectionMapper(allowed=CLASSES, **kwargs)
    for T, dets in frames:
        m.integrate_detections(dets, render_depth(T), K, T)
    return m.build_map(CLASSES)


def iou(obj, box) -> float:
    c, e = np.array(obj["centroid"]), np.array(obj["extent"])
    return fusion.box_iou_3d(c - e / 2, c + e / 2, *box)


def test_views_from_two_sides_fuse_into_one_cuboid_per_object_with_its_class():
    front, front_left, side = camera(0.0), camera(0.6), camera(-2.0, x=2.3, rotation=R_LOOK_Y)
    table_only = [project_box(*TABLE, side) + [0.4, COCO80.index("dining table")]]
    objs = fused([(front, detections(front)), (front_left, detections(front_left)), (side, table_only)])
    assert len(objs) == 2
    table = max(objs, key=lambda o: o["label_probs"][1])
    chair = max(objs, key=lambda o: o["label_probs"][0])
    assert table is not chair
    # the table, seen from the front and the side, is covered; the chair, seen from the front only (its front and
    # right faces), is in its place
    assert iou(table, TABLE) > 0.6, table
    np.testing.assert_allclose(table["centroid"], (TABLE[0] + TABLE[1]) / 2, atol=0.1)
    assert np.all((CHAIR[0] < chair["centroid"]) & (chair["centroid"] < CHAIR[1])) and iou(chair, CHAIR) > 0.3, chair
    # probabilities: the noisy-or confidence of the views, the rest to background
    assert table["label_probs"][1] == pytest.approx(1 - 0.5 * 0.5 * 0.6) and table["label_probs"][0] == 0.0
    assert sum(table["label_probs"]) == pytest.approx(1.0)
    assert chair["label_probs"][3] == pytest.approx(0.65 ** 2)


def test_weak_single_views_other_classes_and_floor_only_boxes_are_dropped():
    T = camera(0.0)
    tv = [100.0, 10.0, 140.0, 40.0, 0.9, COCO80.index("tv")]  # on the wall: kept (strong, in the class list)
    vase = [200.0, 10.0, 240.0, 40.0, 0.9, COCO80.index("vase")]  # not in the class list
    floor = [100.0, 200.0, 220.0, 239.0, 0.9, COCO80.index("chair")]  # only floor pixels: no 3D observation
    objs = fused([(T, detections(T, table_score=0.3, chair_score=0.2, extra=[tv, vase, floor]))])
    # one view: the chair (0.2) and the table (0.3) are below single_view_score; the tv stands alone
    assert len(objs) == 1 and objs[0]["label_probs"][2] == pytest.approx(0.9)
    assert objs[0]["centroid"][0] == pytest.approx(WALL_X, abs=0.05)


def test_merging_and_association_do_not_swallow_a_neighbour():
    views = [camera(y) for y in (-0.3, 0.0, 0.3, 0.6)]
    objs = fused([(T, detections(T, chair_score=0.3)) for T in views], min_views=3)
    assert len(objs) == 2 and all(iou(o, TABLE) < 0.05 or iou(o, CHAIR) < 0.05 for o in objs)


def test_a_cuboid_near_the_floor_reaches_down_to_it_and_one_high_up_does_not():
    views = [camera(y) for y in (-0.3, 0.0, 0.3)]
    upper = (np.array([TABLE[0][0], TABLE[0][1], 0.25]), TABLE[1])  # the detector boxes the table above its legs
    tv = [100.0, 10.0, 140.0, 40.0, 0.9, COCO80.index("tv")]  # on the wall, high up
    frames = [(T, [project_box(*upper, T) + [0.6, COCO80.index("dining table")], tv]) for T in views]
    snapped, kept = fused(frames), fused(frames, floor_snap=0.0)
    table = [o for o in snapped if o["label_probs"][1] > 0][0]
    lo = np.array(table["centroid"]) - np.array(table["extent"]) / 2
    assert lo[2] == pytest.approx(0.0, abs=1e-9) and table["extent"][2] == pytest.approx(TABLE[1][2], abs=0.05)
    lo_kept = [np.array(o["centroid"]) - np.array(o["extent"]) / 2 for o in kept if o["label_probs"][1] > 0][0]
    assert lo_kept[2] > 0.2  # without the snap the cuboid starts where its points do
    for objs in (snapped, kept):
        screen = [o for o in objs if o["label_probs"][2] > 0][0]
        assert screen["centroid"][2] - screen["extent"][2] / 2 > fusion.FLOOR_SNAP_M


def test_without_onnxruntime_or_with_a_missing_recording_the_example_says_so_in_one_line(tmp_path):
    (tmp_path / "onnxruntime.py").write_text("raise ImportError('No module named onnxruntime')\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    proc = subprocess.run([sys.executable, str(EXAMPLE_DIR / "semslam_detector.py"), "--offline", "absent.npz"],
                          capture_output=True, text=True, timeout=60, env=env, cwd=tmp_path)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stderr.strip() == ("semslam_detector: onnxruntime is not installed: pip install "
                                   "'benchbot-task-semslam[detector]' (or uv sync in the BenchBot workspace)")
    proc = subprocess.run([sys.executable, str(EXAMPLE_DIR / "semslam_detector.py"), "--offline", "absent.npz"],
                          capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert proc.returncode == 1 and proc.stderr.startswith("semslam_detector: cannot read --offline absent.npz: ")
    assert "Traceback" not in proc.stderr, proc.stderr


def test_offline_mode_writes_an_object_map_of_recorded_frames(tmp_path):
    """``--offline``: frames of the synthetic room (grey images: the detector finds nothing in them) → a results
    file of the default class list."""
    views = [camera(0.0), camera(0.6)]
    np.savez(tmp_path / "frames.npz", rgb=np.full((2, H, W, 3), 128, np.uint8),
             depth=np.stack([render_depth(T) for T in views]), K=K, T=np.stack(views))
    proc = subprocess.run([sys.executable, str(EXAMPLE_DIR / "semslam_detector.py"), "--offline", "frames.npz",
                           "--output", "result.json"], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "s per frame over 2 frames" in proc.stdout
    results = json.loads((tmp_path / "result.json").read_text())["results"]
    assert results["class_list"][-1] == "background" and results["objects"] == []


@pytest.mark.slow
def test_example_runs_end_to_end_on_the_furnished_miniroom(tmp_path):
    """``benchbot batch --example semslam_detector --envs miniroom:1`` (furnished, sandboxed): a valid results file
    of the task's class list and an OMQ score that finds objects."""
    env = {k: v for k, v in os.environ.items() if k != "BENCHBOT_SIM_STYLE"}  # the conftest's primitives: unset
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--example", "semslam_detector", "--envs",
                           "miniroom:1", "--no-tui", "--output-dir", str(tmp_path)],
                          capture_output=True, text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run_dir,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert [e["status"] for e in manifest["episodes"]] == ["ok"]
    result = json.loads((run_dir / "results" / "000_miniroom_1.json").read_text())["results"]
    assert len(result["objects"]) > 5
    for o in result["objects"]:
        assert len(o["label_probs"]) == len(result["class_list"]) and sum(o["label_probs"]) <= 1 + 1e-9
        assert len(o["centroid"]) == 3 and all(e > 0 for e in o["extent"])
    scores = json.loads((run_dir / "scores.json").read_text())["scores"]
    assert scores["TP"] >= 5 and scores["OMQ"] > 0.1, scores
    log = (run_dir / "logs" / "000_miniroom_1.log").read_text()
    assert "semslam_detector: detector" in log and "s per frame over 48 frames" in log



@pytest.fixture
def detector_main(monkeypatch):
    """The example's ``main(argv)``, its script imported in this process (the example puts its folder and
    semslam_geometric's on ``sys.path`` and imports their modules by plain names: both put back after the test), not
    a new interpreter for each recording (the script run as a user runs it: the tests above and below)."""
    plain = ("fusion", "semslam_geometric")
    monkeypatch.setattr(sys, "path", list(sys.path))
    before = {name: sys.modules.pop(name) for name in plain if name in sys.modules}
    spec = importlib.util.spec_from_file_location("semslam_detector_example", EXAMPLE_DIR / "semslam_detector.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    yield module.main
    for name in plain:
        sys.modules.pop(name, None)
    sys.modules.update(before)


@pytest.mark.parametrize("shapes, message", [
    ({"rgb": None, "K": None, "T": None}, "no array rgb, K, T (an .npz of rgb, depth, K, T is needed)"),
    ({"rgb": (2, H, W, 4)}, f"rgb has shape (2, {H}, {W}, 4), not (N, H, W, 3)"),
    ({"depth": (3, H, W)}, f"depth has shape (3, {H}, {W}), not (2, {H}, {W}) (rgb's N, H, W)"),
    ({"K": (4, 4)}, "K has shape (4, 4), not (3, 3) or (2, 3, 3)"),
    ({"T": (1, 4, 4)}, "T has shape (1, 4, 4), not (2, 4, 4)"),
])
def test_a_recording_of_wrong_arrays_is_named_in_one_line(tmp_path, monkeypatch, detector_main, shapes, message):
    """``--offline`` with an .npz whose arrays are missing (None) or of the wrong shapes: one line naming the
    array, not a traceback from deep in the mapper (``sys.exit`` with the line: Python prints it, exit status 1)."""
    shapes = {"rgb": (2, H, W, 3), "depth": (2, H, W), "K": (3, 3), "T": (2, 4, 4), **shapes}
    np.savez(tmp_path / "frames.npz", **{name: np.zeros(shape, np.uint8 if name == "rgb" else np.float32)
                                         for name, shape in shapes.items() if shape is not None})
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stopped:
        detector_main(["--offline", "frames.npz"])
    assert stopped.value.code == f"semslam_detector: cannot read --offline frames.npz: {message}"
