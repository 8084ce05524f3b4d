"""A world is checked when installed: ``benchbot install`` refuses a content pack whose layouts hold unknown
classes, objects of no size or far from the rest of the home, or start/trajectory poses inside objects, with one line
per problem naming the file, the object and the fix (benchbot.packs.layout_checks); the ten BEAR homes pass."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot.packs import content_packs as cp
from benchbot.packs.layout_checks import FAR_FROM_HOME_M, MAX_PROBLEMS_PER_FILE, layout_problems
from benchbot.core.registry import Registry

BEAR = Path(__file__).resolve().parents[1] / "plugins/worlds/benchbot_worlds/data/bear"
GT = "ground_truths/room_1.json"
ENV = "environments/room.yaml"


pytestmark = pytest.mark.usefixtures("data_dir")  # tests/conftest.py


def miniroom() -> dict:
    """miniroom:1's published layout, renamed to the pack's environment ``hostile_room:1``."""
    data = json.loads((BEAR / "miniroom_1.json").read_text())
    data["environment"] = {k: v for k, v in data["environment"].items() if k != "_file_path"}
    data["environment"].update(name="hostile_room", variant=1)
    return data


def make_pack(root: Path, layout: dict, start_pose: list | None = None) -> Path:
    """A pack with the layout as ground truth and as the map of environment ``hostile_room:1``."""
    (root / "ground_truths").mkdir(parents=True)
    (root / "environments").mkdir()
    (root / GT).write_text(json.dumps(layout))
    env = {"name": "hostile_room", "variant": 1, "type": "sim_taichi", "map_path": "../" + GT,
           "start_pose": start_pose or layout["environment"]["start_pose"],
           "trajectory_poses": layout["environment"]["trajectory_poses"]}
    (root / ENV).write_text(json.dumps(env))
    return root


def cli_install(pack: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "benchbot.cli", "install", str(pack)], capture_output=True, text=True,
                          env={**os.environ, "BENCHBOT_ONLY_PLUGINS": "content_packs,sim_taichi"}, timeout=120)


def _unknown_class(layout):
    layout["ground_truth"]["objects"][0]["class"] = "spaceship"


def _far_away(layout):
    stray = copy.deepcopy(layout["ground_truth"]["objects"][3])
    stray["ID_name"] = "stray_table"
    stray["centroid"][0] += 20.0
    layout["ground_truth"]["objects"].append(stray)


def _zero_extent(layout):
    layout["ground_truth"]["objects"][5]["extent"][2] = 0.0


def _negative_extent(layout):
    layout["ground_truth"]["objects"][5]["extent"][0] = -0.1


def _trajectory_pose_in_bed(layout):
    bed = layout["ground_truth"]["objects"][2]["centroid"]
    layout["environment"]["trajectory_poses"][4][4:6] = bed[:2]


HOSTILE = {
    "unknown class": (_unknown_class, None,
                      f"{GT}: ground_truth.objects[0] 'gadget_073_alrmclock_v1_10' (class 'spaceship'): class "
                      "'spaceship' is not in ground_truth.class_list; use one of its classes"),
    "far away": (_far_away, None,
                 f"{GT}: ground_truth.objects[18] 'stray_table' (class 'table'): 1"),
    "zero extent": (_zero_extent, None,
                    f"{GT}: ground_truth.objects[5] 'prop_books_025_33' (class 'book'): extent [0.16590765999999998, "
                    "0.0487535, 0.0] has a side ≤ 0 m; give every side a positive size"),
    "negative extent": (_negative_extent, None,
                        f"{GT}: ground_truth.objects[5] 'prop_books_025_33' (class 'book'): extent [-0.1, "),
    "start pose in the bed": (None, "bed",
                              f"{ENV}: start_pose at x=2.201, y=0.059 m is inside the footprint of {GT}'s "
                              "ground_truth.objects[2] 'SM_MERGED_SM_MERGED_SM_AI_vol3_3_bed_01_v7_0' (class 'bed'); "
                              "move the pose out of the object"),
    "trajectory pose in the bed": (_trajectory_pose_in_bed, None,
                                   f"{ENV}: trajectory_poses[4] at x=2.201, y=0.059 m is inside the footprint of "
                                   f"{GT}'s ground_truth.objects[2]"),
}


def _hostile_pack(root: Path, case: str) -> Path:
    change, start, _ = HOSTILE[case]
    layout = miniroom()
    if change:
        change(layout)
    pose = None
    if start == "bed":
        bed = layout["ground_truth"]["objects"][2]["centroid"]
        pose = [1.0, 0.0, 0.0, 0.0, bed[0], bed[1], 0.0]
    return make_pack(root, layout, pose)


def test_the_ten_bear_homes_pass_the_checks(registry):
    envs = [registry.get("environments", f"{n}:{v}") for n in ("miniroom", "house") for v in range(1, 6)]
    for env in envs:
        layout = json.loads(Path(env["map_path"]).read_text())
        assert layout_problems(layout, source=env["map_path"], start_pose=env["start_pose"],
                               trajectory_poses=env["trajectory_poses"]) == [], env["name"]
        assert layout_problems(layout, source=env["map_path"]) == []  # the file's own poses too


def test_an_unchanged_copy_of_a_bear_home_installs(tmp_path):
    manifest = cp.install_pack(make_pack(tmp_path / "fine", miniroom()), registry=Registry())
    assert manifest["files"]["environments"] == ["hostile_room:1"]


@pytest.mark.parametrize("case", list(HOSTILE))
def test_a_hostile_layout_is_refused_in_process(tmp_path, case):
    with pytest.raises(cp.PackError, match="nothing installed") as exc:
        cp.install_pack(_hostile_pack(tmp_path / "hostile", case), registry=Registry())
    assert any(line.startswith(HOSTILE[case][2]) for line in exc.value.details), exc.value.details
    assert all("\n" not in line for line in exc.value.details)
    assert not (tmp_path / "data" / "packs" / "hostile").exists()


@pytest.mark.slow
@pytest.mark.parametrize("case", list(HOSTILE))
def test_benchbot_install_refuses_a_hostile_layout_with_one_line(tmp_path, case):
    proc = cli_install(_hostile_pack(tmp_path / "hostile", case))
    assert proc.returncode == 3, proc.stderr
    lines = [line.strip() for line in proc.stderr.splitlines()]
    assert any(line.startswith(HOSTILE[case][2]) for line in lines), proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_benchbot_install_takes_the_unchanged_copy(tmp_path):
    proc = cli_install(make_pack(tmp_path / "fine", miniroom()))
    assert proc.returncode == 0, proc.stderr


def test_far_limit_and_problem_cap(tmp_path):
    layout = miniroom()
    objects = layout["ground_truth"]["objects"]
    near = copy.deepcopy(objects[3])
    near["centroid"][0] += FAR_FROM_HOME_M - 1.0  # within the limit of the others' bounding box: accepted
    objects.append(near)
    assert layout_problems(layout, source="x.json") == []
    for i in range(MAX_PROBLEMS_PER_FILE + 5):
        objects.append({"class": f"alien{i}", "centroid": [0, 0, 1], "extent": [0.1, 0.1, 0.1]})
    problems = layout_problems(layout, source="x.json")
    assert len(problems) == MAX_PROBLEMS_PER_FILE + 1 and problems[-1] == "x.json: and 5 more problem(s) like these"
    assert layout_problems([1, 2], source="x.json")[0].startswith("x.json: not a ground-truth layout")


def test_a_huge_layout_is_checked_in_bounded_work(monkeypatch):
    """A hostile pack's layout of many objects and poses: "did you mean" is worked out only for the lines shown (it
    is O(classes) per name), and a pose inside several objects names the first of them, as the objects are listed."""
    from benchbot.packs import layout_checks

    calls = []
    real = layout_checks.close_names
    monkeypatch.setattr(layout_checks, "close_names", lambda *a, **k: calls.append(a) or real(*a, **k))
    n = 2000
    objects = [{"class": f"alien{i}", "centroid": [i * 0.01, 0, 0.5], "extent": [0.001, 0.001, 1.0]} for i in range(n)]
    objects += [{"class": "chair", "centroid": [3.0, 3.0, 0.5], "extent": [1.0, 1.0, 1.0], "ID_name": name}
                for name in ("first", "second")]
    layout = {"ground_truth": {"class_list": ["chair", *(f"c{i}" for i in range(200))], "objects": objects}}
    poses = [[1, 0, 0, 0, -5.0, 3.0, 0]] * 500 + [[1, 0, 0, 0, 3.1, 2.9, 0]]
    problems = layout_problems(layout, source="x.json", trajectory_poses=poses)
    assert len(calls) <= MAX_PROBLEMS_PER_FILE
    assert problems[-1] == f"x.json: and {n + 1 - MAX_PROBLEMS_PER_FILE} more problem(s) like these"
    last = layout_problems({"ground_truth": {"class_list": ["chair"], "objects": objects[n:]}}, source="x.json",
                           trajectory_poses=poses)
    assert last == ["x.json: trajectory_poses[500] at x=3.100, y=2.900 m is inside the footprint of x.json's "
                    "ground_truth.objects[0] 'first' (class 'chair'); move the pose out of the object "
                    "(or the object away from the pose)"]
