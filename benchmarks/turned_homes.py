"""The geometric baseline's scores on a BEAR home turned, mirrored and moved: the same world turned or moved gives the
same scores.

Each turn (a symmetry of the square: quarter turns, mirrors) or move (a turn and a translation, :data:`MOVES`) of the
home's five variants — objects, start poses, trajectories, by ``benchbot_worlds.homes.home_frame.turned_layout``
— is installed as a content pack (into a temporary data directory: environment ``turned:1`` of ``--env``'s variant,
its trajectory cut to its first ``--poses`` poses, all five variants as its ``home_files``, the turned ground truth
beside it), and ``benchbot batch --example semslam_geometric --envs turned:1`` runs on it in the furnished style.
Every turn gets the same name and variant, so the same home seed and world seed. A mirror mirrors the robot too:
carter's camera sits 6 cm left of its centre line (where the original's left camera was), so in a mirrored home the
pack's robot ``turned_carter`` carries it 6 cm to the right — the robot's mirror image, which sees the home's
images mirrored. The figures: per turn the OMQ and its parts, and the largest gap of OMQ from the unturned home's.

    python benchmarks/turned_homes.py [--env house:2] [--poses 40] [--turns identity,turn90,mirror_y,shift]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs

#: The turns by name: 2 × 2 map → turned map matrices.
TURNS = {"identity": [[1, 0], [0, 1]], "turn90": [[0, -1], [1, 0]], "turn180": [[-1, 0], [0, -1]],
         "turn270": [[0, 1], [-1, 0]], "mirror_x": [[-1, 0], [0, 1]], "mirror_y": [[1, 0], [0, -1]],
         "mirror_diagonal": [[0, 1], [1, 0]], "mirror_antidiagonal": [[0, -1], [-1, 0]]}
#: Moves by name: a turn of :data:`TURNS` then a translation (x, y metres): ``p' = M @ p + offset``. The baseline
#: fuses depth into 4 cm voxels counted from the map's origin (``mapping.py``, ``voxel``), so it sees a home moved by
#: whole voxels (``shift``, ``turn90_shift``) as it sees the home, and one moved by a fraction of a voxel
#: (``shift_off_grid``) through other voxels: other boxes, another OMQ, in the same world.
MOVES = {"shift": ("identity", (7.32, -2.12)), "turn90_shift": ("turn90", (-3.4, 12.92)),
         "shift_off_grid": ("identity", (7.3, -2.1))}
BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def write_pack(folder: Path, home: str, variant: int, M, poses: int, offset=(0.0, 0.0)) -> None:
    """A content pack of the five variants of BEAR home ``home`` turned by ``M`` and moved by ``offset`` (metres):
    ``maps/``, the environment ``turned:1`` (variant ``variant``, its first ``poses`` trajectory poses) and its
    ground truth."""
    import yaml

    from benchbot_worlds.bear import DATA_DIR
    from benchbot_worlds.homes.home_frame import turned_layout

    dicts = [turned_layout(json.loads((DATA_DIR / f"{home}_{v}.json").read_text()), M, offset) for v in range(1, 6)]
    for sub in ("maps", "environments", "ground_truths"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    for v, d in enumerate(dicts, 1):
        (folder / "maps" / f"{home}_{v}.json").write_text(json.dumps(d))
    own = dicts[variant - 1]["environment"]
    env = {"name": "turned", "variant": 1, "type": "sim_taichi", "style": "furnished", "robots": ["carter"],
           "map_path": f"../maps/{home}_{variant}.json",
           "home_files": [f"../maps/{home}_{v}.json" for v in range(1, 6)],
           "start_pose": own["start_pose"], "trajectory_poses": own["trajectory_poses"][:poses],
           "object_labels": own["object_labels"]}
    (folder / "environments" / "turned_1.yaml").write_text(yaml.safe_dump(env))
    (folder / "robots").mkdir(exist_ok=True)
    (folder / "robots" / "turned_carter.yaml").write_text(yaml.safe_dump(robot_for(M)))
    gt = json.loads(json.dumps(dicts[variant - 1]))
    gt["environment"].update(name="turned", variant=1, trajectory_poses=env["trajectory_poses"])
    (folder / "ground_truths" / "turned_1.json").write_text(json.dumps(gt))


def robot_for(M) -> dict:
    """carter's spec as ``turned_carter``, mirrored with the home when ``M`` (2 × 2) is a mirror (its determinant
    −1): each sensor's mount moved to the other side of the robot's centre line (y → −y)."""
    import numpy as np
    import yaml

    from benchbot_sim_taichi.plugin import ROBOTS_DIR

    spec = yaml.safe_load((ROBOTS_DIR / "carter.yaml").read_text(encoding="utf-8"))
    spec["name"] = "turned_carter"
    if np.linalg.det(np.asarray(M, dtype=float)) < 0:
        for sensor in ("camera", "laser"):
            x, y, z = spec["sensors"][sensor]["mount_xyz"]
            spec["sensors"][sensor]["mount_xyz"] = [x, -y, z]
    return spec


def run_turn(root: Path, home: str, variant: int, name: str, poses: int) -> dict:
    """Install the pack of turn ``name`` and run the baseline on it; its scores and the batch's seconds."""
    env = {k: v for k, v in os.environ.items() if k != "BENCHBOT_SIM_STYLE"}
    env["BENCHBOT_DATA_DIR"] = str(root / "data")
    pack = root / f"pack_{name}"
    turn, offset = MOVES.get(name, (name, (0.0, 0.0)))
    write_pack(pack, home, variant, TURNS[turn], poses, offset)
    done = subprocess.run([*BENCHBOT, "install", "--force", "--name", "turned", str(pack)], capture_output=True,
                          text=True, env=env, timeout=600)
    if done.returncode:
        raise SystemExit(f"benchbot install failed for {name}: {done.stderr.strip()[-500:]}")
    out = root / f"runs_{name}"
    start = time.perf_counter()
    done = subprocess.run([*BENCHBOT, "batch", "--example", "semslam_geometric", "--envs", "turned:1",
                           "--robot", "turned_carter",
                           "--output-dir", str(out)], capture_output=True, text=True, env=env, timeout=3600)
    seconds = time.perf_counter() - start
    if done.returncode:
        raise SystemExit(f"benchbot batch failed for {name}: {(done.stdout + done.stderr).strip()[-800:]}")
    (run_dir,) = [p for p in out.iterdir() if p.is_dir()]
    scores = json.loads((run_dir / "scores.json").read_text())["scores"]
    return {"scores": scores, "seconds": seconds}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:2", help="a BEAR environment name:variant (miniroom:1-5, house:1-5)")
    ap.add_argument("--poses", type=int, default=40, help="trajectory poses driven (from the start)")
    ap.add_argument("--turns", default="identity,turn90,turn180,mirror_y,mirror_diagonal",
                    help=f"comma-separated, of: {', '.join([*TURNS, *MOVES])}")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, style=None, env="miniroom:1", poses=2, turns="identity,mirror_y")
    home, _, variant = args.env.partition(":")
    turns = [t.strip() for t in args.turns.split(",") if t.strip()]
    if home not in ("miniroom", "house") or variant not in {str(v) for v in range(1, 6)}:
        ap.error(f"--env {args.env}: give a BEAR environment, miniroom:1-5 or house:1-5")
    if args.poses < 1 or not turns or set(turns) - set(TURNS) - set(MOVES):
        ap.error(f"--poses is at least 1; --turns names some of {', '.join([*TURNS, *MOVES])}")
    with tempfile.TemporaryDirectory(prefix="turned_homes_") as tmp:
        results = {name: run_turn(Path(tmp), home, int(variant), name, args.poses) for name in turns}
    if args.json:
        print(json.dumps({"env": args.env, "poses": args.poses, "turns": results}))
        return 0
    print(f"{args.env}, first {args.poses} poses, semslam_geometric, furnished:")
    for name, r in results.items():
        s = r["scores"]
        print(f"  {name:<20} OMQ {s['OMQ']:.4f}  avg_pairwise {s['avg_pairwise']:.4f}  avg_spatial "
              f"{s['avg_spatial']:.4f}  avg_label {s['avg_label']:.4f}  TP {s['TP']:.0f} FP {s['FP']:.0f} "
              f"FN {s['FN']:.0f}  ({r['seconds']:.0f} s)")
    omqs = [r["scores"]["OMQ"] for r in results.values()]
    print(f"largest OMQ gap between turns: {max(omqs) - min(omqs):.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
