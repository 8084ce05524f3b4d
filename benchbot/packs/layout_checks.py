"""Checks of an environment's layout before anything runs on it: the one home of the content rules that
``benchbot install`` applies to a content pack's environments and ground truths (:mod:`benchbot.packs.content_packs`).

A layout is a ground-truth JSON in the original's ``object_map_ground_truth`` layout, ``{environment, format,
ground_truth: {class_list, objects: [{class, centroid [x,y,z] m, extent [dx,dy,dz] m, ID_name}]}}`` (``map`` frame,
``extent`` the full side lengths of the object's axis-aligned cuboid, centred on ``centroid``): the simulator builds
its scene from it and the evaluation scores against it. :func:`layout_problems` is pure: it reads the parsed data
and returns one line per problem, naming the file, the object and the fix.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from benchbot.core.names import close_names

#: An object whose cuboid is farther than this (metres) from the bounding box of all the other objects is refused:
#: the simulator grows the home to hold every object, so one stray object turns it into a strip of empty rooms. The
#: ten BEAR environments' largest such gap is 0.10 m (house:1, 3, 5).
FAR_FROM_HOME_M = 10.0

#: A start or trajectory pose inside the footprint of an object whose bottom is below this height (metres) is
#: refused: the robot would start inside it or drive into it. Higher objects (a shelf on a wall) do not block the
#: floor beneath them. Taller than every robot BenchBot ships.
BLOCKING_BELOW_M = 2.0

#: At most this many problems are reported per file (then one line says how many more there are).
MAX_PROBLEMS_PER_FILE = 20


def _finite3(value: Any) -> np.ndarray | None:
    try:
        a = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        return None
    return a if a.shape == (3,) and np.isfinite(a).all() else None


def _label(i: int, obj: dict) -> str:
    name = obj.get("ID_name")
    return f"ground_truth.objects[{i}]" + (f" '{name}'" if isinstance(name, str) and name else "") + \
        f" (class '{obj.get('class')}')"


def _pose_xy(pose: Any) -> tuple[float, float] | None:
    try:
        p = [float(v) for v in pose]
    except (TypeError, ValueError):
        return None
    return (p[4], p[5]) if len(p) == 7 and all(math.isfinite(v) for v in p) else None


def layout_problems(layout: Any, *, source: str, poses_source: str | None = None,
                    start_pose: Sequence[float] | None = None,
                    trajectory_poses: Sequence[Sequence[float]] | None = None) -> list[str]:
    """Every content problem of a layout, one line each (``"<source>: <object>: <problem>; <fix>"``):

    * an object whose ``class`` is not in ``ground_truth.class_list`` (the simulator's and the evaluation's classes);
    * an object with a side of zero or negative ``extent``, or a ``centroid``/``extent`` that is not 3 finite numbers;
    * an object more than :data:`FAR_FROM_HOME_M` from the bounding box of the other objects (with two or more);
    * a start or trajectory pose (``[qw,qx,qy,qz,x,y,z]``) whose ``x, y`` lies strictly inside the footprint (the
      ``x, y`` extent) of an object whose bottom is below :data:`BLOCKING_BELOW_M`.

    Args:
        layout: the parsed JSON (any value: a file that is not such a layout is one problem).
        source: how to name the layout's file in the messages (a path relative to the pack).
        poses_source: how to name the file the poses come from (default ``source``).
        start_pose, trajectory_poses: the environment's poses (its spec's); None: the layout's own
            ``environment.start_pose`` / ``environment.trajectory_poses``, if any.

    Returns:
        The problems (at most :data:`MAX_PROBLEMS_PER_FILE` and one line counting the rest); ``[]``: none.
    """
    gt = layout.get("ground_truth") if isinstance(layout, dict) else None
    if not isinstance(gt, dict) or not isinstance(gt.get("objects"), list) or not isinstance(gt.get("class_list"), list):
        return [f"{source}: not a ground-truth layout (no ground_truth.objects and ground_truth.class_list lists); "
                "give a JSON {environment, format, ground_truth: {class_list, objects}} (object_map_ground_truth)"]
    problems: list[str] = []
    classes = [str(c) for c in gt["class_list"]]
    known = set(classes)
    lows, highs, index = [], [], []
    hints: dict[str, str] = {}  # "did you mean" by unknown class, worked out only for lines that are shown
    for i, obj in enumerate(gt["objects"]):
        if not isinstance(obj, dict):
            problems.append(f"{source}: ground_truth.objects[{i}]: not an object; give {{class, centroid, extent}}")
            continue
        label = _label(i, obj)
        cls = obj.get("class")
        if not isinstance(cls, str) or cls not in known:
            if str(cls) not in hints and len(problems) < MAX_PROBLEMS_PER_FILE:  # difflib: O(classes) per name
                near = close_names(str(cls), classes)
                hints[str(cls)] = f" (did you mean '{near[0]}'?)" if near else ""
            hint = hints.get(str(cls), "")
            problems.append(f"{source}: {label}: class '{cls}' is not in ground_truth.class_list; use one of its "
                            f"classes{hint} or add '{cls}' to class_list")
        centroid, extent = _finite3(obj.get("centroid")), _finite3(obj.get("extent"))
        if centroid is None or extent is None:
            problems.append(f"{source}: {label}: centroid and extent must each be 3 finite numbers (metres); "
                            "fix the object's centroid [x, y, z] and extent [dx, dy, dz]")
            continue
        if (extent <= 0).any():
            problems.append(f"{source}: {label}: extent {extent.tolist()} has a side ≤ 0 m; give every side a "
                            "positive size (a flat object still needs a thickness, e.g. 0.01) or remove the object")
            continue
        lows.append(centroid - extent / 2)
        highs.append(centroid + extent / 2)
        index.append(i)
    if len(index) >= 2:
        lo, hi = np.asarray(lows), np.asarray(highs)
        # the bounding box of all objects but k: from prefix and suffix minima/maxima, O(n)
        inf = np.full((1, 3), np.inf)
        pre_lo = np.vstack([inf, np.minimum.accumulate(lo)[:-1]])
        suf_lo = np.vstack([np.minimum.accumulate(lo[::-1])[::-1][1:], inf])
        pre_hi = np.vstack([-inf, np.maximum.accumulate(hi)[:-1]])
        suf_hi = np.vstack([np.maximum.accumulate(hi[::-1])[::-1][1:], -inf])
        rest_lo, rest_hi = np.minimum(pre_lo, suf_lo), np.maximum(pre_hi, suf_hi)
        gap = np.linalg.norm(np.maximum(0.0, np.maximum(rest_lo - hi, lo - rest_hi)), axis=1)
        for k in np.flatnonzero(gap > FAR_FROM_HOME_M):
            i = index[k]
            problems.append(
                f"{source}: {_label(i, gt['objects'][i])}: {gap[k]:.1f} m from the bounding box of the other "
                f"objects (more than {FAR_FROM_HOME_M:g} m); move its centroid into the home or remove it")
    env = layout.get("environment") if isinstance(layout.get("environment"), dict) else {}
    if start_pose is None:
        start_pose = env.get("start_pose")
    if trajectory_poses is None:
        trajectory_poses = env.get("trajectory_poses")
    where = poses_source or source
    poses = ([("start_pose", start_pose)] if start_pose is not None else []) + \
        [(f"trajectory_poses[{j}]", p) for j, p in enumerate(trajectory_poses or [])]
    # the footprints of the blocking objects, in the objects' order: (B,) x/y lows and highs, metres
    lo_all, hi_all = np.asarray(lows).reshape(-1, 3), np.asarray(highs).reshape(-1, 3)
    blocking = np.flatnonzero(lo_all[:, 2] < BLOCKING_BELOW_M)
    (x0, y0), (x1, y1) = lo_all[blocking, :2].T, hi_all[blocking, :2].T
    checked = [(what, xy) for what, pose in poses if (xy := _pose_xy(pose)) is not None] if len(blocking) else []
    # poses against objects in blocks of about 2**22 pairs: vectorised, in bounded memory (a pack may be hostile)
    chunk = max(1, (1 << 22) // max(1, len(blocking)))
    for start in range(0, len(checked), chunk):
        part = checked[start:start + chunk]
        px, py = (np.array([xy[j] for _, xy in part])[:, None] for j in (0, 1))
        inside = (x0 < px) & (px < x1) & (y0 < py) & (py < y1)  # strictly inside: (poses, objects)
        first = inside.argmax(axis=1)  # the first such object, as the objects are listed
        for r in np.flatnonzero(inside.any(axis=1)):
            (what, xy), i = part[r], index[blocking[first[r]]]
            problems.append(f"{where}: {what} at x={xy[0]:.3f}, y={xy[1]:.3f} m is inside the footprint of "
                            f"{source}'s {_label(i, gt['objects'][i])}; move the pose out of the object "
                            "(or the object away from the pose)")
    if len(problems) > MAX_PROBLEMS_PER_FILE:
        more = len(problems) - MAX_PROBLEMS_PER_FILE
        problems = problems[:MAX_PROBLEMS_PER_FILE] + [f"{source}: and {more} more problem(s) like these"]
    return problems
