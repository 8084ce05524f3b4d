"""over_fridge_cabinets.py ENV ...: per environment (``name:variant``), its GT refrigerators and how many get a
cabinet over them (``furnish_walls.place_over_fridges``, as the scene build furnishes the home), then the totals.
Run from the repository root:

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/over_fridge_cabinets.py \
        miniroom:1 miniroom:2 miniroom:3 miniroom:4 miniroom:5 house:1 house:2 house:3 house:4 house:5 \
        $(for i in $(seq 0 99); do echo procedural_val_$i:1; done)
"""
import sys

from benchbot_worlds.homes import furnish

sys.path.insert(0, "benchmarks/results/cpu2_2026-11-29_procedural_kitchens")
from fridge_rooms import furnished  # noqa: E402  (the home as the scene build furnishes it)

counted = {"fridges": 0, "cabinets": 0}
_place = furnish.place_over_fridges


def counting(context, boxes, space, library, plan, bounds_of, out):
    """``place_over_fridges``, counting the fridges it sees and the cabinets it adds."""
    before = len(out.placements)
    _place(context, boxes, space, library, plan, bounds_of, out)
    counted["fridges"] += sum(o.get("class") == "refrigerator" for o in context)
    counted["cabinets"] += len(out.placements) - before


furnish.place_over_fridges = counting
if len(sys.argv) < 2:
    sys.exit("usage: over_fridge_cabinets.py ENV ... (name:variant, e.g. house:1 procedural_val_7:1)")
totals = [0, 0, 0]
for name in sys.argv[1:]:
    counted.update(fridges=0, cabinets=0)
    furnished(name)
    if counted["fridges"]:
        print(f"{name}: {counted['fridges']} fridges, {counted['cabinets']} with a cabinet over them", flush=True)
    totals = [totals[0] + 1, totals[1] + counted["fridges"], totals[2] + counted["cabinets"]]
print(f"{totals[0]} environments: {totals[1]} fridges, {totals[2]} with a cabinet over them")
