"""The procedural home generator: a pure function of a 64-bit seed (and the home's name) to a home's five variants
as BEAR-format ground-truth JSON dicts (NumPy PCG64 only; metres, ``map`` frame, z up).

Steps: the layout (:mod:`.rooms`), the objects (:mod:`.objects`), the variants (:mod:`.variants`), a check of the
union of the variants' objects against the trajectory's free-space model (:mod:`.free_space`, robot radius 0.35 m):
while a room or a side of a door lies outside its main free component, the floor object whose removal helps most
(of the :data:`REPAIR_TRIES` nearest a missed door; nothing standing on it, no bed or toilet, preferred) is dropped
with what stands on it and noted, one passive
trajectory among the union of the variants' objects (:func:`.trajectory.passive_trajectory`, shared by all five so
that every object of every variant is seen; an object it still sees from no pose would be dropped and noted),
then the JSON. The seed's :class:`numpy.random.SeedSequence` is spawned
into independent streams (layout and objects, variants, trajectory), so a change in one step's draws does not
shift another's. Every coordinate is rounded to 1e-6 m, nothing depends on set order, ``hash()``, the platform or
the installed asset library: ``json.dumps(home.variants, sort_keys=True)`` is the same bytes on any machine for a
given (seed, name, :data:`GENERATOR_VERSION`). Relaxed rules (a room or an object dropped, an object no pose
sees) are listed in ``notes``; every loop is bounded.

Data: BEAR (Hall et al., "The Robotic Vision Scene Understanding Challenge", arXiv:2009.05246; benchbot-addons
``ground_truths_isaac_develop``): the class list, class proportions, sizes and variant changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from benchbot_worlds.procedural.layout import Layout, layout_to_dict
from benchbot_worlds.procedural.objects import place_home
from benchbot_worlds.procedural.rooms import generate_layout
from benchbot_worlds.procedural.variants import LIGHTINGS, make_variants

#: The generator's version: bump it whenever the output of any seed may change (docs/worlds.md, *Versions*: 5 stands a
#: keyboard at the front of a desk with a monitor behind it and a mouse beside it, a desk made for it in a home with no
#: office; 4 draws books as single books or groups in BEAR's proportion, groups marked ``isgroup``; 3 keeps the floor
#: in front of a refrigerator clear; 2 draws laptops open or closed in BEAR's proportion; 1 drew every laptop closed).
GENERATOR_VERSION = 5
#: Candidate objects tried per object dropped to clear the robot's way (:func:`_clear_the_way`).
REPAIR_TRIES = 6
#: BEAR's class list (30 classes, background last).
CLASS_LIST = ("bottle", "cup", "knife", "bowl", "wine glass", "fork", "spoon", "banana", "apple", "orange", "cake",
              "potted plant", "mouse", "keyboard", "laptop", "cell phone", "book", "clock", "chair", "table",
              "couch", "bed", "toilet", "tv", "microwave", "toaster", "refrigerator", "oven", "sink", "person",
              "background")


@dataclass
class GeneratedHome:
    """A generated home: ``variants`` (five BEAR-format ground-truth dicts, variants 1..5), its ``layout``, and
    ``notes`` (list[str]: rules relaxed, deterministic)."""

    variants: list[dict]
    layout: Layout
    notes: list[str] = field(default_factory=list)


def _r(v) -> float:
    return round(float(v), 6) + 0.0


def _gt_object(o: dict, id_name: str) -> dict:
    lo, hi = np.round(o["lo"], 6), np.round(o["hi"], 6)
    return {"class": o["class"], "ID_name": id_name, "centroid": [_r(v) for v in (lo + hi) / 2],
            "extent": [_r(v) for v in hi - lo], "isgroup": bool(o.get("isgroup", False))}


def _id_names(objects: list[dict]) -> list[str]:
    """``procedural_<class>_<NNN>`` (spaces as underscores), numbered per class in placing order; a moved object's
    copy keeps its original's name."""
    counts: dict[str, int] = {}
    out: list[str] = []
    for o in objects:
        if "moved_from" in o:
            out.append(out[o["moved_from"]])
            continue
        k = o["class"].replace(" ", "_")
        counts[k] = counts.get(k, 0) + 1
        out.append(f"procedural_{k}_{counts[k]:03d}")
    return out


def _trajectory(layout: Layout, gt: list[dict], seed: int, notes: list[str]):
    from benchbot_worlds.procedural.trajectory import passive_trajectory

    traj = passive_trajectory(layout, gt, seed)
    notes.extend(f"trajectory: {n}" for n in traj.notes)
    start, poses = traj
    return [_r(v) for v in start], [[_r(v) for v in p] for p in poses], list(traj.unseen)


def _standing_on(objects: list[dict], i: int, alive: set[int]) -> list[int]:
    """``i`` and the alive objects standing on it, recursively (a table's items, a stack's books)."""
    out, todo = [i], [i]
    while todo:  # bounded: each object enters once
        b = objects[todo.pop()]
        for j in sorted(alive):
            o = objects[j]
            if j not in out and abs(o["lo"][2] - b["hi"][2]) < 1e-6 and o["lo"][2] > 1e-6 and \
                    np.all(o["lo"][:2] < b["hi"][:2]) and np.all(o["hi"][:2] > b["lo"][:2]):
                out.append(j)
                todo.append(j)
    return out


def _blocked(layout: Layout, objects: list[dict], alive: set[int]) -> tuple[int, list[int]]:
    """(how many rooms and door crossings the trajectory's free space (:func:`.free_space.free_space`, its main
    component) misses, the doors it misses or that lead to a room it misses) with the ``alive`` objects."""
    from benchbot_worlds.procedural.free_space import free_space, main_component
    from benchbot_worlds.procedural.trajectory import DOOR_CLEAR_M

    idx = sorted(alive)
    fs = free_space(layout, [_gt_object(objects[i], "") for i in idx])
    mask, reach = main_component(fs)
    s = layout.wall_thickness / 2 + fs.robot_radius_m + DOOR_CLEAR_M
    bad = []
    for k, d in enumerate(layout.doors):
        pts = np.array([d.centre, d.centre])
        pts[0, d.axis] -= s
        pts[1, d.axis] += s
        ij = fs.cells(pts)
        inside = (ij >= 0).all(axis=1) & (ij < np.array(mask.shape)).all(axis=1)
        ok = inside.all() and bool(mask[ij[inside, 0], ij[inside, 1]].all())
        if not ok or not (reach[d.rooms[0]] and reach[d.rooms[1]]):
            bad.append(k)
    return sum(not r for r in reach) + len(bad), bad


def _clear_the_way(layout: Layout, objects: list[dict], notes: list[str]) -> set[int]:
    """Objects (indices into ``objects``) dropped so that the trajectory's free space reaches every room and both
    sides of every door (:func:`_blocked`): while some are missed, the floor object (with what stands on it) that
    most reduces the misses among the :data:`REPAIR_TRIES` nearest to a missed door in its rooms (objects nothing
    stands on first, beds and toilets last) is dropped and noted. Bounded by the number of objects."""
    from benchbot_worlds.procedural.free_space import OBSTRUCT_BELOW_M

    alive, dropped = set(range(len(objects))), set()
    score, bad = _blocked(layout, objects, alive)
    while score and alive:  # bounded: every pass drops at least one object
        doors = [layout.doors[k] for k in bad]
        rooms = {r for d in doors for r in d.rooms}
        cands = []
        for i in sorted(alive):
            o = objects[i]
            if o["lo"][2] >= OBSTRUCT_BELOW_M or o["room"] not in rooms:
                continue
            dist = min(float(np.hypot(*np.maximum(np.maximum(o["lo"][:2] - d.centre, d.centre - o["hi"][:2]), 0.0)))
                       for d in doors)
            cands.append((o["class"] in ("bed", "toilet"), len(_standing_on(objects, i, alive)) > 1, dist, i))
        if not cands:
            break
        best = None
        for *_, i in sorted(cands)[:REPAIR_TRIES]:
            group = _standing_on(objects, i, alive)
            got = _blocked(layout, objects, alive - set(group))
            if best is None or got[0] < best[0]:
                best = (got[0], got[1], group)
            if got[0] == 0:
                break
        score, bad, group = best
        alive -= set(group)
        dropped |= set(group)
        what = ", ".join(f"{j} ({objects[j]['class']})" for j in group)
        notes.append(f"objects: dropped {what}: they blocked the robot's way")
    if score:
        notes.append(f"objects: the robot's way stays blocked ({score} rooms or door sides missed)")
    return dropped


def generate_home(seed: int, name: str) -> GeneratedHome:
    """Generate one home.

    Args:
        seed: a 64-bit unsigned seed (0 <= seed < 2**64; :mod:`.splits` derives it from the split and index).
        name: the home's name (``environment.name`` and the ``map_path``'s, e.g. ``procedural_train_0007``).

    Returns:
        :class:`GeneratedHome`; ``variants[v - 1]`` is a dict ``{environment: {name, variant, type: "world",
        map_path: "/Game/<name>_<lighting>/Maps/<name>", start_pose [qw,qx,qy,qz,x,y,z], trajectory_poses,
        object_labels (the 30 classes), description, layout (:func:`.layout.layout_to_dict`)}, format: {name:
        object_map_ground_truth}, ground_truth: {class_list (31, background last), objects: [{class, ID_name,
        centroid, extent, isgroup}]}}``.

    Raises:
        ValueError: ``seed`` is not an integer in [0, 2**64).
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= int(seed) < 2 ** 64:
        raise ValueError(f"generate_home: seed {seed!r} is not an integer in [0, 2**64)")
    s_layout, s_variants, s_traj = np.random.SeedSequence(int(seed)).spawn(3)
    notes: list[str] = []
    rng = np.random.Generator(np.random.PCG64(s_layout))
    layout = generate_layout(rng, notes)
    home = place_home(rng, layout, notes)
    members = make_variants(np.random.Generator(np.random.PCG64(s_variants)), home, notes)
    dropped = _clear_the_way(layout, home.objects, notes)
    ids = _id_names(home.objects)
    keep = [i for i in range(len(home.objects)) if i not in dropped]
    union = [_gt_object(home.objects[i], ids[i]) for i in keep]
    traj_seed = int(np.random.Generator(np.random.PCG64(s_traj)).integers(0, 2 ** 63))
    start, poses, unseen = _trajectory(layout, union, traj_seed, notes)
    for k in unseen:  # seen from no pose (none expected): dropped; the poses stay free without them
        dropped.add(keep[k])
        notes.append(f"objects: dropped {keep[k]} ({home.objects[keep[k]]['class']}): no pose sees it")
    if unseen:
        keep = [i for i in keep if i not in dropped]
        union = [_gt_object(home.objects[i], ids[i]) for i in keep]
    pos = {i: k for k, i in enumerate(keep)}
    members = [[pos[i] for i in idx if i in pos] for idx in members]
    lay = layout_to_dict(layout)
    kinds = ", ".join(f"{layout.rooms[i].kind.replace('_', ' ')}" for i in range(len(layout.rooms)))
    variants = []
    for v, (lighting, idx) in enumerate(zip(LIGHTINGS, members), start=1):
        desc = (f"Procedural home {name} (generator v{GENERATOR_VERSION}), variant {v}: {lighting} lighting; "
                f"{len(layout.rooms)} rooms ({kinds}); {len(idx)} objects"
                + ("" if v == 1 else "; objects added, removed and moved from variant 1 as in BEAR's variants"))
        env = {"name": name, "variant": v, "type": "world", "map_path": f"/Game/{name}_{lighting}/Maps/{name}",
               "start_pose": start, "trajectory_poses": poses, "object_labels": list(CLASS_LIST[:-1]),
               "description": desc, "layout": lay}
        variants.append({"environment": env, "format": {"name": "object_map_ground_truth"},
                         "ground_truth": {"class_list": list(CLASS_LIST), "objects": [union[i] for i in idx]}})
    return GeneratedHome(variants, layout, notes)
