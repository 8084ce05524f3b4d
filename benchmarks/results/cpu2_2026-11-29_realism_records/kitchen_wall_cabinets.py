"""kitchen_wall_cabinets.py ENV ...: per environment (``name:variant``), its GT refrigerators, the cabinets over them
and the wall cabinets hung beside those (``furnish_walls.place_over_fridges`` and its kitchen run, as the scene
build furnishes the home), then the totals. It needs ``kitchen_wall_cabinets_beside_fridge.patch`` (beside it)
applied; without it, it says so and exits. Run from the repository root:

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/kitchen_wall_cabinets.py \
        miniroom:1 miniroom:2 miniroom:3 miniroom:4 miniroom:5 house:1 house:2 house:3 house:4 house:5 \
        $(for i in $(seq 0 99); do echo procedural_val_$i:1; done)
"""
import sys

from benchbot_worlds.homes import furnish, furnish_walls

if not hasattr(furnish_walls, "BESIDE_FRIDGE_BOTTOM_M"):
    sys.exit("kitchen_wall_cabinets.py: apply kitchen_wall_cabinets_beside_fridge.patch first (git apply), a trial "
             "that is not in the code")
BESIDE_FRIDGE_BOTTOM_M = furnish_walls.BESIDE_FRIDGE_BOTTOM_M

sys.path.insert(0, "benchmarks/results/cpu2_2026-11-29_procedural_kitchens")
from fridge_rooms import furnished  # noqa: E402  (the home as the scene build furnishes it)

counted = {"fridges": 0, "over": 0, "beside": 0}
_place = furnish.place_over_fridges


def counting(context, boxes, space, library, plan, bounds_of, out):
    """``place_over_fridges``, counting the fridges it sees and the cabinets it hangs over and beside them."""
    before = len(out.boxes.get("distractor", []))
    _place(context, boxes, space, library, plan, bounds_of, out)
    counted["fridges"] += sum(o.get("class") == "refrigerator" for o in context)
    for lo, _ in out.boxes.get("distractor", [])[before:]:
        counted["beside" if abs(float(lo[2]) - BESIDE_FRIDGE_BOTTOM_M) < 1e-9 else "over"] += 1


furnish.place_over_fridges = counting
if len(sys.argv) < 2:
    sys.exit("usage: kitchen_wall_cabinets.py ENV ... (name:variant, e.g. house:1 procedural_val_7:1)")
totals = dict.fromkeys(("environments", "fridges", "over", "beside", "homes with some beside"), 0)
for name in sys.argv[1:]:
    counted.update(fridges=0, over=0, beside=0)
    furnished(name)
    if counted["fridges"]:
        print(f"{name}: {counted['fridges']} fridges, {counted['over']} with a cabinet over them, "
              f"{counted['beside']} wall cabinets beside those", flush=True)
    totals["environments"] += 1
    totals["homes with some beside"] += counted["beside"] > 0
    for k in ("fridges", "over", "beside"):
        totals[k] += counted[k]
print(f"{totals['environments']} environments: {totals['fridges']} fridges, {totals['over']} with a cabinet over "
      f"them, {totals['beside']} wall cabinets beside those in {totals['homes with some beside']} homes")
