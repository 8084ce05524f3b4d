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

from benchbot.core.errors import BenchbotError
from benchbot.core.registry import get_registry
from benchbot.core.seeding import home_seed
from benchbot_worlds.homes.floorplan import home_files
from benchbot_worlds.homes.furnished import furnish_environment

for name in sys.argv[1:]:
    try:
        (env,) = get_registry().scenes(name)
    except (BenchbotError, ValueError):
        sys.exit(f"{name}: no such environment; give name:variant (`benchbot list environments`)")
    data = json.loads(open(env["map_path"]).read())
    objects = data.get("objects") or data["ground_truth"]["objects"]
    home = furnish_environment(objects, home_files(env), [], seed=home_seed(env["name"]))
    rows = [(p.asset_id, p.role, [[round(float(x), 6) for x in r] for r in p.transform])
            for p in home.furnishing.placements]
    print(name, len(rows), hashlib.sha256(json.dumps(rows).encode()).hexdigest()[:16], flush=True)
