"""The detector protocol of ``benchmarks/realism.py``'s Python detectors (``detect_tflite.py``, ``detect_darknet.py``),
the same as ``detect.mjs``'s; the installers copy this file beside each of them.

Binary stdin, text stdout, one frame after another:
  stdin:  [uint32 LE height][uint32 LE width][height*width*3 bytes of RGB, row-major]
  stdout: one JSON line per frame: {"detections": [[x1, y1, x2, y2, score, coco_class], ...]}
          boxes in pixels of the frame (x right, y down), coco_class 0..79 (the 80-class COCO order), score >= the
          minimum the child was given, best first.
A first line {"ready": true, ...} says the model is loaded. A height or width of 0, or the end of input, ends it.
"""

from __future__ import annotations

import json
import struct
import sys
from typing import Callable

import numpy as np


def serve(detect: Callable[[np.ndarray], list], ready: dict) -> int:
    """Write ``{"ready": true, **ready}``, then answer each frame of stdin with ``detect`` ((H, W, 3) uint8 RGB →
    rows ``[x1, y1, x2, y2, score, coco80_class]``) until a zero size or the end of input; returns 0. Input that
    ends inside a frame's pixels ends it with one line on stderr and returns 1."""
    out = sys.stdout
    out.write(json.dumps({"ready": True, **ready}) + "\n")
    out.flush()
    inp = sys.stdin.buffer
    while True:
        head = inp.read(8)
        if len(head) < 8:
            return 0
        h, w = struct.unpack("<II", head)
        if h == 0 or w == 0:
            return 0
        data = inp.read(h * w * 3)
        if len(data) < h * w * 3:
            print(f"frame_protocol: the input ended {len(data)} bytes into a {h}x{w} frame of {h * w * 3}",
                  file=sys.stderr, flush=True)
            return 1
        rgb = np.frombuffer(data, np.uint8).reshape(h, w, 3)
        out.write(json.dumps({"detections": detect(rgb)}) + "\n")
        out.flush()
