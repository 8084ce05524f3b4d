"""Triangle meshes with materials for the Taichi simulator: loading (any file trimesh reads), smooth shading normals,
instancing, flattening into world-space triangles, and the texture atlas the kernels sample (pure NumPy + trimesh;
no Taichi).

Frames: GLB/glTF files follow glTF's conventions (metres, +Y up, the asset's front facing +Z); :func:`load_mesh`
converts them to the simulator's ``map`` frame, z up, with ``(x, y, z)_glTF → (x, −z, y)_map`` (so a glTF asset's
front faces −y). Other formats (OBJ, PLY, STL, …) are taken as already z-up map-frame coordinates.

Materials (:class:`Material`): a linear albedo (glTF ``baseColorFactor``, which glTF defines as linear; an OBJ
``Kd`` or a face colour is sRGB and is linearised), an optional sRGB ``uint8`` albedo texture (``baseColorTexture``
or ``map_Kd``) that multiplies it, roughness and metallic. The sRGB ↔ linear conversion is the plain 2.2 gamma used
everywhere in the simulator (:func:`benchbot_worlds.scene.model.srgb_to_linear`).

Textures are decoded by Pillow, through trimesh. A file whose textures cannot be decoded (Pillow is not installed,
or an image is damaged or of a format Pillow does not read) raises :class:`TextureDecodeError` when loaded: trimesh
itself would leave such a material untextured without a word, and the scene would quietly look different.

Texture coordinates follow trimesh's (OpenGL's) convention: ``v = 0`` is the image's BOTTOM row (trimesh flips
glTF's top-left origin on loading); texture arrays are stored top row first, as images are; textures repeat.

The scene side: :func:`add_mesh_instances` appends :class:`MeshInstance` s to a
:class:`~benchbot_worlds.scene.model.Scene` as triangle primitives with per-vertex normals, UVs and materials, and
adds their textures (with mip-maps, :func:`mip_chain`) to the scene's texture atlas.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import math
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchbot.core.errors import BackendError
from benchbot_worlds.scene.model import LUMA_709

#: Crease angle (degrees) of the smooth normals computed for meshes whose files have none: faces meeting at a
#: vertex are smoothed together when their normals differ by less than this, so curved surfaces look round and
#: boxes keep sharp edges.
SMOOTH_ANGLE_DEG = 40.0
#: Textures larger than this (pixels, on either side) are downsampled (box filter, aspect kept) when loaded, to
#: bound the texture atlas's memory; the renderer's images are 640×480, so larger textures add nothing.
TEXTURE_MAX_SIDE_PX = 1024
#: Meshes kept by :func:`load_mesh`'s cache (by path, modification time and size), least recently used dropped.
MESH_CACHE_ENTRIES = 256
#: More distinct face colours than this in a coloured (untextured) mesh are quantised to 4 bits per channel.
COLOUR_MATERIALS_MAX = 256
#: glTF (+Y up, front +Z) → map (+Z up, front −y): ``p_map = GLTF_TO_MAP @ p_gltf``.
GLTF_TO_MAP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
#: sRGB albedo of meshes whose file has no material (build_scene replaces it with the object's class colour).
DEFAULT_ALBEDO_SRGB = (0.6, 0.6, 0.6)
#: Corners sharing one welded vertex beyond which the crease test is skipped (that vertex's corners keep their
#: faces' normals: a fan apex), which bounds the work of :func:`smooth_normals` (it grows as the square of this).
_FAN_MAX = 256


def _srgb_to_linear(c) -> np.ndarray:
    return np.power(np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0), 2.2).astype(np.float32)


def _linear_to_srgb8(c) -> np.ndarray:
    return np.floor(np.power(np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0), 1.0 / 2.2) * 255.0 + 0.5
                    ).astype(np.uint8)


#: What to do when Pillow, which decodes every texture, is missing.
PILLOW_HINT = "pip install pillow (benchbot-sim-taichi declares it: reinstalling it installs Pillow too)"


class TextureDecodeError(BackendError):
    """A mesh file has textures that cannot be decoded: Pillow (which trimesh decodes images with) is not
    installed, or an image is damaged, missing or of a format Pillow cannot read. Raised by :func:`load_mesh`, so
    that a scene is never built with some of its models untextured; the message names the file and the reason in
    one line, the hint how to fix it."""


class _Undecodable(Exception):
    """Internal: Pillow could not decode one texture image (the message says why)."""


@dataclass(eq=False)
class Material:
    """A surface material.

    Attributes:
        albedo: (3,) float32 linear base colour (multiplies the texture).
        texture: (H, W, 3) uint8 sRGB albedo texture (top row first), or None.
        roughness, metallic: glTF metallic-roughness factors (0..1).
        name: the file's material name, if any.
        from_file: False for the default material given to a mesh whose file has none.
        opacity: 0..1, the glTF base colour's alpha where the material blends (``alphaMode: BLEND``), else 1.
        glass: a window pane: a clear, thin sheet of glass (index 1.5) that the camera sees through and reflects in,
            that lets light through and that depth, segmentation and the laser do not see (see the renderer's module
            docstring); :func:`with_glass_panes` sets it. Other surfaces are opaque, whatever their opacity.
    """

    albedo: np.ndarray
    texture: np.ndarray | None = None
    roughness: float = 1.0
    metallic: float = 0.0
    name: str = ""
    from_file: bool = True
    opacity: float = 1.0
    glass: bool = False


@dataclass(eq=False)
class MeshData:
    """A triangle mesh in its own frame (the map frame's axes: metres, z up).

    Attributes:
        v: (V, 3) float32 vertices. n: (V, 3) float32 unit smooth shading normals. uv: (V, 2) float32 texture
        coordinates (zeros if none; ``v = 0`` is the texture's bottom row). f: (F, 3) int32 vertex indices.
        f_material: (F,) int32 indices into ``materials``. materials: at least one :class:`Material`.
        bounds: (2, 3) float64 ``[min, max]`` of the vertices.
    """

    v: np.ndarray
    n: np.ndarray
    uv: np.ndarray
    f: np.ndarray
    f_material: np.ndarray
    materials: list
    bounds: np.ndarray

    @property
    def n_triangles(self) -> int:
        """Number of triangles."""
        return int(self.f.shape[0])


@dataclass(eq=False)
class MeshInstance:
    """One placement of a mesh: ``transform`` (4, 4) float64 maps mesh coordinates to the map frame (rotation,
    translation and any non-uniform scale; normals are transformed with its inverse transpose); ``object_index``
    indexes the scene's per-object arrays (``box_*``: its class and instance ids in the segmentation), or −1 for
    geometry that is no ground-truth object (walls, floors, distractors, supports: class ``background``,
    instance 0)."""

    mesh: MeshData
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    object_index: int = -1


# ------------------------------------------------------------------------------------------------------- normals
def face_normals(tris: np.ndarray) -> np.ndarray:
    """Unit normals (T, 3) float64 of triangles (T, 3, 3) (counter-clockwise winding; zero for degenerate ones)."""
    t = np.asarray(tris, dtype=np.float64)
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)


def smooth_normals(v: np.ndarray, f: np.ndarray, angle_deg: float = SMOOTH_ANGLE_DEG):
    """Angle-weighted smooth vertex normals with a crease angle.

    Vertices at the same position are welded for the averaging (so UV seams and unshared STL vertices are smoothed
    across); at each corner the normal is the corner-angle-weighted mean of the normals of the faces around that
    position whose normals are within ``angle_deg`` of the corner's own face. Vertices are split where their corners
    get different normals.

    Args:
        v: (V, 3) vertices. f: (F, 3) int vertex indices.

    Returns:
        ``(n (V', 3) float32 unit normals, f' (F, 3) int32, src (V',) int64)``: the new vertex ``i`` is the old
        vertex ``src[i]`` (gather positions, UVs, … with it).
    """
    v = np.asarray(v, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(f, dtype=np.int64).reshape(-1, 3)
    F = f.shape[0]
    if F == 0:
        return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32), np.zeros(0, np.int64)
    tri = v[f]
    fn = face_normals(tri)
    ang = np.empty((F, 3))
    for c in range(3):
        a = tri[:, (c + 1) % 3] - tri[:, c]
        b = tri[:, (c + 2) % 3] - tri[:, c]
        ang[:, c] = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
    extent = float(np.max(v.max(axis=0) - v.min(axis=0))) if len(v) else 1.0
    tol = max(extent, 1e-9) * 1e-7
    weld = np.unique(np.round(v / tol).astype(np.int64), axis=0, return_inverse=True)[1].reshape(-1)
    cw = weld[f].reshape(-1)  # welded vertex of each corner
    cface = np.repeat(np.arange(F), 3)
    cang = ang.reshape(-1)
    order = np.argsort(cw, kind="stable")
    cw_s = cw[order]
    starts = np.flatnonzero(np.r_[True, cw_s[1:] != cw_s[:-1]])
    sizes = np.diff(np.r_[starts, cw_s.size])
    gid = np.repeat(np.arange(starts.size), sizes)
    gstart, gsize = starts[gid], sizes[gid]  # per sorted corner
    normals = fn[cface].copy()  # corners of big fans keep their face's normal
    cos_min = math.cos(math.radians(angle_deg))
    small = np.flatnonzero(gsize <= _FAN_MAX)
    budget = 1 << 22  # pairs per chunk
    i0 = 0
    cum = np.cumsum(gsize[small])
    while i0 < small.size:
        base = cum[i0 - 1] if i0 else 0
        i1 = int(np.searchsorted(cum, base + budget, side="right"))
        i1 = max(i1, i0 + 1)
        chunk = small[i0:i1]
        reps = gsize[chunk]
        ii = np.repeat(np.arange(chunk.size), reps)
        offs = np.arange(int(reps.sum())) - np.repeat(np.cumsum(reps) - reps, reps)
        jj = gstart[chunk][ii] + offs  # sorted positions of the partner corners
        fi = cface[order[chunk[ii]]]
        fj = cface[order[jj]]
        w = np.where(np.einsum("ij,ij->i", fn[fi], fn[fj]) >= cos_min, cang[order[jj]], 0.0)
        acc = np.stack([np.bincount(ii, weights=w * fn[fj, k], minlength=chunk.size) for k in range(3)], axis=1)
        normals[order[chunk]] = acc
        i0 = i1
    ln = np.linalg.norm(normals, axis=1, keepdims=True)
    bad = ln[:, 0] <= 1e-12
    normals = np.divide(normals, ln, out=np.zeros_like(normals), where=~bad[:, None])
    normals[bad] = fn[cface[bad]]
    normals[np.linalg.norm(normals, axis=1) <= 1e-12] = (0.0, 0.0, 1.0)
    key = np.concatenate([f.reshape(-1, 1), np.round(normals * 1e4).astype(np.int64)], axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return (normals[first].astype(np.float32), inverse.reshape(F, 3).astype(np.int32),
            f.reshape(-1)[first].astype(np.int64))


def make_mesh(v, f, *, n=None, uv=None, f_material=None, materials=None,
              smooth_angle_deg: float = SMOOTH_ANGLE_DEG) -> MeshData:
    """A :class:`MeshData` from arrays (for geometry made in code: walls, floors, test meshes).

    Args:
        v: (V, 3) vertices (map-frame axes, metres). f: (F, 3) int vertex indices.
        n: (V, 3) vertex normals (normalised here), or None to compute smooth normals (:func:`smooth_normals`,
            which may split vertices).
        uv: (V, 2) texture coordinates or None (zeros). f_material: (F,) material indices or None (zeros).
        materials: list of :class:`Material` or None (one grey default material, ``from_file=False``).

    Raises:
        ValueError: shapes that do not fit, indices out of range, non-finite values.
    """
    v = np.asarray(v, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(f, dtype=np.int64).reshape(-1, 3)
    V = v.shape[0]
    if f.size and (f.min() < 0 or f.max() >= V):
        raise ValueError(f"make_mesh: face indices must lie in 0..{V - 1}")
    if not np.all(np.isfinite(v)):
        raise ValueError("make_mesh: vertices must be finite")
    uv = np.zeros((V, 2)) if uv is None else np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    if uv.shape[0] != V:
        raise ValueError(f"make_mesh: {uv.shape[0]} UVs for {V} vertices")
    materials = list(materials) if materials else [Material(_srgb_to_linear(DEFAULT_ALBEDO_SRGB), from_file=False)]
    fm = np.zeros(f.shape[0], np.int64) if f_material is None else np.asarray(f_material, np.int64).reshape(-1)
    if fm.shape[0] != f.shape[0] or (fm.size and (fm.min() < 0 or fm.max() >= len(materials))):
        raise ValueError(f"make_mesh: f_material must give one index in 0..{len(materials) - 1} per face")
    if n is not None:
        n = np.asarray(n, dtype=np.float64).reshape(-1, 3)
        if n.shape[0] != V:
            raise ValueError(f"make_mesh: {n.shape[0]} normals for {V} vertices")
        ln = np.linalg.norm(n, axis=1, keepdims=True)
        if not np.all(np.isfinite(ln)) or (f.size > 0 and bool(np.any(ln[np.unique(f)] <= 1e-12))):
            n = None  # unusable normals in the file: compute them
        else:
            n = n / np.maximum(ln, 1e-12)
    if n is None:
        n, f, src = smooth_normals(v, f, smooth_angle_deg)
        v, uv = v[src], uv[src]
    if not np.all(np.isfinite(uv)):
        raise ValueError("make_mesh: texture coordinates must be finite")
    bounds = np.stack([v.min(axis=0), v.max(axis=0)]) if len(v) else np.zeros((2, 3))
    return MeshData(v=v.astype(np.float32), n=np.asarray(n, np.float32), uv=uv.astype(np.float32),
                    f=np.asarray(f, np.int32), f_material=fm.astype(np.int32), materials=materials, bounds=bounds)


def quad_mesh(quads, materials) -> MeshData:
    """A flat-shaded :class:`MeshData` of quadrilateral faces (for boxes made in code: books, keyboards).

    Args:
        quads: sequence of ``(corners, normal, material, uv_of)``: ``corners`` four (x, y, z) points in metres,
            counter-clockwise seen from outside; ``normal`` the face's outward (x, y, z) normal; ``material`` an
            index into ``materials``; ``uv_of`` a function of a corner giving its (u, v) texture coordinates.
        materials: list of :class:`Material`.

    Returns:
        Four vertices and two triangles, ``(c0, c1, c2)`` and ``(c0, c2, c3)``, per quad, each vertex with its face's
        normal (so 4 Q vertices and 2 Q triangles for Q quads).

    Raises:
        ValueError: as :func:`make_mesh` (a material index out of range, non-finite corners or uvs).
    """
    v, n, t, tris, fm = [], [], [], [], []
    for corners, normal, material, uv_of in quads:
        base = len(v)
        for p in corners:
            v.append(p)
            n.append(normal)
            t.append(uv_of(p))
        tris.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]])
        fm.extend([material, material])
    return make_mesh(np.asarray(v, float), np.asarray(tris), n=np.asarray(n, float), uv=np.asarray(t, float),
                     f_material=np.asarray(fm), materials=materials)


# ------------------------------------------------------------------------------------------------------- loading
def _texture_array(image) -> np.ndarray | None:
    """A PIL image (or array) as an (H, W, 3) uint8 sRGB array, at most :data:`TEXTURE_MAX_SIDE_PX` on a side."""
    if image is None:
        return None
    from PIL import Image

    try:
        img = image if isinstance(image, Image.Image) else Image.fromarray(np.asarray(image))
        img = img.convert("RGB")  # decodes the image (trimesh only opened it)
    except (OSError, ValueError, SyntaxError, TypeError) as e:  # what Pillow raises for damaged or odd images
        raise _Undecodable(f"{type(e).__name__}: {e}".splitlines()[0]) from e
    w, h = img.size
    if max(w, h) > TEXTURE_MAX_SIDE_PX:
        s = TEXTURE_MAX_SIDE_PX / max(w, h)
        img = img.resize((max(1, round(w * s)), max(1, round(h * s))), Image.Resampling.BOX)
    a = np.ascontiguousarray(np.asarray(img, dtype=np.uint8))
    a.setflags(write=False)
    return a


def _factor(value, default) -> np.ndarray:
    """A glTF colour factor as floats 0..1 (trimesh stores uint8 0..255)."""
    if value is None:
        return np.asarray(default, dtype=np.float64)
    a = np.asarray(value)
    a = a.astype(np.float64) / 255.0 if a.dtype.kind in "ui" else a.astype(np.float64)
    return np.clip(a, 0.0, 1.0)


def _material_of(tm_material) -> Material:
    """A :class:`Material` from a trimesh material (PBRMaterial: glTF; SimpleMaterial: OBJ/MTL)."""
    from trimesh.visual.material import PBRMaterial, SimpleMaterial

    name = str(getattr(tm_material, "name", "") or "")
    if isinstance(tm_material, PBRMaterial):
        rgba = _factor(tm_material.baseColorFactor, (1.0, 1.0, 1.0, 1.0))  # glTF: linear already
        base = rgba[:3]
        blends = str(getattr(tm_material, "alphaMode", None) or "OPAQUE").upper() == "BLEND"
        rough = tm_material.roughnessFactor
        metal = tm_material.metallicFactor
        return Material(albedo=base.astype(np.float32), texture=_texture_array(tm_material.baseColorTexture),
                        roughness=float(1.0 if rough is None else rough),
                        metallic=float(1.0 if metal is None else metal), name=name,  # glTF's defaults: 1, 1
                        opacity=float(rgba[3]) if blends and len(rgba) > 3 else 1.0)
    if isinstance(tm_material, SimpleMaterial):
        diffuse = _factor(getattr(tm_material, "diffuse", None), (1.0, 1.0, 1.0, 1.0))[:3]  # MTL Kd: sRGB
        gloss = getattr(tm_material, "glossiness", None)
        rough = 1.0 if gloss is None else float(np.clip(math.sqrt(2.0 / (float(gloss) + 2.0)), 0.0, 1.0))
        return Material(albedo=_srgb_to_linear(diffuse), texture=_texture_array(getattr(tm_material, "image", None)),
                        roughness=rough, metallic=0.0, name=name)
    return Material(_srgb_to_linear(DEFAULT_ALBEDO_SRGB), name=name, from_file=False)


def _geometry_materials(geom, shared: dict) -> tuple[np.ndarray | None, list, np.ndarray]:
    """(uv (V, 2) or None, materials, per-face local material index) of one trimesh geometry. ``shared`` maps
    trimesh material ids to Materials already made (so a material used by several primitives is one Material)."""
    from trimesh.visual.texture import TextureVisuals

    visual = geom.visual
    F = len(geom.faces)
    kind = getattr(visual, "kind", None)
    if isinstance(visual, TextureVisuals):
        tm = getattr(visual, "material", None)
        key = id(tm)
        if key not in shared:
            shared[key] = (tm, _material_of(tm))  # keep tm alive so its id stays unique
        uv = getattr(visual, "uv", None)
        uv = None if uv is None or len(uv) != len(geom.vertices) else np.asarray(uv, dtype=np.float64)
        return uv, [shared[key][1]], np.zeros(F, np.int32)
    if kind in ("face", "vertex"):
        fc = np.asarray(visual.face_colors, dtype=np.uint8)[:, :3]
        uniq, inv = np.unique(fc, axis=0, return_inverse=True)
        if len(uniq) > COLOUR_MATERIALS_MAX:
            uniq, inv = np.unique((fc // 16) * 16 + 8, axis=0, return_inverse=True)
        mats = [Material(_srgb_to_linear(c / 255.0), name=f"colour_{i}") for i, c in enumerate(uniq)]
        return None, mats, inv.reshape(-1).astype(np.int32)
    tm = getattr(visual, "material", None)
    if tm is not None:
        return None, [_material_of(tm)], np.zeros(F, np.int32)
    return None, [Material(_srgb_to_linear(DEFAULT_ALBEDO_SRGB), from_file=False)], np.zeros(F, np.int32)


def _file_normals(geom) -> np.ndarray | None:
    """The geometry's vertex normals if its file gave them (trimesh keeps them in its cache), else None."""
    try:
        cached = "vertex_normals" in geom._cache.cache  # noqa: SLF001 - trimesh's own exporters test it so
    except AttributeError:
        cached = False
    if not cached:
        return None
    n = np.asarray(geom.vertex_normals, dtype=np.float64)
    return n if n.shape == (len(geom.vertices), 3) else None


def pillow_missing() -> bool:
    """True when Pillow (``PIL``), which decodes every texture, cannot be imported."""
    try:
        import PIL.Image  # noqa: F401
    except ImportError:
        return True
    return False


def _gltf_json(path: Path) -> dict | None:
    """The JSON of a glTF file (``.gltf``: the file; ``.glb``: its first chunk), or None when the file is not one
    (trimesh then says what is wrong with it)."""
    import json
    import struct

    try:
        with open(path, "rb") as f:
            if path.suffix.lower() == ".gltf":
                data = json.loads(f.read())
            else:
                magic, _version, _length = struct.unpack("<4sII", f.read(12))
                size, kind = struct.unpack("<I4s", f.read(8))
                if magic != b"glTF" or kind != b"JSON":
                    return None
                data = json.loads(f.read(size))
    except (OSError, ValueError, struct.error):
        return None
    return data if isinstance(data, dict) else None


def _declared_textures(path: Path) -> int:
    """How many distinct textured materials the file ``path`` declares, counting only what the loaded mesh can show:
    for glTF, the materials of triangle primitives with a base colour texture that names an image; for OBJ, 1 when
    a material its faces use (``usemtl``) has a ``map_Kd`` in one of its MTL files (its materials are not counted one
    by one); 0 for other formats, and for a file whose JSON or MTL is not of the expected shape (trimesh then reads
    it, or says why it cannot)."""
    suffix = path.suffix.lower()
    if suffix in (".glb", ".gltf"):
        header = _gltf_json(path)
        if header is None:
            return 0
        materials, textures = header.get("materials"), header.get("textures")
        materials = materials if isinstance(materials, list) else []
        textures = textures if isinstance(textures, list) else []
        used = {prim.get("material") for mesh in header.get("meshes") or [] if isinstance(mesh, dict)
                for prim in mesh.get("primitives") or [] if isinstance(prim, dict) and prim.get("mode", 4) == 4}
        count = 0
        for i in used:
            if not isinstance(i, int) or not 0 <= i < len(materials) or not isinstance(materials[i], dict):
                continue
            pbr = materials[i].get("pbrMetallicRoughness")
            ref = pbr.get("baseColorTexture") if isinstance(pbr, dict) else None
            t = ref.get("index") if isinstance(ref, dict) else None
            if isinstance(t, int) and 0 <= t < len(textures) and isinstance(textures[t], dict) and (
                    "source" in textures[t] or any(isinstance(ext, dict) and "source" in ext
                                                   for ext in _values(textures[t].get("extensions")))):
                count += 1
        return count
    if suffix == ".obj":
        try:
            with open(path, "rb") as f:
                words = [line.split() for line in f]
            libs = [name.decode(errors="replace") for w in words if w[:1] == [b"mtllib"] for name in w[1:]]
            used = {b" ".join(w[1:]) for w in words if w[:1] == [b"usemtl"]}
            textured: set[bytes] = set()
            for lib in libs:
                material = None
                with open(path.parent / lib, "rb") as f:
                    for w in (line.split() for line in f):
                        if w[:1] == [b"newmtl"]:
                            material = b" ".join(w[1:])
                        elif w[:1] and w[0].lower() == b"map_kd" and material is not None:
                            textured.add(material)
            return 1 if used & textured else 0
        except OSError:
            return 0
    return 0


def _values(mapping) -> list:
    """The values of ``mapping`` when it is a dict, else none (a glTF field of another shape than the spec's)."""
    return list(mapping.values()) if isinstance(mapping, dict) else []


def _decoded_textures(loaded) -> int:
    """How many distinct materials of a loaded ``trimesh.Scene`` hold a texture image (glTF's base colour texture,
    an MTL's ``map_Kd``); trimesh gives every primitive of one file material the same material object."""
    textured = set()
    for geom in loaded.geometry.values():
        material = getattr(getattr(geom, "visual", None), "material", None)
        if material is not None and (getattr(material, "baseColorTexture", None) is not None
                                     or getattr(material, "image", None) is not None):
            textured.add(id(material))
    return len(textured)


def _read_mesh(path: Path) -> MeshData:
    import trimesh

    hint = "use a GLB/glTF, OBJ, PLY or STL file that trimesh can read"
    declared = _declared_textures(path)
    if declared and pillow_missing():
        raise TextureDecodeError(f"textures cannot be decoded: Pillow is not installed (the mesh {path} has "
                                 f"{declared} textured material{'s' if declared > 1 else ''})", PILLOW_HINT)
    try:
        loaded = trimesh.load_scene(str(path), process=False)
    except Exception as e:  # noqa: BLE001 - trimesh raises many kinds
        raise BackendError(f"cannot read the mesh {path}: {e}", hint) from e
    decoded = _decoded_textures(loaded)
    if decoded < declared:
        raise TextureDecodeError(
            f"textures cannot be decoded: {declared - decoded} of the {declared} textured materials of the mesh "
            f"{path} have no image that Pillow could read (damaged, missing, or a format it does not decode)",
            "fix or re-export the model's textures (PNG or JPEG), or check that Pillow reads them: "
            "python -c \"import PIL.Image; PIL.Image.open('texture.png').load()\"")
    try:
        return _mesh_data(loaded, path, trimesh)
    except _Undecodable as e:
        raise TextureDecodeError(f"textures cannot be decoded: an image of the mesh {path} is unreadable ({e})",
                                 "fix or re-export the model's textures (PNG or JPEG)") from e


def _mesh_data(loaded, path: Path, trimesh) -> MeshData:
    """:class:`MeshData` of a loaded ``trimesh.Scene`` of the file ``path`` (see :func:`load_mesh`)."""
    gltf = path.suffix.lower() in (".glb", ".gltf")
    shared: dict = {}
    materials: list[Material] = []
    mat_index: dict[int, int] = {}
    vs, ns, uvs, fs, fms = [], [], [], [], []
    nv = 0
    for node in loaded.graph.nodes_geometry:
        T, gname = loaded.graph[node]
        geom = loaded.geometry.get(gname)
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        T = np.asarray(T, dtype=np.float64)
        A = T[:3, :3]
        if gltf:
            A = GLTF_TO_MAP @ A
        t = (GLTF_TO_MAP @ T[:3, 3]) if gltf else T[:3, 3]
        v = np.asarray(geom.vertices, dtype=np.float64) @ A.T + t
        f = np.asarray(geom.faces, dtype=np.int64)
        uv, mats, fm_local = _geometry_materials(geom, shared)
        fm = np.array([mat_index.setdefault(id(m), len(mat_index)) for m in mats], dtype=np.int32)[fm_local]
        for m in mats:
            if mat_index[id(m)] == len(materials):
                materials.append(m)
        n = _file_normals(geom)
        if n is not None:
            n = n @ np.linalg.inv(A)  # = (A⁻ᵀ n) row-wise: the inverse transpose
        part = make_mesh(v, f, n=n, uv=uv, f_material=fm, materials=materials)
        vs.append(part.v)
        ns.append(part.n)
        uvs.append(part.uv)
        fs.append(part.f.astype(np.int64) + nv)
        fms.append(part.f_material)
        nv += part.v.shape[0]
    if not fs:
        raise BackendError(f"the mesh {path} has no triangles", "use a triangle mesh")
    mesh = MeshData(v=np.concatenate(vs), n=np.concatenate(ns), uv=np.concatenate(uvs),
                    f=np.concatenate(fs).astype(np.int32), f_material=np.concatenate(fms), materials=materials,
                    bounds=np.zeros((2, 3)))
    mesh.bounds = np.stack([mesh.v.min(axis=0), mesh.v.max(axis=0)]).astype(np.float64)
    for a in (mesh.v, mesh.n, mesh.uv, mesh.f, mesh.f_material, mesh.bounds):
        a.setflags(write=False)  # shared through the cache
    return mesh


_CACHE: "collections.OrderedDict[tuple, MeshData]" = collections.OrderedDict()
_CACHE_LOCK = threading.Lock()


def load_mesh(path: "str | Path") -> MeshData:
    """Load a mesh file as :class:`MeshData` in the map frame (see the module docstring), every node of a scene file
    with its transform, materials and textures kept. Cached by path, modification time and size (the arrays are
    read-only: copy before changing them).

    Raises:
        BackendError: the file is missing or unreadable, trimesh cannot read it, or it has no triangles.
        TextureDecodeError: (a BackendError) the file has textures that cannot be decoded: Pillow is not installed,
            or an image is damaged, missing or in a format Pillow cannot read.
    """
    p = Path(path).expanduser()
    try:
        p = p.resolve()
        st = p.stat()
    except OSError as e:
        raise BackendError(f"cannot read the mesh {p}: {e.strerror or e}",
                           "mesh paths are absolute or relative to the environment file") from e
    key = (str(p), st.st_mtime_ns, st.st_size)
    with _CACHE_LOCK:
        hit = _CACHE.get(key)
        if hit is not None:
            _CACHE.move_to_end(key)
            return hit
    mesh = _read_mesh(p)
    with _CACHE_LOCK:
        _CACHE[key] = mesh
        while len(_CACHE) > MESH_CACHE_ENTRIES:
            _CACHE.popitem(last=False)
    return mesh


def with_albedo(mesh: MeshData, albedo_linear) -> MeshData:
    """``mesh`` (sharing its arrays) with every default material (``from_file=False``) replaced by one of
    ``albedo_linear`` (3,): files without materials take the object's colour."""
    if all(m.from_file for m in mesh.materials):
        return mesh
    col = np.asarray(albedo_linear, dtype=np.float32).reshape(3)
    mats = [m if m.from_file else dataclasses.replace(m, albedo=col) for m in mesh.materials]
    return dataclasses.replace(mesh, materials=mats)


# ------------------------------------------------------------------------------------------------------ flattening
#: Materials less opaque than this are glass (see :func:`with_glass_panes`): the packaged window panes are 0.35–0.50,
#: sheer curtains 0.66.
GLASS_OPACITY = 0.6


def with_glass_panes(mesh: MeshData) -> MeshData:
    """``mesh`` (sharing its arrays) with its glass materials (``opacity`` < :data:`GLASS_OPACITY`) marked as window
    panes (``Material.glass``): what a window or glazed door becomes, so that the camera sees, and the sun shines,
    through its panes. Returns ``mesh`` itself when it has no glass."""
    if not any(m.opacity < GLASS_OPACITY for m in mesh.materials):
        return mesh
    mats = [dataclasses.replace(m, glass=True) if m.opacity < GLASS_OPACITY else m for m in mesh.materials]
    return dataclasses.replace(mesh, materials=mats)


#: The darkest albedo (linear, Rec. 709 luminance) of a model's untextured material in a furnished home: about
#: black paint's, black plastic's or charcoal's (they reflect 3-5 % of the light; physically based material guides
#: put the darkest dielectric base colour near 50 in sRGB, 0.03 linear). Sweet Home 3D's models leave many
#: materials at 0.0-0.012, darker than black velvet (about 0.01), so that they draw as flat silhouettes.
MIN_BLACK_ALBEDO = 0.03


@functools.lru_cache(maxsize=512)
def with_real_blacks(mesh: MeshData) -> MeshData:
    """``mesh`` (sharing its arrays) with each untextured, opaque material whose albedo's luminance is below
    :data:`MIN_BLACK_ALBEDO` lifted to it by adding the same amount to every channel (a black level: a dark red
    stays red, with a little grey in it); textured materials and glass are as they are. Returns ``mesh`` itself
    when none is that dark; the same mesh gives the same result (cached by identity, so that a model placed many
    times keeps one set of materials).

    Args:
        mesh: a loaded model; each ``Material.albedo`` is (3,) float32 linear RGB in [0, 1].
    Returns:
        a :class:`MeshData` whose lifted materials have (3,) float32 albedos of Rec. 709 luminance exactly
        :data:`MIN_BLACK_ALBEDO`. Raises nothing for a valid mesh."""
    luma = np.asarray(LUMA_709, np.float32)

    def lifted(m: Material) -> Material:
        lum = float(luma @ np.asarray(m.albedo, np.float32))
        if m.texture is not None or m.opacity < GLASS_OPACITY or m.glass or lum >= MIN_BLACK_ALBEDO:
            return m
        return dataclasses.replace(m, albedo=(np.asarray(m.albedo, np.float32) + (MIN_BLACK_ALBEDO - lum)))

    mats = [lifted(m) for m in mesh.materials]
    if all(a is b for a, b in zip(mats, mesh.materials)):
        return mesh
    return dataclasses.replace(mesh, materials=mats)


def instance_bounds(inst: MeshInstance) -> np.ndarray:
    """(2, 3) float64 map-frame axis-aligned bounds of a placed mesh (of its transformed vertices)."""
    M = np.asarray(inst.transform, dtype=np.float64)
    v = inst.mesh.v.astype(np.float64) @ M[:3, :3].T + M[:3, 3]
    return np.stack([v.min(axis=0), v.max(axis=0)])


def flatten_instances(instances) -> dict:
    """World-space triangles of mesh instances.

    Returns:
        ``{'tri_v': (T, 3, 3) float32, 'tri_n': (T, 3, 3) float32 unit vertex normals (inverse transpose of each
        transform, renormalised), 'tri_uv': (T, 3, 2) float32, 'tri_material': (T,) int32 index into 'materials',
        'tri_object': (T,) int32 (the instance's ``object_index``), 'materials': list of Material (each distinct
        Material object once)}``.

    Raises:
        ValueError: a transform that is not a finite, invertible (4, 4) matrix.
    """
    mats: list[Material] = []
    index: dict[int, int] = {}
    tv, tn, tuv, tm, to = [], [], [], [], []
    for inst in instances:
        M = np.asarray(inst.transform, dtype=np.float64)
        if M.shape != (4, 4) or not np.all(np.isfinite(M)):
            raise ValueError("flatten_instances: a transform must be a finite (4, 4) matrix")
        A = M[:3, :3]
        det = float(np.linalg.det(A))
        if abs(det) < 1e-18:
            raise ValueError("flatten_instances: a transform is singular (a zero scale?)")
        mesh = inst.mesh
        v = mesh.v.astype(np.float64) @ A.T + M[:3, 3]
        n = mesh.n.astype(np.float64) @ np.linalg.inv(A)  # row-wise A⁻ᵀ n
        ln = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.divide(n, ln, out=np.tile([0.0, 0.0, 1.0], (len(n), 1)), where=ln > 1e-20)
        local = np.array([index.setdefault(id(m), len(index)) for m in mesh.materials], dtype=np.int32)
        for m in mesh.materials:
            if index[id(m)] == len(mats):
                mats.append(m)
        tv.append(v[mesh.f].astype(np.float32))
        tn.append(n[mesh.f].astype(np.float32))
        tuv.append(mesh.uv[mesh.f])
        tm.append(local[mesh.f_material])
        to.append(np.full(mesh.f.shape[0], int(inst.object_index), np.int32))
    if not tv:
        return {"tri_v": np.zeros((0, 3, 3), np.float32), "tri_n": np.zeros((0, 3, 3), np.float32),
                "tri_uv": np.zeros((0, 3, 2), np.float32), "tri_material": np.zeros(0, np.int32),
                "tri_object": np.zeros(0, np.int32), "materials": []}
    return {"tri_v": np.concatenate(tv), "tri_n": np.concatenate(tn), "tri_uv": np.concatenate(tuv).astype(np.float32),
            "tri_material": np.concatenate(tm).astype(np.int32), "tri_object": np.concatenate(to),
            "materials": mats}


# --------------------------------------------------------------------------------------------------------- textures
def mip_levels(width: int, height: int) -> int:
    """Number of mip levels of a ``width`` × ``height`` texture (down to 1 × 1; level l is
    ``max(1, width >> l)`` × ``max(1, height >> l)``)."""
    return 1 + int(math.floor(math.log2(max(int(width), int(height), 1))))


def _half(a: np.ndarray) -> np.ndarray:
    h, w = a.shape[:2]
    if h > 1:
        a = a[: h // 2 * 2]
        a = 0.5 * (a[0::2] + a[1::2])
    if w > 1:
        a = a[:, : w // 2 * 2]
        a = 0.5 * (a[:, 0::2] + a[:, 1::2])
    return a


_MIPS: "collections.OrderedDict[int, tuple]" = collections.OrderedDict()


def mip_chain(texture: np.ndarray) -> list[np.ndarray]:
    """The mip-maps of an (H, W, 3) uint8 sRGB texture: a list of (max(1, H>>l), max(1, W>>l), 3) uint8 sRGB
    images, level 0 the texture itself, each next level the 2 × 2 box average (in linear light) of the previous one
    (an odd last row or column is dropped). Cached per texture array."""
    key = id(texture)
    hit = _MIPS.get(key)
    if hit is not None and hit[0] is texture:
        return hit[1]
    tex = np.ascontiguousarray(np.asarray(texture, dtype=np.uint8)[..., :3])
    lut = np.power(np.arange(256) / 255.0, 2.2)
    lin = lut[tex]
    levels = [tex]
    for _ in range(mip_levels(tex.shape[1], tex.shape[0]) - 1):
        lin = _half(lin)
        levels.append(_linear_to_srgb8(lin))
    _MIPS[key] = (texture, levels)
    while len(_MIPS) > MESH_CACHE_ENTRIES * 4:
        _MIPS.popitem(last=False)
    return levels


def texture_atlas(textures) -> tuple[np.ndarray, np.ndarray]:
    """Pack textures with their mip-maps into one texel array.

    Args:
        textures: list of (H, W, 3) uint8 sRGB images.

    Returns:
        ``(texels (N, 3) uint8 sRGB, info (X, 4) int32 [offset, width, height, levels])``: texture x's level l
        (``max(1, width >> l)`` × ``max(1, height >> l)``, row-major, top row first) starts at ``offset`` plus the
        sizes of its levels before l.
    """
    chunks, info = [], []
    off = 0
    for tex in textures:
        levels = mip_chain(tex)
        h, w = levels[0].shape[:2]
        info.append([off, w, h, len(levels)])
        for lv in levels:
            chunks.append(lv.reshape(-1, 3))
            off += lv.shape[0] * lv.shape[1]
    texels = np.concatenate(chunks) if chunks else np.zeros((0, 3), np.uint8)
    return texels.astype(np.uint8), np.asarray(info, dtype=np.int32).reshape(-1, 4)


# ------------------------------------------------------------------------------------------------------ scene side
def ensure_triangle_attributes(scene) -> None:
    """Give a scene's triangles per-vertex normals (their face normals), zero UVs and no material (−1) where its
    ``tri_n``/``tri_uv``/``tri_material`` do not cover every triangle (scenes made before those fields)."""
    T = int(scene.tri_v.shape[0])
    if scene.tri_n.shape[0] != T:
        fn = face_normals(scene.tri_v).astype(np.float32)
        scene.tri_n = np.repeat(fn[:, None, :], 3, axis=1)
    if scene.tri_uv.shape[0] != T:
        scene.tri_uv = np.zeros((T, 3, 2), np.float32)
    if scene.tri_material.shape[0] != T:
        scene.tri_material = np.full(T, -1, np.int32)


def add_mesh_instances(scene, instances) -> tuple[int, int]:
    """Append mesh instances to ``scene`` (in place) as triangle primitives: ``prim_*`` (``PRIM_TRIANGLE``,
    ``prim_axis`` the triangle index, ``prim_object`` each instance's ``object_index``, −1 = background),
    ``tri_v``/``tri_n``/``tri_uv``/``tri_material``, the materials (``mat_*``) and their textures with mip-maps
    (``tex_texels``/``tex_info``). Object boxes (``box_*``) are not changed: the caller owns the ground truth.

    Returns:
        ``(first, end)``: the new triangles' indices in ``scene.tri_v`` (``first <= i < end``).

    Raises:
        ValueError: a bad transform (see :func:`flatten_instances`) or an ``object_index`` outside −1 ..
            ``scene.n_boxes − 1``.
    """
    from benchbot_worlds.scene.model import PRIM_TRIANGLE

    instances = list(instances)
    for inst in instances:
        if not -1 <= int(inst.object_index) < scene.n_boxes:
            raise ValueError(f"add_mesh_instances: object_index {inst.object_index} is outside -1..{scene.n_boxes - 1}")
    flat = flatten_instances(instances)
    ensure_triangle_attributes(scene)
    T0, T = int(scene.tri_v.shape[0]), int(flat["tri_v"].shape[0])
    K0 = int(scene.mat_albedo.shape[0])
    X0 = int(scene.tex_info.shape[0])
    new_tex: list[np.ndarray] = []
    tex_index: dict[int, int] = {}
    mat_tex = []
    for m in flat["materials"]:
        if m.texture is None:
            mat_tex.append(-1)
        else:
            mat_tex.append(X0 + tex_index.setdefault(id(m.texture), len(tex_index)))
            if tex_index[id(m.texture)] == len(new_tex):
                new_tex.append(m.texture)
    if new_tex:
        texels, info = texture_atlas(new_tex)
        info[:, 0] += int(scene.tex_texels.shape[0])
        scene.tex_texels = np.concatenate([scene.tex_texels.reshape(-1, 3).astype(np.uint8), texels])
        scene.tex_info = np.concatenate([scene.tex_info.reshape(-1, 4).astype(np.int32), info])
    mats = flat["materials"]
    scene.mat_albedo = np.concatenate([scene.mat_albedo.reshape(-1, 3),
                                       np.asarray([m.albedo for m in mats], np.float32).reshape(-1, 3)]).astype(np.float32)
    scene.mat_texture = np.concatenate([scene.mat_texture, np.asarray(mat_tex, np.int32)]).astype(np.int32)
    scene.mat_roughness = np.concatenate([scene.mat_roughness,
                                          np.asarray([m.roughness for m in mats], np.float32)]).astype(np.float32)
    scene.mat_metallic = np.concatenate([scene.mat_metallic,
                                         np.asarray([m.metallic for m in mats], np.float32)]).astype(np.float32)
    scene.mat_glass = np.concatenate([np.asarray(scene.mat_glass, bool).reshape(-1),
                                      np.asarray([m.glass for m in mats], bool)])
    tri_mat = flat["tri_material"] + K0
    scene.tri_v = np.concatenate([scene.tri_v.reshape(-1, 3, 3), flat["tri_v"]]).astype(np.float32)
    scene.tri_n = np.concatenate([scene.tri_n.reshape(-1, 3, 3), flat["tri_n"]]).astype(np.float32)
    scene.tri_uv = np.concatenate([scene.tri_uv.reshape(-1, 3, 2), flat["tri_uv"]]).astype(np.float32)
    scene.tri_material = np.concatenate([scene.tri_material, tri_mat]).astype(np.int32)
    tv = flat["tri_v"]
    scene.prim_type = np.concatenate([scene.prim_type, np.full(T, PRIM_TRIANGLE, np.int32)]).astype(np.int32)
    scene.prim_axis = np.concatenate([scene.prim_axis, np.arange(T0, T0 + T, dtype=np.int32)]).astype(np.int32)
    scene.prim_min = np.concatenate([scene.prim_min.reshape(-1, 3), tv.min(axis=1)]).astype(np.float32)
    scene.prim_max = np.concatenate([scene.prim_max.reshape(-1, 3), tv.max(axis=1)]).astype(np.float32)
    scene.prim_albedo = np.concatenate([scene.prim_albedo.reshape(-1, 3),
                                        scene.mat_albedo[tri_mat].reshape(-1, 3)]).astype(np.float32)
    scene.prim_object = np.concatenate([scene.prim_object, flat["tri_object"]]).astype(np.int32)
    return T0, T0 + T
