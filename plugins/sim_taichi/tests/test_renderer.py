"""The Taichi kernels against the NumPy reference, and known geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchbot.core.geometry import se2_to_matrix


def _cam(x, y, yaw, h=0.8):
    from benchbot_sim_taichi.backend import R_BODY_OPTICAL

    T = np.eye(4)
    T[:3, :3] = R_BODY_OPTICAL
    T[:3, 3] = (0.0, 0.0, h)
    return se2_to_matrix(x, y, yaw) @ T


@pytest.mark.parametrize("key,pose_index", [("miniroom:1", 0), ("miniroom:3", 20), ("house:2", 40), ("house:5", 100)])
def test_render_matches_numpy_reference(bear_envs, key, pose_index):
    from benchbot_sim_taichi.render.reference import render_reference
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    scene = build_scene(bear_envs[key])
    r = Renderer("cpu")
    r.set_scene(scene)
    W, H = 64, 48
    K = intrinsics(W, H, 90.0)
    x, y, yaw = scene.trajectory_se2[pose_index]
    T = _cam(x, y, yaw)
    got = r.render(K, T, W, H)
    ref = render_reference(scene, K, T, W, H)
    assert got["rgb"].shape == (H, W, 3) and got["rgb"].dtype == np.uint8
    assert got["depth"].shape == (H, W) and got["depth"].dtype == np.float32
    same = got["class"] == ref["class"]
    assert (~same).sum() <= 6
    assert ((got["instance"] != ref["instance"]).sum()) <= 6
    close = np.isclose(got["depth"], ref["depth"], rtol=1e-4, atol=1e-4)
    assert (~close).sum() <= 6
    diff = np.abs(got["rgb"].astype(int) - ref["rgb"].astype(int)).max(axis=2)
    assert (diff > 2).sum() <= 8, np.sort(diff.ravel())[-10:]
    assert np.all(got["depth"] > 0)  # the shell closes the room


def test_scan_matches_numpy_reference(bear_envs):
    from benchbot_sim_taichi.render.reference import scan_reference
    from benchbot_sim_taichi.render.renderer import Renderer
    from benchbot_worlds.scene.build import build_scene

    scene = build_scene(bear_envs["house:1"])
    r = Renderer("cpu")
    r.set_scene(scene)
    angles = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    T = se2_to_matrix(*scene.start_se2, z=0.3)
    got = r.scan(T, angles)
    assert got.dtype == np.float64 and got.shape == (720,)
    np.testing.assert_allclose(got, scan_reference(scene, T, angles), rtol=1e-4, atol=1e-4)


def test_depth_of_known_box(synthetic_env):
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    # a 1 m cube whose near face is the plane x = 2.0, camera at the origin looking along +x at 0.8 m
    env = synthetic_env([("chair", (2.5, 0.0, 0.8), (1.0, 1.0, 1.0))])
    env["procedural"] = False  # one box per object
    scene = build_scene(env)
    r = Renderer("cpu")
    r.set_scene(scene)
    W, H = 64, 48
    K = intrinsics(W, H, 60.0)
    out = r.render(K, _cam(0.0, 0.0, 0.0), W, H)
    d = out["depth"]
    c = (H // 2, W // 2)
    assert d[c] == pytest.approx(2.0, abs=1e-5)
    assert out["class"][c] == 0 and out["instance"][c] == 1
    # the face is a plane of constant z-depth; back-projected pixels lie on x = 2
    face = out["instance"] == 1
    assert face.sum() > 50
    np.testing.assert_allclose(d[face], 2.0, atol=1e-5)
    v, u = np.nonzero(face)
    pts = (np.linalg.inv(K) @ np.stack([u, v, np.ones_like(u)])) * d[face]
    world = _cam(0.0, 0.0, 0.0)[:3, :3] @ pts + _cam(0.0, 0.0, 0.0)[:3, 3:4]
    np.testing.assert_allclose(world[0], 2.0, atol=1e-4)
    assert np.all(np.abs(world[1]) <= 0.5 + 1e-4) and np.all(np.abs(world[2] - 0.8) <= 0.5 + 1e-4)
    # background pixels are the shell: class 'background' (2), instance 0
    bg = ~face
    assert np.all(out["class"][bg] == 2) and np.all(out["instance"][bg] == 0)


def test_laser_sees_wall(synthetic_env):
    from benchbot_sim_taichi.render.renderer import Renderer
    from benchbot_worlds.scene.build import build_scene

    # one low box far away to one side sets the room extent; the robot at the origin
    env = synthetic_env([("table", (3.0, 2.0, 0.4), (0.5, 0.5, 0.8))])
    env["procedural"] = False  # one box per object
    scene = build_scene(env)
    r = Renderer("cpu")
    r.set_scene(scene)
    T = se2_to_matrix(0.0, 0.0, 0.0, z=0.3)
    ranges = r.scan(T, np.array([0.0, math.pi / 2, -math.pi / 2, math.pi - 1e-9]))
    np.testing.assert_allclose(ranges[0], scene.room_max[0], atol=1e-4)  # +x wall
    np.testing.assert_allclose(ranges[1], scene.room_max[1], atol=1e-4)  # +y wall
    np.testing.assert_allclose(ranges[2], -scene.room_min[1], atol=1e-4)  # -y wall
    np.testing.assert_allclose(ranges[3], -scene.room_min[0], atol=1e-4)  # -x wall
    # the box at the laser height is seen at the right range
    yaw = math.atan2(2.0, 2.75)
    rb = r.scan(se2_to_matrix(0.0, 0.0, yaw, z=0.3), np.array([0.0]))
    assert rb[0] == pytest.approx(math.hypot(2.75, 2.75 * math.tan(yaw)), abs=1e-3)
    assert rb[0] < ranges[0]


def test_device_buffers_and_render_sensors_match_the_numpy_path(bear_envs):
    """The device-buffer path (Taichi ndarrays: GPU memory on CUDA, exercised here on the CPU) gives the same
    images and scans as the NumPy path; one render_sensors launch equals per-view render() and scan() calls."""
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    scene = build_scene(bear_envs["house:1"])
    W, H = 48, 36
    K = intrinsics(W, H, 90.0)
    poses = scene.trajectory_se2[[0, 30, 60]]
    cams = np.stack([_cam(*p) for p in poses])
    lidars = np.stack([se2_to_matrix(*p, z=0.3) for p in poses])
    angles = np.radians(np.arange(-180.0, 180.0, 2.0))
    host = Renderer("cpu", device_buffers=False)
    host.set_scene(scene)
    dev = Renderer("cpu")  # device buffers and the compiled graph: the default on every arch
    dev.set_scene(scene)
    assert dev.device_buffers and not host.device_buffers
    a = host.render_sensors(K, cams, W, H, lidars, angles)
    b = dev.render_sensors(K, cams, W, H, lidars, angles)
    assert set(a) == set(b) == {"rgb", "depth", "class", "instance", "ranges"}
    for k in a:
        assert isinstance(b[k], np.ndarray) and np.array_equal(a[k], b[k]), k
    pinned = dev.render_sensors(K, cams, W, H, lidars, angles, to_host="pinned")  # CUDA's reused host arrays
    assert all(np.array_equal(a[k], pinned[k]) for k in a)
    with pytest.raises(ValueError, match="to_host must be"):
        dev.render_sensors(K, cams, W, H, lidars, angles, to_host="gpu")
    kept = dev.render_sensors(K, cams, W, H, lidars, angles, to_host=False)
    dev.sync()
    assert not isinstance(kept["rgb"], np.ndarray) and np.array_equal(kept["rgb"].to_numpy(), a["rgb"])
    for i in range(len(poses)):
        one = dev.render(K, cams[i], W, H)
        assert all(np.array_equal(one[k], a[k][i]) for k in one)
        assert np.array_equal(dev.scan(lidars[i], angles), a["ranges"][i].astype(np.float64))
    with pytest.raises(ValueError, match="lidar poses"):
        host.render_sensors(K, cams, W, H, lidars[:2], angles)
    with pytest.raises(ValueError, match="needs angles"):
        host.render_sensors(K, cams, W, H, lidars)
    # a kernel timer (benchmarks/sensors_kernels.py) runs each kernel inside it, instead of the compiled graph,
    # and changes nothing in what comes out
    from contextlib import contextmanager

    from benchbot_sim_taichi.render.sensors import sensors_kernels

    seen = []

    @contextmanager
    def timer(name):
        seen.append(name)
        yield

    for renderer in (host, dev):
        renderer.kernel_timer = timer
        seen.clear()
        timed = renderer.render_sensors(K, cams, W, H, lidars, angles)
        assert seen == [k.__name__ for k in sensors_kernels("cpu")]
        assert all(np.array_equal(a[k], timed[k]) for k in a)


@pytest.mark.parametrize("camera", ["default", "filmic", "metered"])
def test_quality_mode_finished_in_device_memory_equals_the_numpy_path(bear_envs, camera):
    """Quality mode with device buffers (GPU memory on CUDA; exercised here on the CPU, where OIDN's CPU device reads
    the Taichi ndarrays in place) denoises where the path tracer wrote its images and encodes them there with the
    camera model (``pathtrace.encode_kernel``, float64): every output equals the NumPy path's, bit for bit, denoised
    or not, for the default camera, one with exposure, the filmic curve and vignetting, and one that meters its
    exposure (the meter's pixels gathered on the device, ``pathtrace.meter_sample_kernel``)."""
    from benchbot_sim_taichi.render.camera_model import CameraModel
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    model = {"default": CameraModel(), "filmic": CameraModel(exposure_ev=0.7, tone_curve="filmic", vignetting=0.6),
             "metered": CameraModel(exposure_ev=-0.5, tone_curve="filmic", vignetting=0.3, auto_exposure=True)}[camera]
    scene = build_scene(bear_envs["miniroom:1"])
    W, H = 40, 30
    K = intrinsics(W, H, 90.0)
    T = _cam(*scene.trajectory_se2[5])
    host = Renderer("cpu", device_buffers=False, camera=model)
    host.set_scene(scene)
    dev = Renderer("cpu", device_buffers=True, camera=model)
    dev.set_scene(scene)
    for denoise in (True, False):
        a = host.render(K, T, W, H, mode="quality", spp=2, denoise=denoise)
        b = dev.render(K, T, W, H, mode="quality", spp=2, denoise=denoise)
        assert set(a) == set(b) == {"rgb", "depth", "class", "instance", "radiance"}
        for k in a:
            assert isinstance(b[k], np.ndarray) and b[k].dtype == a[k].dtype and np.array_equal(a[k], b[k]), k
    assert ("quality_denoised", (1, H, W, 3)) in dev._buffers  # the in-place path ran (the NumPy one has no buffers)
    assert (("quality_meter", (1, 4, 5, 3)) in dev._buffers) == model.auto_exposure
    b["rgb"][:] = 0  # the caller owns what it got: the next frame is not written into it
    assert np.array_equal(dev.render(K, T, W, H, mode="quality", spp=2, denoise=False)["rgb"], a["rgb"])


def test_device_arrays_of_a_renderer_dropped_on_another_thread_are_freed_on_the_taichi_thread(bear_envs):
    """Freeing GPU memory off Taichi's thread aborts a CUDA process, so a Renderer dropped (or garbage-collected)
    on another thread only retires its device arrays; they are freed on the rendering thread once nothing else
    refers to them (exercised with device buffers on the CPU, where the bookkeeping is the same)."""
    import threading

    from benchbot_sim_taichi.render import renderer as rmod
    from benchbot_sim_taichi.render.host_copy import host_view
    from benchbot_sim_taichi.render.scene_arrays import SceneArrays
    from benchbot_worlds.scene.build import build_scene

    scene = build_scene(bear_envs["miniroom:1"])
    K = rmod.intrinsics(16, 12, 90.0)
    cam = _cam(*scene.trajectory_se2[0])
    import gc

    gc.collect()  # renderers of earlier tests left in reference cycles are retired now, not during this test
    rmod._free_retired()
    elsewhere = len(rmod._RETIRED)  # retired arrays that something outside this test still holds: left alone
    held_before = len(rmod._DEVICE_ARRAYS)
    owner = rmod.Renderer("cpu", device_buffers=True)
    owner.set_scene(scene)
    kept = owner.render_sensors(K, cam[None], 16, 12, to_host=False)["depth"]  # a caller still holds an output
    made = len(rmod._DEVICE_ARRAYS) - held_before
    assert made >= len(SceneArrays.arrays()) + 4

    box = [owner]
    del owner
    dropper = threading.Thread(target=box.clear)  # the last reference goes on another thread
    dropper.start()
    dropper.join()
    assert len(rmod._DEVICE_ARRAYS) == held_before and len(rmod._RETIRED) == elsewhere + made  # nothing freed there
    assert rmod._free_retired() == elsewhere + 1  # on this (Taichi's) thread: all freed but the output still held
    assert np.isfinite(host_view(kept)).all() and kept.shape == (1, 12, 16)  # and that one is still valid (not
    # to_numpy: its first call in a process compiles a copy kernel, which keeps its arguments in a reference cycle)
    del kept
    assert rmod._free_retired() == elsewhere

    closing = rmod.Renderer("cpu", device_buffers=True)
    closing.set_scene(scene)
    closing.render(K, cam, 16, 12)
    closing.close()  # frees at once, on this thread
    assert len(rmod._DEVICE_ARRAYS) == held_before and len(rmod._RETIRED) == elsewhere
    with pytest.raises(RuntimeError, match="set_scene"):
        closing.render(K, cam, 16, 12)


def test_host_view_shows_an_ndarrays_memory_and_keeps_it_alive():
    """On the CPU, ``host_copy.host_view`` is a NumPy array over a Taichi ndarray's own memory (what the renderer's
    outputs are copied from): it shows what a kernel wrote there, of the ndarray's dtype and shape, and holds the
    ndarray, so dropping every other reference does not free the memory under it."""
    import gc

    import taichi as ti

    from benchbot_sim_taichi.render.host_copy import host_view
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")
    for dtype, np_dtype in ((ti.f32, np.float32), (ti.i64, np.int64), (ti.u8, np.uint8)):
        nd = ti.ndarray(dtype=dtype, shape=(3, 5, 2))
        values = (np.arange(30).reshape(3, 5, 2) * 7 % 251).astype(np_dtype)
        nd.from_numpy(values)
        view = host_view(nd)
        assert view.dtype == np_dtype and view.shape == (3, 5, 2) and np.array_equal(view, values)
        nd.fill(3)  # a kernel writes: the view shows it
        assert (view == 3).all()
        root = view
        while isinstance(root, np.ndarray):
            root = root.base
        assert root.owner is nd  # the view's buffer holds the ndarray
        del nd
        gc.collect()
        assert (view == 3).all()  # still the ndarray's memory, held by the view


def test_compiling_the_sensors_graph_leaves_no_ndarray_for_the_garbage_collector():
    """Taichi's graph compiler makes placeholder ndarrays that end up in reference cycles; the collector would
    free them on whatever thread it runs, which aborts a CUDA process off Taichi's thread. Compiling collects them
    on the compiling thread."""
    import gc

    from taichi.lang._ndarray import Ndarray

    from benchbot_sim_taichi.render import renderer as rmod
    from benchbot_sim_taichi.render import sensors

    rmod.ensure_taichi("cpu")
    sensors.reset_graph()
    gc.collect()  # ndarrays of earlier tests' renderers, freed now: only the compiler's own may count below
    rmod._free_retired()
    gc.disable()  # so that nothing but the compiler's own collect runs during the compile
    try:
        sensors.sensors_graph("cpu")
        tracked = set(rmod._DEVICE_ARRAYS) | {id(a) for a in rmod._RETIRED}  # the renderer's own, held or retired
        stray = [o for o in gc.get_objects() if isinstance(o, Ndarray) and id(o) not in tracked]
    finally:
        gc.enable()
    assert stray == []


def test_a_lamps_own_shade_does_not_shadow_the_ceiling_around_it(synthetic_env):
    """A point light 5 cm under a 0.6 m wide shade (a ceiling lamp): the ceiling around the shade is lit (shadow rays
    stop LAMP_FIXTURE_M short of a point light), in the kernels and in the NumPy reference alike; shadows of
    anything farther from the light stay."""
    from benchbot_sim_taichi.render.kernels import LAMP_FIXTURE_M
    from benchbot_sim_taichi.render.reference import render_reference
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene
    from benchbot_worlds.scene.model import LIGHT_POINT

    env = synthetic_env([("table", (3.0, 0.0, 2.15), (0.6, 0.6, 0.1)), ("chair", (0.5, 3.0, 0.3), (0.4, 0.4, 0.6))])
    scene = build_scene({**env, "procedural": False})  # the shade: one box
    assert abs(float(scene.room_max[2]) - 2.6) < 1e-6 and LAMP_FIXTURE_M > 2.6 - 2.05  # ceiling within reach
    scene.ambient = np.zeros(3, np.float32)
    scene.light_kind = np.array([LIGHT_POINT], np.int32)
    scene.light_vec = np.array([[3.0, 0.0, 2.05]], np.float32)
    scene.light_colour = np.array([[1.0, 1.0, 1.0]], np.float32)
    scene.light_range = np.array([6.0], np.float32)
    r = Renderer("cpu")
    r.set_scene(scene)
    W, H = 48, 48
    K = intrinsics(W, H, 90.0)
    up = np.eye(4)  # optical z (forward) = map +z: looking straight up from 0.3 m under the lamp
    up[:3, 3] = (3.0, 0.0, 0.3)
    got = r.render(K, up, W, H)
    ref = render_reference(scene, K, up, W, H)
    ceiling = np.isclose(got["depth"], 2.3, atol=1e-3)  # the ceiling seen around the shade
    assert ceiling.sum() > 0.3 * W * H
    assert got["rgb"][ceiling].min() > 20, "the shade shadows the ceiling"
    diff = np.abs(got["rgb"].astype(int) - ref["rgb"].astype(int)).max(axis=2)
    assert (diff > 2).sum() <= 8
    down = np.diag([1.0, -1.0, -1.0, 1.0])  # looking straight down at the floor
    down[:3, 3] = (3.0, 0.0, 1.5)  # under the lamp: lit (a pendant lamp shines down; its fixture casts no shadow)
    assert r.render(K, down, W, H)["rgb"][H // 2, W // 2].min() > 20
    down[:3, 3] = (0.07, 3.51, 1.0)  # behind the chair, seen from the lamp: the chair's shadow stays
    assert r.render(K, down, W, H)["rgb"][H // 2 - 1:H // 2 + 1, W // 2 - 1:W // 2 + 1].max() == 0


@pytest.mark.slow  # subprocesses that build a furnished scene and render it both ways
def test_the_cpu_paths_benchmark_and_render_py_numpy_buffers():
    """``benchmarks/cpu_paths.py`` (the CPU's two launch paths, in the docs), tiny: one burst of each path per round,
    the rates and their ratio reported, a bad count refused in one line; ``benchmarks/render.py --numpy-buffers``
    runs the renderer without device buffers and says so in its JSON."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    script = [sys.executable, str(root / "benchmarks" / "cpu_paths.py")]
    proc = subprocess.run(script + ["--env", "miniroom:1", "--width", "32", "--height", "24", "--rounds", "2",
                                    "--frames", "2", "--json"], capture_output=True, text=True, timeout=900, cwd=root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout)
    assert set(out["fps"]) == {"graph", "numpy"} and all(len(v) == 2 and min(v) > 0 for v in out["fps"].values())
    assert out["ratio_min"] <= out["ratio_graph_over_numpy"] <= out["ratio_max"] and out["frames_per_burst"] == 2
    bad = subprocess.run(script + ["--rounds", "0"], capture_output=True, text=True, timeout=120, cwd=root)
    assert bad.returncode == 2 and "must be at least 1" in bad.stderr and "Traceback" not in bad.stderr
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "render.py"), "--env", "miniroom:1", "--width",
                           "32", "--height", "24", "--frames", "2", "--numpy-buffers", "--no-embree", "--json"],
                          capture_output=True, text=True, timeout=900, cwd=root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout)
    assert out["device_buffers"] is False and out["fps"] > 0 and out["fps_with_host_copy"] == out["fps"]
