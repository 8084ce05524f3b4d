"""semslam_detector: a perception-driven semantic-mapping solution for ``semantic_slam:passive:ground_truth``.

A COCO object detector trained on real photos (CenterNet, MobileNetV3 backbone, as ONNX on ONNX Runtime's CPU
provider: ``benchbot_task_semslam.coco_detector``) runs on every ``image_rgb``; each detection whose class (COCO
names mapped to BEAR's: ``dining table`` → ``table``) is in the task's class list is back-projected with
``image_depth``, the intrinsics of ``image_rgb_info`` and ``poses['camera']``, and the detections are fused across
views into axis-aligned cuboids with class probabilities (``fusion.py``). Uses only the task's observations, never
ground truth. The results file is written as ``semslam_geometric`` writes its own (its ``save_result``).

Run against BenchBot (from the examples' folder, as the core does)::

    python semslam_detector/semslam_detector.py

Run offline on recorded frames (an ``.npz`` as ``semslam_geometric --offline`` reads: ``rgb`` (N, H, W, 3) uint8,
``depth`` (N, H, W) float32 metres, ``K`` (3, 3) or (N, 3, 3), ``T`` (N, 4, 4) T_map_camera of the optical frame)::

    python semslam_detector.py --offline frames.npz --output result.json

Needs ``onnxruntime`` (``pip install 'benchbot-task-semslam[detector]'``). Prints the detector's mean seconds per
frame at the end.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(1, os.path.join(os.path.dirname(HERE), "semslam_geometric"))
from fusion import DetectionMapper  # noqa: E402
from semslam_geometric import (  # noqa: E402
    DEFAULT_CLASS_LIST, BenchBot, GeometricAgent, fuse_recording, observation_frame,
)

from benchbot_task_semslam.coco_detector import CocoDetector, DetectorUnavailable  # noqa: E402


class DetectorAgent(GeometricAgent):
    """Passive agent: detects and fuses every observation, follows the trajectory with ``move_next`` until it ends,
    and saves the fused object map (``GeometricAgent.save_result``).

    Args:
        detector: the 2D detector (default: a :class:`CocoDetector` on the shipped model).
        mapper_kwargs: passed to :class:`fusion.DetectionMapper`.
    """

    NAME = "semslam_detector"

    def __init__(self, detector: CocoDetector | None = None, **mapper_kwargs):
        super().__init__(**mapper_kwargs)
        self.detector = detector or CocoDetector()
        self.detect_seconds = 0.0
        self.frames = 0

    def _detect(self, rgb: np.ndarray) -> list:
        t0 = time.perf_counter()
        dets = self.detector.detect(rgb)
        self.detect_seconds += time.perf_counter() - t0
        self.frames += 1
        return dets

    def _mapper(self, scene: int) -> DetectionMapper:
        if scene not in self.mappers:
            # the object_map format's default class list (the task's; save_result keeps only its classes)
            self.mappers[scene] = DetectionMapper(self._detect, allowed=DEFAULT_CLASS_LIST, **self._mapper_kwargs)
        return self.mappers[scene]

    def pick_action(self, observations, action_list):
        frame = observation_frame(observations)
        if frame is not None:
            self._mapper(int(observations.get("scene_number", 0) or 0)).integrate(*frame)
        return "move_next", {}

    def save_result(self, filename, empty_results, results_format_fns):
        if self.frames:
            print(f"{self.NAME}: detector {self.detect_seconds / self.frames:.3f} s per frame over {self.frames} "
                  f"frames ({self.detector.threads} threads)")
        super().save_result(filename, empty_results, results_format_fns)


def run_offline(path: str, output: str, **mapper_kwargs) -> dict:
    """Detect and fuse the frames recorded in ``path`` (.npz, see the module docstring) and write an object_map
    result to ``output``; returns it.

    Raises:
        DetectorUnavailable: no onnxruntime or no model. OSError, ValueError: ``path`` cannot be read or holds no
            valid recording (``semslam_geometric.load_recording``: the message names the array).
    """
    return fuse_recording(DetectorAgent(**mapper_kwargs), path, output)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--offline", metavar="NPZ", help="detect and fuse recorded frames instead of connecting to BenchBot")
    p.add_argument("--output", default="semslam_detector_result.json", help="results file in offline mode")
    p.add_argument("--min-score", type=float, default=None,
                   help="lowest detection score fused (default: fusion.DetectionMapper's, 0.3)")
    args = p.parse_args(argv)
    kwargs = {} if args.min_score is None else dict(min_score=args.min_score)
    try:
        if args.offline:
            try:
                run_offline(args.offline, args.output, **kwargs)
            except (OSError, ValueError) as exc:
                sys.exit(f"semslam_detector: cannot read --offline {args.offline}: {exc}")
            return
        if BenchBot is None:
            sys.exit("benchbot_api is not installed: use --offline")
        BenchBot(agent=DetectorAgent(**kwargs)).run()
    except DetectorUnavailable as exc:  # no onnxruntime, or no model: one line, not a traceback
        sys.exit(f"semslam_detector: {exc}")


if __name__ == "__main__":
    main()
