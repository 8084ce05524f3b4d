"""The procedural home generator: a pure function of a 64-bit seed (and the home's name) to a home's five variants
as BEAR-format ground-truth JSON dicts (NumPy PCG64 only; metres, ``map`` frame, z up).

Steps: the layout (:mod:`.rooms`), the objects (:mod:`.objects`), the variants (:mod:`.variants`), one passive
trajectory among the union of the variants' objects (:func:`.trajectory.passive_trajectory`, shared by all five so
that every object of every variant is seen), then the JSON. The seed's :class:`numpy.random.SeedSequence` is spawned
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

#: The generator's version: bump it whenever the output of any seed may change.
GENERATOR_VERSION = 1
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
            "extent": [_r(v) for v in hi - lo], "isgroup": False}


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
    return [_r(v) for v in start], [[_r(v) for v in p] for p in poses]


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
    ids = _id_names(home.objects)
    union = [_gt_object(o, ids[i]) for i, o in enumerate(home.objects)]
    traj_seed = int(np.random.Generator(np.random.PCG64(s_traj)).integers(0, 2 ** 63))
    start, poses = _trajectory(layout, union, traj_seed, notes)
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
