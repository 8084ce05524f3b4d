"""Where a generator version stands its keyboards: for validation homes 0..N-1, the keyboards by the role and room of
the table under them (before the variants), how many have a monitor (``tv``) on the same top, and how many lie with
their long side along their table's long side.

    uv run python benchmarks/results/cpu2_2026-11-30_workstations/desk_objects.py --version 4 --homes 100

``--version`` picks the seeds (``splits.home_seed``) and the rules run are those of the installed code, so the
seeds of version 4 under version 5's code show the rule on the same layouts. A negative or zero ``--homes`` is one
line and exit 2.
"""

from __future__ import annotations

import argparse
import collections
import sys

import numpy as np


def _on(o: dict, t: dict) -> bool:
    """Whether object ``o`` stands on table ``t`` (its bottom on the top, its footprint inside it; metres)."""
    return abs(t["hi"][2] - o["lo"][2]) < 1e-6 and bool(np.all(o["lo"][:2] >= t["lo"][:2] - 1e-6)) and \
        bool(np.all(o["hi"][:2] <= t["hi"][:2] + 1e-6))


def main(argv: list[str] | None = None) -> int:
    from benchbot_worlds.procedural import splits
    from benchbot_worlds.procedural.generator import GENERATOR_VERSION
    from benchbot_worlds.procedural.objects import place_home
    from benchbot_worlds.procedural.rooms import generate_layout

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--version", type=int, default=GENERATOR_VERSION, help="the version whose seeds are used")
    ap.add_argument("--homes", type=int, default=100, help="validation homes 0..N-1")
    args = ap.parse_args(argv)
    if args.homes <= 0:
        print(f"error: --homes {args.homes}: give a positive number of homes", file=sys.stderr)
        return 2
    where, offices, keyboards, with_monitor, along = collections.Counter(), 0, 0, 0, 0
    for index in range(args.homes):
        s_layout = np.random.SeedSequence(splits.home_seed("val", index, args.version)).spawn(3)[0]
        rng = np.random.Generator(np.random.PCG64(s_layout))
        layout = generate_layout(rng, [])
        home = place_home(rng, layout, [])
        offices += any(r.kind == "office" for r in layout.rooms)
        for o in (o for o in home.objects if o["class"] == "keyboard"):
            table = next((home.objects[i] for i in home.tops if _on(o, home.objects[i])), None)
            if table is None:
                continue
            keyboards += 1
            where[(table["role"], layout.rooms[table["room"]].kind)] += 1
            with_monitor += any(p["class"] == "tv" and _on(p, table) for p in home.objects)
            along += int(np.argmax(table["hi"][:2] - table["lo"][:2])) == int(np.argmax(o["hi"][:2] - o["lo"][:2]))
    print(f"seeds of version {args.version}, code of version {GENERATOR_VERSION}: {args.homes} homes, "
          f"{offices} with an office")
    for (role, kind), n in sorted(where.items()):
        print(f"  keyboards on a {role} table in a {kind}: {n}")
    print(f"keyboards {keyboards}: a monitor on the same top {with_monitor}, long side along the table's {along}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
