"""The five variants of a procedural home, as BEAR's (pure NumPy; metres, ``map`` frame).

BEAR (Hall et al., arXiv:2009.05246; benchbot-addons ``ground_truths_isaac_develop``) gives each home five variants:
1 ``base`` lighting, 2 ``day``, 3 ``night``, 4 ``day_extra``, 5 ``night_extra`` (the lighting is encoded in the
Unreal ``map_path``, :func:`benchbot_worlds.bear.lighting_of_map_path`), and variants 2-5 differ from variant 1 by
objects added, removed and moved. Measured on the bundled files (variant 1 against each other variant of miniroom
and house; an object matched by class and ``ID_name``, else by class and the nearest centroid within 1 m; moved:
its centroid differs by more than 1 cm), with :func:`measure_bear_changes` (``python -c "from
benchbot_worlds.procedural.variants import measure_bear_changes as m; print(m())"``; 8 pairs, 296 base objects)::

    variant   moved   removed   added   (per object of variant 1, both homes pooled)
    2         0.027   0.108     0.135
    3         0.014   0.135     0.135
    4         0.014   0.162     0.162
    5         0.041   0.203     0.162

(moves were 0.5-0.9 m). :data:`VARIANT_CHANGES` holds these fractions; a variant draws its counts as
``floor(f N) + Bernoulli(frac)``. Removed: objects nothing stands on. Added: classes drawn by BEAR's proportions,
placed as :mod:`.objects` places leftovers (on tables or floors), mutually clear of every object of every variant
(the variants' union is one consistent layout, as the floor plan takes it). Moved: a small object on a table or a
chair, placed anew (same size and ``ID_name``) clear of everything.
"""

from __future__ import annotations

import numpy as np

from benchbot_worlds.procedural import objects as objs

#: Lighting of variants 1..5.
LIGHTINGS = ("base", "day", "night", "day_extra", "night_extra")
#: (moved, removed, added) per object of variant 1, for variants 2..5 (module docstring).
VARIANT_CHANGES = {2: (0.027, 0.108, 0.135), 3: (0.014, 0.135, 0.135), 4: (0.014, 0.162, 0.162),
                   5: (0.041, 0.203, 0.162)}
#: Draws per placement of an object a variant adds or moves (fewer than the base's: a full home says no fast).
VARIANT_PLACE_TRIES = 10
MOVABLE = objs.SMALL_CLASSES + objs.DESK_CLASSES + ("chair", "potted plant")


def _count(rng: np.random.Generator, f: float, n: int) -> int:
    x = f * n
    return int(np.floor(x)) + int(rng.random() < x - np.floor(x))


def _removable(home: objs._Home, alive: list[int]) -> list[int]:
    """Objects of ``alive`` that no other alive object stands on (no table with items on it)."""
    if not alive:
        return []
    lo = np.array([home.objects[i]["lo"] for i in alive])
    hi = np.array([home.objects[i]["hi"] for i in alive])
    on = np.abs(hi[None, :, 2] - lo[:, None, 2]) < 1e-6  # [i, j]: i's bottom at j's top
    on &= np.all(lo[:, None, :2] < hi[None, :, :2], axis=2) & np.all(hi[:, None, :2] > lo[None, :, :2], axis=2)
    on &= lo[:, None, 2] > 1e-6
    np.fill_diagonal(on, False)
    held = on.any(axis=0)
    return [i for k, i in enumerate(alive) if not held[k]]


def _add(home: objs._Home, cls: str) -> int | None:
    """Place one more ``cls`` object (index into ``home.objects``) or None."""
    n = len(home.objects)
    rooms = [r.index for r in home.layout.rooms if r.kind != "bathroom"] or [r.index for r in home.layout.rooms]
    if cls in objs.SMALL_CLASSES + objs.DESK_CLASSES + ("tv",):
        size, group = home.draw_object(cls)
        ok = bool(home.tops) and home.on_table(cls, size, sorted(home.tops), group)
    else:
        ok = objs._floor_anywhere(home, cls, rooms)
    return n if ok and len(home.objects) > n else None


def make_variants(rng: np.random.Generator, home: objs._Home, notes: list[str]) -> list[list[int]]:
    """The objects of variants 1..5 as lists of indices into ``home.objects`` (variant 1: every object placed so
    far); objects added or moved-to are appended to ``home.objects`` (a moved object's new copy carries
    ``"moved_from"``: the index it replaces). Changes that find no place are noted, never retried."""
    base = list(range(len(home.objects)))
    home.tries = VARIANT_PLACE_TRIES
    names, p = objs.bear_proportions()
    out = [base]
    for v in (2, 3, 4, 5):
        f_move, f_rem, f_add = VARIANT_CHANGES[v]
        alive = list(base)
        removable = _removable(home, alive)
        k = min(_count(rng, f_rem, len(base)), len(removable))
        gone = {removable[i] for i in rng.choice(len(removable), size=k, replace=False)} if k else set()
        alive = [i for i in alive if i not in gone]
        free = set(_removable(home, alive))
        movable = [i for i in alive if home.objects[i]["class"] in MOVABLE and i in free]
        k = min(_count(rng, f_move, len(base)), len(movable))
        for i in (sorted(movable[j] for j in rng.choice(len(movable), size=k, replace=False)) if k else []):
            j = _add(home, home.objects[i]["class"])
            if j is None:
                notes.append(f"variant {v}: no place to move object {i} ({home.objects[i]['class']}) to")
                continue
            home.objects[j]["moved_from"] = i
            alive = [j if a == i else a for a in alive]
        for _ in range(_count(rng, f_add, len(base))):
            cls = names[int(rng.choice(len(names), p=p))]
            j = _add(home, cls)
            if j is None:
                notes.append(f"variant {v}: no place to add a {cls}")
            else:
                alive.append(j)
        out.append(alive)
    return out


def measure_bear_changes() -> dict[int, tuple[float, float, float]]:
    """{variant: (moved, removed, added) per object of variant 1} measured on BEAR's bundled miniroom and house
    files (module docstring), both homes pooled, rounded to 3 decimals."""
    import json

    from benchbot_worlds.bear import DATA_DIR

    tot: dict[int, list[int]] = {}
    for name in ("miniroom", "house"):
        base = json.loads((DATA_DIR / f"{name}_1.json").read_text())["ground_truth"]["objects"]
        for v in (2, 3, 4, 5):
            other = json.loads((DATA_DIR / f"{name}_{v}.json").read_text())["ground_truth"]["objects"]
            used: set[int] = set()
            moved = kept = 0
            for b in base:
                def dist(j, b=b):
                    return float(np.linalg.norm(np.subtract(other[j]["centroid"], b["centroid"])))

                same = [j for j, x in enumerate(other) if j not in used and x["class"] == b["class"]]
                m = [j for j in same if other[j].get("ID_name") == b.get("ID_name")] or \
                    [j for j in same if dist(j) < 1.0]
                if not m:
                    continue
                j = min(m, key=dist)
                used.add(j)
                moved, kept = (moved + 1, kept) if dist(j) > 0.01 else (moved, kept + 1)
            t = tot.setdefault(v, [0, 0, 0, 0])
            t[0] += len(base)
            t[1] += moved
            t[2] += len(base) - kept - moved
            t[3] += len(other) - len(used)
    return {v: (round(t[1] / t[0], 3), round(t[2] / t[0], 3), round(t[3] / t[0], 3)) for v, t in tot.items()}
