"""models_placed.py MODEL ENV ...: per environment (``name:variant``), how many times the furnishing places the pack
model MODEL (an asset id, e.g. ``tv__sc_apple_pc_monitor``), as the scene build furnishes the home. Run from the
repository root (history: *A dark screen for the pack's monitor*: no BEAR home places that monitor):

    uv run python benchmarks/results/cpu2_2026-11-29_procedural_kitchens/models_placed.py tv__sc_apple_pc_monitor \
        miniroom:1 miniroom:2 miniroom:3 miniroom:4 miniroom:5 house:1 house:2 house:3 house:4 house:5
"""
import sys

from fridge_rooms import furnished  # this folder's helper: the home as the scene build furnishes it

if len(sys.argv) < 3:
    sys.exit("usage: models_placed.py MODEL ENV [ENV ...] (ENV: name:variant, e.g. house:1)")
model = sys.argv[1]
for name in sys.argv[2:]:
    _, _, home = furnished(name)
    ids = [p.asset_id for p in home.furnishing.placements]
    print(name, f"{ids.count(model)} of {len(ids)} placements", flush=True)
