"""How long `benchbot install`'s content checks take on a hostile layout: the worst cases a pack may bring.

:func:`benchbot.packs.layout_checks.layout_problems` runs on every ground truth and environment layout of a pack
when it is installed. A hostile pack may fill its files up to ``BENCHBOT_MAX_SPEC_BYTES`` (4 MiB each): this script
builds such layouts in memory — ``--objects`` thin boxes in a row (class ``--class``, the class list ``--classes``
names ``c0``, ``c1``, …; an unknown class makes every object a problem) and ``--poses`` trajectory poses outside
every box — and times the checks. ``json_bytes`` is the size the layout and the poses would have as files, so a case
can be compared with the file limit.

    python benchmarks/layout_checks.py [--objects 20000] [--poses 0] [--class zz] [--classes 1000] [--json]

Cases quoted in the review notes: ``--objects 20000 --class zz --classes 1000`` (every object of an unknown class)
and ``--objects 50000 --poses 150000 --class c0 --classes 10`` (9.9 MB of JSON in all, files near the 4 MiB limit:
every pose against every object).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import smoke  # this folder is on sys.path when a script here runs


def hostile_layout(objects: int, poses: int, cls: str, classes: int) -> tuple[dict, list[list[float]]]:
    """A layout of ``objects`` boxes 0.5 mm wide, 1 m high, 1 mm apart along x (class ``cls``; class list ``c0`` …
    ``c{classes-1}``) and ``poses`` trajectory poses ``[qw,qx,qy,qz,x,y,z]`` at (-5, 3) m, outside every box."""
    boxes = [{"class": cls, "centroid": [i * 0.001, 0.0, 0.5], "extent": [0.0005, 0.0005, 1.0]}
             for i in range(objects)]
    layout = {"ground_truth": {"class_list": [f"c{i}" for i in range(classes)], "objects": boxes}}
    return layout, [[1.0, 0.0, 0.0, 0.0, -5.0, 3.0, 0.0]] * poses


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", type=int, default=20000)
    ap.add_argument("--poses", type=int, default=0)
    ap.add_argument("--class", dest="cls", default="zz", help="the objects' class (zz: not in the class list)")
    ap.add_argument("--classes", type=int, default=1000, help="names in the class list")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, style=None, objects=200, poses=50, classes=10)
    if min(args.objects, args.poses, args.classes) < 0:
        ap.error("--objects, --poses and --classes must be 0 or more")

    from benchbot.packs.layout_checks import layout_problems

    layout, poses = hostile_layout(args.objects, args.poses, args.cls, args.classes)
    t = time.perf_counter()
    problems = layout_problems(layout, source="hostile.json", trajectory_poses=poses)
    seconds = time.perf_counter() - t
    report = {"machine": f"{platform.node()} ({os.cpu_count()} cores)", "objects": args.objects,
              "poses": args.poses, "class": args.cls, "classes": args.classes,
              "json_bytes": len(json.dumps(layout)) + len(json.dumps(poses)), "problems": len(problems),
              "seconds": seconds}
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{args.objects} objects x {args.poses} poses ({report['json_bytes']} bytes as JSON): "
              f"{len(problems)} problem lines in {seconds:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
