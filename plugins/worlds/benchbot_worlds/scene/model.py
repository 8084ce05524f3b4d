"""The scene the renderer draws (pure NumPy, no Taichi): :class:`Scene`, its primitives, lights and materials, in
the ``map`` frame (metres, z up). :mod:`benchbot_worlds.scene.build` makes one from an environment."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

#: Light kinds in :attr:`Scene.light_kind`.
LIGHT_DIRECTIONAL = 0
LIGHT_POINT = 1

#: Rec. 709 (sRGB) luminance weights of linear R, G, B: ``Y = 0.2126 R + 0.7152 G + 0.0722 B`` (ITU-R BT.709-6,
#: item 3.2). The one copy that the scene, the renderer and the camera model read.
LUMA_709 = (0.2126, 0.7152, 0.0722)

#: Shell surfaces, indices into :attr:`Scene.shell_albedo`.
SHELL_FLOOR, SHELL_WALL, SHELL_CEILING = 0, 1, 2


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB (0..1) → linear (0..1), a plain 2.2 gamma (float32, same shape)."""
    return np.power(np.clip(np.asarray(c, dtype=np.float32), 0.0, 1.0), np.float32(2.2)).astype(np.float32)


@dataclass
class Scene:
    """A box scene in the ``map`` frame (metres, z up).

    Attributes:
        box_min, box_max: (N, 3) float32 box corners.
        box_albedo: (N, 3) float32 linear albedo.
        box_class: (N,) int32 class ids (index in ``class_list``).
        box_instance: (N,) int32 instance ids ``class_id * 1000 + instance`` (instance ≥ 1, per class).
        box_names: the objects' ``ID_name``.
        box_models: the furnished style's model of each object: the asset id
            (:class:`~benchbot.packs.assets.AssetInfo`) of the mesh that draws it, ``closed_book``,
            ``computer_keyboard`` and ``pop_up_toaster`` for books, keyboards and toasters made in code, ``""``
            where the object keeps its primitive model;
            empty in the primitives style.
        room_min, room_max: (3,) float32 corners of the room shell (floor at ``room_min[2] = 0``).
        shell_albedo: (3, 3) float32 linear albedo of the floor, walls, ceiling.
        background_class: class id of ``background`` (the shell's class; instance id 0).
        class_list: class names; ``class_ids`` maps them to ids.
        ambient: (3,) float32 ambient radiance.
        light_kind: (L,) int32 (:data:`LIGHT_DIRECTIONAL` or :data:`LIGHT_POINT`).
        light_vec: (L, 3) float32 direction *towards* the light (directional, unit) or position (point).
        light_colour: (L, 3) float32 radiance (point lights: at 1 m, falling off as 1/d²).
        light_range: (L,) float32 cut-off distance of point lights (metres; ignored for directional ones).
        lighting: the lighting name.
        start_se2: (3,) float64 start pose ``[x, y, yaw]`` as the original placed the robot
            (:func:`benchbot.core.geometry.start_pose_to_se2`); trajectory_se2: (M, 3) float64.
        prim_type, prim_axis, prim_min, prim_max, prim_albedo, prim_object: the primitives drawn (see
            :data:`PRIM_BOX` …; ``prim_object`` indexes the per-object arrays ``box_*``, whose boxes are each object's
            cuboid, i.e. the AABB of its primitives; −1: not an object — class ``background``, instance 0);
            ``prim_albedo`` (linear) of a triangle with a material is ``mat_albedo[tri_material]``.
        tri_v: (T, 3, 3) float32 triangle vertices (a triangle primitive's ``prim_axis`` indexes them).
        tri_n: (T, 3, 3) float32 unit per-vertex shading normals (interpolated across the triangle).
        tri_uv: (T, 3, 2) float32 per-vertex texture coordinates (``v = 0``: the texture's bottom row).
        tri_material: (T,) int32 index into ``mat_*`` (−1: none, the primitive's albedo, no texture).
            Scenes whose ``tri_n``/``tri_uv``/``tri_material`` do not cover every triangle are drawn with face
            normals and no texture (see :func:`benchbot_worlds.scene.meshes.ensure_triangle_attributes`).
        mat_albedo: (K, 3) float32 linear base colour; mat_texture: (K,) int32 index into ``tex_info`` (−1: none);
            mat_roughness, mat_metallic: (K,) float32 glTF factors; mat_glass: (K,) bool window panes
            (``meshes.Material.glass``).
        tex_texels: (N, 3) uint8 sRGB texels of every texture and its mip-maps; tex_info: (X, 4) int32
            ``[offset, width, height, levels]`` per texture, level l (``max(1, width >> l)`` ×
            ``max(1, height >> l)``, row-major, top row first) stored right after level l − 1
            (:func:`benchbot_worlds.scene.meshes.texture_atlas`).
        style: the style it was built in (:data:`STYLES`).
        obstacle_min, obstacle_max, obstacle_bottom, obstacle_names: (Q, 2) float64 xy rectangles besides the
            objects' cuboids that the robot's footprint may not touch if it is taller than their (Q,) bottom heights
            (m) — a furnished home's walls, supports and distractor furniture — and their names.
        plan: the furnished home's :class:`~benchbot_worlds.homes.floorplan.FloorPlan` (rooms, walls, openings,
            lamps); ``None`` in the primitives style.
        Mesh instances are added with :func:`benchbot_worlds.scene.meshes.add_mesh_instances`.
    """

    box_min: np.ndarray  # per object: its cuboid (AABB of its primitives)
    box_max: np.ndarray
    box_albedo: np.ndarray
    box_class: np.ndarray
    box_instance: np.ndarray
    box_names: list[str]
    room_min: np.ndarray
    room_max: np.ndarray
    shell_albedo: np.ndarray
    background_class: int
    class_list: list[str]
    ambient: np.ndarray
    light_kind: np.ndarray
    light_vec: np.ndarray
    light_colour: np.ndarray
    light_range: np.ndarray
    lighting: str
    start_se2: np.ndarray
    trajectory_se2: np.ndarray
    class_ids: dict[str, int] = field(default_factory=dict)
    prim_type: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    prim_axis: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    prim_min: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    prim_max: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    prim_albedo: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    prim_object: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    tri_v: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3), np.float32))
    tri_n: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3), np.float32))
    tri_uv: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 2), np.float32))
    tri_material: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    mat_albedo: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    mat_texture: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    mat_roughness: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    mat_metallic: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    mat_glass: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    tex_texels: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.uint8))
    tex_info: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.int32))
    style: str = "primitives"
    obstacle_min: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.float64))
    obstacle_max: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.float64))
    obstacle_bottom: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float64))
    obstacle_names: list[str] = field(default_factory=list)
    plan: object | None = None
    box_models: list[str] = field(default_factory=list)

    @property
    def n_boxes(self) -> int:
        """Number of object boxes."""
        return int(self.box_min.shape[0])

    def with_lights(self, which: str) -> "Scene":
        """A copy of the scene with ``which`` of its lights: ``'all'``, ``'sun'`` (the directional lights only),
        ``'lamps'`` (the point lights only) or ``'none'``; the ambient light stays (benchmarks use it to show what
        each kind of light costs).

        Raises:
            ValueError: ``which`` is none of those.
        """
        keep = {"all": np.ones_like(self.light_kind, bool), "sun": self.light_kind == LIGHT_DIRECTIONAL,
                "lamps": self.light_kind == LIGHT_POINT, "none": np.zeros_like(self.light_kind, bool)}.get(which)
        if keep is None:
            raise ValueError(f"Scene.with_lights: which must be all, sun, lamps or none, got {which!r}")
        return replace(self, light_kind=self.light_kind[keep], light_vec=self.light_vec[keep],
                       light_colour=self.light_colour[keep], light_range=self.light_range[keep])

    def prim_glass(self) -> np.ndarray:
        """(P,) bool: the primitives that are window panes (triangles whose material is glass, ``mat_glass``)."""
        glass = np.asarray(self.mat_glass, bool).reshape(-1)
        out = np.zeros(self.prim_type.shape[0], bool)
        tri_mat = np.asarray(self.tri_material).reshape(-1)
        if not glass.any() or tri_mat.shape[0] != self.tri_v.shape[0]:
            return out
        tri = np.flatnonzero(self.prim_type == PRIM_TRIANGLE)
        m = tri_mat[self.prim_axis[tri]]
        ok = (m >= 0) & (m < glass.shape[0])
        out[tri[ok]] = glass[m[ok]]
        return out


#: Primitive kinds (:attr:`Scene.prim_type`). Boxes, ellipsoids and cylinders are inscribed in their AABB
#: ``prim_min..prim_max`` (so a primitive's bounds ARE its AABB); a cylinder's axis is :attr:`Scene.prim_axis`
#: (0 x, 1 y, 2 z; elliptic cross-section filling the other two extents); a triangle's vertices are
#: ``Scene.tri_v[prim_axis]``.
PRIM_BOX, PRIM_ELLIPSOID, PRIM_CYLINDER, PRIM_TRIANGLE = 0, 1, 2, 3
