"""fridge_rooms.py [--why] ENV ...: the rooms that hold a refrigerator and the kitchen furniture the furnishing puts
in them, per environment (``name:variant``), then the totals.

For each GT refrigerator of each environment's layout, as the scene build furnishes it
(``furnish_environment`` with the home's seed): the kind and floor area of its room, and the counters, cabinets
and wall cabinets (distractors or supports) whose origin lies in that room. With ``--why``: along every wall span
of those rooms, every 0.1 m, whether a 0.60 x 0.61 x 0.89 m kitchen base unit (``cabinet__cc0_lowerCabinet``)
would stand there, and if not, why (the furnishing's own ``Space.why_not``, with the distractors' 5 cm clearance,
before any furniture is placed): the tally of reasons. Run from the repository root:

    uv run python benchmarks/results/cpu2_2026-11-29_procedural_kitchens/fridge_rooms.py house:1 house:2 house:4
    uv run python benchmarks/results/cpu2_2026-11-29_procedural_kitchens/fridge_rooms.py --why \
        $(for i in $(seq 0 99); do echo procedural_val_$i:1; done)
"""
import collections
import sys

import numpy as np

from benchbot.core.errors import BenchbotError
from benchbot.core.registry import get_registry
from benchbot.core.seeding import home_seed
from benchbot.packs.assets import asset_library
from benchbot_worlds.homes import furnish_walls
from benchbot_worlds.homes.floorplan import home_files
from benchbot_worlds.homes.furnish_space import Space, gt_box
from benchbot_worlds.homes.furnish_supports import standing_box
from benchbot_worlds.homes.furnished import _home_plan
from benchbot_worlds.scene.build import furnished_home, load_ground_truth_json

KITCHEN_KINDS = ("counter", "cabinet", "wall_cabinet")


def environment(name: str) -> dict:
    """The registered environment spec of ``name`` (``name:variant``); exits with one line if there is none."""
    try:
        (env,) = get_registry().scenes(name)
    except (BenchbotError, ValueError):
        sys.exit(f"{name}: no such environment; give name:variant (`benchbot list environments`)")
    return env


def furnished(name: str):
    """(environment spec, its GT objects (map frame), its ``FurnishedHome``) of ``name`` (``name:variant``), furnished
    as the scene build furnishes it (``scene.build.furnished_home``); exits with one line if there is no such
    environment. The other record scripts of this folder and of ``cpu2_2026-11-29_realism_records/`` use it too."""
    env = environment(name)
    data = load_ground_truth_json(env["map_path"])
    objects = data["ground_truth"]["objects"]
    return env, objects, furnished_home(env, data.get("environment") or {}, objects, env["map_path"])


def units_by_fridge(name: str, library) -> list[tuple[str, float, collections.Counter]]:
    """(room kind, room area m², kitchen furniture in the room by kind) for each refrigerator of ``name``."""
    _, objects, home = furnished(name)
    plan, out = home.plan, []
    for o in objects:
        if o["class"] != "refrigerator":
            continue
        room = plan.room_at(np.asarray(o["centroid"], float)[:2])
        counts = collections.Counter()
        for p in home.furnishing.placements:
            if p.role not in ("distractor", "support"):
                continue
            T = np.asarray(p.transform, float)
            T = T if home.frame.is_identity else home.frame.T_map_home @ T
            kind = library.get(p.asset_id).kind
            if kind in KITCHEN_KINDS and plan.room_at(T[:2, 3]) == room:
                counts[kind] += 1
        r = plan.rooms[room]
        out.append((r.kind, float(np.prod(np.asarray(r.hi)[:2] - np.asarray(r.lo)[:2])), counts))
    return out


def why_no_unit(name: str, unit, tally: collections.Counter) -> None:
    """Add to ``tally`` the reason at each 0.1 m of the wall spans of ``name``'s fridge rooms (module docstring)."""
    env = environment(name)
    frame, plan, context = _home_plan(home_files(env), [], [], home_seed(env["name"]))
    classes = [o["class"] for o in context]
    space = Space(plan, [standing_box(o, gt_box(o)) for o in context], classes, classes)
    rooms = {plan.room_at(np.asarray(o["centroid"], float)[:2]) for o in context if o["class"] == "refrigerator"}
    for span in plan.wall_spans:
        if span.room not in rooms:
            continue
        a, b, n = (np.asarray(x, float)[:2] for x in (span.a, span.b, span.inward))
        length = float(np.linalg.norm(b - a))
        for s in np.arange(0.0, length - 0.6, 0.1):
            lo, hi, _ = furnish_walls._natural_box(unit, a, (b - a) / length, n, s, 0.0, 1.0)
            why = "under a window sill" if hi[2] > span.max_height else space.why_not(
                lo, hi, gt_margin=furnish_walls.DISTRACTOR_CLEARANCE_M,
                placed_margin=furnish_walls.DISTRACTOR_CLEARANCE_M, openings=True)
            if why and "GT object" in why:
                why = f"a GT {why.split('GT object ')[1]} stands there"
            tally[why or "it fits"] += 1


def main(argv: list[str]) -> None:
    why = "--why" in argv
    names = [a for a in argv if a != "--why"]
    library = asset_library()
    totals, rooms, bare, kinds = collections.Counter(), 0, 0, collections.Counter()
    for name in names:
        for kind, area, counts in units_by_fridge(name, library):
            print(f"{name}: a fridge in a {kind} of {area:.1f} m²; kitchen furniture there: {dict(counts) or 'none'}")
            rooms, bare = rooms + 1, bare + (not counts)
            totals.update(counts)
            kinds[kind] += 1
    print(f"{rooms} fridges in {len(names)} environments; their rooms: {dict(kinds)}; "
          f"{bare} rooms with no kitchen furniture; in all: {dict(totals)}")
    if why:
        unit = library.get("cabinet__cc0_lowerCabinet")
        tally = collections.Counter()
        for name in names:
            why_no_unit(name, unit, tally)
        print(f"a kitchen base unit along the walls of those rooms, {sum(tally.values())} positions:")
        for reason, count in tally.most_common():
            print(f"  {count:5d}  {reason}")


if __name__ == "__main__":
    main(sys.argv[1:])
