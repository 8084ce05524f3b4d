"""Furniture along the walls: distractors by room kind, pictures, radiators and curtains at windows, door and window
models in the openings, a cabinet over a refrigerator that backs onto a wall, ceiling lamps (pure NumPy).

Distractors stand along ``plan.wall_spans`` at their natural size (± 5 %), back to the wall, kinds drawn by room
(:data:`ROOM_DISTRACTORS`; never a GT class), no taller than the span allows (a window's sill); pictures hang on
free wall above :data:`~benchbot_worlds.homes.furnish_space.OVERHEAD_CLEAR_Z_M`; a radiator under each window sill and
curtains beside it; a door model fitted to each doorway that takes a leaf (a door frame where the robot passes:
never a closed door), a window model to each window; a ceiling lamp over each of ``plan.lights``. Each keeps
:data:`DISTRACTOR_CLEARANCE_M` from every GT cuboid, support and other distractor, cuts no wall, covers no window or
door hole; floor-standing ones keep clear of the robot corridor and of the floor at doorways.
"""

from __future__ import annotations

import math

import numpy as np

from benchbot_worlds.homes.fitting import FACING_WEIGHT, choose_model, fit_to_cuboid, turns_facing
from benchbot_worlds.homes.furnish_space import (
    OVERHEAD_CLEAR_Z_M, Furnishing, Placement, Space, add_placement, furniture_of_kinds, room_of, seeded_rng,
    wall_faces)

#: Floor-standing distractors keep this clearance (m) from GT cuboids, supports and each other.
DISTRACTOR_CLEARANCE_M = 0.05

#: Probability of trying a distractor at each free position of a wall span.
DISTRACTOR_FILL = 0.7

#: Distractor kinds per room kind: (kind, weight). Never a GT class (checked).
ROOM_DISTRACTORS: dict[str, tuple[tuple[str, float], ...]] = {
    "kitchen": (("counter", 3.0), ("cabinet", 2.0), ("shelf", 0.5), ("trash_can", 0.5)),
    "bathroom": (("bathtub", 2.0), ("shower", 1.0), ("washing_machine", 1.5), ("dryer", 0.5), ("cabinet", 1.0),
                 ("laundry_basket", 0.5), ("trash_can", 0.3)),
    "bedroom": (("wardrobe", 2.0), ("dresser", 2.0), ("nightstand", 1.0), ("bookcase", 0.5),
                ("laundry_basket", 0.3)),
    "living_room": (("bookcase", 2.0), ("cabinet", 2.0), ("floor_lamp", 1.0), ("dresser", 0.5), ("piano", 0.5),
                    ("fireplace", 0.5), ("speaker", 0.5)),
    "office": (("bookcase", 2.0), ("shelf", 2.0), ("cabinet", 1.0), ("floor_lamp", 0.5), ("trash_can", 0.5)),
    "hall": (("cabinet", 1.0), ("shelf", 1.0), ("floor_lamp", 0.5), ("trash_can", 0.3)),
}

#: What goes with a distractor: {its kind: ((kind added, probability), ...)} — things on its top (models mounted
#: on a ``surface``: a table lamp, a photo frame), a wall cabinet WALL_CABINET_GAP_M above a kitchen counter.
TOPPERS: dict[str, tuple[tuple[str, float], ...]] = {
    "nightstand": (("table_lamp", 0.6), ("picture", 0.3)),
    "dresser": (("table_lamp", 0.4), ("picture", 0.5)),
    "cabinet": (("picture", 0.3),),
    "shelf": (("picture", 0.3),),
    "counter": (("wall_cabinet", 0.7),),
}
#: Gap (m) between a kitchen counter's top and the wall cabinet above it.
WALL_CABINET_GAP_M = 0.55
#: Wall-hung distractors (models mounted on a ``wall``, in every room): {kind: range (m) of the height of its
#: centre} (its bottom stays above OVERHEAD_CLEAR_Z_M, its top under the ceiling).
WALL_DISTRACTORS: dict[str, tuple[float, float]] = {"picture": (1.45, 1.75), "mirror": (1.4, 1.6),
                                                    "air_conditioner": (2.05, 2.3)}
#: The most wall-hung distractors of a kind per room (kinds not listed: no limit).
WALL_DISTRACTORS_PER_ROOM = {"air_conditioner": 1, "mirror": 1}

#: A refrigerator whose back stands within this distance (m) of a wall gets a cabinet over it
#: (:func:`place_over_fridges`); BEAR's houses stand theirs 0.49 m out, in the room.
FRIDGE_AT_WALL_M = 0.15
#: Gap (m) between a refrigerator's top and the cabinet over it.
OVER_FRIDGE_GAP_M = 0.06
#: The shortest cabinet (m) worth hanging over a refrigerator.
OVER_FRIDGE_MIN_HEIGHT_M = 0.3
#: A cabinet over a refrigerator stops this far (m) under the ceiling.
CEILING_GAP_M = 0.02

#: Tallest ceiling lamp (m); bigger models are scaled down uniformly.
LAMP_MAX_DROP_M = 0.5


def _natural_box(asset, a: np.ndarray, t: np.ndarray, n: np.ndarray, s: float, z0: float, scale: float):
    """Box of an asset at natural size × scale with its back on the line a + t·s (the wall face), front along n."""
    w, d, h = (float(v) * scale for v in asset.size_m)
    p0 = a + t * s
    p1 = p0 + t * w + n * d
    lo = np.array([min(p0[0], p1[0]), min(p0[1], p1[1]), z0])
    hi = np.array([max(p0[0], p1[0]), max(p0[1], p1[1]), z0 + h])
    return lo, hi, w


def _weighted_kind(rng, table, library) -> list:
    avail = [(k, wt, furniture_of_kinds(library, (k,))) for k, wt in table]
    avail = [x for x in avail if x[2]]
    if not avail:
        return []
    p = np.array([x[1] for x in avail], dtype=np.float64)
    return avail[int(rng.choice(len(avail), p=p / p.sum()))][2]


def place_over_fridges(context, boxes, space: Space, library, plan, bounds_of, out: Furnishing) -> None:
    """A wall cabinet over each refrigerator that stands with its back to a wall, as fitted kitchens build one (and
    the detectors trained on photos of kitchens expect: docs/realism.md, *What paid*).

    The cabinet spans the fridge's width, its back on that wall (the wall :func:`wall_faces` finds nearest, the one
    the fridge's model backs onto), OVER_FRIDGE_GAP_M over the fridge's top; the model whose width is nearest the
    fridge's, scaled uniformly to it, and squashed to stop CEILING_GAP_M under the ceiling (over-fridge cabinets
    are short). Left out where it would be under OVER_FRIDGE_MIN_HEIGHT_M or hit anything (a window, another
    distractor). ``context``: GT objects (dicts with ``class``); ``boxes``: their (lo (3,), hi (3,)) boxes, home
    frame, metres; ``out`` and ``space`` gain each cabinet. Raises nothing: a library without wall-mounted wall
    cabinets, or a fridge with no wall behind it, gets no cabinet."""
    cabinets = sorted((x for x in furniture_of_kinds(library, ("wall_cabinet",)) if x.mount == "wall"),
                      key=lambda x: x.id)
    if not cabinets:
        return
    ceiling = float(getattr(plan, "wall_height", 2.6)) - CEILING_GAP_M
    for o, (lo, hi) in zip(context, boxes):
        if o.get("class") != "refrigerator":
            continue
        lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        faces = wall_faces(space, lo, hi)
        if not faces or faces[0][0] > FRIDGE_AT_WALL_M:
            continue
        _, away, ax, face = faces[0]
        other = 1 - ax
        along = float(hi[other] - lo[other])
        if along <= 1e-6:  # a flat cuboid: no model is drawn for it either
            continue
        z0 = float(hi[2]) + OVER_FRIDGE_GAP_M
        for asset in sorted(cabinets, key=lambda x: abs(math.log(along / float(x.size_m[0])))):
            w0, d0, h0 = (float(v) for v in asset.size_m)
            depth, height = d0 * along / w0, min(h0 * along / w0, ceiling - z0)
            blo, bhi = np.zeros(3), np.zeros(3)
            blo[other], bhi[other] = lo[other], hi[other]
            blo[ax], bhi[ax] = (face, face + depth) if away[ax] > 0 else (face - depth, face)
            blo[2], bhi[2] = z0, z0 + height
            if height >= OVER_FRIDGE_MIN_HEIGHT_M and space.why_not(
                    blo, bhi, gt_margin=OVER_FRIDGE_GAP_M / 2, corridor=False, doors=False, openings=True) is None:
                add_placement(out, space, asset, blo, bhi, turns_facing(away), "distractor", bounds_of)
                break


def place_span(span, idx: int, space: Space, library, plan, seed, bounds_of, out: Furnishing) -> None:
    """Distractors along one wall span (``plan.wall_spans[idx]``): floor furniture of its room's kinds, then
    wall-hung pictures; each added to ``out`` and ``space``."""
    a = np.asarray(span.a, dtype=np.float64)[:2]
    b = np.asarray(span.b, dtype=np.float64)[:2]
    n = np.asarray(span.inward, dtype=np.float64)[:2]
    length = float(np.linalg.norm(b - a))
    if length < 0.3:
        return
    t = (b - a) / length
    k = turns_facing(n)
    rng = seeded_rng(seed, "span", idx)
    room = next((r for r in plan.rooms if int(getattr(r, "index", -2)) == int(span.room)), None)
    if room is None:
        room = room_of(plan, (a + b) / 2 + n * 0.1)
    table = ROOM_DISTRACTORS.get(getattr(room, "kind", "hall"), ROOM_DISTRACTORS["hall"])
    max_h = float(getattr(span, "max_height", math.inf))  # under a window: its sill
    s = float(rng.uniform(0.05, 0.4))
    while s < length - 0.3:
        if rng.random() > DISTRACTOR_FILL:
            s += float(rng.uniform(0.3, 1.0))
            continue
        assets = _weighted_kind(rng, table, library)
        if not assets:
            break
        asset = assets[int(rng.integers(len(assets)))]
        lo, hi, w = _natural_box(asset, a, t, n, s, 0.0, float(rng.uniform(0.95, 1.05)))
        if s + w <= length and hi[2] <= max_h and space.why_not(lo, hi, gt_margin=DISTRACTOR_CLEARANCE_M,
                                             placed_margin=DISTRACTOR_CLEARANCE_M, openings=True) is None:
            add_placement(out, space, asset, lo, hi, k, "distractor", bounds_of)
            _add_toppers(asset, lo, hi, a, t, n, s, k, space, library, plan, rng, bounds_of, out)
            s += w + float(rng.uniform(0.05, 0.5))
        else:
            s += 0.2
    # pictures, mirrors, air conditioners on the wall above the robot
    hung = [x for kd in WALL_DISTRACTORS for x in furniture_of_kinds(library, (kd,)) if x.mount == "wall"]
    s = float(rng.uniform(0.2, 0.8))
    while hung and s < length - 0.3:
        asset = hung[int(rng.integers(len(hung)))]
        if space.counts.get((span.room, asset.kind), 0) >= WALL_DISTRACTORS_PER_ROOM.get(asset.kind, math.inf):
            hung = [x for x in hung if x.kind != asset.kind]
            continue
        zc = float(rng.uniform(*WALL_DISTRACTORS[asset.kind]))
        sc = float(rng.uniform(0.9, 1.1))
        h = float(asset.size_m[2]) * sc
        z0 = max(zc - h / 2, OVERHEAD_CLEAR_Z_M)
        lo, hi, w = _natural_box(asset, a, t, n, s, z0, sc)
        if (s + w <= length and hi[2] < float(getattr(plan, "wall_height", 2.6)) - 0.05
                and space.why_not(lo, hi, gt_margin=DISTRACTOR_CLEARANCE_M, placed_margin=DISTRACTOR_CLEARANCE_M,
                                  corridor=False, doors=False, openings=True) is None):
            add_placement(out, space, asset, lo, hi, k, "distractor", bounds_of)
            space.counts[(span.room, asset.kind)] = space.counts.get((span.room, asset.kind), 0) + 1
            s += w + float(rng.uniform(0.8, 2.0))
        else:
            s += 0.3


def _add_toppers(unit, lo, hi, a, t, n, s, k, space: Space, library, plan, rng, bounds_of, out: Furnishing) -> None:
    """What goes with a distractor just placed at ``s`` along its wall span (TOPPERS): things standing on its top
    (a table lamp, a photo frame: models whose mount is ``surface``), side by side; a wall cabinet above a kitchen
    counter (aligned with it)."""
    along = float(np.dot(hi[:2] - lo[:2], np.abs(t)))  # the unit's width along the wall ...
    depth = float(np.dot(hi[:2] - lo[:2], np.abs(n)))  # ... and its depth
    slots = [0.0, 0.5]  # on top: the first thing in the left half, the next in the right half
    for kind, p in TOPPERS.get(unit.kind, ()):
        if rng.random() >= p:
            continue
        wall = kind == "wall_cabinet"
        assets = [x for x in furniture_of_kinds(library, (kind,))
                  if (x.mount == "wall") == wall and (wall or x.mount in ("surface", None))]
        if not assets:
            continue
        asset = assets[int(rng.integers(len(assets)))]
        w0, d0, h0 = (float(v) for v in asset.size_m)
        if wall:
            sc = float(np.clip(along / w0, 0.8, 1.2))
            z0 = float(hi[2]) + WALL_CABINET_GAP_M
            blo, bhi, _ = _natural_box(asset, a, t, n, s + (along - w0 * sc) / 2, z0, sc)
            if bhi[2] > float(getattr(plan, "wall_height", 2.6)) - 0.02:
                continue
            kw = {"corridor": z0 < OVERHEAD_CLEAR_Z_M, "doors": False, "openings": True}
        else:
            if not slots:
                break
            sc = min(1.0, 0.8 * depth / d0, 0.45 * along / w0)
            start = slots.pop(0) * along + float(rng.uniform(0.05, 0.95)) * max(0.5 * along - w0 * sc, 0.0)
            blo, bhi, _ = _natural_box(asset, a + n * (depth - d0 * sc) / 2, t, n, s + start, float(hi[2]), sc)
            kw = {"corridor": False, "doors": False}
        if space.why_not(blo, bhi, gt_margin=DISTRACTOR_CLEARANCE_M, **kw) is None:
            add_placement(out, space, asset, blo, bhi, k, "distractor", bounds_of)


def place_openings(space: Space, library, plan, seed, bounds_of, out: Furnishing) -> None:
    """Door models in doorways that take a leaf (a frame where the robot passes), window models in windows, a
    radiator under and curtains beside each window; added to ``out`` and ``space``."""
    H = float(getattr(plan, "wall_height", 2.6))
    for idx, o in enumerate(getattr(plan, "openings", []) or []):
        lo, hi = np.asarray(o.lo, dtype=np.float64), np.asarray(o.hi, dtype=np.float64)
        outward = np.asarray(o.outward, dtype=np.float64)[:2]
        rng = seeded_rng(seed, "opening", idx)
        if o.kind == "door":
            if not getattr(o, "leaf", True):
                continue  # an open passage (open plan): no door model
            ax = int(np.argmax(np.abs(outward)))
            zlo, zhi = lo.copy(), hi.copy()
            zlo[ax] -= 0.5
            zhi[ax] += 0.5
            on_path = space.blocked(zlo, zhi)  # the robot passes (or passes by): no closed door leaf
            kinds = ("door_frame", "doorway") if on_path else ("door", "door_frame", "doorway")
            assets = next((list(library.by_kind(kd)) for kd in kinds if library.by_kind(kd)), [])
            role = "door"
        else:
            assets = list(library.by_kind("window"))
            role = "window"
        if assets and np.all(hi - lo > 1e-6):
            pick = choose_model(assets, hi - lo, -outward, FACING_WEIGHT, rng)
            a, k = pick
            out.placements.append(Placement(a.id, fit_to_cuboid(a, lo, hi, k, bounds=bounds_of(a)), -1, role))
            out.boxes.setdefault(role, []).append((lo, hi))
        if o.kind != "window":
            continue
        ax = int(np.argmax(np.abs(outward)))
        along = 1 - ax
        inward = -outward
        face = lo[ax] if inward[ax] < 0 else hi[ax]  # the hole's face on the room side
        # a radiator under the window
        rads = furniture_of_kinds(library, ("radiator",))
        sill = float(lo[2])
        if rads and sill > 0.45:
            asset = rads[int(rng.integers(len(rads)))]
            w0, d0, h0 = (float(v) for v in asset.size_m)
            sc = min(1.0, (sill - 0.2) / h0, (hi[along] - lo[along]) * 0.9 / w0)
            w, d, h = w0 * sc, d0 * sc, h0 * sc
            c = (lo[along] + hi[along]) / 2
            blo, bhi = np.zeros(3), np.zeros(3)
            blo[along], bhi[along] = c - w / 2, c + w / 2
            blo[ax], bhi[ax] = (face, face + d) if inward[ax] > 0 else (face - d, face)
            blo[2], bhi[2] = 0.12, 0.12 + h
            if space.why_not(blo, bhi, gt_margin=DISTRACTOR_CLEARANCE_M, placed_margin=0.0) is None:
                add_placement(out, space, asset, blo, bhi, turns_facing(inward), "distractor", bounds_of)
        # curtains beside the window
        curtains = furniture_of_kinds(library, ("curtain",))
        if curtains:
            asset = curtains[int(rng.integers(len(curtains)))]
            width = float(np.clip(asset.size_m[0], 0.25, 0.5))
            depth = float(np.clip(asset.size_m[1], 0.05, 0.15))
            top = min(H - 0.02, float(hi[2]) + 0.15)
            for side in (-1.0, 1.0):
                blo, bhi = np.zeros(3), np.zeros(3)
                edge = lo[along] if side < 0 else hi[along]
                blo[along], bhi[along] = (edge - width, edge) if side < 0 else (edge, edge + width)
                blo[ax], bhi[ax] = (face, face + depth) if inward[ax] > 0 else (face - depth, face)
                blo[2], bhi[2] = 0.02, top
                if space.why_not(blo, bhi, gt_margin=DISTRACTOR_CLEARANCE_M, placed_margin=0.0) is None:
                    add_placement(out, space, asset, blo, bhi, turns_facing(inward), "distractor", bounds_of)


def place_lights(space: Space, library, plan, seed, bounds_of, out: Furnishing) -> None:
    """A ceiling lamp model (role ``light``) above each of ``plan.lights``, top at the ceiling, its bottom above the
    light (scaled down to at most LAMP_MAX_DROP_M); skipped where it would meet a GT cuboid or furniture."""
    lamps = furniture_of_kinds(library, ("ceiling_lamp",))
    if not lamps:
        return
    H = float(getattr(plan, "wall_height", 2.6))
    for idx, p in enumerate(getattr(plan, "lights", []) or []):
        p = np.asarray(p, dtype=np.float64).reshape(3)
        rng = seeded_rng(seed, "light", idx)
        asset = lamps[int(rng.integers(len(lamps)))]
        w, d, h = (float(v) for v in asset.size_m)
        drop = min(LAMP_MAX_DROP_M, max(H - p[2] - 0.02, 0.03))
        sc = min(1.0, drop / h)
        lo = np.array([p[0] - w * sc / 2, p[1] - d * sc / 2, H - h * sc])
        hi = np.array([p[0] + w * sc / 2, p[1] + d * sc / 2, H])
        if space.why_not(lo, hi, gt_margin=DISTRACTOR_CLEARANCE_M, corridor=False, doors=False) is None:
            add_placement(out, space, asset, lo, hi, int(rng.integers(4)), "light", bounds_of)
