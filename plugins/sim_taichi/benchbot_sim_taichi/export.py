"""A :class:`~benchbot_sim_taichi.scene.Scene` as one triangle mesh (trimesh): every primitive tessellated (boxes: 12
triangles; ellipsoids: icospheres scaled into their box; cylinders: ``sections``-gon prisms), mesh triangles as they
are, plus the room shell (floor, walls, ceiling facing inwards). Face colours are the sRGB albedos; the per-face
instance ids are in ``mesh.metadata['face_instance']``. Used by ``benchbot sim export`` and by the Embree
comparison of ``benchmarks/render.py``."""

from __future__ import annotations

import numpy as np

from benchbot_sim_taichi.scene import PRIM_BOX, PRIM_CYLINDER, PRIM_ELLIPSOID


def _unit_parts(subdivisions: int, sections: int):
    import trimesh

    box = trimesh.creation.box(extents=(1, 1, 1))
    sph = trimesh.creation.icosphere(subdivisions=subdivisions, radius=0.5)
    cyl = {ax: trimesh.creation.cylinder(radius=0.5, height=1.0, sections=sections) for ax in range(3)}
    rot = {0: trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]),
           1: trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0])}
    for ax, R in rot.items():
        cyl[ax] = cyl[ax].copy()
        cyl[ax].apply_transform(R)
    return box, sph, cyl


def scene_mesh(scene, *, subdivisions: int = 2, sections: int = 24, shell: bool = True):
    """The whole scene as one ``trimesh.Trimesh`` (map frame, metres)."""
    import trimesh

    box, sph, cyl = _unit_parts(subdivisions, sections)
    verts, faces, colours, inst = [], [], [], []
    nv = 0
    lin2srgb = lambda c: np.clip(np.power(np.clip(c, 0, 1), 1 / 2.2) * 255, 0, 255).astype(np.uint8)  # noqa: E731
    for i in range(int(scene.prim_type.shape[0])):
        kind = int(scene.prim_type[i])
        lo, hi = scene.prim_min[i].astype(np.float64), scene.prim_max[i].astype(np.float64)
        if kind in (PRIM_BOX, PRIM_ELLIPSOID, PRIM_CYLINDER):
            unit = box if kind == PRIM_BOX else sph if kind == PRIM_ELLIPSOID else cyl[int(scene.prim_axis[i])]
            v = unit.vertices * (hi - lo) + (lo + hi) / 2.0
            f = unit.faces
        else:
            v = scene.tri_v[int(scene.prim_axis[i])].astype(np.float64)
            f = np.array([[0, 1, 2]])
        verts.append(v)
        faces.append(f + nv)
        nv += len(v)
        colours.append(np.repeat(lin2srgb(scene.prim_albedo[i])[None], len(f), axis=0))
        inst.append(np.full(len(f), int(scene.box_instance[scene.prim_object[i]]), dtype=np.int32))
    if shell:
        rb = trimesh.creation.box(bounds=np.stack([scene.room_min, scene.room_max]).astype(np.float64))
        rb.invert()  # normals inwards
        verts.append(rb.vertices)
        faces.append(rb.faces + nv)
        nv += len(rb.vertices)
        centre_z = rb.triangles_center[:, 2]
        surf = np.where(centre_z <= scene.room_min[2] + 1e-6, 0, np.where(centre_z >= scene.room_max[2] - 1e-6, 2, 1))
        colours.append(lin2srgb(scene.shell_albedo[surf]))
        inst.append(np.zeros(len(rb.faces), dtype=np.int32))
    mesh = trimesh.Trimesh(vertices=np.concatenate(verts), faces=np.concatenate(faces), process=False)
    fc = np.concatenate(colours)
    mesh.visual.face_colors = np.concatenate([fc, np.full((len(fc), 1), 255, np.uint8)], axis=1)
    mesh.metadata["face_instance"] = np.concatenate(inst)
    return mesh
