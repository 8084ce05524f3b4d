"""Scenes for the Taichi simulator, built from a BEAR ground-truth JSON (pure NumPy, no Taichi).

A :class:`Scene` is a set of axis-aligned boxes (one per ground-truth object, its AABB exactly the ground-truth
cuboid ``centroid ± extent / 2``), a room shell (floor at z = 0, four walls, a ceiling) enclosing every object and
every pose, and a list of lights. All coordinates are metres in the environment's ``map`` frame (z up).

The object → geometry step is :func:`object_geometry` (one box per object today; procedural models later).
"""

from __future__ import annotations

import json
import math
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchbot.core.errors import BackendError
from benchbot.core.geometry import pose7_to_se2

#: Light kinds in :attr:`Scene.light_kind`.
LIGHT_DIRECTIONAL = 0
LIGHT_POINT = 1

#: Shell surfaces, indices into :attr:`Scene.shell_albedo`.
SHELL_FLOOR, SHELL_WALL, SHELL_CEILING = 0, 1, 2

#: Margin (metres) between the walls and every object / pose.
WALL_MARGIN_M = 0.5
#: Minimum ceiling height (metres) and clearance above the highest object.
CEILING_MIN_M = 2.6
CEILING_CLEARANCE_M = 0.3

# Plausible sRGB albedos (0..1) per class; a list means "pick one per instance".
_CLASS_COLOURS: dict[str, object] = {
    "bottle": [(0.20, 0.45, 0.25), (0.55, 0.35, 0.15), (0.75, 0.80, 0.82)],
    "cup": [(0.92, 0.92, 0.90), (0.75, 0.20, 0.18), (0.25, 0.40, 0.65)],
    "knife": (0.72, 0.73, 0.75),
    "bowl": [(0.93, 0.92, 0.88), (0.80, 0.70, 0.55), (0.35, 0.50, 0.60)],
    "wine glass": (0.82, 0.86, 0.88),
    "fork": (0.72, 0.73, 0.75),
    "spoon": (0.72, 0.73, 0.75),
    "banana": (0.95, 0.82, 0.25),
    "apple": (0.75, 0.12, 0.10),
    "orange": (0.95, 0.55, 0.10),
    "cake": (0.85, 0.70, 0.50),
    "potted plant": (0.22, 0.48, 0.18),
    "mouse": (0.12, 0.12, 0.13),
    "keyboard": (0.14, 0.14, 0.15),
    "laptop": (0.25, 0.26, 0.28),
    "cell phone": (0.08, 0.08, 0.09),
    "book": [
        (0.60, 0.12, 0.12), (0.15, 0.25, 0.55), (0.20, 0.45, 0.25), (0.85, 0.75, 0.45),
        (0.35, 0.20, 0.40), (0.90, 0.88, 0.82), (0.20, 0.20, 0.22), (0.80, 0.45, 0.15),
    ],
    "clock": (0.85, 0.85, 0.82),
    "chair": [(0.50, 0.33, 0.18), (0.42, 0.27, 0.15), (0.30, 0.30, 0.32)],
    "table": [(0.55, 0.37, 0.20), (0.45, 0.30, 0.16), (0.68, 0.52, 0.34)],
    "couch": [(0.45, 0.47, 0.50), (0.55, 0.40, 0.30), (0.25, 0.32, 0.45), (0.62, 0.58, 0.50)],
    "bed": (0.90, 0.88, 0.84),
    "toilet": (0.95, 0.95, 0.94),
    "tv": (0.07, 0.07, 0.08),
    "microwave": (0.80, 0.80, 0.80),
    "toaster": (0.75, 0.76, 0.78),
    "refrigerator": (0.88, 0.89, 0.90),
    "oven": (0.30, 0.30, 0.32),
    "sink": (0.94, 0.94, 0.93),
    "person": (0.80, 0.62, 0.50),
}
_DEFAULT_COLOUR = (0.6, 0.6, 0.6)
# Floor (wood), walls (off-white), ceiling (white).
_SHELL_COLOURS = ((0.62, 0.48, 0.33), (0.86, 0.84, 0.78), (0.95, 0.95, 0.94))

_LIGHTINGS = ("base", "day", "night", "day_extra", "night_extra")


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB (0..1) → linear (0..1), a plain 2.2 gamma (float32, same shape)."""
    return np.power(np.clip(np.asarray(c, dtype=np.float32), 0.0, 1.0), np.float32(2.2)).astype(np.float32)


def lighting_of_map_path(map_path: str) -> str:
    """The lighting name (``base``, ``day``, ``night``, ``day_extra``, ``night_extra``) encoded in an original
    Unreal ``map_path`` such as ``/Game/AI_vol3_03_base/Maps/AI_vol3_scene_03``; ``base`` if none is found."""
    first = [p for p in str(map_path).split("/") if p][1:2] or [str(map_path)]
    name = first[0]
    for suffix in ("night_extra", "day_extra", "night", "day", "base"):
        if name.endswith("_" + suffix):
            return suffix
    return "base"


@dataclass
class Scene:
    """A box scene in the ``map`` frame (metres, z up).

    Attributes:
        box_min, box_max: (N, 3) float32 box corners.
        box_albedo: (N, 3) float32 linear albedo.
        box_class: (N,) int32 class ids (index in ``class_list``).
        box_instance: (N,) int32 instance ids ``class_id * 1000 + instance`` (instance ≥ 1, per class).
        box_names: the objects' ``ID_name``.
        room_min, room_max: (3,) float32 corners of the room shell (floor at ``room_min[2] = 0``).
        shell_albedo: (3, 3) float32 linear albedo of the floor, walls, ceiling.
        background_class: class id of ``background`` (the shell's class; instance id 0).
        class_list: class names; ``class_ids`` maps them to ids.
        ambient: (3,) float32 ambient radiance.
        light_kind: (L,) int32 (:data:`LIGHT_DIRECTIONAL` or :data:`LIGHT_POINT`).
        light_vec: (L, 3) float32 direction *towards* the light (directional, unit) or position (point).
        light_colour: (L, 3) float32 radiance (point lights: at 1 m, falling off as 1/d²).
        light_range: (L,) float32 cut-off distance of point lights (metres; ignored for directional ones).
        lighting: the lighting name.
        start_se2: (3,) float64 normalised start pose ``[x, y, yaw]``; trajectory_se2: (M, 3) float64.
    """

    box_min: np.ndarray
    box_max: np.ndarray
    box_albedo: np.ndarray
    box_class: np.ndarray
    box_instance: np.ndarray
    box_names: list[str]
    room_min: np.ndarray
    room_max: np.ndarray
    shell_albedo: np.ndarray
    background_class: int
    class_list: list[str]
    ambient: np.ndarray
    light_kind: np.ndarray
    light_vec: np.ndarray
    light_colour: np.ndarray
    light_range: np.ndarray
    lighting: str
    start_se2: np.ndarray
    trajectory_se2: np.ndarray
    class_ids: dict[str, int] = field(default_factory=dict)

    @property
    def n_boxes(self) -> int:
        """Number of object boxes."""
        return int(self.box_min.shape[0])


def load_ground_truth_json(path: "str | Path") -> dict:
    """Load and check a BEAR ground-truth JSON ``{environment, format, ground_truth}``.

    Raises:
        BackendError: the file is missing, unreadable, not JSON, or lacks ``ground_truth.objects`` /
            ``class_list`` or an object's ``class``/``centroid``/``extent``.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise BackendError(f"cannot read the scene file {p}: {e.strerror or e}",
                           "check the environment's map_path: it must name a BEAR ground-truth JSON file") from e
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise BackendError(f"the scene file {p} is not valid JSON (line {e.lineno}: {e.msg})",
                           "map_path must name a BEAR ground-truth JSON {environment, format, ground_truth}") from e
    gt = data.get("ground_truth") if isinstance(data, dict) else None
    if not isinstance(gt, dict) or not isinstance(gt.get("objects"), list) or not isinstance(gt.get("class_list"), list):
        raise BackendError(f"the scene file {p} has no ground_truth.objects / ground_truth.class_list",
                           "map_path must name a BEAR ground-truth JSON {environment, format, ground_truth}")
    for i, o in enumerate(gt["objects"]):
        try:
            c = np.asarray(o["centroid"], dtype=np.float64)
            x = np.asarray(o["extent"], dtype=np.float64)
            str(o["class"])
        except (KeyError, TypeError, ValueError) as e:
            raise BackendError(f"the scene file {p}: ground_truth.objects[{i}] is malformed ({e!r})",
                               "every object needs class, centroid [x,y,z] and extent [dx,dy,dz]") from e
        if c.shape != (3,) or x.shape != (3,) or not (np.all(np.isfinite(c)) and np.all(np.isfinite(x))) or np.any(x < 0):
            raise BackendError(f"the scene file {p}: ground_truth.objects[{i}] has a bad centroid/extent",
                               "centroid and extent must be 3 finite numbers, extents ≥ 0")
    return data


def object_geometry(obj: dict) -> list[tuple[np.ndarray, np.ndarray]]:
    """Geometry of one ground-truth object as a list of axis-aligned boxes ``(min (3,), max (3,))`` float64, metres,
    map frame. Today one box equal to the ground-truth cuboid ``centroid ± extent / 2`` (so the union's AABB is the
    cuboid); a later version may return several boxes (procedural models) with the same AABB."""
    c = np.asarray(obj["centroid"], dtype=np.float64)
    e = np.asarray(obj["extent"], dtype=np.float64)
    return [(c - e / 2.0, c + e / 2.0)]


def object_colour(cls: str, id_name: str, seed: int) -> np.ndarray:
    """sRGB albedo (3,) float32 of one object: its class colour (or one of its palette, chosen per instance), with a
    small per-instance variation seeded by ``ID_name`` and ``seed``."""
    key = zlib.crc32(f"{id_name}|{seed}".encode("utf-8"))
    rng = np.random.default_rng(key)
    base = _CLASS_COLOURS.get(cls, _DEFAULT_COLOUR)
    if isinstance(base, list):
        base = base[int(rng.integers(len(base)))]
    jitter = rng.uniform(-0.04, 0.04, size=3) + rng.uniform(-0.04, 0.04)
    return np.clip(np.asarray(base, dtype=np.float64) + jitter, 0.02, 0.98).astype(np.float32)


def _lights(lighting: str, room_min: np.ndarray, room_max: np.ndarray):
    """(ambient, kind, vec, colour, range) for a lighting name and a room."""
    h = float(room_max[2])
    sun_dir = np.array([0.45, 0.30, 0.84], dtype=np.float64)
    sun_dir /= np.linalg.norm(sun_dir)
    kinds, vecs, cols, ranges = [], [], [], []

    def sun(intensity):
        kinds.append(LIGHT_DIRECTIONAL)
        vecs.append(sun_dir)
        cols.append(np.array([1.0, 0.93, 0.82]) * intensity)
        ranges.append(0.0)

    def ceiling(intensity, spacing):
        nx = max(1, int(math.ceil((room_max[0] - room_min[0]) / spacing)))
        ny = max(1, int(math.ceil((room_max[1] - room_min[1]) / spacing)))
        for i in range(nx):
            for j in range(ny):
                x = room_min[0] + (i + 0.5) * (room_max[0] - room_min[0]) / nx
                y = room_min[1] + (j + 0.5) * (room_max[1] - room_min[1]) / ny
                kinds.append(LIGHT_POINT)
                vecs.append(np.array([x, y, h - 0.15]))
                cols.append(np.array([1.0, 0.82, 0.60]) * intensity)
                ranges.append(spacing * 1.25)

    if lighting == "day":
        ambient = np.array([0.30, 0.31, 0.33])
        sun(0.95)
    elif lighting == "day_extra":
        ambient = np.array([0.34, 0.35, 0.37])
        sun(1.05)
        ceiling(1.2, 4.0)
    elif lighting == "night":
        ambient = np.array([0.05, 0.05, 0.07])
        ceiling(2.2, 4.0)
    elif lighting == "night_extra":
        ambient = np.array([0.08, 0.075, 0.08])
        ceiling(3.0, 3.0)
    else:  # base: warm interior light
        ambient = np.array([0.26, 0.24, 0.21])
        sun(0.75)
    return (
        ambient.astype(np.float32),
        np.asarray(kinds, dtype=np.int32),
        np.asarray(vecs, dtype=np.float32).reshape(-1, 3),
        np.asarray(cols, dtype=np.float32).reshape(-1, 3),
        np.asarray(ranges, dtype=np.float32),
    )


def build_scene(environment: dict, *, seed: int = 0) -> Scene:
    """Build the :class:`Scene` of an environment spec.

    Args:
        environment: an environment spec; ``map_path`` names a BEAR ground-truth JSON (objects, class list);
            ``start_pose``/``trajectory_poses`` (``[qw,qx,qy,qz,x,y,z]``) are taken from the spec, else from the
            JSON; ``lighting`` from the spec, else from the JSON's original Unreal ``map_path``.
        seed: seeds the per-instance colour variation.

    Raises:
        BackendError: ``map_path`` is missing, unreadable or malformed, or a pose is malformed.
    """
    map_path = environment.get("map_path")
    if not map_path:
        raise BackendError(f"environment {environment.get('name')}:{environment.get('variant')} has no map_path",
                           "set map_path to a BEAR ground-truth JSON file")
    data = load_ground_truth_json(map_path)
    gt = data["ground_truth"]
    file_env = data.get("environment") or {}
    class_list = [str(c) for c in gt["class_list"]]
    class_ids = {c: i for i, c in enumerate(class_list)}
    background = class_ids.get("background", len(class_list) - 1)

    mins, maxs, albedo, cls_ids, inst_ids, names = [], [], [], [], [], []
    counters: dict[int, int] = {}
    for obj in gt["objects"]:
        cname = str(obj["class"])
        cid = class_ids.get(cname)
        if cid is None:
            raise BackendError(f"the scene file {map_path}: object class {cname!r} is not in class_list",
                               "every object's class must appear in ground_truth.class_list")
        counters[cid] = counters.get(cid, 0) + 1
        colour = object_colour(cname, str(obj.get("ID_name", "")), seed)
        for bmin, bmax in object_geometry(obj):
            mins.append(bmin)
            maxs.append(bmax)
            albedo.append(colour)
            cls_ids.append(cid)
            inst_ids.append(cid * 1000 + counters[cid])
            names.append(str(obj.get("ID_name", "")))

    def poses(key):
        v = environment.get(key)
        if v is None:
            v = file_env.get(key)
        return v

    try:
        sp = poses("start_pose")
        start = pose7_to_se2(sp) if sp is not None else np.zeros(3)
        traj = np.array([pose7_to_se2(p) for p in (poses("trajectory_poses") or [])], dtype=np.float64).reshape(-1, 3)
    except (ValueError, TypeError) as e:
        raise BackendError(f"environment {environment.get('name')}:{environment.get('variant')}: bad pose ({e})",
                           "poses are [qw,qx,qy,qz,x,y,z] with a non-zero quaternion") from e

    box_min = np.asarray(mins, dtype=np.float32).reshape(-1, 3)
    box_max = np.asarray(maxs, dtype=np.float32).reshape(-1, 3)
    pts = np.concatenate([start[None, :2], traj[:, :2]], axis=0)
    lo = pts.min(axis=0)
    hi = pts.max(axis=0)
    if len(box_min):
        lo = np.minimum(lo, box_min[:, :2].min(axis=0))
        hi = np.maximum(hi, box_max[:, :2].max(axis=0))
    top = float(box_max[:, 2].max()) if len(box_max) else 0.0
    room_min = np.array([lo[0] - WALL_MARGIN_M, lo[1] - WALL_MARGIN_M, 0.0], dtype=np.float32)
    room_max = np.array([hi[0] + WALL_MARGIN_M, hi[1] + WALL_MARGIN_M,
                         max(CEILING_MIN_M, top + CEILING_CLEARANCE_M)], dtype=np.float32)

    lighting = environment.get("lighting") or lighting_of_map_path(file_env.get("map_path", ""))
    if lighting not in _LIGHTINGS:
        lighting = "base"
    ambient, kind, vec, col, rng = _lights(lighting, room_min, room_max)
    return Scene(
        box_min=box_min,
        box_max=box_max,
        box_albedo=srgb_to_linear(np.asarray(albedo, dtype=np.float32).reshape(-1, 3)),
        box_class=np.asarray(cls_ids, dtype=np.int32),
        box_instance=np.asarray(inst_ids, dtype=np.int32),
        box_names=names,
        room_min=room_min,
        room_max=room_max,
        shell_albedo=srgb_to_linear(np.asarray(_SHELL_COLOURS, dtype=np.float32)),
        background_class=int(background),
        class_list=class_list,
        class_ids=class_ids,
        ambient=ambient,
        light_kind=kind,
        light_vec=vec,
        light_colour=col,
        light_range=rng,
        lighting=lighting,
        start_se2=start,
        trajectory_se2=traj,
    )
