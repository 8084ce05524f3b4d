"""tools/render_gallery.py: views through the robot's default camera, several views spread along the trajectory,
and the before/after contact sheet of two styles seen from the same poses (a real render of miniroom:4, small)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def gallery():
    spec = importlib.util.spec_from_file_location("render_gallery_tool", ROOT / "tools" / "render_gallery.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["render_gallery_tool"] = mod
    spec.loader.exec_module(mod)
    yield mod
    sys.modules.pop("render_gallery_tool", None)


def test_views_are_the_robot_cameras_own(gallery):
    """``--robot-camera`` views are the default camera's poses on the trajectory (``backend.trajectory_cameras``),
    and the field of view is the default camera's."""
    from benchbot_sim_taichi.backend import DEFAULT_SENSORS, trajectory_cameras

    scene = SimpleNamespace(start_se2=np.zeros(3), trajectory_se2=np.array([[1.0, 2.0, 0.3], [-0.5, 0.25, -2.0]]))
    for pose, T in zip(scene.trajectory_se2, trajectory_cameras(scene)):
        np.testing.assert_allclose(gallery.view_camera(pose, None), T, atol=1e-12)
    assert gallery.view_camera(scene.trajectory_se2[0], 1.1)[2, 3] == pytest.approx(1.1)
    assert gallery.FOV_DEG == DEFAULT_SENSORS["camera"]["horizontal_fov_deg"]


@pytest.mark.slow
def test_contact_sheet_and_views_of_two_styles(gallery, tmp_path, monkeypatch):
    monkeypatch.setenv("BENCHBOT_SCENE_CACHE_BYTES", "0")  # build here, leave no cache behind
    common = ["--envs", "miniroom:4", "--modes", "fast", "--views", "2", "--robot-camera", "--width", "64",
              "--height", "48", "--every", "8", "--shadow-samples", "1", "--out", str(tmp_path)]
    assert gallery.main(common + ["--styles", "primitives"]) == 0
    views = [cv2.imread(str(tmp_path / f"miniroom_4_primitives_fast_{n}.png")) for n in (1, 2)]
    assert all(v is not None and v.shape == (48, 64, 3) for v in views)
    assert not np.array_equal(views[0], views[1])  # two poses, two pictures
    assert not (tmp_path / "miniroom_4_plan.png").exists()  # primitives have no plan
    assert gallery.main(common + ["--styles", "primitives,primitives", "--sheet"]) == 0
    sheet = cv2.imread(str(tmp_path / "miniroom_4_sheet.jpg"))
    assert sheet.shape == (2 * 48, 2 * 64, 3)  # rows: the two styles, columns: the two views
    top, bottom = sheet[:48].astype(int), sheet[48:].astype(int)
    assert np.abs(top - bottom).mean() < 2.0  # the same world from the same poses (up to the JPEG)
    assert np.abs(top[30:, :64] - views[0][30:].astype(int)).mean() < 8.0  # the first view, below its label


def test_views_are_chosen_by_the_objects_they_show(gallery):
    """A view's worth: objects of at least MIN_OBJECT_PIXELS pixels (a wall of one fridge counts once), then pixels."""
    img = np.zeros((120, 160), np.int32)
    img[:100, :100] = 72001  # one object filling the view
    assert gallery.objects_seen(img) == (1, 10000)
    img[:] = 0
    img[0:5, 0:5], img[10:15, 10:15], img[20:22, 20:22] = 19001, 18001, 18002  # two seen, one too small
    assert gallery.objects_seen(img) == (2, 54)
    assert gallery.objects_seen(img, min_pixels=4) == (3, 54)


@pytest.mark.parametrize("argv, message", [
    (["--envs", "miniroom:1,miniroom:9"], "--envs: no environment named 'miniroom:9'"),
    (["--styles", "fancy"], "--styles must be a comma-separated list of furnished, primitives"),
    (["--width", "0"], "--width must be 1 or more"),
    (["--every", "0"], "--every must be 1 or more"),
])
def test_a_bad_flag_is_one_line_before_anything_is_rendered(gallery, tmp_path, capsys, argv, message):
    """Before: an unknown environment or style, or --width 0, ended in a traceback (a SpecError, a BackendError
    from build_scene, Taichi's 'not a valid shape'), the unknown environment only after the homes before it."""
    with pytest.raises(SystemExit) as exc:
        gallery.main(argv + ["--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and message in err.splitlines()[-1] and "Traceback" not in err
    assert not (tmp_path / "out").exists()
