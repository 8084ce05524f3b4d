"""beds_clear_of_neighbours.py ENV ...: per environment (``name:variant``), each GT bed whose model is drawn back
from its cuboid (``beds.clear_of_neighbours``, as the scene build furnishes the home): by how much on which side, then
the totals. Run from the repository root:

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/beds_clear_of_neighbours.py \
        miniroom:1 miniroom:2 miniroom:3 miniroom:4 miniroom:5 house:1 house:2 house:3 house:4 house:5 \
        $(for i in $(seq 0 99); do echo procedural_val_$i:1; done)
"""
import sys

import numpy as np

from benchbot.packs.assets import asset_library
from benchbot_worlds.homes.fitting import asset_bounds, transformed_bounds
from benchbot_worlds.homes.furnish_space import gt_box

sys.path.insert(0, "benchmarks/results/cpu2_2026-11-29_procedural_kitchens")
from fridge_rooms import furnished  # noqa: E402  (the home as the scene build furnishes it)

SIDES = ("-x", "-y", "+x", "+y")


def drawn_back(name: str, library) -> tuple[int, list[str]]:
    """(GT beds of ``name``, one line per bed whose model's box differs from its cuboid by over 1 mm)."""
    _, objects, home = furnished(name)
    beds, lines = 0, []
    for p in home.furnishing.placements:
        if p.role != "object" or objects[p.object_index]["class"] != "bed":
            continue
        beds += 1
        lo, hi = home.frame.box_to_map(*transformed_bounds(p.transform, asset_bounds(library.get(p.asset_id))))
        glo, ghi = gt_box(objects[p.object_index])
        cuts = np.concatenate([lo - glo, ghi - hi])[[0, 1, 3, 4]]
        if np.any(np.abs(cuts) > 1e-3):
            width = ghi[:2] - glo[:2]
            lines.append(f"{name}: bed {objects[p.object_index].get('ID_name')} ({width[0]:.2f} x {width[1]:.2f} m) "
                         "drawn back " + ", ".join(f"{c:.3f} m on {s}" for c, s in zip(cuts, SIDES) if abs(c) > 1e-3))
    return beds, lines


def main(names: list[str]) -> None:
    if not names:
        sys.exit("usage: beds_clear_of_neighbours.py ENV ... (name:variant, e.g. miniroom:3 procedural_val_7:1)")
    library = asset_library()
    beds = back = 0
    for name in names:
        n, lines = drawn_back(name, library)
        beds, back = beds + n, back + len(lines)
        for line in lines:
            print(line)
    print(f"{beds} GT beds in {len(names)} environments; {back} drawn back from their cuboid")


if __name__ == "__main__":
    main(sys.argv[1:])
