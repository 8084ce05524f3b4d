"""The 80 MS-COCO detection classes, their BEAR names, and the box geometry a COCO detector's output needs.

One home for what ``benchmarks/realism.py`` (the simulator's realism, judged by a COCO detector) and the
``semslam_detector`` example (a COCO detector's boxes fused into an object map) share.
"""

from __future__ import annotations

#: The 80 COCO classes in the order of a COCO detector's class index (0..79): the 2017 detection classes as
#: ``pycocotools`` lists them with the 11 unused ids dropped (CenterNet's and most detectors' output order).
COCO80 = (
    "person", "bicycle", "car", "motorcycle", "airplane", "bus", "train", "truck", "boat", "traffic light",
    "fire hydrant", "stop sign", "parking meter", "bench", "bird", "cat", "dog", "horse", "sheep", "cow", "elephant",
    "bear", "zebra", "giraffe", "backpack", "umbrella", "handbag", "tie", "suitcase", "frisbee", "skis", "snowboard",
    "sports ball", "kite", "baseball bat", "baseball glove", "skateboard", "surfboard", "tennis racket", "bottle",
    "wine glass", "cup", "fork", "knife", "spoon", "bowl", "banana", "apple", "sandwich", "orange", "broccoli",
    "carrot", "hot dog", "pizza", "donut", "cake", "chair", "couch", "potted plant", "bed", "dining table", "toilet",
    "tv", "laptop", "mouse", "remote", "keyboard", "cell phone", "microwave", "oven", "toaster", "sink",
    "refrigerator", "book", "clock", "vase", "scissors", "teddy bear", "hair drier", "toothbrush",
)
#: COCO names that BEAR spells differently (every other BEAR class is a COCO name).
COCO_TO_BEAR = {"dining table": "table"}
#: IoU above which class-agnostic non-maximum suppression drops the weaker of two boxes (as ``@vladmandic/human``
#: does after its CenterNet).
NMS_IOU = 0.4


def bear_name(coco_class: int) -> str:
    """The BEAR class name of a COCO class index (0..79); COCO names BEAR lacks are returned as they are.

    Raises:
        IndexError: ``coco_class`` is outside 0..79.
    """
    name = COCO80[int(coco_class)]
    return COCO_TO_BEAR.get(name, name)


def box_iou(a, b) -> float:
    """IoU of two boxes ``[x1, y1, x2, y2]`` (pixels, x2 > x1 for a non-empty box); 0 for empty ones."""
    ix = min(a[2], b[2]) - max(a[0], b[0])
    iy = min(a[3], b[3]) - max(a[1], b[1])
    if ix <= 0 or iy <= 0:
        return 0.0
    inter = ix * iy
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return float(inter / union) if union > 0 else 0.0


def nms(detections: list, iou: float = NMS_IOU) -> list:
    """Class-agnostic non-maximum suppression: ``detections`` rows ``[x1, y1, x2, y2, score, class]``, kept best
    score first; a row overlapping a kept one at IoU > ``iou`` is dropped."""
    kept: list = []
    for d in sorted(detections, key=lambda r: -r[4]):
        if all(box_iou(d, k) <= iou for k in kept):
            kept.append(d)
    return kept
