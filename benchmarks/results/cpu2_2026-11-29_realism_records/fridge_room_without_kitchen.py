"""Trial (29 Nov 2026), the reverse of the procedural homes' lead: the BEAR houses' fridges with their room's kitchen
distractors taken away (the counters, cabinets and wall cabinets the furnishing stands along its walls; the counters
that support ground-truth objects stay, so that nothing floats). Does the kitchen around the fridge help a
detector find it? Run from the repository root with benchmarks/realism.py's arguments, the scene cache off (its key
does not see this wrapper):

    BENCHBOT_SCENE_CACHE_BYTES=0 uv run --extra realism python \
        benchmarks/results/cpu2_2026-11-29_realism_records/fridge_room_without_kitchen.py \
        --env house:1 --env house:2 --env house:4 --every 4 --quality-frames 0 --reference-frames 0 \
        --detector centernet --out DIR
"""
import sys

import numpy as np

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402
import benchbot_worlds.homes.furnish as furnish  # noqa: E402

KITCHEN_KINDS = ("counter", "cabinet", "wall_cabinet")
_furnish_home = furnish.furnish_home


def furnish_home_without_kitchen(objects, plan, library, **kw):
    """``furnish_home``'s furnishing less the kitchen distractors in the rooms that hold a refrigerator (home
    frame, as ``furnish_home`` works)."""
    out = _furnish_home(objects, plan, library, **kw)
    context = list(kw.get("context_objects") or objects)
    rooms = {plan.room_at(np.asarray(o["centroid"], float)[:2]) for o in context if o.get("class") == "refrigerator"}
    kept = []
    for p in out.placements:
        at = np.asarray(p.transform, float)[:2, 3]
        if p.role == "distractor" and library.get(p.asset_id).kind in KITCHEN_KINDS and plan.room_at(at) in rooms:
            continue
        kept.append(p)
    print(f"furnish: {len(out.placements) - len(kept)} kitchen distractors taken away", flush=True)
    out.placements[:] = kept
    return out


furnish.furnish_home = furnish_home_without_kitchen

if __name__ == "__main__":
    sys.exit(R.main(sys.argv[1:]))
