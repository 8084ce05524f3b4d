"""A :class:`~benchbot_worlds.scene.model.Scene` as triangles for other programs.

:func:`scene_mesh`: one triangle mesh (trimesh): every primitive tessellated (boxes: 12 triangles; ellipsoids:
icospheres scaled into their box; cylinders: ``sections``-gon prisms), mesh triangles as they are, plus the room
shell (floor, walls, ceiling facing inwards). Face colours are the sRGB albedos; the per-face instance ids are in
``mesh.metadata['face_instance']``. Used by ``benchbot sim export`` for formats other than GLB and by the Embree
comparison of ``benchmarks/render.py``.

:func:`export_scene`: a glTF binary with the materials (PBR factors, textures), vertex normals and UVs, one node per
material and object, so that a reference renderer (Blender Cycles, Mitsuba) draws the same scene. Window panes
(``Scene.mat_glass``) are materials named ``glass_<k>`` (white, roughness 0, alpha-blended at 0.1): a reference
renderer should give them the renderer's thin-glass model (Fresnel reflection, the rest passed straight through).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchbot_worlds.scene.model import PRIM_BOX, PRIM_CYLINDER, PRIM_ELLIPSOID, PRIM_TRIANGLE

#: Name prefix of the exported materials of window panes.
GLASS_MATERIAL_PREFIX = "glass_"


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


# ------------------------------------------------------------------------------------------ textured glTF export
#: The map frame (z up) → glTF (+Y up): ``p_gltf = MAP_TO_GLTF @ p_map`` (the inverse of ``meshes.GLTF_TO_MAP``).
MAP_TO_GLTF = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def _smooth_unit_parts(subdivisions: int, sections: int) -> dict:
    """Unit primitives (unit box / sphere / cylinders along x, y, z, centred on 0) as unindexed (T, 3, 3) triangles
    with (T, 3, 3) vertex normals: smooth where curved, sharp at creases (the box's edges, the cylinders' rims)."""
    from benchbot_worlds.scene.meshes import smooth_normals

    box, sph, cyl = _unit_parts(subdivisions, sections)
    out = {}
    for key, m in (("box", box), ("ellipsoid", sph), (0, cyl[0]), (1, cyl[1]), (2, cyl[2])):
        n, f, src = smooth_normals(m.vertices, m.faces)
        v = np.asarray(m.vertices, dtype=np.float64)[src]
        out[key] = (v[f], n.astype(np.float64)[f])
    return out


def _level0(scene, x: int) -> np.ndarray:
    """Texture x of the scene's atlas at full size: (H, W, 3) uint8 sRGB."""
    off, w, h, _ = (int(a) for a in scene.tex_info[x])
    return np.asarray(scene.tex_texels[off:off + w * h], np.uint8).reshape(h, w, 3)


def export_scene(scene, path, *, subdivisions: int = 2, sections: int = 24, shell: bool = True):
    """Write the scene as a glTF binary (``.glb``) with PBR materials, for other renderers (Blender Cycles through
    its glTF importer; Mitsuba after converting the GLB's meshes) to draw the same scene.

    Every primitive is tessellated (as :func:`scene_mesh`: boxes, icospheres with ``subdivisions``, ``sections``-gon
    cylinders) with smooth normals where curved; triangles keep their vertex normals and UVs; each material becomes a
    glTF metallic-roughness material (``baseColorFactor`` = the linear albedo, ``baseColorTexture`` = its texture at
    full size, ``metallicFactor``, ``roughnessFactor``); primitives and untextured triangles get one material per
    albedo. One node per (material, object): its name ``i<instance>_c<class>_m<n>`` carries the segmentation ids.
    Coordinates are converted from the map frame (z up) to glTF's +Y up (:data:`MAP_TO_GLTF`), so a glTF importer
    that turns +Y up into z up (Blender's) gives back map coordinates, and so does
    :func:`benchbot_worlds.scene.meshes.load_mesh`. The scene's extras (``benchbot``) hold the lights (map frame),
    ambient radiance, room shell and class list. Not exported: the floor's tile modulation.

    Args:
        scene: a :class:`~benchbot_worlds.scene.model.Scene`. path: the ``.glb`` file to write.

    Returns:
        The ``trimesh.Scene`` written.

    Raises:
        ValueError: ``path`` does not end in ``.glb``.
        OSError: the file cannot be written.
    """
    import trimesh
    from PIL import Image

    from benchbot_worlds.scene.meshes import face_normals

    path = Path(path)
    if path.suffix.lower() != ".glb":
        raise ValueError(f"export_scene writes glTF binary files (.glb), not {path.suffix or 'files without a suffix'}")
    units = _smooth_unit_parts(subdivisions, sections)
    groups: dict = {}  # (material key, class, instance) -> [tris (n,3,3), normals (n,3,3), uvs (n,3,2) or None]

    def add(key, tris, normals, uvs=None):
        g = groups.setdefault(key, [[], [], []])
        g[0].append(tris)
        g[1].append(normals)
        g[2].append(uvs)

    nb = scene.n_boxes
    T = int(scene.tri_v.shape[0])
    tri_mat = np.asarray(scene.tri_material, np.int64) if scene.tri_material.shape[0] == T else np.full(T, -1)
    tri_n = scene.tri_n if scene.tri_n.shape == (T, 3, 3) else None
    tri_uv = scene.tri_uv if scene.tri_uv.shape == (T, 3, 2) else np.zeros((T, 3, 2), np.float32)

    def ids(obj):
        return ((int(scene.box_class[obj]), int(scene.box_instance[obj])) if 0 <= obj < nb
                else (int(scene.background_class), 0))

    kind = scene.prim_type
    tri_prims = np.flatnonzero(kind == PRIM_TRIANGLE)
    j = scene.prim_axis[tri_prims]
    with_mat = tri_mat[j] >= 0
    for sel, material in ((tri_prims[with_mat], True), (tri_prims[~with_mat], False)):
        if not sel.size:
            continue
        jj = scene.prim_axis[sel]
        objs = scene.prim_object[sel]
        keys = (np.stack([tri_mat[jj], objs], 1) if material else
                np.concatenate([np.round(scene.prim_albedo[sel] * 1e4).astype(np.int64), objs[:, None]], 1))
        uniq, inv = np.unique(keys, axis=0, return_inverse=True)
        for u, key in enumerate(uniq):
            m = np.flatnonzero(inv.reshape(-1) == u)
            t = scene.tri_v[jj[m]].astype(np.float64)
            n = (tri_n[jj[m]].astype(np.float64) if tri_n is not None
                 else np.repeat(face_normals(t)[:, None], 3, axis=1))
            mk = ("mat", int(key[0])) if material else ("albedo", tuple(scene.prim_albedo[sel[m[0]]].tolist()))
            add((mk, *ids(int(key[-1]))), t, n, tri_uv[jj[m]] if material else None)
    for i in np.flatnonzero(kind != PRIM_TRIANGLE):
        k = int(kind[i])
        unit = units["box"] if k == PRIM_BOX else units["ellipsoid"] if k == PRIM_ELLIPSOID else units[int(scene.prim_axis[i])]
        lo, hi = scene.prim_min[i].astype(np.float64), scene.prim_max[i].astype(np.float64)
        ext = np.maximum(hi - lo, 1e-9)
        n = unit[1] / ext
        n /= np.linalg.norm(n, axis=2, keepdims=True)
        add((("albedo", tuple(scene.prim_albedo[i].tolist())), *ids(int(scene.prim_object[i]))),
            unit[0] * (hi - lo) + (lo + hi) / 2.0, n)
    if shell:
        rb = trimesh.creation.box(bounds=np.stack([scene.room_min, scene.room_max]).astype(np.float64))
        rb.invert()  # normals inwards
        t = rb.triangles
        cz = t.mean(axis=1)[:, 2]
        surf = np.where(cz <= scene.room_min[2] + 1e-6, 0, np.where(cz >= scene.room_max[2] - 1e-6, 2, 1))
        for s in range(3):
            m = surf == s
            add((("albedo", tuple(scene.shell_albedo[s].tolist())), int(scene.background_class), 0), t[m],
                np.repeat(face_normals(t[m])[:, None], 3, axis=1))

    out = trimesh.Scene()
    materials: dict = {}
    textures: dict = {}

    def material(mk):
        if mk not in materials:
            if mk[0] == "mat":
                k = mk[1]
                x = int(scene.mat_texture[k]) if k < scene.mat_texture.shape[0] else -1
                if x >= 0 and x not in textures:
                    textures[x] = Image.fromarray(_level0(scene, x))
                glass = k < len(scene.mat_glass) and bool(scene.mat_glass[k])
                if glass:  # a window pane: clear glass, named glass_* for the reference renderer
                    materials[mk] = trimesh.visual.material.PBRMaterial(
                        name=f"{GLASS_MATERIAL_PREFIX}{k}", baseColorFactor=[1.0, 1.0, 1.0, 0.1], alphaMode="BLEND",
                        metallicFactor=0.0, roughnessFactor=0.0)
                else:
                    materials[mk] = trimesh.visual.material.PBRMaterial(
                        name=f"material_{k}", baseColorFactor=[*np.clip(scene.mat_albedo[k], 0, 1).tolist(), 1.0],
                        baseColorTexture=textures.get(x) if x >= 0 else None,
                        metallicFactor=float(scene.mat_metallic[k]), roughnessFactor=float(scene.mat_roughness[k]))
            else:
                materials[mk] = trimesh.visual.material.PBRMaterial(
                    name=f"albedo_{len(materials)}", baseColorFactor=[*np.clip(mk[1], 0, 1), 1.0], metallicFactor=0.0,
                    roughnessFactor=1.0)
        return materials[mk]

    for (mk, cls, inst), (ts, ns, uvs) in groups.items():
        t = np.concatenate(ts).reshape(-1, 3) @ MAP_TO_GLTF.T
        n = np.concatenate(ns).reshape(-1, 3) @ MAP_TO_GLTF.T
        mesh = trimesh.Trimesh(vertices=t, faces=np.arange(len(t)).reshape(-1, 3), vertex_normals=n, process=False)
        uv = np.concatenate(uvs).reshape(-1, 2) if uvs[0] is not None else None
        mesh.visual = trimesh.visual.TextureVisuals(uv=uv, material=material(mk))
        tag = mk[1] if mk[0] == "mat" else list(materials).index(mk)
        out.add_geometry(mesh, node_name=f"i{inst}_c{cls}_m{mk[0][0]}{tag}", geom_name=f"i{inst}_c{cls}_m{mk[0][0]}{tag}")
    out.metadata["benchbot"] = {
        "frame": "glTF +Y up; map (z up) = (x, -z, y) of these coordinates",
        "class_list": list(scene.class_list), "background_class": int(scene.background_class),
        "room_min": scene.room_min.tolist(), "room_max": scene.room_max.tolist(), "ambient": scene.ambient.tolist(),
        "lights": [{"kind": "directional" if int(k) == 0 else "point", "vec_map": v.tolist(), "colour": c.tolist(),
                    "range": float(r)} for k, v, c, r in zip(scene.light_kind, scene.light_vec, scene.light_colour,
                                                              scene.light_range)],
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    out.export(str(path))
    return out
