"""Furnishing a floor plan: real models for the ground-truth objects, supports under floating ones, distractors.

:func:`furnish_home` (and :func:`furnish`, its placements only) turns the ground-truth (GT) objects of an environment,
its :class:`~benchbot_worlds.homes.floorplan.FloorPlan` and an :class:`~benchbot.packs.assets.AssetLibrary` into
:class:`~benchbot_worlds.homes.furnish_space.Placement` s: an asset id and the (4, 4) transform taking the asset's
map-frame model (z up, front −y, origin at the centre of the bottom of its bounds) to the map. Pure NumPy,
deterministic per ``seed``; GT is never changed. The steps:

* **GT objects** (here): a model of the object's class fitted EXACTLY to its cuboid
  (:func:`~benchbot_worlds.homes.fitting.fit_to_cuboid`; a toilet whose cuboid boxes its bowl alone, a little over
  the floor, from the floor up: :func:`~benchbot_worlds.homes.furnish_supports.standing_box`), model and quarter
  turn chosen by proportion distortion, a size term (``SIZE_WEIGHT``: a model near its real size is preferred) and a
  facing preference (:func:`~benchbot_worlds.homes.fitting.choose_model`: facing decides between turns that
  distort alike and yields to proportions once the facing it wants would distort by more than ~``FACING_WEIGHT``, a
  1.8× aspect change for 0.6). The model is drawn, seeded by the object's class and ``ID_name`` (so a home's variants
  draw an object alike), among the ``CHOICE_TOP`` best within ``CHOICE_MARGIN``. Facings: chairs toward the nearest GT
  table of the home (of any of its variants, so a chair that stays faces the same way in all of them) within
  :data:`CHAIR_TABLE_RANGE_M` (else the room centre); :data:`BACK_TO_WALL` classes with their back to the nearest
  wall; :data:`FACE_ROOM` classes toward the room centre; the rest a seeded random turn (weight
  ``RANDOM_FACING_WEIGHT``, a tie-break). Books are closed books made in code, not models
  (:func:`~benchbot_worlds.homes.books.closed_books`): an ``isgroup`` cuboid a row of standing books along its
  long horizontal axis, spines toward the room (a stack of lying books when the cuboid is flat), seeded thicknesses,
  heights, depths and spine colours, their union exactly the cuboid, all with the object's index; one book standing or
  lying (:attr:`Placement.mesh` holds each book's mesh). Keyboards are made in code too
  (:func:`~benchbot_worlds.homes.keyboards.keyboard`): a case exactly the cuboid, a cap standing on its sloping
  plate for every key, the keys' near side away from the nearest wall; and toasters
  (:func:`~benchbot_worlds.homes.toasters.toaster`): a two-slot pop-up toaster exactly the cuboid, its front away from
  the wall behind it. A class with models tagged :data:`PROPORTIONAL_TAG` (the
  clocks' round dial) takes one of them, never stretched: uniformly scaled into the cuboid against its back
  (:func:`proportional_box`); so does the model chosen for a class of :data:`UNSTRETCHED_CLASSES` (bottles). A
  class of :data:`NOT_STRETCHED_TALL` (cups) chooses among the models that its cuboid stretches at most
  :data:`MAX_TALL_STRETCH` taller than wide, if any (a teacup stays in low cuboids). A
  bed's model, chosen for its cuboid, is drawn back from a side where a lower GT object beside it reaches in
  (:mod:`~benchbot_worlds.homes.beds`: BEAR's minirooms box a bed with its headboard, and their nightstand stands
  inside the cuboid). A
  chair cuboid from :data:`SEAT_HEIGHT_M` up to :data:`LOW_CHAIR_M` high takes a model tagged :data:`DINING_TAG` (a
  chair with a back, squashed), if the class has one; a bowl cuboid at least :data:`FRUIT_BOWL_M` across one tagged
  :data:`FRUIT_TAG` (a bowl of fruit). A class not in :data:`MADE_IN_CODE` with no
  model, or a flat cuboid: no placement (:attr:`Furnishing.without_model`; the caller draws it otherwise).
* **Supports** (:mod:`benchbot_worlds.homes.furnish_supports`): counters, cabinets, shelves … under objects that
  would float, their tops at the objects' bottoms; the ones left without are reported with why
  (:attr:`Furnishing.unsupported`).
* **Along the walls** (:mod:`benchbot_worlds.homes.furnish_walls`): distractors by room kind (never a GT class),
  pictures, radiators and curtains at windows, door and window models, a cabinet over each refrigerator that backs
  onto a wall, ceiling lamps.

Everything that is not a GT model is derived from ``context_objects`` (the home's union over its variants) so the
variants of a home share it; an object that floats in one variant only (what it rested on is absent there) gets a
support of its own.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from benchbot_worlds.homes.beds import CLEARED_CLASSES, clear_of_neighbours
from benchbot_worlds.homes.books import closed_books
from benchbot_worlds.homes.fitting import (
    FACING_WEIGHT, RANDOM_FACING_WEIGHT, SIZE_WEIGHT, asset_bounds, choose_model, fit_to_cuboid, front_of,
    tall_stretch, transformed_bounds, turns_facing)
from benchbot_worlds.homes.furnish_space import (
    Furnishing, Placement, Space, gt_box, nearest_wall_away, rect_gap, room_centre, seeded_rng, unit_vector)
from benchbot_worlds.homes.furnish_supports import (
    FLOAT_MIN_Z_M, place_supports, rests_on, standing_box, stands_on_own_foot, supported_by)
from benchbot_worlds.homes.furnish_tables import dress_tables
from benchbot_worlds.homes.furnish_walls import place_lights, place_openings, place_over_fridges, place_span
from benchbot_worlds.homes.keyboards import keyboard
from benchbot_worlds.homes.toasters import toaster

__all__ = ["Furnishing", "Placement", "asset_bounds", "fit_to_cuboid", "furnish", "furnish_home",
           "transformed_bounds"]

log = logging.getLogger(__name__)

#: Chairs face the nearest GT table whose footprint is within this distance (m), else the room centre.
CHAIR_TABLE_RANGE_M = 1.5

#: Classes placed with their back to the nearest wall (front toward the room).
BACK_TO_WALL = frozenset(("couch", "bed", "toilet", "refrigerator", "oven", "tv", "sink", "microwave", "toaster",
                          "clock", "laptop", "keyboard"))

#: Classes drawn facing the room centre.
FACE_ROOM = frozenset(("person",))

#: The ``asset_id`` of the placements of closed books made in code (:mod:`~benchbot_worlds.homes.books`).
CLOSED_BOOK_ID = "closed_book"
#: The ``asset_id`` of the placements of keyboards made in code (:mod:`~benchbot_worlds.homes.keyboards`).
KEYBOARD_ID = "computer_keyboard"
#: The ``asset_id`` of the placements of toasters made in code (:mod:`~benchbot_worlds.homes.toasters`).
TOASTER_ID = "pop_up_toaster"
#: Classes drawn by meshes made in code, whatever models the asset packs have for them.
MADE_IN_CODE = frozenset(("book", "keyboard", "toaster"))


def _facing(i: int, obj: dict, box, space: Space, tables: list, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """(preferred facing (2,), weight) of a GT object."""
    lo, hi = box
    c = (lo[:2] + hi[:2]) / 2
    cls = str(obj.get("class", ""))
    if cls == "chair":
        best, best_d = None, math.inf
        for tlo, thi in tables:
            d = rect_gap(lo, hi, tlo, thi)
            if d < best_d:
                best, best_d = (tlo, thi), d
        if best is not None and best_d <= CHAIR_TABLE_RANGE_M:
            target = np.clip(c, best[0][:2], best[1][:2])
            if np.linalg.norm(target - c) <= 1e-3:  # the chair stands under the table: face its centre
                target = (best[0][:2] + best[1][:2]) / 2
            v = unit_vector(target - c)
            if v is not None:
                return v, FACING_WEIGHT
        v = unit_vector(room_centre(space.plan, c) - c)
        return (v if v is not None else front_of(int(rng.integers(4)))), FACING_WEIGHT
    if cls in BACK_TO_WALL:
        away = nearest_wall_away(space, lo, hi)
        if away is not None:
            return away, FACING_WEIGHT
    if cls in FACE_ROOM:
        v = unit_vector(room_centre(space.plan, c) - c)
        if v is not None:
            return v, FACING_WEIGHT
    return front_of(int(rng.integers(4))), RANDOM_FACING_WEIGHT


#: The tag of a model that is never stretched (a clock's round dial): it is scaled uniformly to the largest size that
#: fits the cuboid, its back against the cuboid's back side, on its bottom, centred across (:func:`proportional_box`).
PROPORTIONAL_TAG = "proportional"


def proportional_box(size: np.ndarray, lo: np.ndarray, hi: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The box (lo, hi) (3,) float64, map frame, metres, that a model of ``size`` (3,) metres turned by ``k`` quarter
    turns fills when scaled uniformly to the largest size inside the cuboid ``lo``..``hi``: on the cuboid's bottom,
    its back flush with the cuboid's side opposite :func:`front_of` (k), centred along the other horizontal axis."""
    sz = np.asarray(size, dtype=np.float64)[[1, 0, 2]] if k % 2 else np.asarray(size, dtype=np.float64)
    d = sz * float(np.min((hi - lo) / sz))
    blo, bhi = (lo + hi) / 2 - d / 2, (lo + hi) / 2 + d / 2
    blo[2], bhi[2] = lo[2], lo[2] + d[2]
    f = front_of(k)
    ax = 0 if abs(f[0]) > 0.5 else 1
    blo[ax], bhi[ax] = (lo[ax], lo[ax] + d[ax]) if f[ax] > 0 else (hi[ax] - d[ax], hi[ax])
    return np.minimum(np.maximum(blo, lo), hi), np.minimum(np.maximum(bhi, lo), hi)


#: The tag of a dining chair (four legs and a back) ...
DINING_TAG = "dining"

#: ... which a chair cuboid at least :data:`SEAT_HEIGHT_M` but lower than this high (m) takes, squashed: BEAR's
#: 0.51 m chair cuboids at the houses' dining tables fit a legless floor chair or a stool with the least distortion,
#: but the COCO detector of ``benchmarks/realism.py`` finds a squashed dining chair in them far more often
#: (docs/realism.md, 25 Nov 2026).
LOW_CHAIR_M = 0.55

#: A chair cuboid lower than a seat (m) keeps the models that fit it best (a stool): a dining chair squashed into
#: BEAR's 0.39 m cuboids was found more often than the stool, but its chair boxes matched the low cuboids' visible
#: parts less often (more false positives; docs/realism.md, 25 Nov 2026).
SEAT_HEIGHT_M = 0.45


#: The tag of a bowl of fruit ...
FRUIT_TAG = "fruit"

#: ... which a bowl cuboid at least this wide on both horizontal sides (m) takes, if the class has one: BEAR's big
#: bowl cuboids (0.46-0.55 m across, on the houses' counters) took the pack's plain bowl at 1.3x its size, a bare
#: hemisphere from the camera's height that the COCO detector of ``benchmarks/realism.py`` hardly ever took for a bowl
#: (docs/realism.md, 25 Nov 2026); its small ones (0.15-0.24 m) keep the models that fit them best.
FRUIT_BOWL_M = 0.4


#: Classes whose chosen model is never stretched, only scaled uniformly into its cuboid like a
#: :data:`PROPORTIONAL_TAG` model (:func:`proportional_box`): a glass bottle keeps its proportions, and BEAR's wide
#: bottle cuboids (0.24 x 0.31 x 0.30 m in the houses) drew a squat jar the COCO detectors of
#: ``benchmarks/realism.py`` did not read as a bottle (docs/realism.md, 26 Nov 2026).
UNSTRETCHED_CLASSES = frozenset(("bottle",))


#: Classes whose models are never stretched more than :data:`MAX_TALL_STRETCH` taller than wide
#: (:func:`~benchbot_worlds.homes.fitting.tall_stretch`), if the class has a model that fits so: the pack's teacup on
#: its saucer fitted into the procedural homes' mug-sized cup cuboids (0.12 x 0.15 x 0.12 m, BEAR's median) was
#: stretched 1.75 times in height and 1.24 across (1.4 taller than wide), a vase more than a cup
#: (docs/history/realism-2026-11.md, *Teacups kept to low cuboids*).
NOT_STRETCHED_TALL = frozenset(("cup",))
#: The most a model of :data:`NOT_STRETCHED_TALL` is stretched taller than wide.
MAX_TALL_STRETCH = 1.2


def _place_objects(objects, boxes, space, library, seed, bounds_of, out: Furnishing, tables: list) -> None:
    """A model for every GT object (module docstring); ``tables``: the (lo, hi) boxes of the home's GT tables (in
    every variant: a chair of several variants faces the same way in all of them)."""
    for i, obj in enumerate(objects):
        lo, hi = boxes[i]
        cls = str(obj.get("class", ""))
        assets = [a for a in library.by_class(cls) if getattr(a, "role", "object") == "object"]
        if (not assets and cls not in MADE_IN_CODE) or np.any(hi - lo <= 1e-6):
            out.without_model.append(i)
            continue
        key = (cls, obj.get("ID_name", i))
        rng = seeded_rng(seed, "object", *key)
        prefer, weight = _facing(i, obj, (lo, hi), space, tables, rng)
        if cls == "book":  # closed books made in code, spines toward the room (away from the nearest wall)
            away = nearest_wall_away(space, lo, hi)
            for mesh, T in closed_books(lo, hi, isgroup=bool(obj.get("isgroup")), away=away, rng=rng):
                out.placements.append(Placement(CLOSED_BOOK_ID, T, i, "object", mesh=mesh))
            continue
        if cls == "keyboard":  # a keyboard made in code, its typist's side away from the nearest wall
            mesh, T = keyboard(lo, hi, prefer=prefer, rng=rng)
            out.placements.append(Placement(KEYBOARD_ID, T, i, "object", mesh=mesh))
            continue
        if cls == "toaster":  # a toaster made in code, its front away from the wall behind it
            mesh, T = toaster(lo, hi, prefer=prefer, rng=rng)
            out.placements.append(Placement(TOASTER_ID, T, i, "object", mesh=mesh))
            continue
        proportional = [a for a in assets if PROPORTIONAL_TAG in getattr(a, "tags", ())]
        if proportional:  # seeded among them; the turn that faces the preferred way
            a = proportional[int(rng.integers(len(proportional)))]
            k = turns_facing(prefer)
            bounds = bounds_of(a)
            blo, bhi = proportional_box(bounds[1] - bounds[0], lo, hi, k)
            out.placements.append(Placement(a.id, fit_to_cuboid(a, blo, bhi, k, bounds=bounds), i, "object"))
            continue
        if cls == "chair" and SEAT_HEIGHT_M <= hi[2] - lo[2] < LOW_CHAIR_M:  # squashed: see LOW_CHAIR_M
            assets = [a for a in assets if DINING_TAG in getattr(a, "tags", ())] or assets
        if cls == "bowl" and min(hi[0] - lo[0], hi[1] - lo[1]) >= FRUIT_BOWL_M:  # see FRUIT_BOWL_M
            assets = [a for a in assets if FRUIT_TAG in getattr(a, "tags", ())] or assets
        if cls in NOT_STRETCHED_TALL:  # see NOT_STRETCHED_TALL
            assets = [a for a in assets if tall_stretch(a.size_m, hi - lo) <= MAX_TALL_STRETCH] or assets
        lo, hi = standing_box(obj, (lo, hi))  # a toilet's bowl boxed alone stands on its own foot
        a, k = choose_model(assets, hi - lo, prefer, weight, rng, size_weight=SIZE_WEIGHT)
        if cls in CLEARED_CLASSES:  # the model chosen for the cuboid, clear of the nightstand beside it
            lo, hi = clear_of_neighbours(lo, hi, space)
        bounds = bounds_of(a)
        if cls in UNSTRETCHED_CLASSES:  # see UNSTRETCHED_CLASSES
            lo, hi = proportional_box(bounds[1] - bounds[0], lo, hi, k)
        out.placements.append(Placement(a.id, fit_to_cuboid(a, lo, hi, k, bounds=bounds), i, "object"))


def _default_bounds_of(asset: Any) -> np.ndarray:
    return asset_bounds(asset)


def _key(o: dict) -> tuple:
    """Identity of a GT object across a home's variants: class, ID_name, centroid and extent (to 1 µm)."""
    return (str(o.get("class")), str(o.get("ID_name")), tuple(np.round(np.asarray(o["centroid"], float), 6)),
            tuple(np.round(np.asarray(o["extent"], float), 6)))


def _dedupe(objs: Sequence[dict]) -> list[dict]:
    seen, out = set(), []
    for o in objs:
        if _key(o) not in seen:
            seen.add(_key(o))
            out.append(o)
    return out


def furnish_home(objects: Sequence[dict], plan: Any, library: Any, *, seed: int = 0,
                 context_objects: Sequence[dict] | None = None,
                 bounds_of: Callable[[Any], np.ndarray] | None = None,
                 mesh_of: Callable[[Any], Any] | None = None) -> Furnishing:
    """Models, supports, distractors, doors, windows and lamps for one environment (see the module docstring).

    Args:
        objects: the environment's GT objects (dicts with ``class``, ``centroid`` (3,), ``extent`` (3,), optional
            ``ID_name``, ``isgroup``), map frame, metres.
        plan: its :class:`~benchbot_worlds.homes.floorplan.FloorPlan`.
        library: an :class:`~benchbot.packs.assets.AssetLibrary`.
        seed: the same seed gives the same placements.
        context_objects: every GT object of the home (the union over its variants). Supports and distractors are
            derived from these, so the variants of a home share their furniture; default ``objects``.
        bounds_of: the (2, 3) true model-frame bounds of an asset (e.g. its mesh's) for exact fits; default from
            ``size_m``.
        mesh_of: an asset's mesh (``v`` (V, 3) model frame, metres; ``f`` (F, 3) int), to stand things on the GT
            tables' tops (:func:`~benchbot_worlds.homes.furnish_tables.dress_tables`); None: tables stay bare.

    Returns:
        A :class:`Furnishing`.
    """
    bounds_of = bounds_of or _default_bounds_of
    objects = list(objects)
    context = _dedupe(list(context_objects or []) + objects) if context_objects is not None else list(objects)
    ctx_boxes = [gt_box(o) for o in context]
    # the space a GT object's model takes (a toilet's foot under its cuboid) is kept free of other furniture
    space = Space(plan, [standing_box(o, b) for o, b in zip(context, ctx_boxes)],
                  [f"{o.get('class')} {o.get('ID_name', '')}".strip() for o in context],
                  [str(o.get("class", "")) for o in context])
    out = Furnishing()
    boxes = [gt_box(o) for o in objects]
    tables = [b for o, b in zip(context, ctx_boxes) if o.get("class") == "table"]
    _place_objects(objects, boxes, space, library, seed, bounds_of, out, tables)
    # supports for the whole home (stable across variants), then distractors
    ctx_out = Furnishing()
    place_supports(context, ctx_boxes, space, library, plan, seed, bounds_of, ctx_out)
    place_openings(space, library, plan, seed, bounds_of, ctx_out)
    place_over_fridges(context, ctx_boxes, space, library, plan, bounds_of, ctx_out)
    for idx, span in enumerate(getattr(plan, "wall_spans", []) or []):
        place_span(span, idx, space, library, plan, seed, bounds_of, ctx_out)
    place_lights(space, library, plan, seed, bounds_of, ctx_out)
    out.placements.extend(ctx_out.placements)
    for role, bl in ctx_out.boxes.items():
        out.boxes.setdefault(role, []).extend(bl)
    # report in terms of `objects`; an object that floats here although it rests on something in the home's
    # union (that something is absent in this variant) gets a support of its own
    ctx_index = {_key(o): j for j, o in enumerate(context)}
    unsupported_ctx = dict(ctx_out.unsupported)
    hanging_ctx = set(ctx_out.hanging)
    extra = []
    for i, o in enumerate(objects):
        j = ctx_index.get(_key(o))
        if j in hanging_ctx:
            out.hanging.append(i)
        elif j in unsupported_ctx:
            out.unsupported.append((i, unsupported_ctx[j]))
        elif boxes[i][0][2] > FLOAT_MIN_Z_M and np.all(boxes[i][1] - boxes[i][0] > 1e-6) \
                and not stands_on_own_foot(o, boxes[i]) and not rests_on(i, boxes) \
                and not supported_by(boxes[i], out.boxes.get("support", [])):
            extra.append(i)
    if extra:
        local = Furnishing()
        sub = [objects[i] for i in extra]
        place_supports(sub, [boxes[i] for i in extra], space, library, plan, seed, bounds_of, local)
        out.placements.extend(local.placements)
        for role, bl in local.boxes.items():
            out.boxes.setdefault(role, []).extend(bl)
        out.unsupported.extend((extra[j], why) for j, why in local.unsupported)
        out.hanging.extend(extra[j] for j in local.hanging)
    if mesh_of is not None:  # last: what the home's other variants place is in the space already
        dress_tables(objects, [p for p in out.placements if p.role == "object"], space, library, seed, mesh_of,
                     bounds_of, out)
    out.unsupported.sort()
    out.hanging.sort()
    for i, why in out.unsupported:
        log.info("furnish: object %d (%s) has no support: %s", i, objects[i].get("class"), why)
    return out


def furnish(objects: Sequence[dict], plan: Any, library: Any, *, seed: int = 0,
            context_objects: Sequence[dict] | None = None,
            bounds_of: Callable[[Any], np.ndarray] | None = None) -> list[Placement]:
    """The placements of :func:`furnish_home` (which also reports objects without a model or support)."""
    return furnish_home(objects, plan, library, seed=seed, context_objects=context_objects,
                        bounds_of=bounds_of).placements
