"""The furnished style of a scene: a BEAR home as a house (pure NumPy, no Taichi).

:func:`furnish_environment` turns an environment's ground-truth objects and robot paths into what
:func:`benchbot_worlds.scene.build.build_scene` draws in the ``furnished`` style (the default):

1. the floor plan shared by the variants of the home that the environment declares
   (:func:`benchbot_worlds.homes.floorplan.home_files`, :func:`benchbot_worlds.homes.floorplan.plan_for_files`):
   rooms, walls with doors and windows, lamps;
2. the furnishing (:func:`benchbot_worlds.homes.furnish.furnish_home`): a textured model of its class fitted exactly
   to every ground-truth cuboid, supports under objects that would float, distractor furniture of no ground-truth
   class, door frames, windows, ceiling lamps — models from the asset packs of the plugins
   (:func:`benchbot.packs.assets.asset_library`);
3. the structure as textured triangles (:data:`benchbot_worlds.scene.surfaces`): floors, walls and ceilings with
   materials chosen by room kind;
4. the robot's obstacles: the walls, and every support and distractor (with its bottom height: what the robot
   passes under is no obstacle).

The ground truth is not changed: an object's drawn bounds are its cuboid (the fit is exact; a round clock and a
bottle are scaled uniformly inside it), and an object of a class no asset pack provides is drawn with the procedural
primitives of the ``primitives`` style.

Steps 1–3 happen in the home's frame (:mod:`benchbot_worlds.homes.home_frame`), and what they make is carried to
the map frame, so that a turned or mirrored layout gives the same home turned or mirrored.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchbot_worlds.scene.meshes import (
    Material, MeshInstance, load_mesh, make_mesh, with_glass_panes, with_real_blacks)
from benchbot_worlds.scene.surfaces import TILE_SIZE_M, room_materials, surface_texture

#: Roles of placements that stand in the robot's way (when their bottom is below its height).
OBSTACLE_ROLES = ("support", "distractor")
#: A ceiling light sits this far (m) below the bottom of its lamp model (so the lamp does not shadow it).
LAMP_LIGHT_DROP_M = 0.05


@dataclass
class FurnishedHome:
    """What the furnished style adds to a scene.

    Attributes:
        plan: the home's :class:`~benchbot_worlds.homes.floorplan.FloorPlan` (map frame).
        furnishing: the :class:`~benchbot_worlds.homes.furnish.Furnishing` (placements, objects left without a model
            or support), in the home frame: ``frame.T_map_home @ placement.transform`` is a placement in the map.
        frame: the :class:`~benchbot_worlds.homes.home_frame.HomeFrame` the home was derived in (the plan, the
            furnishing and the structure's texture coordinates; the sun's direction is fixed there).
        instances: mesh instances in the map frame (the structure's transform carries it from the home frame);
            ``object_index`` is the index of the ground-truth object in the
            ``objects`` given to :func:`furnish_environment`, −1 for everything else.
        without_model: indices of ground-truth objects with no model (drawn with primitives instead).
        obstacles: ``(lo_xy (2,), hi_xy (2,), bottom_z, name)`` what the robot's footprint may not touch when the
            robot is taller than ``bottom_z`` (m): walls, supports and distractor furniture.
        lamps: (K, 3) float64 ceiling light positions (metres, map frame).
        windows: (W, 2, 3) float64 per window the centre of its opening and the unit normal pointing into the home
            (metres, map frame).
        outer_lo, outer_hi: (2,) float64 xy of the outer walls' outer faces.
        wall_height: metres.
    """

    plan: object
    furnishing: object
    frame: object = None
    instances: list[MeshInstance] = field(default_factory=list)
    without_model: list[int] = field(default_factory=list)
    obstacles: list[tuple[np.ndarray, np.ndarray, float, str]] = field(default_factory=list)
    lamps: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    windows: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 3)))
    outer_lo: np.ndarray = field(default_factory=lambda: np.zeros(2))
    outer_hi: np.ndarray = field(default_factory=lambda: np.zeros(2))
    wall_height: float = 2.6


# ------------------------------------------------------------------------------------------------------ structure
@functools.lru_cache(maxsize=256)
def _surface_material(kind: str, seed: int) -> Material:
    return Material(albedo=np.ones(3, np.float32), texture=surface_texture(kind, seed), roughness=0.8,
                    name=f"{kind}:{seed}", from_file=False)


def _quad(v: list, n: list, uv: list, f: list, fm: list, corners: np.ndarray, normal: np.ndarray, mat: int,
          tile_m: float) -> None:
    """Append one planar quad (4 corners, counter-clockwise seen from ``normal``) with UVs = world metres / tile."""
    ax = int(np.argmax(np.abs(normal)))
    keep = [a for a in range(3) if a != ax]
    base = len(v)
    for c in corners:
        v.append(c)
        n.append(normal)
        uv.append([c[keep[0]] / tile_m, c[keep[1]] / tile_m] if ax != 0 else [c[1] / tile_m, c[2] / tile_m])
    f.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]])
    fm.extend([mat, mat])


def _box_faces(lo: np.ndarray, hi: np.ndarray):
    """The 6 faces of a box: (corners (4, 3) counter-clockwise seen from outside, outward normal (3,))."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    return [
        (np.array([[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]]), np.array([1.0, 0, 0])),
        (np.array([[x0, y1, z0], [x0, y0, z0], [x0, y0, z1], [x0, y1, z1]]), np.array([-1.0, 0, 0])),
        (np.array([[x1, y1, z0], [x0, y1, z0], [x0, y1, z1], [x1, y1, z1]]), np.array([0, 1.0, 0])),
        (np.array([[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]]), np.array([0, -1.0, 0])),
        (np.array([[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]]), np.array([0, 0, 1.0])),
        (np.array([[x0, y1, z0], [x1, y1, z0], [x1, y0, z0], [x0, y0, z0]]), np.array([0, 0, -1.0])),
    ]


def structure_mesh(plan, *, seed: int = 0):
    """Floors, ceilings and walls of a floor plan as one textured :class:`~benchbot_worlds.scene.meshes.MeshData`
    (map frame, metres).

    Each room's floor and ceiling extend under the walls' half thickness (so doorways have a floor); every wall face
    takes the painted plaster of the room it faces (the exterior plaster outside); materials by room kind from
    :func:`benchbot_worlds.scene.surfaces.room_materials` (seeded per room).
    """
    mats: list[Material] = []
    index: dict[tuple, int] = {}

    def mat(kind_seed: tuple) -> int:
        if kind_seed not in index:
            index[kind_seed] = len(mats)
            mats.append(_surface_material(*kind_seed))
        return index[kind_seed]

    per_room = [room_materials(r.kind, seed * 1000 + r.index) for r in plan.rooms]
    v, n, uv, f, fm = [], [], [], [], []
    half = float(plan.wall_thickness) / 2 + 1e-3
    H = float(plan.wall_height)
    for r, m in zip(plan.rooms, per_room):
        lo, hi = np.asarray(r.lo, float) - half, np.asarray(r.hi, float) + half
        floor = np.array([[lo[0], lo[1], 0], [hi[0], lo[1], 0], [hi[0], hi[1], 0], [lo[0], hi[1], 0]])
        kind, s = m["floor"]
        _quad(v, n, uv, f, fm, floor, np.array([0, 0, 1.0]), mat((kind, s)), TILE_SIZE_M[kind])
        ceil = np.array([[lo[0], hi[1], H], [hi[0], hi[1], H], [hi[0], lo[1], H], [lo[0], lo[1], H]])
        kind, s = m["ceiling"]
        _quad(v, n, uv, f, fm, ceil, np.array([0, 0, -1.0]), mat((kind, s)), TILE_SIZE_M[kind])
    for w in plan.walls:
        lo, hi = np.asarray(w.lo, float), np.asarray(w.hi, float)
        for corners, normal in _box_faces(lo, hi):
            centre = corners.mean(axis=0) + normal * (half + 0.02)
            room = plan.room_at(centre[:2]) if abs(normal[2]) < 0.5 else -1
            if room < 0 and abs(normal[2]) > 0.5:  # tops and bottoms (lintels, sills): the room on either side
                room = plan.room_at(corners.mean(axis=0)[:2])
            key = per_room[room]["wall"] if room >= 0 else ("exterior", 0)
            _quad(v, n, uv, f, fm, corners, normal, mat(key), TILE_SIZE_M[key[0]])
    return make_mesh(np.asarray(v), np.asarray(f), n=np.asarray(n), uv=np.asarray(uv), f_material=np.asarray(fm),
                     materials=mats)


# ------------------------------------------------------------------------------------------------------- the home
def _home_plan(files, objects: list[dict], paths: list[np.ndarray], seed: int):
    """(frame, plan, context objects), the plan and the context in the home frame
    (:mod:`benchbot_worlds.homes.home_frame`): the plan shared by the home's ground-truth ``files``, else one of
    this environment's objects and paths alone."""
    from benchbot_worlds.homes.floorplan import home_inputs, home_plan, home_plan_for_files

    if files:
        frame, plan = home_plan_for_files(files, seed=seed)
        import json

        context, _ = home_inputs([json.loads(Path(p).read_text()) for p in files])
        return frame, plan, frame.objects_to_home(context)
    frame, plan = home_plan(objects, paths, seed=seed)
    return frame, plan, frame.objects_to_home(objects)


def _transformed_bounds(T: np.ndarray, bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = np.asarray(bounds, float)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    p = corners @ T[:3, :3].T + T[:3, 3]
    return p.min(axis=0), p.max(axis=0)


def furnish_environment(objects: list[dict], home_files: list | None, paths: list[np.ndarray], *, seed: int = 0,
                        library=None) -> FurnishedHome:
    """The furnished home of one environment.

    Args:
        objects: the environment's ground-truth objects (``class``, ``centroid``, ``extent``, ``ID_name``,
            ``isgroup``), map frame, metres; ``instances[i].object_index`` refers to this list.
        home_files: the BEAR ground-truth JSON files of the home's variants
            (:func:`~benchbot_worlds.homes.floorplan.home_files`: the environment's own map file and those its
            ``home_files`` field declares): the floor plan is derived from their union, and every variant listing
            the same files shares it. ``None`` or empty: a plan of ``objects`` and ``paths`` alone.
        paths: (M, 2) xy robot paths (start pose and trajectory) — used when there are no ``home_files``.
        seed: the home's seed (:func:`benchbot.core.seeding.home_seed` of its name, as the scene build passes it):
            the same seed gives the same home; pass the same one for every variant of a home, so that they share
            their plan, materials and furniture.
        library: an :class:`~benchbot.packs.assets.AssetLibrary` (default: every installed asset pack).

    Raises:
        BackendError: a ground-truth file or pose is unreadable (from the floor plan); a model file that cannot be read
            (from :func:`~benchbot_worlds.scene.meshes.load_mesh`).
    """
    from benchbot.packs.assets import asset_library
    from benchbot_worlds.homes.furnish import furnish_home

    library = asset_library() if library is None else library
    frame, home_plan, context = _home_plan(home_files, objects, paths, seed)
    plan = frame.plan_to_map(home_plan)
    to_map = None if frame.is_identity else frame.T_map_home

    def bounds_of(asset):
        return load_mesh(asset.path).bounds

    furnishing = furnish_home(frame.objects_to_home(objects), home_plan, library, seed=seed, context_objects=context,
                              bounds_of=bounds_of, mesh_of=lambda asset: load_mesh(asset.path))
    home = FurnishedHome(plan=plan, furnishing=furnishing, wall_height=float(plan.wall_height), frame=frame)
    home.without_model = sorted(set(furnishing.without_model))
    home.instances.append(MeshInstance(structure_mesh(home_plan, seed=seed), np.eye(4) if to_map is None else to_map,
                                       -1))
    lamps = []
    for p in furnishing.placements:
        mesh = p.mesh if p.mesh is not None else with_real_blacks(load_mesh(library.get(p.asset_id).path))
        if p.role in ("window", "door"):  # glass panes: the outdoors is seen and the sun shines in through them
            mesh = with_glass_panes(mesh)
        T = np.asarray(p.transform, dtype=np.float64)
        if to_map is not None:
            T = to_map @ T
        home.instances.append(MeshInstance(mesh, T, int(p.object_index) if p.role == "object" else -1))
        lo, hi = _transformed_bounds(T, mesh.bounds)
        if p.role in OBSTACLE_ROLES:
            home.obstacles.append((lo[:2], hi[:2], float(lo[2]), f"{p.role} {library.get(p.asset_id).kind}"))
        if p.role == "light":
            lamps.append([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2] - LAMP_LIGHT_DROP_M])
    for w in plan.walls:
        home.obstacles.append((np.asarray(w.lo[:2], float), np.asarray(w.hi[:2], float), float(w.lo[2]), "wall"))
    placed = {(round(q[0], 2), round(q[1], 2)) for q in lamps}
    for q in plan.lights:  # rooms whose lamp model did not fit still get their light
        q = np.asarray(q, float)
        if not any(abs(q[0] - a) < 0.6 and abs(q[1] - b) < 0.6 for a, b in placed):
            lamps.append(q.tolist())
    home.lamps = np.asarray(lamps, dtype=np.float64).reshape(-1, 3)
    home.windows = np.asarray([[(np.asarray(o.lo, float) + np.asarray(o.hi, float)) / 2,
                                [-float(o.outward[0]), -float(o.outward[1]), 0.0]]
                               for o in plan.openings if o.kind == "window"], dtype=np.float64).reshape(-1, 2, 3)
    half = float(plan.wall_thickness)
    home.outer_lo = np.asarray(plan.outer_lo, float) - half
    home.outer_hi = np.asarray(plan.outer_hi, float) + half
    return home
