"""Realism of the Taichi simulator's images, judged two ways on the same frames: a COCO detector trained on real
photos, and a physically based reference renderer (Blender Cycles) on the same exported scene.

    python benchmarks/realism.py [--env miniroom:1 --env house:1 | --all-homes] [--frames 16] [--quality-frames 4]
        [--reference-frames 1] [--reference-spp 64] [--ladder 1,4,16] [--style furnished|primitives]
        [--seed 0] [--out runs/realism] [--arch cpu|cuda] [--real-reference]

Per environment (``--all-homes``: the ten BEAR homes) it builds the world an episode run with ``--seed`` sees (world
seed ``benchbot.core.seeding.world_seed(seed, name, variant)``, through the scene cache as the simulator loads it),
renders ``--frames`` camera frames spread evenly along the trajectory (``--every K``: every K-th pose instead) in
``fast`` mode (``--with-class CLS``: keeping only those in which a CLS object is visible), the first
``--quality-frames`` of them also in ``quality`` mode, through the robot's default camera (``DEFAULT_SENSORS``:
intrinsics, mount; ``backend.camera_model()``: exposure, tone curve), and:

- **Detector.** CenterNet (MobileNetV3 backbone, trained on MS-COCO photos) from the npm package ``@vladmandic/human``
  3.3.6, run by TF.js on WebAssembly through Node.js (``benchmarks/realism/detect.mjs``; installed with ``npm ci``
  from ``benchmarks/realism/package-lock.json`` into ``--detector-dir``, nothing downloaded from a model hub);
  ``--detector nanodet``, ``ssd`` (SSD MobileNetV2, LiteRT, ``detect_tflite.py``) or ``yolo`` (YOLOv4-tiny, ONNX
  Runtime, ``detect_darknet.py``) instead, each fetched once from a registry package (:mod:`realism_detectors`,
  beside this file). A ground-truth object is *visible* in a frame when its instance mask has at least
  ``--min-pixels`` pixels and at least ``1 − --max-truncation`` of its cuboid projects inside the image; its box
  is the mask's bounding box (a sink's: of its basin, the mask within ``SINK_BASIN_M`` under its cuboid's top, as COCO
  boxes sinks). Detections (class-agnostic NMS at IoU 0.4, as the package itself applies) of score ≥ each threshold
  are matched greedily, best score first, to boxes of the same class (COCO names mapped to BEAR's: ``dining table`` →
  ``table``) at IoU ≥ ``--iou``. Per class: visible objects, objects detected; per frame: false positives (detections
  matching no object, visible or not; those matching an object too small or truncated are ignored). ``localised``
  counts visible objects hit by a box of any class. Beside the plain counts, the column ``fast, crowd rule`` counts
  the fast frames under COCO's ``iscrowd`` rule: a ground-truth box that BEAR marks ``isgroup`` (one cuboid for a row
  or a stack of books) is neither visible nor missed, and a detection of its class lying mostly inside it
  (intersection over the detection's area ≥ ``--iou``) is no false positive (``with_crowd_rule``); the same rule for
  every detector.
- **Reference.** The first ``--reference-frames`` frames are rendered by Blender Cycles (``bpy``, in its own
  environment: ``uv run --no-project --python 3.11 --with bpy==5.0.1``) from the scene exported by
  ``benchbot_worlds.scene.export.export_scene`` (glTF, PBR materials with their textures, shading normals), the
  same camera (intrinsics and pose) and the same lights (sun, lamps, ambient as a sky), path traced at
  ``--reference-spp`` samples per pixel with no denoiser, and at each ``--ladder`` count (timed: Cycles' time to a
  given error). Images are encoded as ours are (the robot's camera model: exposure, tone curve, gamma 2.2, 8 bits);
  PSNR (dB) and SSIM (luma, 11×11 Gaussian window, σ 1.5) of ours fast and quality against the reference, also
  with the reference's exposure matched to ours (``exposure_gain``, one scalar), and of each ladder rung (``cycles_s_to_same_psnr``: Cycles'
  time to our error, interpolated); ``reference_psnr_est_db`` estimates the reference's own noise from its largest
  rung (the rung's MSE against it is σ²/s + σ²/S for s and S samples). The detector also runs on the reference
  frames. Side-by-side PNGs: ours fast | ours quality | reference.

``--supersample N`` renders the fast frames as a camera with ``sensors.camera.samples_per_pixel`` N² sees them
(:mod:`benchbot_sim_taichi.render.pixel_integration`: an N × N grid of sub-pixels averaged in linear radiance, as a
sensor's pixel integrates the light on its area); the objects, masks and boxes are the pixel centres', as always. It
says what aliasing costs the detector; the default robot's camera has 1 sample a pixel.

``--real-reference`` runs the same detector, with the same settings, on the real photos of ``--real-photos`` (784
COCO val2017 photos shipped in ``benchmarks/realism/photos``, not in the detectors' training set) and prints per
BEAR class the sim's recall (fast frames, COCO's crowd rule), the photos' recall weighted to the sim's pixel-size
mix, their ratio, each with a bootstrap interval over images, and the objects on each side
(:mod:`realism_real`); with ``--quality-frames``, two more tables: the frames rendered in quality mode, in quality
mode and in fast mode, against the same photos. ``realism.json``'s ``real_reference`` has it all and each photo's
detections. Each table ends with the goal's verdict for its detector (:func:`realism_real.goal`); ``--verdict
RUN/realism.json ...`` prints it again from finished runs and renders nothing.

Writes ``<out>/realism.json``, ``<out>/per_class.md`` (the per-class tables it prints: all environments, then
each one; then, fast mode, found / visible per class and model, the model being the scene's ``box_models``) and
PNGs (annotated frames: green = detected visible object, red = missed visible object, grey = ignored object,
yellow = detection, with class and score). Exit code 2
with one line on bad flags or a missing tool (Node.js/npm, uv). ``--smoke``: miniroom:4, two 32×24 frames (one also
in quality mode at 1 spp), written under the system's temporary folder, without the two tools that ``uv sync`` does
not install: no detector, and the reference's scene exported and its job written but not rendered by Cycles.
Limits: the module constants below (``--help``). Re-run it after the simulator changes: it renders whatever
``build_scene`` builds (``--style`` sets ``environment['style']`` for simulators that read it).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:  # run as a script it is; loaded by path (tests/test_realism.py), not
    sys.path.append(str(HERE))
import smoke  # noqa: E402 - benchmarks/smoke.py, beside this file

from benchbot.core import atomic  # noqa: E402
from benchbot_task_semslam.coco import COCO80, COCO_TO_BEAR, NMS_IOU, bear_name, box_iou, nms  # noqa: E402, F401
from realism_counting import (MATCH_IOU, MAX_TRUNCATION, MIN_PIXELS, FrameScore, Truth, crowd_instances,  # noqa: E402
                              frame_truths, score_frame, with_crowd_rule)
from realism_detectors import (DETECTOR_SOURCES, DETECTOR_THRESHOLDS, DETECTOR_TIMEOUT_S,  # noqa: E402
                               DETECTORS, SCORE_THRESHOLDS, Detector, RealismError, control_check,
                               install_detector, install_nanodet, install_ssd, install_yolo, require_tool)
ASSETS = HERE / "realism"

#: Environments judged by default.
DEFAULT_ENVS = ("miniroom:1", "house:1")
#: Frames per environment (spread evenly along its trajectory), and how many of them are also rendered in quality
#: mode and by the reference renderer. ``--frames``, ``--quality-frames``, ``--reference-frames``.
FRAMES_PER_ENV = 16
QUALITY_FRAMES_PER_ENV = 4
REFERENCE_FRAMES_PER_ENV = 1
#: Samples per pixel of our quality mode (``--quality-spp``; the renderer's default).
QUALITY_SPP = 16
#: Cycles: samples per pixel of the converged reference (``--reference-spp``), the timed lower counts
#: (``--ladder``), the bpy requirement (``--bpy``), the time allowed for one reference job (``--reference-timeout``).
REFERENCE_SPP = 64
REFERENCE_LADDER = (1, 4, 16)
BPY_REQUIREMENT = "bpy==5.0.1"
REFERENCE_TIMEOUT_S = 3600
#: Annotated PNGs written per environment and mode (``--pngs``).
PNGS_PER_ENV = 3
#: ``--supersample`` at most (4: a 640 × 480 frame is shaded at 2560 × 1920).
MAX_SUPERSAMPLE = 4


# ---------------------------------------------------------------------------------------------------- image metrics
def _gauss_blur(img: np.ndarray, sigma: float = 1.5, radius: int = 5) -> np.ndarray:
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    k = np.exp(-0.5 * (x / sigma) ** 2)
    k /= k.sum()
    out = img.astype(np.float64)
    for axis in (0, 1):
        pad = [(0, 0)] * out.ndim
        pad[axis] = (radius, radius)
        p = np.pad(out, pad, mode="reflect")
        acc = np.zeros_like(out)
        for i, w in enumerate(k):
            sl = [slice(None)] * out.ndim
            sl[axis] = slice(i, i + out.shape[axis])
            acc += w * p[tuple(sl)]
        out = acc
    return out


def luma(rgb: np.ndarray) -> np.ndarray:
    """Rec. 601 luma (H, W) float64 0..255 of an (H, W, 3) uint8 image."""
    return rgb.astype(np.float64) @ np.array([0.299, 0.587, 0.114])


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR (dB) between two uint8 images of one shape (all channels); ``inf`` when equal."""
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return math.inf if mse == 0 else 10.0 * math.log10(255.0 ** 2 / mse)


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Mean SSIM of the luma of two (H, W, 3) uint8 images (Gaussian window σ 1.5, K1 0.01, K2 0.03, L 255)."""
    x, y = luma(a), luma(b)
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2
    mx, my = _gauss_blur(x), _gauss_blur(y)
    sxx = _gauss_blur(x * x) - mx * mx
    syy = _gauss_blur(y * y) - my * my
    sxy = _gauss_blur(x * y) - mx * my
    s = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
    return float(s.mean())


def encode_like_ours(linear: np.ndarray, camera=None) -> np.ndarray:
    """(H, W, 3) uint8 of linear radiance, encoded as our renderer encodes it: through ``camera`` (a
    ``CameraModel``, e.g. :func:`camera_model`: exposure, tone curve, vignetting, gamma), else the plain one: clamp to
    [0, 1], ``x^(1/2.2)``, 8 bits (``benchbot_sim_taichi.render.camera_model.GAMMA``)."""
    from benchbot_sim_taichi.render.camera_model import GAMMA

    if camera is not None:
        return camera.encode(linear, camera_setup(linear.shape[1], linear.shape[0])[0])
    return np.floor(np.power(np.clip(linear, 0.0, 1.0), GAMMA) * 255.0 + 0.5).astype(np.uint8)


def exposure_gain(ours: np.ndarray, reference_linear: np.ndarray) -> float:
    """The scalar g for which ``g · reference_linear`` has the linear radiance of ``ours`` ((H, W, 3) uint8, decoded
    with our gamma) summed over the pixels ours has not clipped (all channels < 250): a camera's exposure, so that
    PSNR/SSIM can also be read with the overall brightness factored out. 1 when nothing is left to compare."""
    decoded = np.power(ours.astype(np.float64) / 255.0, 2.2)
    keep = ours.max(axis=2) < 250
    den = float(np.asarray(reference_linear, np.float64)[keep].sum())
    return float(decoded[keep].sum() / den) if den > 1e-12 else 1.0


# -------------------------------------------------------------------------------------------------------- reference
#: map (x, y, z; z up) → glTF (x, y, z; +Y up): (x, z, −y); Blender's importer maps it back.
MAP_TO_GLTF = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0, -1.0, 0, 0], [0, 0, 0, 1.0]])


def _flat_material(linear_rgb, name: str):
    import trimesh

    rgba = np.concatenate([np.clip(np.asarray(linear_rgb, dtype=np.float64), 0, 1), [1.0]])
    return trimesh.visual.material.PBRMaterial(name=name, baseColorFactor=rgba, metallicFactor=0.0,
                                               roughnessFactor=1.0, doubleSided=True)


def _shell_meshes(scene) -> list:
    """The room shell (floor tiled as our renderer tiles it, walls, ceiling) as named flat-coloured meshes."""
    import trimesh

    lo, hi = np.asarray(scene.room_min, np.float64), np.asarray(scene.room_max, np.float64)
    alb = np.asarray(scene.shell_albedo, np.float64)
    try:
        from benchbot_sim_taichi.render.kernels import TILE_CONTRAST, TILE_M
    except ImportError:
        TILE_M, TILE_CONTRAST = 1.0, 0.0
    edges = [np.unique(np.concatenate([[lo[k]], np.arange(math.ceil(lo[k] / TILE_M), math.floor(hi[k] / TILE_M) + 1)
                                       * TILE_M, [hi[k]]])) for k in (0, 1)]
    tiles = {0: [], 1: []}
    for i in range(len(edges[0]) - 1):
        for j in range(len(edges[1]) - 1):
            x0, x1, y0, y1 = edges[0][i], edges[0][i + 1], edges[1][j], edges[1][j + 1]
            if x1 - x0 < 1e-6 or y1 - y0 < 1e-6:
                continue
            parity = (math.floor((x0 + x1) / 2 / TILE_M) + math.floor((y0 + y1) / 2 / TILE_M)) & 1
            tiles[parity].append([[x0, y0, lo[2]], [x1, y0, lo[2]], [x1, y1, lo[2]], [x0, y1, lo[2]]])
    out = []
    for parity, quads in tiles.items():
        if quads:
            v = np.asarray(quads, dtype=np.float64).reshape(-1, 3)
            f = np.array([[4 * q, 4 * q + 1, 4 * q + 2] for q in range(len(quads))]
                         + [[4 * q, 4 * q + 2, 4 * q + 3] for q in range(len(quads))])
            m = trimesh.Trimesh(v, f, process=False)
            m.visual = trimesh.visual.TextureVisuals(
                material=_flat_material(alb[0] * (1.0 + TILE_CONTRAST * (2.0 * parity - 1.0)), f"floor{parity}"))
            out.append((f"shell_floor{parity}", m))
    box = trimesh.creation.box(bounds=np.stack([lo, hi]))
    box.invert()
    cz = box.triangles_center[:, 2]
    for name, sel, a in (("shell_walls", (cz > lo[2] + 1e-6) & (cz < hi[2] - 1e-6), alb[1]),
                         ("shell_ceiling", cz >= hi[2] - 1e-6, alb[2])):
        m = box.submesh([np.nonzero(sel)[0]], append=True)
        m.visual = trimesh.visual.TextureVisuals(material=_flat_material(a, name))
        out.append((name, m))
    return out


def export_reference_glb(scene, path: Path, *, shell: bool = True) -> dict:
    """Write the scene as glTF binary (+Y up) for the reference renderer: ``export.export_scene(scene, shell=False)``
    (PBR materials with their textures, vertex normals, UVs) plus, with ``shell``, the room shell as nodes
    ``shell_*`` (the floor tiled as our renderer tiles it, which the export leaves out).

    Returns:
        ``{'triangles': int, 'meshes': int, 'textured_meshes': int}``.
    """
    from benchbot_worlds.scene.export import export_scene

    exported = export_scene(scene, path, shell=False)  # in glTF coordinates
    for name, mesh in _shell_meshes(scene) if shell else []:
        m = mesh.copy()
        m.apply_transform(MAP_TO_GLTF)
        exported.add_geometry(m, node_name=name, geom_name=name)
    path.write_bytes(exported.export(file_type="glb"))
    geoms = list(exported.geometry.values())
    textured = sum(1 for g in geoms if getattr(getattr(g.visual, "material", None), "baseColorTexture", None)
                   is not None)
    return {"triangles": int(sum(len(g.faces) for g in geoms)), "meshes": len(geoms), "textured_meshes": textured}


def seconds_to_reach(ladder: dict, target_db: float) -> dict:
    """Cycles' time to reach ``target_db`` PSNR against the reference, from the ladder (``{spp: {seconds,
    psnr_db}}``): interpolated linearly in PSNR between the rungs around it → ``{'seconds': s, 'bound': '='}``; below
    the lowest rung ``{'seconds': that rung's, 'bound': '<'}``, above the highest ``'>'``; ``{}`` without rungs."""
    rungs = sorted((int(k), v["seconds"], v["psnr_db"]) for k, v in ladder.items())
    if not rungs:
        return {}
    if target_db <= rungs[0][2]:
        return {"seconds": rungs[0][1], "bound": "<"}
    for (_, s0, p0), (_, s1, p1) in itertools.pairwise(rungs):
        if p0 <= target_db <= p1:
            f = (target_db - p0) / (p1 - p0) if p1 > p0 else 1.0
            return {"seconds": s0 + f * (s1 - s0), "bound": "="}
    return {"seconds": rungs[-1][1], "bound": ">"}


def blender_camera(K: np.ndarray, T_map_camera: np.ndarray, width: int, height: int,
                   sensor_mm: float = 36.0) -> dict:
    """Blender camera settings of a pinhole camera: ``K`` (3, 3) pixels (square pixels; principal point anywhere),
    ``T_map_camera`` (4, 4) its OPTICAL frame (z forward, x right, y down) in the map (= Blender world) frame.
    Returns ``{width, height, lens_mm, sensor_mm, shift_x, shift_y, matrix_world}`` (Blender cameras look down −z
    with +y up, a horizontal sensor fit, shifts in units of the width)."""
    M = np.asarray(T_map_camera, dtype=np.float64) @ np.diag([1.0, -1.0, -1.0, 1.0])
    return {"width": int(width), "height": int(height), "sensor_mm": sensor_mm,
            "lens_mm": float(K[0, 0]) * sensor_mm / width,
            "shift_x": -(float(K[0, 2]) - (width - 1) / 2.0) / width,
            "shift_y": (float(K[1, 2]) - (height - 1) / 2.0) / width,
            "matrix_world": M.tolist()}


def reference_lights(scene) -> dict:
    """The scene's lights for the reference: ``ambient`` (3,), ``suns`` and ``points`` (see
    ``benchmarks/realism/cycles_reference.py``), with the sun's angular radius and the lamps' radius of our
    renderer's soft shadows."""
    from benchbot_sim_taichi.render.kernels import LAMP_RADIUS, SUN_RADIUS
    from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL

    suns, points = [], []
    for kind, vec, col in zip(np.asarray(scene.light_kind).tolist(), np.asarray(scene.light_vec, np.float64),
                              np.asarray(scene.light_colour, np.float64)):
        if kind == LIGHT_DIRECTIONAL:
            suns.append({"direction": (vec / np.linalg.norm(vec)).tolist(), "colour": col.tolist(),
                         "angle_rad": 2.0 * SUN_RADIUS})
        else:
            points.append({"position": vec.tolist(), "colour": col.tolist(), "radius": LAMP_RADIUS})
    return {"ambient": np.asarray(scene.ambient, np.float64).tolist(), "suns": suns, "points": points}


def run_cycles(job: dict, job_path: Path, bpy_requirement: str = BPY_REQUIREMENT,
               timeout_s: float = REFERENCE_TIMEOUT_S) -> dict:
    """Run ``benchmarks/realism/cycles_reference.py`` on ``job`` (written to ``job_path``) in an environment with
    ``bpy`` (``uv run --no-project --python 3.11 --with <bpy_requirement>``); returns its ``timings.json``.

    Raises:
        RealismError: uv is missing, the render fails or takes longer than ``timeout_s``.
    """
    uv = require_tool("uv", "install uv (https://docs.astral.sh/uv/), or pass --reference-frames 0")
    job_path.write_text(json.dumps(job))
    cmd = [uv, "run", "--no-project", "--python", "3.11", "--with", bpy_requirement, "python",
           str(ASSETS / "cycles_reference.py"), str(job_path)]
    log = Path(job["out_dir"]) / "cycles.log"
    with open(log, "w") as f:
        try:
            proc = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, timeout=timeout_s, check=False)
        except subprocess.TimeoutExpired:
            raise RealismError(f"the Cycles reference took more than {timeout_s:.0f} s",
                               "lower --reference-spp or --reference-frames, or raise --reference-timeout") from None
    if proc.returncode != 0:
        raise RealismError(f"the Cycles reference failed (exit {proc.returncode})", f"see {log}")
    return json.loads((Path(job["out_dir"]) / "timings.json").read_text())


# -------------------------------------------------------------------------------------------------------- drawing
def annotate(rgb: np.ndarray, truths: list[Truth], detections: list, score: FrameScore, threshold: float,
             title: str = ""):
    """A PIL image of ``rgb`` with the objects' mask boxes (green: detected, red: missed, grey: not counted) and
    the detections of score ≥ ``threshold`` (yellow, ``class score``)."""
    from PIL import Image, ImageDraw

    img = Image.fromarray(rgb)
    d = ImageDraw.Draw(img)
    for t in truths:
        colour = (140, 140, 140) if not t.visible else (40, 220, 40) if score.hits.get(t.instance) else (230, 40, 40)
        d.rectangle([t.box[0], t.box[1], t.box[2] - 1, t.box[3] - 1], outline=colour, width=2)
        d.text((t.box[0] + 3, t.box[3] - 13), t.cls, fill=colour)
    for det in detections:
        if det[4] >= threshold:
            d.rectangle(det[:4], outline=(250, 220, 0), width=1)
            d.text((det[0] + 2, det[1] + 1), f"{COCO80[det[5]]} {det[4]:.2f}", fill=(250, 220, 0))
    if title:
        d.text((4, 4), title, fill=(255, 255, 255))
    return img


def side_by_side(images: list, labels: list):
    """The images (each (H, W, 3) uint8, one size) in a row, labelled at the top left."""
    from PIL import Image, ImageDraw

    h, w = images[0].shape[:2]
    canvas = Image.new("RGB", (w * len(images), h))
    d = ImageDraw.Draw(canvas)
    for k, (img, label) in enumerate(zip(images, labels)):
        canvas.paste(Image.fromarray(img), (k * w, 0))
        d.text((k * w + 4, 4), label, fill=(255, 255, 255))
    return canvas


# -------------------------------------------------------------------------------------------------------- running
def select_frames(n_poses: int, frames: int, every: int | None = None) -> list[int]:
    """Pose indices: every ``every``-th pose, else ``frames`` indices spread evenly over ``n_poses`` (all of them
    when there are fewer)."""
    if n_poses <= 0:
        return []
    if every:
        return list(range(0, n_poses, every))
    if frames >= n_poses:
        return list(range(n_poses))
    return sorted({round(i * (n_poses - 1) / max(frames - 1, 1)) for i in range(frames)})


def camera_setup(width: int, height: int):
    """(K, T_robot_camera) of the robot's default camera (``DEFAULT_SENSORS``) at ``width`` × ``height``."""
    from benchbot_sim_taichi.backend import DEFAULT_SENSORS, camera_mount
    from benchbot_sim_taichi.render.renderer import intrinsics

    cam = DEFAULT_SENSORS["camera"]
    return intrinsics(width, height, float(cam["horizontal_fov_deg"])), camera_mount(cam)


def camera_model():
    """The robot's default camera model (``DEFAULT_SENSORS``: exposure, tone curve, vignetting), as the simulator
    gives it to a solution."""
    from benchbot_sim_taichi.backend import camera_model as default_camera_model

    return default_camera_model()


#: The fast frames' counts under COCO's crowd rule (:func:`with_crowd_rule`), a column beside the plain ones.
CROWD_SOURCE = "fast, crowd rule"
#: The image sources counted, in the tables' column order.
SOURCES = ("fast", CROWD_SOURCE, "quality", "reference")

#: How the per-model counts name an object drawn by its primitive model (``Truth.model`` ``""``).
PRIMITIVE_MODEL = "(primitive)"


class Tally:
    """Per-class and per-model counts over frames for one image source (fast, quality, reference) at each
    threshold. Objects are counted under ``(class, model)`` (:attr:`Truth.model`, :data:`PRIMITIVE_MODEL` for
    ``""``); the per-class counts :attr:`visible` and :attr:`detected` are their sums."""

    def __init__(self, thresholds) -> None:
        self.thresholds = tuple(thresholds)
        self.visible_models: Counter[tuple[str, str]] = Counter()
        self.detected_models: dict[float, Counter[tuple[str, str]]] = {t: Counter() for t in self.thresholds}
        self.localised: dict[float, Counter[str]] = {t: Counter() for t in self.thresholds}
        self.fp = {t: 0 for t in self.thresholds}
        self.fp_classes: dict[float, Counter[str]] = {t: Counter() for t in self.thresholds}
        self.frames = 0

    @staticmethod
    def _per_class(by_model: Counter) -> Counter:
        out: Counter[str] = Counter()
        for (cls, _model), n in by_model.items():
            out[cls] += n
        return out

    @property
    def visible(self) -> Counter:
        """Visible objects per class."""
        return self._per_class(self.visible_models)

    @property
    def detected(self) -> dict:
        """{threshold: objects detected per class}."""
        return {thr: self._per_class(d) for thr, d in self.detected_models.items()}

    def add(self, truths: list[Truth], scores: dict) -> None:
        """Count one frame: its truths and its :class:`FrameScore` per threshold."""
        self.frames += 1
        key_of = {t.instance: (t.cls, t.model or PRIMITIVE_MODEL) for t in truths}
        self.visible_models.update(key_of[t.instance] for t in truths if t.visible)
        for thr, s in scores.items():
            for iid, hit in s.hits.items():
                self.detected_models[thr][key_of[iid]] += int(hit)
            for iid, hit in s.localised.items():
                self.localised[thr][key_of[iid][0]] += int(hit)
            self.fp[thr] += len(s.false_positives)
            self.fp_classes[thr].update(COCO80[d[5]] for d in s.false_positives)

    def merge(self, other: Tally) -> None:
        """Add another tally's counts (same thresholds)."""
        self.frames += other.frames
        self.visible_models.update(other.visible_models)
        for thr in self.thresholds:
            self.detected_models[thr].update(other.detected_models[thr])
            self.localised[thr].update(other.localised[thr])
            self.fp_classes[thr].update(other.fp_classes[thr])
            self.fp[thr] += other.fp[thr]

    def as_dict(self) -> dict:
        """JSON-ready: frames, visible per class (and per class and model, keys ``"<class> <model>"``), and per
        threshold detected/localised per class (detected also per class and model), recall, false positives per
        frame and their COCO classes."""
        visible = self.visible
        vis = sum(visible.values())
        out = {"frames": self.frames, "visible": dict(sorted(visible.items())), "visible_total": vis,
               "visible_by_model": _by_model_json(self.visible_models)}
        for thr, detected in self.detected.items():
            det = sum(detected.values())
            out[f"score>={thr}"] = {
                "detected": dict(sorted(detected.items())), "detected_total": det,
                "detected_by_model": _by_model_json(self.detected_models[thr]),
                "recall": det / vis if vis else None,
                "localised_total": sum(self.localised[thr].values()),
                "false_positives_per_frame": self.fp[thr] / self.frames if self.frames else None,
                "false_positive_classes": dict(sorted(self.fp_classes[thr].items(), key=lambda kv: -kv[1])),
            }
        return out


def _by_model_json(counts: Counter) -> dict:
    """``{"<class> <model>": n}``, sorted, of counts keyed by ``(class, model)``."""
    return {f"{cls} {model}": n for (cls, model), n in sorted(counts.items())}


def all_homes() -> list[str]:
    """``name:variant`` of every BEAR home the simulator ships (miniroom:1..5, then house:1..5)."""
    from benchbot_worlds import bear

    names = [(e["name"], int(e["variant"])) for e in bear.environment_specs()]
    return [f"{n}:{v}" for n, v in sorted(names, key=lambda nv: (nv[0] != "miniroom", nv))]


def _env_spec(name: str, style: str | None) -> dict:
    """The environment spec of ``name``: any registered one, generated homes too (``procedural_val_3:1``)."""
    from benchbot.core.errors import BenchbotError
    from benchbot.core.registry import get_registry

    try:
        (spec,) = get_registry().scenes(name)
    except (BenchbotError, ValueError) as e:
        raise RealismError(f"unknown environment {name!r}", "give one name:variant (benchbot list environments)") from e
    env = dict(spec)
    if style:
        env["style"] = style
    return env


def shows_class(truths: list[Truth], cls: str | None) -> bool:
    """Whether a frame's ``truths`` hold a visible object of class ``cls`` (always, when ``cls`` is None): the frames
    ``--with-class`` keeps."""
    return cls is None or any(t.visible and t.cls == cls for t in truths)


def judge_environment(name: str, args, detector: Detector | None, out_dir: Path, thresholds) -> dict:
    """Render, detect, compare for one environment; returns its JSON section and fills PNGs under ``out_dir``."""
    env = _env_spec(name, args.style)
    from benchbot_sim_taichi.render.renderer import Renderer
    from benchbot_sim_taichi import scene_cache
    from benchbot_worlds.scene.build import build_scene

    from benchbot.core.geometry import se2_to_matrix
    from benchbot.core.seeding import environment_world_seed

    world = environment_world_seed(args.seed, env)  # the world an episode run with --seed sees
    t0 = time.perf_counter()
    scene, key = scene_cache.scene_for(env, world, build=build_scene)  # as the simulator loads it
    build_s = time.perf_counter() - t0
    W, H = args.width, args.height
    K, Tc = camera_setup(W, H)
    poses = scene.trajectory_se2 if len(scene.trajectory_se2) else scene.start_se2[None]
    idx = select_frames(len(poses), args.frames, args.every)
    t0 = time.perf_counter()
    r = Renderer(args.arch, seed=world, camera=camera_model())
    scene_cache.set_scene(r, scene, key)
    setup_s = time.perf_counter() - t0
    env_dir = out_dir / name.replace(":", "_")
    env_dir.mkdir(parents=True, exist_ok=True)
    modes = {m: Tally(thresholds) for m in SOURCES}
    crowd = crowd_instances(scene, env)
    times = {"fast": [], "quality": []}
    frames_json, images, kept = [], {}, []
    compiled = set()

    def timed_render(mode: str, T: np.ndarray) -> dict:
        if mode not in compiled:  # compile the mode's kernels outside the timing (they do not depend on the size)
            r.render(camera_setup(8, 8)[0], T, 8, 8, mode=mode, spp=args.quality_spp,
                     samples_per_pixel=args.supersample ** 2)
            compiled.add(mode)
        t1 = time.perf_counter()
        out = r.render(K, T, W, H, mode=mode, spp=args.quality_spp, samples_per_pixel=args.supersample ** 2)
        times[mode].append(time.perf_counter() - t1)
        return out

    for i in idx:
        n = len(kept)  # the frame's number among those kept
        T = se2_to_matrix(*poses[i]) @ Tc
        outs = {"fast": timed_render("fast", T)}
        truths = frame_truths(outs["fast"]["instance"], scene, K, T, args.min_pixels, args.max_truncation, crowd,
                              depth=outs["fast"]["depth"])
        if not shows_class(truths, args.with_class):  # left out: no quality frame, no detector, no PNG
            continue
        if n < args.quality_frames:
            outs["quality"] = timed_render("quality", T)
        kept.append(i)
        fj = {"pose_index": i, "objects": [t.__dict__ for t in truths]}
        images[n] = {"T": T, "pose_index": i, "truths": truths, **{m: o["rgb"] for m, o in outs.items()}}
        if detector is not None:
            for mode, o in outs.items():
                dets = detector.detect(o["rgb"])
                scores = {thr: score_frame(truths, dets, thr, args.iou) for thr in thresholds}
                modes[mode].add(truths, scores)
                if mode == "fast":  # beside the plain figure: BEAR's group boxes as COCO's crowd regions
                    as_crowd = with_crowd_rule(truths)
                    modes[CROWD_SOURCE].add(as_crowd, {thr: score_frame(as_crowd, dets, thr, args.iou, crowd_rule=True)
                                                       for thr in thresholds})
                fj[f"detections_{mode}"] = dets
                images[n][f"dets_{mode}"] = (dets, scores)
                if n < args.pngs:
                    annotate(o["rgb"], truths, dets, scores[thresholds[0]], thresholds[0],
                             f"{name} pose {i} {mode}").save(env_dir / f"pose{i:03d}_{mode}.png")
        elif n < args.pngs:
            for mode, o in outs.items():
                from PIL import Image
                Image.fromarray(o["rgb"]).save(env_dir / f"pose{i:03d}_{mode}.png")
        frames_json.append(fj)
    section = {"style": scene.style, "world_seed": world, "lighting": scene.lighting, "poses": len(poses),
               "pose_indices": kept, "with_class": args.with_class,
               "build_scene_s": build_s, "renderer_setup_s": setup_s,
               "primitives": int(np.asarray(scene.prim_type).shape[0]),
               "triangles": int(np.asarray(scene.tri_v).shape[0]),
               "ms_per_frame": {m: 1e3 * float(np.mean(v)) for m, v in times.items() if v},
               "quality_spp": args.quality_spp, "fast_supersample": args.supersample, "frames": frames_json}
    if detector is not None:
        section["detector"] = {m: t.as_dict() for m, t in modes.items() if t.frames}
    n_ref = min(args.reference_frames, len(kept))
    if n_ref > 0:
        section["reference"] = reference_section(name, scene, K, W, H, images, n_ref, args, detector, modes,
                                                 thresholds, env_dir)
        if detector is not None and modes["reference"].frames:
            section["detector"]["reference"] = modes["reference"].as_dict()
    section["_tallies"] = modes
    return section


def reference_section(name: str, scene, K, W: int, H: int, images: dict, n_ref: int, args, detector, modes,
                      thresholds, env_dir: Path) -> dict:
    """Render the first ``n_ref`` frames with Cycles; PSNR/SSIM of ours against them; ladder; side-by-sides."""
    from PIL import Image

    ref_dir = env_dir / "reference"
    ref_dir.mkdir(exist_ok=True)
    t0 = time.perf_counter()
    glb = export_reference_glb(scene, ref_dir / "scene.glb", shell=args.shell != "none")
    export_s = time.perf_counter() - t0
    ladder = [s for s in args.ladder if s < args.reference_spp]
    frames = []
    for n in range(n_ref):
        cam = blender_camera(K, images[n]["T"], W, H)
        cam["name"] = f"frame{n}"
        frames.append(cam)
    job = {"glb": str(ref_dir / "scene.glb"), "shell": "solid" if args.shell == "solid" else "camera-only",
           "lights": reference_lights(scene), "frames": frames, "spp": args.reference_spp, "ladder": ladder,
           "seed": args.seed, "out_dir": str(ref_dir)}
    if args.smoke:
        (ref_dir / "job.json").write_text(json.dumps(job))  # as run_cycles writes it
        smoke.left_out(f"the Cycles reference of {name}", f"it needs bpy, which `uv sync` does not install; {ref_dir} "
                       "has the scene and the job Cycles would render")
        return {"export": {**glb, "seconds": export_s}, "spp": args.reference_spp, "ladder": ladder,
                "shell": job["shell"], "frames": [], "left_out": "Cycles (smoke)"}
    t0 = time.perf_counter()
    timings = run_cycles(job, ref_dir / "job.json", args.bpy, args.reference_timeout)
    wall_s = time.perf_counter() - t0
    out = {"export": {**glb, "seconds": export_s}, "spp": args.reference_spp, "ladder": ladder,
           "shell": job["shell"], "blender": timings.get("blender"), "import_s": timings.get("import_s"),
           "wall_s": wall_s, "frames": []}
    camera = camera_model()  # the reference goes through the camera our images went through
    for n in range(n_ref):
        per = timings["frames"][f"frame{n}"]
        ref_linear = np.load(ref_dir / f"frame{n}_spp{args.reference_spp}.npy")
        ref = encode_like_ours(ref_linear, camera)
        Image.fromarray(ref).save(ref_dir / f"frame{n}_reference.png")
        fr = {"pose_index": images[n]["pose_index"], "reference_s": per[str(args.reference_spp)], "ours": {},
              "ladder": {}}
        for mode in ("fast", "quality"):
            if mode in images[n]:
                ours = images[n][mode]
                gain = exposure_gain(ours, ref_linear)
                matched = encode_like_ours(gain * ref_linear, camera)
                fr["ours"][mode] = {"psnr_db": psnr(ours, ref), "ssim": ssim(ours, ref), "exposure_gain": gain,
                                    "psnr_db_exposure_matched": psnr(ours, matched),
                                    "ssim_exposure_matched": ssim(ours, matched)}
        for s in ladder:
            img = encode_like_ours(np.load(ref_dir / f"frame{n}_spp{s}.npy"), camera)
            fr["ladder"][str(s)] = {"seconds": per[str(s)], "psnr_db": psnr(img, ref), "ssim": ssim(img, ref)}
        if ladder:
            top = fr["ladder"][str(ladder[-1])]["psnr_db"]
            fr["reference_psnr_est_db"] = top + 10 * math.log10(args.reference_spp / ladder[-1] + 1.0)
            for mode, v in fr["ours"].items():
                v["cycles_s_to_same_psnr"] = seconds_to_reach(fr["ladder"], v["psnr_db"])
        imgs = [images[n].get("fast"), images[n].get("quality"), ref]
        labels = ["ours fast", f"ours quality ({args.quality_spp} spp)", f"Cycles {args.reference_spp} spp"]
        pairs = [(i, lab) for i, lab in zip(imgs, labels) if i is not None]
        side_by_side([p[0] for p in pairs], [p[1] for p in pairs]).save(ref_dir / f"side_by_side_{n}.png")
        if detector is not None:
            dets = detector.detect(ref)
            truths = images[n]["truths"]
            scores = {thr: score_frame(truths, dets, thr, args.iou) for thr in thresholds}
            modes["reference"].add(truths, scores)
            annotate(ref, truths, dets, scores[thresholds[0]], thresholds[0],
                     f"{name} Cycles").save(ref_dir / f"frame{n}_detections.png")
        out["frames"].append(fr)
    return out


def class_table(title: str, tallies: dict, thresholds) -> str:
    """A Markdown table under a ``title`` heading: per class, objects detected at the first threshold / visible, per
    image source (fast, quality, reference: the columns with frames); then recall and false positives per frame at
    each threshold and the frame count. Empty when no source has frames."""
    sources = [m for m in SOURCES if tallies.get(m) and tallies[m].frames]
    if not sources:
        return ""
    thr = thresholds[0]
    seen = set().union(*[tallies[m].visible for m in sources])
    classes = sorted(seen, key=lambda c: (-tallies[sources[0]].visible.get(c, 0), c))  # most seen first
    lines = [f"### {title}: objects detected at score ≥ {thr} / visible", "",
             "| class | " + " | ".join(sources) + " |", "|---" * (len(sources) + 1) + "|"]
    for c in classes:
        lines.append(f"| {c} | " + " | ".join(f"{tallies[m].detected[thr].get(c, 0)}/{tallies[m].visible.get(c, 0)}"
                                               for m in sources) + " |")
    for th in thresholds:
        cells = []
        for m in sources:
            t = tallies[m]
            det, vis = sum(t.detected[th].values()), sum(t.visible.values())
            cells.append(f"{det}/{vis} ({100.0 * det / vis:.1f} %)" if vis else "–")
        lines.append(f"| **all classes, score ≥ {th}** | " + " | ".join(cells) + " |")
    lines.append("| false positives per frame (" + " / ".join(f"≥ {th}" for th in thresholds) + ") | "
                 + " | ".join(" / ".join(f"{tallies[m].fp[th] / tallies[m].frames:.3f}" for th in thresholds)
                              for m in sources) + " |")
    lines.append("| frames | " + " | ".join(str(tallies[m].frames) for m in sources) + " |")
    return "\n".join(lines) + "\n"


def model_table(title: str, tally: Tally, threshold: float) -> str:
    """A Markdown table under a ``title`` heading: per class and model (most seen first), objects detected at
    ``threshold`` / visible in ``tally``'s frames. Empty without frames."""
    if not tally.frames:
        return ""
    lines = [f"### {title}: per model, objects detected at score ≥ {threshold} / visible", "",
             "| class | model | found / visible |", "|---|---|---|"]
    per_class, detected = tally.visible, tally.detected_models[threshold]
    for (cls, model), n in sorted(tally.visible_models.items(), key=lambda kv: (-per_class[kv[0][0]], kv[0][0],
                                                                                -kv[1], kv[0][1])):
        lines.append(f"| {cls} | {model} | {detected[(cls, model)]}/{n} |")
    return "\n".join(lines) + "\n"


def _int_list(text: str) -> list[int]:
    try:
        vals = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of whole numbers") from None
    if any(v <= 0 for v in vals):
        raise argparse.ArgumentTypeError(f"{text!r}: sample counts must be positive")
    return vals


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--env", action="append", help=f"environment name:variant, repeatable (default {DEFAULT_ENVS})")
    ap.add_argument("--all-homes", action="store_true",
                    help="every BEAR home (miniroom:1..5, house:1..5) instead of --env")
    ap.add_argument("--style", default=None, help="environment['style'] for the scene builder (default: its own)")
    ap.add_argument("--frames", type=int, default=FRAMES_PER_ENV, help="frames per environment")
    ap.add_argument("--every", type=int, default=None, help="every K-th trajectory pose instead of --frames")
    ap.add_argument("--quality-frames", type=int, default=QUALITY_FRAMES_PER_ENV)
    ap.add_argument("--quality-spp", type=int, default=QUALITY_SPP)
    ap.add_argument("--reference-frames", type=int, default=REFERENCE_FRAMES_PER_ENV,
                    help="frames per environment rendered by Cycles (0: none): the first ones")
    ap.add_argument("--reference-spp", type=int, default=REFERENCE_SPP)
    ap.add_argument("--ladder", type=_int_list, default=list(REFERENCE_LADDER), help="e.g. 1,4,16")
    ap.add_argument("--reference-timeout", type=float, default=REFERENCE_TIMEOUT_S, help="seconds")
    ap.add_argument("--bpy", default=BPY_REQUIREMENT, help="the bpy requirement for uv")
    ap.add_argument("--shell", choices=("camera-only", "solid", "none"), default="camera-only",
                    help="the room shell in the reference: seen by the camera only (as our renderer, whose shell "
                         "casts no shadows), solid, or left out")
    ap.add_argument("--supersample", type=int, default=1, metavar="N",
                    help="fast frames as a camera with samples_per_pixel N x N sees them (sensors.camera.\n"
                         "samples_per_pixel: an N x N grid of sub-pixels averaged in linear radiance, as a sensor's\n"
                         "pixel integrates light over its area); objects, masks and boxes stay the pixel centres'.\n"
                         "It measures what aliasing costs the detector (default 1, the default camera's; at most\n"
                         f"{MAX_SUPERSAMPLE})")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--seed", type=int, default=0,
                    help="the run's seed, as `benchbot run --seed`: each environment's world is\n"
                         "benchbot.core.seeding.world_seed(seed, name, variant), the world an episode sees;\n"
                         "it also seeds Cycles' sampling")
    ap.add_argument("--min-pixels", type=int, default=MIN_PIXELS)
    ap.add_argument("--max-truncation", type=float, default=MAX_TRUNCATION)
    ap.add_argument("--iou", type=float, default=MATCH_IOU)
    ap.add_argument("--no-detector", action="store_true", help="skip the detector (no Node.js needed)")
    ap.add_argument("--detector", choices=DETECTORS, default="centernet",
                    help="which COCO detector judges the frames: centernet (the default, the instrument of the "
                         "figures in docs/realism.md), nanodet, a second one not in this repository, to check "
                         "that a gain is not a fit to one network (first use: npm pack, about 145 MB), ssd, a "
                         "third of another family (SSD MobileNetV2, TensorFlow Lite; first use: npm pack, 8.6 MB, "
                         "and LiteRT from PyPI), or yolo, a fourth never used to choose a change (YOLOv4-tiny, "
                         "Darknet, on ONNX Runtime; first use: a 23 MB wheel and ONNX Runtime from PyPI)")
    ap.add_argument("--detector-dir", type=Path,
                    default=Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "benchbot" /
                    "realism-detector", help="where the detectors are installed (npm, uv)")
    ap.add_argument("--detector-timeout", type=float, default=DETECTOR_TIMEOUT_S, help="seconds per frame")
    ap.add_argument("--control-photos", type=Path, default=None,
                    help="folder with the control photos (astronaut.png, coffee.png, dog.jpg, ...): check the "
                         "detector on real photos first")
    ap.add_argument("--real-reference", action="store_true",
                    help="also run the detector on the real photos of --real-photos (COCO val2017) and print sim,\n"
                         "real and sim / real recall per class with bootstrap intervals (benchmarks/realism_real.py);\n"
                         "with --quality-frames also for those frames in quality and in fast mode")
    ap.add_argument("--real-photos", type=Path, default=HERE / "realism" / "photos",
                    help="the real-photo reference set (coco_val2017.json and its photos)")
    ap.add_argument("--real-limit", type=int, default=None, help="only the first N photos (default: all)")
    ap.add_argument("--real-drop-border", action="store_true",
                    help="leave out the photos' objects whose box touches the photo's border (the nearest\n"
                         "stand-in for --max-truncation, which COCO's boxes cannot give)")
    ap.add_argument("--real-resamples", type=int, default=2000, help="bootstrap resamples of the intervals")
    ap.add_argument("--verdict", type=Path, nargs="+", metavar="RUN/realism.json", default=None,
                    help="print the goal's verdict (the line that ends each real-photo table) of finished\n"
                         "--real-reference runs, one line each, and exit; renders nothing")
    ap.add_argument("--pngs", type=int, default=PNGS_PER_ENV, help="annotated PNGs per environment and mode")
    ap.add_argument("--with-class", metavar="CLASS", default=None,
                    help="keep only the frames in which a CLASS object is visible (fast mode's truths; the others\n"
                         "are rendered to tell, then left out): one class's lever judged in a fraction of the time")
    ap.add_argument("--out", type=Path, default=Path("runs") / "realism")
    args = smoke.parse_args(ap, argv, frames=2, quality_frames=1, quality_spp=1, reference_spp=8, ladder=[1],
                            no_detector=True, width=32, height=24, min_pixels=20, pngs=1, real_limit=2,
                            real_resamples=50,
                            out=Path(tempfile.gettempdir()) / "benchbot-smoke" / "realism")
    for flag in ("frames", "quality_spp", "reference_spp", "width", "height", "min_pixels", "supersample"):
        if getattr(args, flag) <= 0:
            ap.error(f"--{flag.replace('_', '-')} must be positive")
    if args.supersample > MAX_SUPERSAMPLE:
        ap.error(f"--supersample must be at most {MAX_SUPERSAMPLE} (a frame is rendered at N x its width and height)")
    from benchbot.core.limits import MAX_CAMERA_SIDE

    side = max(args.width, args.height) * args.supersample
    if side > MAX_CAMERA_SIDE.value():
        ap.error(f"--width and --height (times --supersample) must be at most {int(MAX_CAMERA_SIDE.value())} pixels: "
                 f"the rendered side would be {side}")
    if args.real_reference and args.no_detector and not args.smoke:  # else every object would count as missed
        ap.error("--real-reference needs the detector: drop --no-detector")
    if (args.real_limit is not None and args.real_limit <= 0) or args.real_resamples < 2:
        ap.error("--real-limit must be positive and --real-resamples at least 2")
    for flag in ("quality_frames", "reference_frames", "pngs"):
        if getattr(args, flag) < 0:
            ap.error(f"--{flag.replace('_', '-')} must be 0 or more")
    if args.every is not None and args.every <= 0:
        ap.error("--every must be positive")
    if not 0.0 <= args.max_truncation <= 1.0 or not 0.0 < args.iou <= 1.0:
        ap.error("--max-truncation must be in [0, 1] and --iou in (0, 1]")
    if args.all_homes and args.env:
        ap.error("--all-homes and --env name the environments both ways: give one")
    if args.no_detector and args.detector != "centernet" and not args.smoke:  # else --detector is dropped silently
        ap.error(f"--detector {args.detector} and --no-detector contradict each other: give one")
    from benchbot_worlds.scene.build import STYLES

    if args.style is not None and args.style not in STYLES:  # else build_scene's BackendError, a traceback
        ap.error(f"--style must be one of {', '.join(STYLES)}")
    import realism_real

    if args.with_class is not None and args.with_class not in realism_real.bear_classes():
        ap.error(f"--with-class {args.with_class!r} is no BEAR class; give one of "
                 f"{', '.join(sorted(realism_real.bear_classes()))}")
    args.env = all_homes() if args.all_homes else args.env or (["miniroom:4"] if args.smoke else list(DEFAULT_ENVS))
    return args


def start_detector(args) -> Detector:
    """Install ``--detector`` into ``--detector-dir`` (what is missing, from the registries) and start it."""
    if args.detector in ("ssd", "yolo"):
        python, script = (install_ssd if args.detector == "ssd" else install_yolo)(args.detector_dir)
        return Detector(script, args.detector_timeout, args.detector, python=python)
    script = install_detector(args.detector_dir)
    if args.detector == "nanodet":
        install_nanodet(args.detector_dir)
    return Detector(script, args.detector_timeout, args.detector)


def real_reference(args, detector, sections: dict, threshold: float) -> tuple[dict, str]:
    """``--real-reference``: :func:`realism_real.run` (sim against real photos); in the smoke run, without a detector,
    every object of both sides counts as missed and this is said."""
    import realism_real

    if detector is None:
        smoke.left_out("the real photos' detections", "no detector in the smoke run: every object counts as missed")
    return realism_real.run(sys.modules[__name__], args, detector, sections, threshold)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (or, with ``--verdict``, print finished runs' verdicts); 0 on success, 2 on a bad flag, a
    missing tool or a ``--verdict`` file that is no finished ``--real-reference`` run (an error line and a hint on
    stderr)."""
    args = parse_args(argv)
    try:
        return _verdicts(args.verdict) if args.verdict else _run(args)
    except RealismError as exc:
        print(f"error: {exc.message}", file=sys.stderr)
        if exc.hint:
            print(f"hint: {exc.hint}", file=sys.stderr)
        return 2


def _verdicts(paths: list[Path]) -> int:
    """``--verdict``: the goal's verdict of each finished run (:func:`realism_real.verdict`), one line each on stdout;
    0, or :class:`RealismError` for a file that is not a finished ``--real-reference`` run."""
    import realism_real

    for path in paths:
        try:
            print(realism_real.verdict(path))
        except ValueError as e:
            raise RealismError(str(e), "give the realism.json of a run made with --real-reference") from e
    return 0


def _run(args) -> int:
    thresholds = SCORE_THRESHOLDS if args.no_detector else DETECTOR_THRESHOLDS[args.detector]
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    detector = None
    report: dict = {"command": " ".join([Path(sys.argv[0]).name] + sys.argv[1:]),
                    "machine": {"processor": platform.processor() or platform.machine(), "cpu_count": os.cpu_count()},
                    "settings": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
                    "thresholds": list(thresholds), "environments": {}}
    if args.smoke and args.no_detector:
        smoke.left_out("the detector", "it needs Node.js and npm, and `npm ci` downloads its package; `uv sync` "
                       "installs neither")
    try:
        if not args.no_detector:
            detector = start_detector(args)
            report["detector"] = {"model": args.detector, "runtime": detector.info, **DETECTOR_SOURCES[args.detector]}
            if args.control_photos:
                report["detector"]["control"] = control_check(detector, args.control_photos)
                found = [v["found"] for v in report["detector"]["control"].values()]
                print(f"control photos: main object found in {sum(found)} of {len(found)}")
        overall = {m: Tally(thresholds) for m in SOURCES}
        tables: list[str] = []
        for name in args.env:
            section = judge_environment(name, args, detector, args.out, thresholds)
            tallies = section.pop("_tallies")
            report["environments"][name] = section
            ms = section["ms_per_frame"]
            print(f"{name} ({section['triangles']} triangles, {section['primitives']} primitives): "
                  f"{len(section['pose_indices'])} frames at {args.width}x{args.height}, fast "
                  f"{f'(supersampled {args.supersample} x {args.supersample}) ' if args.supersample > 1 else ''}"
                  f"{ms.get('fast', math.nan):.1f} ms a frame, quality {ms.get('quality', math.nan):.1f} ms "
                  f"({args.quality_spp} spp)")
            if detector is not None:
                tables.append(class_table(name, tallies, thresholds))
                print("\n" + tables[-1])
                for m, t in tallies.items():
                    overall[m].merge(t)
            for fr in section.get("reference", {}).get("frames", []):
                ours = ", ".join(f"{m} {v['psnr_db']:.2f} dB SSIM {v['ssim']:.3f} (Cycles "
                                 f"{v['cycles_s_to_same_psnr'].get('bound', '')}"
                                 f"{v['cycles_s_to_same_psnr'].get('seconds', math.nan):.0f} s to match)"
                                 for m, v in fr["ours"].items())
                print(f"{name}: vs Cycles {args.reference_spp} spp ({fr['reference_s']:.0f} s): {ours}")
        if detector is not None and len(args.env) > 1:
            tables.insert(0, class_table(f"all {len(args.env)} environments ({', '.join(args.env)})", overall,
                                         thresholds))
            print("\n" + tables[0])
            report["detector"]["overall"] = {m: t.as_dict() for m, t in overall.items() if t.frames}
        if detector is not None and overall["fast"].frames:  # per model: in the file only (about 60 rows)
            tables.append(model_table(f"{', '.join(args.env)}, fast mode", overall["fast"], thresholds[0]))
        if args.real_reference:
            report["real_reference"], real_table = real_reference(args, detector, report["environments"], thresholds[0])
            tables.append(real_table)
            print("\n" + real_table)
    finally:
        if detector is not None:
            report.setdefault("detector", {})["seconds_per_frame"] = detector.seconds / max(1, detector.frames)
            detector.close()
    report["total_s"] = time.perf_counter() - t_start
    atomic.write_text(args.out / "realism.json", json.dumps(report, indent=1, default=float))
    written = [args.out / "realism.json"]
    if tables:
        if args.supersample > 1:  # the tables' "fast" column is then not the image episodes see: say so first
            tables.insert(0, f"Fast frames with {args.supersample ** 2} samples a pixel (`--supersample "
                             f"{args.supersample}`, the camera's samples_per_pixel): not the default camera's image.\n")
        atomic.write_text(args.out / "per_class.md", "\n".join(tables))
        written.append(args.out / "per_class.md")
    print(f"\nwrote {', '.join(map(str, written))} ({report['total_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
