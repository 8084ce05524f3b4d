"""placements_digest.py ENV ...: per environment (``name:variant``), the number of furnishing placements and a
SHA-256 of them all (asset id, role and transform rounded to a micrometre), as the scene build furnishes the home.
Run it without and with ``kitchen_run_beside_fridges.patch`` applied: a home whose digest stays is furnished alike.
From the repository root:

    uv run python benchmarks/results/cpu2_2026-11-29_procedural_kitchens/placements_digest.py \
        miniroom:1 miniroom:2 miniroom:3 miniroom:4 miniroom:5 house:1 house:2 house:3 house:4 house:5
"""
import hashlib
import json
import sys

from fridge_rooms import furnished  # this folder's helper: the home as the scene build furnishes it

for name in sys.argv[1:]:
    _, _, home = furnished(name)
    rows = [(p.asset_id, p.role, [[round(float(x), 6) for x in r] for r in p.transform])
            for p in home.furnishing.placements]
    print(name, len(rows), hashlib.sha256(json.dumps(rows).encode()).hexdigest()[:16], flush=True)
