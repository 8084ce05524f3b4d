"""Print the digests of procedural homes, to compare machines: for each home of ``--split`` from ``--start``, the
SHA-256 of its five ground-truth files' bytes as written (:func:`benchbot_worlds.procedural.worlds.home_files`) and
of its floor plan (:meth:`benchbot_worlds.homes.floorplan.FloorPlan.digest` of
:func:`~benchbot_worlds.homes.floorplan.plan_for_home`), with the Python and NumPy versions.

    uv run python tools/world_digests.py --split val --count 100 -o digests.json
    uv run python tools/world_digests.py --compare a.json b.json      # exit 1 when any home differs

The same generator version gives the same digests on every machine (docs/worlds.md, *Splits*).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path


def digests(split: str, start: int, count: int) -> dict:
    """``{"python", "numpy", "homes": {name: {"files", "plan"}}}`` of homes start..start+count-1 of ``split``."""
    import numpy as np

    from benchbot.core.seeding import home_seed
    from benchbot_worlds.homes.floorplan import plan_for_home
    from benchbot_worlds.procedural.worlds import home_files, home_name

    homes = {}
    for index in range(start, start + count):
        files = home_files(split, index)
        data = [Path(f).read_bytes() for f in files]
        plan = plan_for_home([json.loads(d) for d in data], seed=home_seed(home_name(split, index)))
        homes[home_name(split, index)] = {"files": hashlib.sha256(b"".join(data)).hexdigest(), "plan": plan.digest()}
    return {"python": sys.version.split()[0], "numpy": np.__version__, "homes": homes}


def compare(a: dict, b: dict) -> list[str]:
    """The names of the homes both hold whose digests differ."""
    return sorted(k for k in set(a["homes"]) & set(b["homes"]) if a["homes"][k] != b["homes"][k])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--split", default="val")
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--count", type=int, default=10)
    ap.add_argument("-o", "--output", type=Path, default=None, help="write the JSON here (default: print it)")
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("A", "B"), help="compare two files of digests")
    args = ap.parse_args(argv)
    if args.compare:
        a, b = (json.loads(p.read_text()) for p in args.compare)
        differ = compare(a, b)
        both = len(set(a["homes"]) & set(b["homes"]))
        print(f"{both - len(differ)} of {both} homes identical (Python {a['python']}, NumPy {a['numpy']} against "
              f"Python {b['python']}, NumPy {b['numpy']})" + (f"; differ: {', '.join(differ[:10])}" if differ else ""))
        return 1 if differ or not both else 0
    out = json.dumps(digests(args.split, args.start, args.count), indent=1)
    if args.output:
        args.output.write_text(out + "\n")
        print(f"wrote {args.output}")
    else:
        print(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
