"""Which model draws each cup of the BEAR homes and of procedural validation homes, with and without the rule that
keeps cups' models from being stretched taller than wide (``furnish.NOT_STRETCHED_TALL``, ``MAX_TALL_STRETCH``):
the cups whose model the rule changes, per model. The furnishing is the one an episode builds
(``furnished.furnish_environment``, the home's seed as ``benchbot run`` passes it); the rule is switched off by
setting ``MAX_TALL_STRETCH`` to infinity in this process.

    uv run python cup_models.py [--homes 100]      # the ten BEAR homes and validation homes 0..N-1, variant 1
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import sys


def _cups(objects, files, seed) -> dict:
    from benchbot_worlds.homes.furnished import furnish_environment

    home = furnish_environment(objects, files, [], seed=seed)
    return {p.object_index: p.asset_id for p in home.furnishing.placements
            if p.role == "object" and objects[p.object_index].get("class") == "cup"}


def _environments(homes: int):
    """(name, objects, home files, seed) of the BEAR homes and validation homes 0..homes-1, variant 1."""
    from benchbot.core.seeding import home_seed
    from benchbot_worlds.bear import DATA_DIR, home_files_of
    from benchbot_worlds.homes.floorplan import home_files
    from benchbot_worlds.procedural.worlds import home_files as procedural_files, home_name

    for home in ("miniroom", "house"):
        for v in range(1, 6):
            path = DATA_DIR / f"{home}_{v}.json"
            env = dict(json.loads(path.read_text())["environment"])
            env["map_path"] = str(path)
            env["home_files"] = home_files_of(env["name"])
            yield f"{home}:{v}", json.loads(path.read_text())["ground_truth"]["objects"], home_files(env), \
                home_seed(env["name"])
    for i in range(homes):
        files = procedural_files("val", i)
        yield f"procedural_val_{i}:1", json.loads(files[0].read_text())["ground_truth"]["objects"], \
            [str(f) for f in files], home_seed(home_name("val", i))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--homes", type=int, default=100, help="procedural validation homes 0..N-1 (default 100)")
    args = ap.parse_args(argv)
    if not 0 <= args.homes <= 10_000:
        print("error: --homes must lie in 0..10000", file=sys.stderr)
        return 2
    from benchbot_worlds.homes import furnish

    rule = furnish.MAX_TALL_STRETCH
    totals = {"bear": collections.Counter(), "procedural": collections.Counter()}
    cups = {"bear": 0, "procedural": 0}
    for name, objects, files, seed in _environments(args.homes):
        furnish.MAX_TALL_STRETCH = math.inf
        without = _cups(objects, files, seed)
        furnish.MAX_TALL_STRETCH = rule
        with_rule = _cups(objects, files, seed)
        kind = "procedural" if name.startswith("procedural") else "bear"
        cups[kind] += len(with_rule)
        for i, model in with_rule.items():
            totals[kind][(without[i], model)] += 1
    for kind in ("bear", "procedural"):
        changed = {k: n for k, n in totals[kind].items() if k[0] != k[1]}
        print(f"{kind}: {cups[kind]} cups, {sum(changed.values())} change model: "
              + (", ".join(f"{a} -> {b} {n}" for (a, b), n in sorted(changed.items())) or "none"))
        models = collections.Counter()
        for (_, model), n in totals[kind].items():
            models[model] += n
        print("  with the rule: " + ", ".join(f"{m} {n}" for m, n in sorted(models.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
