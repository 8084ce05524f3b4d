"""Tests of the ``semslam_geometric`` example's mapper on a synthetic room rendered by a small NumPy ray-caster.

The scene: a 4 × 4.5 m room (floor z = 0, four walls, ceiling 2.6 m) with axis-aligned coloured boxes; an RGB-D
camera (160 × 120, 90° horizontal field of view, level, 0.8 m above the floor, optical frame z forward / x right /
y down) looks around from a few poses. The mapper must find each box and nothing of the room shell.
"""

from __future__ import annotations

import importlib.util
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import pytest

EXAMPLE_DIR = Path(__file__).resolve().parents[1] / "benchbot_task_semslam" / "examples" / "semslam_geometric"


def _load(name: str, filename: str):
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, EXAMPLE_DIR / filename)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


mapping = _load("semslam_geometric_mapping", "mapping.py")

CLASS_LIST = ["bottle", "cup", "knife", "bowl", "wine glass", "fork", "spoon", "banana", "apple", "orange", "cake",
              "potted plant", "mouse", "keyboard", "laptop", "cell phone", "book", "clock", "chair", "table", "couch",
              "bed", "toilet", "tv", "microwave", "toaster", "refrigerator", "oven", "sink", "person", "background"]

ROOM_LO = np.array([0.0, 0.0, 0.0])
ROOM_HI = np.array([4.0, 4.5, 2.6])
#: (name, lo (3,), hi (3,), sRGB 0..255)
BOXES = [
    ("table", (0.6, 2.6, 0.0), (1.8, 3.3, 0.75), (140, 95, 52)),
    ("microwave", (0.9, 2.75, 0.75), (1.4, 3.1, 1.05), (40, 40, 42)),  # stands on the table
    ("potted plant", (3.2, 0.5, 0.0), (3.6, 0.9, 0.7), (56, 122, 46)),
    ("refrigerator", (3.3, 3.7, 0.0), (4.0, 4.5, 1.8), (228, 230, 232)),  # in a corner, against two walls
    ("chair", (2.0, 1.0, 0.0), (2.5, 1.5, 0.9), (125, 82, 45)),
]
SHELL_COLOURS = {"floor": (158, 122, 84), "wall": (219, 214, 199), "ceiling": (242, 242, 240)}
W, H = 160, 120
K = np.array([[80.0, 0, 79.5], [0, 80.0, 59.5], [0, 0, 1]])


def camera_pose(position, yaw) -> np.ndarray:
    """T_map_camera (4, 4) of a level optical-frame camera at ``position`` looking along ``yaw`` (rad)."""
    f = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    x = np.cross(f, [0.0, 0.0, 1.0])
    y = np.cross(f, x)
    T = np.eye(4)
    T[:3, :3] = np.stack([x, y, f], axis=1)
    T[:3, 3] = position
    return T


def render(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ray-cast the scene: (rgb (H, W, 3) uint8, depth (H, W) float32 metres along the optical axis)."""
    v, u = np.mgrid[0:H, 0:W]
    rays_c = np.linalg.inv(K) @ np.stack([u.ravel(), v.ravel(), np.ones(u.size)])  # z = 1: t is the depth
    d = (T[:3, :3] @ rays_c).T
    o = T[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        # room: exit distance from inside
        t_exit = np.where(d > 0, (ROOM_HI - o) * inv, (ROOM_LO - o) * inv)
        t_exit[~np.isfinite(t_exit)] = np.inf
        best = t_exit.min(axis=1)
        axis = t_exit.argmin(axis=1)
        colour = np.zeros((len(d), 3))
        hit_dir = d[np.arange(len(d)), axis]
        shade_wall = np.where(axis == 0, 0.9, 0.8)
        colour[:] = np.array(SHELL_COLOURS["wall"]) * shade_wall[:, None]
        colour[(axis == 2) & (hit_dir < 0)] = SHELL_COLOURS["floor"]
        colour[(axis == 2) & (hit_dir > 0)] = SHELL_COLOURS["ceiling"]
        for _, lo, hi, rgb in BOXES:
            t1, t2 = (np.array(lo) - o) * inv, (np.array(hi) - o) * inv
            tmin, tmax = np.minimum(t1, t2), np.maximum(t1, t2)
            tmin[np.isnan(tmin)] = -np.inf
            tmax[np.isnan(tmax)] = np.inf
            t_in, t_out = tmin.max(axis=1), tmax.min(axis=1)
            hit = (t_in <= t_out) & (t_in > 0) & (t_in < best)
            face = tmin.argmax(axis=1)
            shade = np.where(face == 2, 1.0, np.where(face == 0, 0.85, 0.7))
            best = np.where(hit, t_in, best)
            colour[hit] = np.array(rgb) * shade[hit, None]
    depth = best.reshape(H, W).astype(np.float32)
    rgb = np.clip(colour, 0, 255).reshape(H, W, 3).astype(np.uint8)
    return rgb, depth


def trajectory() -> list[np.ndarray]:
    """Camera poses on a loop around the room centre, looking inwards and along the loop."""
    poses = []
    c = np.array([2.0, 2.25])
    for i in range(16):
        a = 2 * math.pi * i / 16
        p = c + np.array([1.2 * math.cos(a), 1.3 * math.sin(a)])
        for yaw in (a + math.pi, a + math.pi / 2):  # towards the centre, and tangentially (walls, corners)
            poses.append(camera_pose(np.array([p[0], p[1], 0.8]), yaw))
    return poses


@pytest.fixture(scope="module")
def frames():
    return [(*render(T), T) for T in trajectory()]


@pytest.fixture(scope="module")
def mapped(frames):
    mapper = mapping.GeometricMapper(stride=1)
    t0 = time.perf_counter()
    for rgb, depth, T in frames:
        mapper.integrate(rgb, depth, K, T)
    t1 = time.perf_counter()
    objects = mapper.build_map(CLASS_LIST)
    t2 = time.perf_counter()
    print(f"\nintegrate {1e3 * (t1 - t0) / len(frames):.1f} ms/frame ({W}x{H}), build_map {1e3 * (t2 - t1):.0f} ms, "
          f"{len(objects)} objects")
    return mapper, objects


def _match(objects, lo, hi):
    c = 0.5 * (np.array(lo) + np.array(hi))
    dists = [np.linalg.norm(np.array(o["centroid"]) - c) for o in objects]
    return objects[int(np.argmin(dists))], float(min(dists))


def test_renderer_depth_is_along_the_optical_axis():
    T = camera_pose(np.array([2.0, 2.25, 0.8]), 0.0)  # looking along +x at the wall x = 4
    _, depth = render(T)
    # the middle of the centre row hits the wall x = 4 (2 m ahead): the depth is constant along it, not a range
    assert np.allclose(depth[H // 2, W // 2 - 30:W // 2 + 30], 2.0, atol=1e-4)


def test_room_shell_found(mapped):
    mapper, _ = mapped
    shell = mapper.shell
    assert shell.floor_z == pytest.approx(0.0, abs=0.03)
    assert shell.ceiling_z == pytest.approx(2.6, abs=0.03)
    found = sorted((a, round(p, 1)) for a, p, _, _ in shell.walls)
    assert found == [(0, 0.0), (0, 4.0), (1, 0.0), (1, 4.5)]


@pytest.mark.parametrize("name,lo,hi,rgb", BOXES, ids=[b[0] for b in BOXES])
def test_each_box_found(mapped, name, lo, hi, rgb):
    _, objects = mapped
    obj, dist = _match(objects, lo, hi)
    assert dist < 0.1, (name, obj)
    ext = np.array(hi) - np.array(lo)
    assert np.all(np.abs(np.array(obj["extent"]) - ext) < 0.15), (name, obj["extent"], ext)
    assert len(obj["label_probs"]) == len(CLASS_LIST)
    assert sum(obj["label_probs"]) == pytest.approx(1.0, abs=1e-6)


def test_no_shell_objects(mapped):
    """Every reported object lies near a box: nothing of the floor, walls or ceiling is reported."""
    _, objects = mapped
    assert len(objects) <= len(BOXES) + 1
    for o in objects:
        c = np.array(o["centroid"])
        near = [np.all((c > np.array(lo) - 0.15) & (c < np.array(hi) + 0.15)) for _, lo, hi, _ in BOXES]
        assert any(near), o
        assert max(o["extent"]) < 2.5


def test_labels(mapped):
    _, objects = mapped
    plant, _ = _match(objects, BOXES[2][1], BOXES[2][2])
    assert CLASS_LIST[int(np.argmax(plant["label_probs"]))] == "potted plant"
    for name, lo, hi, _ in BOXES:
        obj, _ = _match(objects, lo, hi)
        top = CLASS_LIST[int(np.argmax(obj["label_probs"]))]
        print(name, "->", top, round(max(obj["label_probs"]), 2))


def test_probabilities_calibrated_with_background():
    """A shapeless grey blob of no class's size keeps most of its mass on background."""
    blob = mapping.Cluster(lo=np.zeros(3), hi=np.array([2.8, 0.05, 2.0]), colour=np.array([128.0, 0, 128.0]),
                           n_voxels=5)
    p = mapping.label_probabilities(blob, CLASS_LIST)
    assert p[-1] > 0.5 and p.sum() == pytest.approx(1.0)


def test_offline_script(frames, tmp_path):
    """The submission script's offline mode reads recorded frames and writes a valid object_map results file."""
    script = _load("semslam_geometric_script", "semslam_geometric.py")
    rec = tmp_path / "frames.npz"
    np.savez(rec, rgb=np.stack([f[0] for f in frames]), depth=np.stack([f[1] for f in frames]), K=K,
             T=np.stack([f[2] for f in frames]))
    out = tmp_path / "result.json"
    script.main(["--offline", str(rec), "--output", str(out), "--stride", "1"])
    res = json.loads(out.read_text())
    objs = res["results"]["objects"]
    assert res["results"]["class_list"] == CLASS_LIST
    assert len(objs) >= len(BOXES)
    for o in objs:
        assert len(o["label_probs"]) == 31 and len(o["centroid"]) == 3 and len(o["extent"]) == 3


@pytest.mark.parametrize("preset, expected", [(None, 1), ("2", 2)])
def test_script_runs_numpy_with_one_blas_thread_unless_told_otherwise(preset, expected):
    """Run as the solution, the script gives NumPy's OpenBLAS one thread (its spinning threads took the simulator's
    cores while it rendered the next frame), or the count the user set in OPENBLAS_NUM_THREADS."""
    import os
    import subprocess

    code = f"""
import ctypes, glob, os, runpy, sys
sys.argv = ["semslam_geometric.py", "--help"]
try:
    runpy.run_path({str(EXAMPLE_DIR / "semslam_geometric.py")!r}, run_name="__main__")
except SystemExit:
    pass
import numpy
libs = glob.glob(os.path.join(os.path.dirname(numpy.__path__[0]), "numpy.libs", "libscipy_openblas*.so"))
print(ctypes.CDLL(libs[0]).scipy_openblas_get_num_threads64_() if libs else "no OpenBLAS library found")
"""
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if preset is not None:
        env["OPENBLAS_NUM_THREADS"] = preset
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    last = proc.stdout.strip().splitlines()[-1]
    if last == "no OpenBLAS library found":
        pytest.skip("this NumPy is not built with scipy-openblas")
    assert int(last) == expected


def test_pose_to_matrix_equals_scipys_rotation_bit_for_bit():
    """The example computes SciPy's ``Rotation.from_quat(q).as_matrix()`` itself (no ``scipy.spatial`` import at
    its start): equal bit for bit on random quaternions of any length, unit ones, and the axes' quarter turns."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(7)
    quats = rng.normal(size=(20000, 4)) * rng.uniform(0.01, 5.0, size=(20000, 1))
    quats[::3] /= np.linalg.norm(quats[::3], axis=1, keepdims=True)
    half = math.sqrt(0.5)
    special = [[0, 0, 0, 1], [1, 0, 0, 0], [0, 0, half, half], [0, half, 0, -half], [0, 0, 0.3826834, 0.9238795]]
    quats = np.concatenate([quats, np.array(special, dtype=np.float64)])
    expected = Rotation.from_quat(quats).as_matrix()
    got = np.stack([mapping.pose_to_matrix([1.0, 2.0, 3.0], q)[:3, :3] for q in quats])
    assert np.array_equal(got, expected)
    assert mapping.pose_to_matrix([1.0, 2.0, 3.0], [0, 0, 0, 1])[:3, 3].tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError):
        mapping.pose_to_matrix([0, 0, 0], [0, 0, 0, 0])


def _reference_frame_sums(rgb, depth, T, stride=2, voxel=0.04, min_depth=0.1, max_depth=6.0):
    """One frame's ``(voxel keys, hits, position sums, colour sums)`` as the mapper computed them before it skipped
    the masks of a frame with every pixel kept and sorted only the keys' runs: ``np.unique`` over every kept pixel's
    key, then ``np.bincount``."""
    d = np.asarray(depth, np.float32)[::stride, ::stride]
    h, w = d.shape
    v, u = np.mgrid[0:h * stride:stride, 0:w * stride:stride]
    rays = (np.linalg.inv(K) @ np.stack([u.ravel(), v.ravel(), np.ones(u.size)]).astype(np.float64)).T
    rays = rays.astype(np.float32)
    d = d.ravel()
    ok = np.isfinite(d) & (d > min_depth) & (d < max_depth)
    pts = (rays[ok] * d[ok, None]) @ T[:3, :3].T.astype(np.float32) + T[:3, 3].astype(np.float32)
    cols = rgb[::stride, ::stride].reshape(-1, 3)[ok].astype(np.float32)
    keys, inv = np.unique(mapping._encode(np.floor(pts / voxel).astype(np.int64)), return_inverse=True)
    n = len(keys)
    return (keys, np.bincount(inv, minlength=n).astype(np.float64),
            np.stack([np.bincount(inv, pts[:, i], minlength=n) for i in range(3)], axis=1),
            np.stack([np.bincount(inv, cols[:, i], minlength=n) for i in range(3)], axis=1))


@pytest.mark.parametrize("holes", [False, True], ids=["every pixel kept", "pixels without depth"])
def test_a_frame_sums_equal_those_of_numpy_unique_bit_for_bit(frames, holes):
    """What :meth:`GeometricMapper.integrate` keeps of a frame (its voxels' keys, hits and sums) equals, bit for bit,
    the ``np.unique`` + ``np.bincount`` computation it replaced, for a frame whose every pixel has a depth (no masks
    then) and for one with pixels without a return (zero, infinite, too far), so its results files do not change."""
    for rgb, depth, T in frames[:6]:
        if holes:
            depth = depth.copy()
            depth[::7, ::5] = 0.0
            depth[40:60, 30:90] = np.inf
            depth[:10] = 7.0
        mapper = mapping.GeometricMapper(merge_every=100)
        mapper.integrate(rgb, depth, K, T)
        for got, want in zip(mapper._buffer[0], _reference_frame_sums(rgb, depth, T)):
            assert got.dtype == want.dtype and np.array_equal(got, want)


@pytest.mark.parametrize("unique_inverse", ["_unique_inverse", "_sorted_unique_inverse"])
def test_unique_inverse_equals_numpys(unique_inverse):
    """``mapping._unique_inverse`` (a frame's keys) and ``mapping._sorted_unique_inverse`` (the map's merge) give
    what ``np.unique(keys, return_inverse=True)`` gives (values, dtypes, shapes) for keys in runs, keys without runs,
    sorted runs one after another (a map and the frames merged into it), one key and none."""
    rng = np.random.default_rng(3)
    runs = np.repeat(rng.integers(-50, 50, size=300), rng.integers(1, 9, size=300))
    sorted_runs = np.concatenate([np.unique(rng.integers(-5000, 5000, size=n)) for n in (4000, 700, 700, 50)])
    for keys in (runs, rng.integers(-(1 << 40), 1 << 40, size=1000), sorted_runs, np.array([5]),
                 np.zeros(0, np.int64)):
        keys = keys.astype(np.int64)
        got, want = getattr(mapping, unique_inverse)(keys), np.unique(keys, return_inverse=True)
        for g, w in zip(got, want):
            assert g.dtype == w.dtype and g.shape == w.shape and np.array_equal(g, w)


def test_scipy_ndimage_is_imported_for_the_clustering_only():
    """Importing the example's mapper leaves SciPy's ``ndimage`` (0.17 s of the solution's start) unimported; the
    clustering at the end imports it."""
    import subprocess

    code = f"""
import sys
import numpy as np
sys.path.insert(0, {str(EXAMPLE_DIR)!r})
import mapping
assert "scipy.ndimage" not in sys.modules, "mapping imported scipy.ndimage"
mapping.GeometricMapper()._components(np.array([[0, 0, 0], [0, 0, 1], [5, 5, 5]]), 1)
assert "scipy.ndimage" in sys.modules
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_lab_conversion_matches_published_srgb_values():
    """sRGB → CIE L*a*b* (D65) against published values of the sRGB primaries, white, black and mid grey (Bruce
    Lindbloom's colour calculator, sRGB / D65: red 53.24, 80.09, 67.20; green 87.73, −86.18, 83.18; blue 32.30,
    79.19, −107.86; grey 128 53.59, 0, 0)."""
    lab = mapping._lab(np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255], [0, 0, 0], [128, 128, 128]]))
    expected = np.array([[53.24, 80.09, 67.20], [87.73, -86.18, 83.18], [32.30, 79.19, -107.86],
                         [100.0, 0.0, 0.0], [0.0, 0.0, 0.0], [53.59, 0.0, 0.0]])
    np.testing.assert_allclose(lab, expected, atol=0.05)


def _observations(rgb, depth, T) -> dict:
    """The BenchBot observations of one frame (``image_rgb``, ``image_depth``, intrinsics, the camera's pose)."""
    from scipy.spatial.transform import Rotation

    camera = {"translation_xyz": list(T[:3, 3]), "rotation_xyzw": list(Rotation.from_matrix(T[:3, :3]).as_quat())}
    return {"image_rgb": rgb, "image_depth": depth, "image_rgb_info": {"matrix_intrinsics": K.tolist()},
            "poses": {"camera": camera}, "scene_number": 0}


def test_fusing_ahead_on_a_thread_builds_the_same_map_bit_for_bit(frames):
    """The agent fuses each frame on its thread while the next step is on its way (the default): its map and objects
    equal those of an agent that fuses every frame in ``pick_action``, bit for bit."""
    script = _load("semslam_geometric_script", "semslam_geometric.py")
    maps = {}
    for ahead in (True, False):
        agent = script.GeometricAgent(fuse_ahead=ahead, stride=1)
        for rgb, depth, T in frames:
            assert agent.pick_action(_observations(rgb, depth, T), ["move_next"]) == ("move_next", {})
        objects = agent.build_objects(CLASS_LIST)
        maps[ahead] = (json.dumps(objects), *(a.tobytes() for a in agent.mappers[0].voxels()))
    assert len(json.loads(maps[True][0])) >= len(BOXES)
    assert maps[True] == maps[False]


def test_an_error_of_a_frame_fused_ahead_is_raised_at_the_next_step(frames):
    """A frame whose fusion fails on the agent's thread raises its error at the next ``pick_action``."""
    script = _load("semslam_geometric_script", "semslam_geometric.py")
    agent = script.GeometricAgent(stride=1)
    rgb, depth, T = frames[0]
    agent.pick_action(_observations(rgb, depth, T), ["move_next"])

    def broken(*frame):
        raise FloatingPointError("the frame cannot be fused")

    agent.mappers[0].integrate = broken
    agent.pick_action(_observations(rgb, depth, T), ["move_next"])
    with pytest.raises(FloatingPointError, match="cannot be fused"):
        agent.pick_action(_observations(rgb, depth, T), ["move_next"])


def test_dilating_by_the_cube_one_axis_at_a_time_equals_scipys_binary_dilation():
    """``mapping._dilate_by_cube`` (the clustering's bridge over one-voxel gaps) equals
    ``scipy.ndimage.binary_dilation`` by the 3 × 3 × 3 cube, at the grid's faces and on axes one voxel long."""
    from scipy import ndimage

    rng = np.random.default_rng(7)
    for shape, fill in (((17, 9, 5), 0.05), ((1, 12, 7), 0.2), ((6, 1, 1), 0.5), ((30, 20, 10), 0.01)):
        grid = rng.random(shape) < fill
        grid[0, 0, 0] = grid[-1, -1, -1] = True
        want = ndimage.binary_dilation(grid, structure=np.ones((3, 3, 3), bool))
        got = mapping._dilate_by_cube(grid)
        assert got.dtype == want.dtype and np.array_equal(got, want)
        assert np.array_equal(mapping._dilate_by_cube(got), ndimage.binary_dilation(grid, np.ones((3, 3, 3), bool),
                                                                                    iterations=2))


def test_the_map_is_the_same_bit_for_bit_however_many_frames_are_buffered(frames):
    """Frames merged into the map one at a time, by threes, by eights (the old default) or all at the end give the
    same voxels, sums and objects, bit for bit: ``merge_every`` is a matter of speed only."""
    maps = set()
    for merge_every in (1, 3, 8, 32, 1000):
        mapper = mapping.GeometricMapper(merge_every=merge_every)
        for rgb, depth, T in frames:
            depth = depth.copy()
            depth[::9, ::4] = 0.0  # pixels without a return: the masked path
            mapper.integrate(rgb, depth, K, T)
        maps.add((b"".join(a.tobytes() for a in mapper.voxels()), json.dumps(mapper.build_map(CLASS_LIST))))
    assert len(maps) == 1
