"""Two checks of ``benchbot install`` on a content pack's environments: a ``map_path`` naming no file of the pack is
refused at install (it used to install with exit 0 and fail only when the environment was used), and a start pose
whose quaternion is not unit length installs, read as the original BenchBot read it, with a warning naming the pose
and both headings."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from benchbot.core.geometry import pose7_to_se2, start_pose_to_se2
from benchbot.core.registry import Registry

ROOT = Path(__file__).resolve().parents[1]
MINIROOM_1 = ROOT / "tests" / "data" / "original_addons" / "ground_truths_isaac_develop" / "ground_truths" \
    / "miniroom_1.json"

pytestmark = pytest.mark.usefixtures("data_dir")


def install(*args: str):
    from benchbot.cli.main import app

    return CliRunner().invoke(app, ["install", *args], env={"COLUMNS": "400"})


def room_pack(tmp_path: Path, map_path: str, start_pose: str, name: str = "rooms") -> Path:
    """A pack with one environment ``myroom:1`` (BEAR's miniroom:1 layout in ``maps/room_1.json``)."""
    pack = tmp_path / name
    (pack / "environments").mkdir(parents=True)
    (pack / "maps").mkdir()
    shutil.copy(MINIROOM_1, pack / "maps" / "room_1.json")
    (pack / "environments" / "room.yaml").write_text(
        f"name: myroom\nvariant: 1\ntype: sim_taichi\nmap_path: {map_path}\nstart_pose: {start_pose}\n")
    return pack


@pytest.mark.parametrize("dry_run", [False, True])
def test_a_map_path_naming_no_file_is_refused_at_install(tmp_path, data_dir, dry_run):
    pack = room_pack(tmp_path, "../maps/room_2.json", "[0.7, 0, 0, -0.7, 1.2, 1.5, 0.3]")
    result = install(str(pack), *(["--dry-run"] if dry_run else []))
    assert result.exit_code == 3 and "Traceback" not in result.stderr
    assert ("environments/room.yaml: $.map_path: '../maps/room_2.json' names no file of the pack (it would be "
            "maps/room_2.json): put the map file there, or correct map_path (a path relative to the environment "
            "file)") in result.stderr
    assert not (data_dir / "packs" / "rooms").exists()
    (pack / "maps" / "room_1.json").rename(pack / "maps" / "room_2.json")
    assert install(str(pack)).exit_code == 0  # the file in place: it installs


def test_a_map_file_removed_after_the_install_is_reported_by_the_registry(tmp_path, data_dir):
    """The registry scans installed packs with the install's checks: the environment is left out with its line."""
    pack = room_pack(tmp_path, "../maps/room_1.json", "[1, 0, 0, 0, 1.2, 1.5, 0.3]")
    assert install(str(pack)).exit_code == 0
    assert "myroom:1" in Registry().names("environments")
    (data_dir / "packs" / "rooms" / "maps" / "room_1.json").unlink()
    reg = Registry()
    assert "myroom:1" not in reg.names("environments")
    assert any("$.map_path: '../maps/room_1.json' names no file of the pack" in p for p in reg.problems.values())


@pytest.mark.parametrize("quaternion, read_deg, normalised_deg", [
    ("1, 0, 0, 0.8", 99.9, 77.3),     # the original's house environments: length 1.281
    ("0.7, 0, 0, -0.7", -88.8, -90.0),  # its minirooms: length 0.990
])
def test_a_start_pose_that_is_not_unit_length_installs_read_as_the_original_read_it_with_a_warning(
        tmp_path, quaternion, read_deg, normalised_deg):
    pack = room_pack(tmp_path, "../maps/room_1.json", f"[{quaternion}, 1.2, 1.5, 0.3]")
    result = install(str(pack))
    assert result.exit_code == 0, result.stderr
    warnings = [line.strip() for line in result.stderr.splitlines() if line.strip().startswith("warning:")]
    assert len(warnings) == 1, result.stderr
    assert warnings[0].startswith(f"warning: environments/room.yaml: $.start_pose: [{quaternion}, 1.2, 1.5, 0.3] has "
                                  "a quaternion of length ")
    assert (f"it is read as the original BenchBot read it, a heading of {read_deg:.1f} degrees (normalised it would "
            f"be {normalised_deg:.1f})") in warnings[0]
    env = Registry().get("environments", "myroom:1")
    assert math.degrees(start_pose_to_se2(env["start_pose"])[2]) == pytest.approx(read_deg, abs=0.05)
    assert math.degrees(pose7_to_se2(env["start_pose"])[2]) == pytest.approx(normalised_deg, abs=0.05)
    # the unit quaternion the warning offers says the same heading, both ways of reading it
    offered = [float(v) for v in warnings[0].rsplit("write [", 1)[1].rstrip("]").split(",")]
    assert math.sqrt(sum(v * v for v in offered[:4])) == pytest.approx(1.0, abs=1e-4)
    for read in (start_pose_to_se2, pose7_to_se2):
        assert math.degrees(read(offered)[2]) == pytest.approx(read_deg, abs=0.05)
    assert offered[4:] == [1.2, 1.5, 0.3]


def test_a_unit_start_pose_installs_without_a_warning(tmp_path):
    half = math.sqrt(0.5)
    result = install(str(room_pack(tmp_path, "../maps/room_1.json", f"[{half}, 0, 0, {-half}, 1.2, 1.5, 0.3]")))
    assert result.exit_code == 0 and "warning:" not in result.stderr, result.stderr
