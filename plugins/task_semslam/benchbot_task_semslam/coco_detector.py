"""A COCO object detector trained on real photos, run by ONNX Runtime on the CPU: CenterNet with a MobileNetV3
backbone (MS-COCO, 80 classes), the model of ``benchmarks/realism.py`` (npm ``@vladmandic/human`` 3.3.6), converted
once to ONNX by ``tools/centernet_to_onnx.py`` and shipped in ``models/`` (licence, origin and the conversion
command: ``models/MODEL.md``). Nothing is downloaded at run time.

Needs ``onnxruntime`` (``pip install 'benchbot-task-semslam[detector]'``; the workspace's ``uv sync`` installs it).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from benchbot_task_semslam.coco import NMS_IOU, nms

#: The shipped ONNX model: input ``images`` (1, H, W, 3) float32 RGB 0..255 (any H, W: the model resizes the frame
#: to its 512 × 512 input as TF.js's ``resizeBilinear`` does), output ``detections`` (1, 100, 6) float32 rows
#: ``x1, y1, x2, y2`` (pixels of the 512 × 512 input), score (0..1), COCO class index (0..79, see ``coco.COCO80``).
MODEL_PATH = Path(__file__).resolve().parent / "models" / "centernet_mobilenetv3_coco.onnx"
#: The model's square input side, pixels.
MODEL_INPUT = 512
#: Lowest score reported by default (the one ``benchmarks/realism.py``'s npm detector reports).
MIN_SCORE = 0.05


def default_threads() -> int:
    """ONNX Runtime's intra-op threads when none are asked for: ``OMP_NUM_THREADS`` when it is a positive integer (a
    batch of ``--workers N`` sets it to the cores / N each solution may use; ONNX Runtime itself ignores it), else
    the CPUs this process may use."""
    value = os.environ.get("OMP_NUM_THREADS", "").split(",")[0].strip()
    if value.isdigit() and int(value) > 0:
        return int(value)
    return len(os.sched_getaffinity(0))


class DetectorUnavailable(RuntimeError):
    """onnxruntime is not installed, or the model file is missing or unreadable (the message says which)."""


class CocoDetector:
    """CenterNet (MobileNetV3, MS-COCO) on ONNX Runtime's CPU provider.

    Args:
        model_path: the ONNX model (default :data:`MODEL_PATH`).
        threads: intra-op threads (default: :func:`default_threads`).
        min_score: lowest score :meth:`detect` returns.

    Raises:
        DetectorUnavailable: onnxruntime is missing or the model cannot be loaded.
    """

    def __init__(self, model_path: str | os.PathLike = MODEL_PATH, threads: int | None = None,
                 min_score: float = MIN_SCORE) -> None:
        try:
            import onnxruntime as ort
        except ImportError:
            raise DetectorUnavailable("onnxruntime is not installed: pip install 'benchbot-task-semslam[detector]'"
                                      " (or uv sync in the BenchBot workspace)") from None
        opts = ort.SessionOptions()
        #: intra-op threads of the session
        self.threads = int(threads or default_threads())
        opts.intra_op_num_threads = self.threads
        opts.inter_op_num_threads = 1
        opts.log_severity_level = 3
        try:
            self._session = ort.InferenceSession(str(model_path), sess_options=opts,
                                                 providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own exception types (file missing, bad protobuf)
            raise DetectorUnavailable(f"cannot load the detector model {model_path}: {exc}") from None
        self.min_score = float(min_score)

    def raw(self, rgb: np.ndarray) -> np.ndarray:
        """The model's 100 rows for an (H, W, 3) uint8 RGB image: (100, 6) float32 ``x1, y1, x2, y2`` in pixels of
        the image (x right, y down), score, COCO class index; in the model's order (best first), no threshold, no
        NMS.

        Raises:
            ValueError: ``rgb`` is not (H, W, 3)."""
        rgb = np.asarray(rgb)
        if rgb.ndim != 3 or rgb.shape[2] != 3:
            raise ValueError(f"expected an (H, W, 3) RGB image, got shape {rgb.shape}")
        h, w = rgb.shape[:2]
        out = self._session.run(["detections"], {"images": rgb[None].astype(np.float32)})[0][0]
        out[:, [0, 2]] *= w / MODEL_INPUT
        out[:, [1, 3]] *= h / MODEL_INPUT
        return out

    def detect(self, rgb: np.ndarray, iou: float = NMS_IOU) -> list[list]:
        """Detections of an (H, W, 3) uint8 RGB image: rows ``[x1, y1, x2, y2, score, coco_class]`` (pixels as
        floats, score float, class int 0..79) of score ≥ ``min_score``, best first, after class-agnostic NMS at
        ``iou`` (as ``@vladmandic/human`` and ``benchmarks/realism.py`` apply it).

        Raises:
            ValueError: ``rgb`` is not (H, W, 3)."""
        rows = [[float(v) for v in r[:5]] + [int(round(float(r[5])))] for r in self.raw(rgb)
                if r[4] >= self.min_score and np.isfinite(r[5])]
        return nms(rows, iou)
