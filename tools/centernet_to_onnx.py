"""Convert the COCO detector of ``benchmarks/realism.py`` (CenterNet, MobileNetV3 backbone, from the npm package
``@vladmandic/human`` 3.3.6, a TF.js graph model) once to ONNX, for the ``semslam_detector`` example.

    uv run --no-project --python 3.11 --with tensorflow==2.19.0 --with tf2onnx==1.17.0 --with onnx==1.22.0 \\
        --with onnxruntime==1.32.0 \\
        python tools/centernet_to_onnx.py \\
        --out plugins/task_semslam/benchbot_task_semslam/models/centernet_mobilenetv3_coco.onnx

Steps: ``npm ci --ignore-scripts`` of ``benchmarks/realism/package-lock.json`` into a temporary folder (or
``--package-dir``, a folder where that was done); the graph model (``models/centernet.json`` + ``.bin``: a TF
GraphDef written as JSON, weights float16-quantised) is read back into a TF GraphDef, its weights decoded to float32
(float16 → float32 is exact), TF.js's fused ops rewritten as the plain TF ops they stand for (``_FusedConv2D`` →
``Conv2D`` + ``BiasAdd`` [+ ``Relu``]; ``FusedDepthwiseConv2dNative`` → ``DepthwiseConv2dNative`` + ``BiasAdd``
[+ ``Relu``]); in front of the model's 512×512 input goes the resize that TF.js applies in
``benchmarks/realism/detect.mjs`` (``ResizeBilinear``, no corner alignment, no half-pixel centres), so that the ONNX
model takes a frame of any size, ``images`` (1, H, W, 3) float32 0..255 RGB, and gives ``detections`` (1, 100, 6):
``x1, y1, x2, y2`` in 512×512 input pixels, score, COCO class index (0..79) as float. tf2onnx converts the graph
(opset 17); float32 initialisers whose values are all exact in float16 are then stored as float16 with a ``Cast``
(lossless: it halves the file). The script checks the ONNX model against TF on a random frame before writing it.

Needs Node.js's npm (for the package) and the four Python packages above (a throwaway environment: none of them
is a dependency of BenchBot). Writes ``--out`` atomically and prints its SHA-256.
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
LOCK_DIR = REPO / "benchmarks" / "realism"
INPUT = 512  # the model's square input
OPSET = 17


def install_package(directory: Path) -> Path:
    """``npm ci --ignore-scripts`` of ``benchmarks/realism``'s lock file into ``directory``; returns the folder of
    the package's models. Raises SystemExit with one line when npm is missing or fails."""
    npm = shutil.which("npm")
    if npm is None:
        sys.exit("npm is not on PATH: install Node.js and npm (Debian: apt-get install nodejs npm)")
    for name in ("package.json", "package-lock.json"):
        shutil.copyfile(LOCK_DIR / name, directory / name)
    proc = subprocess.run([npm, "ci", "--no-audit", "--no-fund", "--ignore-scripts"], cwd=directory,
                          capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        sys.exit(f"npm ci in {directory} failed: {(proc.stderr.strip().splitlines() or ['?'])[-1]}")
    return directory / "node_modules" / "@vladmandic" / "human" / "models"


def decode_weights(manifest: dict, models: Path) -> dict[str, np.ndarray]:
    """The graph model's weights by name (float16-quantised ones decoded to float32), from its ``.bin`` shards."""
    out: dict[str, np.ndarray] = {}
    for group in manifest["weightsManifest"]:
        data = b"".join((models / p).read_bytes() for p in group["paths"])
        offset = 0
        for w in group["weights"]:
            shape = [int(s) for s in w["shape"]]
            count = int(np.prod(shape)) if shape else 1
            q = w.get("quantization")
            dtype = np.dtype(q["dtype"] if q else w["dtype"])
            if q and q["dtype"] != "float16":
                raise SystemExit(f"weight {w['name']}: quantisation {q['dtype']} is not handled")
            arr = np.frombuffer(data, dtype=dtype, count=count, offset=offset).reshape(shape)
            offset += count * dtype.itemsize
            out[w["name"]] = arr.astype(np.float32) if q else arr.copy()
    return out


def build_graph_def(manifest: dict, weights: dict):
    """A TF GraphDef of the model with plain TF ops, a resize in front (input ``images``: (1, H, W, 3) float32) and
    the output renamed ``detections``."""
    import tensorflow as tf
    from google.protobuf import json_format

    nodes = []
    b64 = lambda s: base64.b64encode(s.encode()).decode()  # noqa: E731
    for n in manifest["modelTopology"]["node"]:
        n = json.loads(json.dumps(n))
        n.pop("device", None)
        attr = {k: v for k, v in n.get("attr", {}).items() if not k.startswith("_grappler")}
        n["attr"] = attr
        if n["op"] == "Const" and n["name"] in weights:
            proto = tf.make_tensor_proto(weights[n["name"]])
            attr["value"] = {"tensor": json_format.MessageToDict(proto)}
        if n["op"] == "Placeholder":  # the model's input becomes the resize's output
            n = {"name": n["name"], "op": "ResizeBilinear", "input": ["images", "resize_size"],
                 "attr": {"T": {"type": "DT_FLOAT"}, "align_corners": {"b": False},
                          "half_pixel_centers": {"b": False}}}
            size = tf.make_tensor_proto(np.array([INPUT, INPUT], np.int32))
            nodes.append({"name": "images", "op": "Placeholder", "attr": {
                "dtype": {"type": "DT_FLOAT"},
                "shape": {"shape": {"dim": [{"size": "1"}, {"size": "-1"}, {"size": "-1"}, {"size": "3"}]}}}})
            nodes.append({"name": "resize_size", "op": "Const", "attr": {
                "dtype": {"type": "DT_INT32"}, "value": {"tensor": json_format.MessageToDict(size)}}})
        if n["op"] in ("_FusedConv2D", "FusedDepthwiseConv2dNative"):
            fused = [base64.b64decode(s).decode() for s in attr.pop("fused_ops")["list"]["s"]]
            attr.pop("num_args", None)
            attr.pop("epsilon", None)
            if fused[0] != "BiasAdd" or fused[1:] not in ([], ["Relu"]):
                raise SystemExit(f"node {n['name']}: fused ops {fused} are not handled")
            conv_op = "Conv2D" if n["op"] == "_FusedConv2D" else "DepthwiseConv2dNative"
            if conv_op == "DepthwiseConv2dNative":
                attr.pop("use_cudnn_on_gpu", None)
            x, w, bias = n["input"]
            name = n["name"]
            nodes.append({"name": name + "/conv", "op": conv_op, "input": [x, w], "attr": attr})
            bias_name = name if len(fused) == 1 else name + "/bias"
            nodes.append({"name": bias_name, "op": "BiasAdd", "input": [name + "/conv", bias],
                          "attr": {"T": {"type": "DT_FLOAT"}, "data_format": {"s": b64("NHWC")}}})
            if len(fused) == 2:
                nodes.append({"name": name, "op": "Relu", "input": [bias_name], "attr": {"T": {"type": "DT_FLOAT"}}})
            continue
        nodes.append(n)
    nodes.append({"name": "detections", "op": "Identity", "input": ["tower_0/detections"],
                  "attr": {"T": {"type": "DT_FLOAT"}}})
    return json_format.ParseDict({"node": nodes}, tf.compat.v1.GraphDef())


def to_float16_initialisers(model) -> int:
    """Store every float32 initialiser of ≥ 64 values that float16 holds exactly as float16 plus a ``Cast``
    (lossless); returns how many were changed."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    changed = 0
    casts = []
    for init in list(model.graph.initializer):
        if init.data_type != TensorProto.FLOAT:
            continue
        arr = numpy_helper.to_array(init)
        if arr.size < 64 or not np.array_equal(arr.astype(np.float16).astype(np.float32), arr):
            continue
        name = init.name
        init.CopyFrom(numpy_helper.from_array(arr.astype(np.float16), name + "_f16"))
        casts.append(helper.make_node("Cast", [name + "_f16"], [name], to=TensorProto.FLOAT, name=name + "_cast"))
        changed += 1
    for i, node in enumerate(casts):
        model.graph.node.insert(i, node)
    onnx.checker.check_model(model)
    return changed


def convert(models: Path, out: Path) -> str:
    """Convert ``models/centernet.json`` to ONNX at ``out``; returns its SHA-256 (hex)."""
    import onnx
    import onnxruntime as ort
    import tensorflow as tf
    import tf2onnx

    manifest = json.loads((models / "centernet.json").read_text())
    graph_def = build_graph_def(manifest, decode_weights(manifest, models))
    model_proto, _ = tf2onnx.convert.from_graph_def(graph_def, input_names=["images:0"],
                                                    output_names=["detections:0"], opset=OPSET)
    # plain names for the ONNX input and output
    for coll in (model_proto.graph.input, model_proto.graph.output):
        for v in coll:
            plain = v.name.split(":")[0]
            for node in model_proto.graph.node:
                node.input[:] = [plain if i == v.name else i for i in node.input]
                node.output[:] = [plain if o == v.name else o for o in node.output]
            v.name = plain
    n16 = to_float16_initialisers(model_proto)
    model_proto.producer_name = "benchbot tools/centernet_to_onnx.py"
    model_proto.doc_string = ("CenterNet (MobileNetV3 backbone, MS-COCO) from the npm package @vladmandic/human 3.3.6 "
                              "(models/centernet.json, MIT); input images (1,H,W,3) float32 RGB 0..255, output "
                              "detections (1,100,6) x1,y1,x2,y2 (512x512 input pixels), score, COCO class")
    # check against TF on a random frame
    rng = np.random.default_rng(0)
    frame = rng.uniform(0, 255, (1, 300, 400, 3)).astype(np.float32)
    graph = tf.Graph()
    with graph.as_default():
        tf.import_graph_def(graph_def, name="")
    with tf.compat.v1.Session(graph=graph) as sess:
        ref = sess.run("detections:0", {"images:0": frame})
    sess = ort.InferenceSession(model_proto.SerializeToString(), providers=["CPUExecutionProvider"])
    got = sess.run(["detections"], {"images": frame})[0]
    top = ref[0, :, 4] >= 0.05
    err = float(np.abs(got[0, top] - ref[0, top]).max()) if top.any() else 0.0
    print(f"{n16} initialisers stored as float16; ONNX vs TF on a random 400x300 frame: {int(top.sum())} "
          f"detections of score >= 0.05, max abs difference {err:.2e}")
    if err > 1e-2:
        raise SystemExit(f"ONNX model differs from TF by {err}")
    tmp = out.with_name(out.name + ".tmp")
    onnx.save(model_proto, str(tmp))
    os.replace(tmp, out)
    return hashlib.sha256(out.read_bytes()).hexdigest()


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, required=True, help="the ONNX file to write")
    p.add_argument("--package-dir", type=Path, help="a folder where `npm ci` of benchmarks/realism was run")
    args = p.parse_args(argv)
    if args.package_dir:
        models = args.package_dir / "node_modules" / "@vladmandic" / "human" / "models"
        if not (models / "centernet.json").is_file():
            sys.exit(f"--package-dir {args.package_dir}: no node_modules/@vladmandic/human/models/centernet.json")
        digest = convert(models, args.out)
    else:
        with tempfile.TemporaryDirectory(prefix="centernet-npm-") as tmp:
            digest = convert(install_package(Path(tmp)), args.out)
    print(f"wrote {args.out} ({args.out.stat().st_size} bytes, sha256 {digest})")


if __name__ == "__main__":
    main()
