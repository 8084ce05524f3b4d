"""kitchen_run_homes.py ENV ...: with ``kitchen_run_beside_fridges.patch`` applied (``git apply`` it first; on trees from
``d06a386`` on, ``../cpu2_2026-11-29_realism_records/kitchen_run_with_fridge_cabinet.patch`` instead), per
environment (``name:variant``): its GT refrigerators and the base units the patch's ``place_kitchen_runs`` puts
beside them (wall cabinets above them not counted), as the scene build furnishes the home. Run from the repository
root:

    git apply benchmarks/results/cpu2_2026-11-29_procedural_kitchens/kitchen_run_beside_fridges.patch
    uv run python benchmarks/results/cpu2_2026-11-29_procedural_kitchens/kitchen_run_homes.py \
        $(for i in $(seq 0 99); do echo procedural_val_$i:1; done)
"""
import sys

import benchbot_worlds.homes.furnish as furnish
from fridge_rooms import furnished  # this folder's helper: the home as the scene build furnishes it

placed: list[int] = []
if not hasattr(furnish, "place_kitchen_runs"):
    sys.exit("the patch is not applied: git apply benchmarks/results/cpu2_2026-11-29_realism_records/"
             "kitchen_run_with_fridge_cabinet.patch (before d06a386: cpu2_2026-11-29_procedural_kitchens/"
             "kitchen_run_beside_fridges.patch)")
_place_kitchen_runs = furnish.place_kitchen_runs


def counting(space, library, plan, seed, bounds_of, out) -> None:
    """The patch's step, counting the base units it adds."""
    n = len(out.placements)
    _place_kitchen_runs(space, library, plan, seed, bounds_of, out)
    placed.append(sum(1 for p in out.placements[n:] if library.get(p.asset_id).kind != "wall_cabinet"))


furnish.place_kitchen_runs = counting
fridges = units = homes = 0
for name in sys.argv[1:]:
    _, objects, _ = furnished(name)
    n = sum(o["class"] == "refrigerator" for o in objects)
    print(f"{name}: {n} fridges, {placed[-1]} base units beside them", flush=True)
    fridges, units, homes = fridges + n, units + placed[-1], homes + (placed[-1] > 0)
print(f"{fridges} fridges in {len(sys.argv) - 1} environments; {units} base units beside them, in {homes} homes")
