"""The COCO detector that ``semslam_detector`` runs (``benchbot_task_semslam.coco_detector``: CenterNet MobileNetV3 as
ONNX, on ONNX Runtime) on real rendered frames of ``miniroom:1``: its boxes land on ground-truth objects of the
right class, and it gives the detections of the npm package's model run by TF.js (``benchmarks/realism.py``'s
detector) on the same frames."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from benchbot_task_semslam.coco import COCO80, COCO_TO_BEAR, bear_name
from benchbot_task_semslam.coco_detector import MODEL_PATH, CocoDetector, DetectorUnavailable

ROOT = Path(__file__).resolve().parents[1]
#: Trajectory poses of miniroom:1 rendered: six spread evenly along its 48 (``realism.select_frames(48, 6)``).
POSES = (0, 9, 19, 28, 38, 47)


@pytest.fixture(scope="module")
def frames(realism, realism_counting):
    """``[(pose index, rgb (480, 640, 3) uint8, ground-truth objects)]`` of miniroom:1 as an episode with seed 0
    sees it, through the robot's default camera (fast mode)."""
    from benchbot_sim_taichi.render.renderer import Renderer
    from benchbot_sim_taichi import scene_cache
    from benchbot_worlds.scene.build import build_scene

    from benchbot.core.geometry import se2_to_matrix
    from benchbot.core.seeding import environment_world_seed

    env = realism._env_spec("miniroom:1", None)
    world = environment_world_seed(0, env)
    scene, key = scene_cache.scene_for(env, world, build=build_scene)
    K, Tc = realism.camera_setup(640, 480)
    r = Renderer("cpu", seed=world, camera=realism.camera_model())
    scene_cache.set_scene(r, scene, key)
    out = []
    for i in POSES:
        T = se2_to_matrix(*scene.trajectory_se2[i]) @ Tc
        img = r.render(K, T, 640, 480, mode="fast")
        out.append((i, img["rgb"], realism_counting.frame_truths(img["instance"], scene, K, T)))
    return out


def test_coco_names_map_to_bear_names():
    assert len(COCO80) == 80 and bear_name(COCO80.index("dining table")) == "table"
    assert bear_name(COCO80.index("potted plant")) == "potted plant"
    assert set(COCO_TO_BEAR.values()) == {"table"}


def test_a_missing_model_is_one_error(tmp_path):
    with pytest.raises(DetectorUnavailable, match="cannot load the detector model"):
        CocoDetector(tmp_path / "absent.onnx")


def test_the_shipped_model_is_small_and_takes_any_frame_size():
    assert 3e6 < MODEL_PATH.stat().st_size < 6e6  # float16 weights: a few MB
    det = CocoDetector(threads=1)
    raw = det.raw(np.zeros((60, 80, 3), np.uint8))
    assert raw.shape == (100, 6) and np.isfinite(raw).all()
    assert raw[:, 2].max() <= 80 * 1.2 and raw[:, 3].max() <= 60 * 1.2  # in the frame's pixels, not the 512 input's
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        det.raw(np.zeros((60, 80), np.uint8))


def test_the_detector_takes_the_batchs_thread_share(monkeypatch):
    """A batch of --workers N sets OMP_NUM_THREADS to each solution's share of the cores; ONNX Runtime ignores it,
    so the detector reads it: N detectors do not each start one thread per core."""
    from benchbot_task_semslam.coco_detector import default_threads

    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    assert default_threads() == 3
    for unusable in ("", "0", "many"):
        monkeypatch.setenv("OMP_NUM_THREADS", unusable)
        assert default_threads() == len(os.sched_getaffinity(0))


@pytest.mark.slow
def test_boxes_land_on_ground_truth_objects_of_rendered_frames(realism_counting, frames):
    """At a score of 0.1, over six frames: at least four visible ground-truth objects get a box (IoU ≥ 0.5 with
    their mask's box) and at least two get a box of their own class."""
    det = CocoDetector()
    found = localised = 0
    for _, rgb, truths in frames:
        dets = det.detect(rgb)
        assert dets == sorted(dets, key=lambda d: -d[4]) and all(d[4] >= det.min_score for d in dets)
        s = realism_counting.score_frame(truths, dets, 0.1)
        found += sum(s.hits.values())
        localised += sum(s.localised.values())
    print(f"{found} objects found, {localised} localised")
    assert localised >= 4, f"only {localised} ground-truth objects got a box"
    assert found >= 2, f"only {found} ground-truth objects got a box of their class"


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("npm") is None or shutil.which("node") is None, reason="needs Node.js and npm")
def test_onnx_model_gives_the_npm_packages_detections(realism_detectors, frames, tmp_path_factory):
    """The same frames through the npm package's model on TF.js (WebAssembly) and through the ONNX conversion: the
    same boxes (within 0.5 px), scores (within 0.005) and classes, for every detection of score ≥ 0.1."""
    npm = realism_detectors.Detector(realism_detectors.install_detector(tmp_path_factory.mktemp("npm-detector")))
    onnx = CocoDetector()
    try:
        for pose, rgb, _ in frames:
            a = [d for d in onnx.detect(rgb) if d[4] >= 0.1]
            b = [d for d in npm.detect(rgb) if d[4] >= 0.1]
            assert len(a) == len(b) > 0, f"pose {pose}: {len(a)} ONNX detections, {len(b)} npm ones"
            for x, y in zip(a, b):
                assert x[5] == y[5], f"pose {pose}: {COCO80[x[5]]} vs {COCO80[y[5]]}"
                np.testing.assert_allclose(x[:4], y[:4], atol=0.5)
                assert abs(x[4] - y[4]) < 0.005
    finally:
        npm.close()
