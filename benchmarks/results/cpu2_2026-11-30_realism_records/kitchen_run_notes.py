"""kitchen_run_notes.py FIRST LAST: for validation homes FIRST..LAST of the procedural generator as the tree stands,
the kind of room each refrigerator stands in and the generator's notes on the kitchen run kept beside it (with
``kitchen_run_kept_free.patch`` applied: ``git apply`` it first, ``git checkout`` the file after), then the counts.
Run from the repository root:

    git apply benchmarks/results/cpu2_2026-11-30_realism_records/kitchen_run_kept_free.patch
    uv run python benchmarks/results/cpu2_2026-11-30_realism_records/kitchen_run_notes.py 0 19
    git checkout plugins/worlds/benchbot_worlds/procedural/objects.py
"""
import collections
import sys

from benchbot_worlds.procedural import splits
from benchbot_worlds.procedural.generator import GENERATOR_VERSION, generate_home

try:
    first, last = (int(v) for v in sys.argv[1:3])
except ValueError:
    sys.exit("usage: kitchen_run_notes.py FIRST LAST (validation home indices, e.g. 0 19)")
tally: collections.Counter = collections.Counter()
for i in range(first, last + 1):
    home = generate_home(splits.home_seed("val", i, GENERATOR_VERSION), f"procedural_val_{i}")
    kinds = [r.kind for r in home.layout.rooms]
    gt = home.variants[0]["ground_truth"]["objects"]
    rooms = []
    for o in gt:
        if o["class"] == "refrigerator":
            x, y = o["centroid"][:2]
            rooms += [r.kind for r in home.layout.rooms if r.lo[0] <= x <= r.hi[0] and r.lo[1] <= y <= r.hi[1]][:1]
    notes = [n for n in home.notes if "kitchen run" in n]
    print(f"procedural_val_{i}: rooms {'kitchen' in kinds and 'with' or 'without'} a kitchen; fridges in "
          f"{rooms or 'none'}; {'; '.join(notes) or 'no run tried (no fridge placed in a kitchen)'}")
    tally["homes with a kitchen"] += "kitchen" in kinds
    tally["runs kept free"] += sum("kept free" in n for n in notes)
    tally["runs that did not fit"] += sum("no kitchen run" in n for n in notes)
print(dict(tally))
