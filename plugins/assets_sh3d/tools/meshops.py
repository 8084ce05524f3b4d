"""Mesh steps of ``build_pack.py``: per-material primitives from an OBJ, quadric decimation that keeps texture
coordinates, smooth (angle-weighted, crease-aware) normals, downsized textures. Build-time only (numpy, scipy,
Pillow, fast-simplification)."""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

CREASE_DEG = 50.0
"""Faces meeting at a smaller angle than this share smooth normals; sharper edges (a cabinet's corners) stay
sharp."""

TEXTURE_MAX_PX = 256
"""Largest side of an embedded texture (pixels): enough for 640x480 views of furniture a few metres away."""

TEXTURE_PIXELS_PER_ASSET = 2 * 256 * 256
"""Most texture pixels of one model, all its textures together: a model with many textures (a person's skin,
hair, clothes) gets smaller ones."""

JPEG_QUALITY = 85


@dataclass
class Part:
    """Triangles of one material before GLB conversion: ``positions`` (F,3,3) corner positions, ``uvs`` (F,3,2)
    glTF-convention texture coordinates (v down) or None, ``material`` key."""

    positions: np.ndarray
    uvs: np.ndarray | None
    material: str


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    c = np.clip(np.asarray(c, dtype=np.float64), 0, 1)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def weld(points: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """``(unique points, inverse)`` of (N,3) points merged on a grid of ``tol``."""
    key = np.round(points / tol).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return points[first], inverse.reshape(-1)


def drop_duplicate_faces(part: Part, tol: float) -> Part:
    """``part`` without triangles that repeat another's three (welded) corners, in any order or winding: the
    two-sided sheets of the libraries (glTF materials here are ``doubleSided``)."""
    _, pid = weld(part.positions.reshape(-1, 3), tol)
    _, first = np.unique(np.sort(pid.reshape(-1, 3), axis=1), axis=0, return_index=True)
    keep = np.sort(first)
    if len(keep) == len(part.positions):
        return part
    return Part(part.positions[keep], part.uvs[keep] if part.uvs is not None else None, part.material)


def face_normals(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F,3,3) triangles → (unit normals (F,3), areas (F,))."""
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    return n / np.maximum(length, 1e-20)[:, None], length / 2


DECIMATION_MAX_ERROR = 0.02
"""Decimation tolerance, as a fraction of the whole model's bounds diagonal: the 98th percentile of the distances
between a decimated part and the original (either way, over 3000 sampled surface points each) may be 0.4 of it,
the largest 2.5 times it (a lost knob). Past it, the part is decimated less (twice the target, then four times
...) or not at all: a seat must not vanish to meet a triangle budget."""


def surface_error(tri_a: np.ndarray, tri_b: np.ndarray, samples: int = 3000) -> tuple[float, float]:
    """``(98th percentile, max)`` of the distances between points sampled (seeded) on each of two triangle soups
    (F,3,3) and the other surface, both ways (metres)."""
    import trimesh

    def mesh(tri):
        return trimesh.Trimesh(tri.reshape(-1, 3), np.arange(len(tri) * 3).reshape(-1, 3), process=False)

    a, b = mesh(tri_a), mesh(tri_b)
    pa, _ = trimesh.sample.sample_surface(a, samples, seed=1)
    pb, _ = trimesh.sample.sample_surface(b, samples, seed=2)
    _, da, _ = trimesh.proximity.closest_point(b, pa)
    _, db, _ = trimesh.proximity.closest_point(a, pb)
    d = np.r_[da, db]
    return float(np.percentile(d, 98)), float(d.max())


def surviving_vertices(n: int, faces: np.ndarray, collapses: np.ndarray, new_faces: np.ndarray) -> np.ndarray | None:
    """The original vertex of each vertex of a decimated mesh: each collapse ``[i0, i1]`` merged ``i1`` into
    ``i0``; the decimated mesh's vertices are the surviving ones still used by a face, in original order.
    Returns None unless that reproduces ``new_faces`` exactly."""
    root = np.arange(n)
    for i0, i1 in collapses:
        root[i1] = i0
    # follow chains to the final survivor
    for _ in range(64):
        nxt = root[root]
        if np.array_equal(nxt, root):
            break
        root = nxt
    mapped = root[faces]
    keep = (mapped[:, 0] != mapped[:, 1]) & (mapped[:, 1] != mapped[:, 2]) & (mapped[:, 0] != mapped[:, 2])
    mapped = mapped[keep]
    used, compact = np.unique(mapped, return_inverse=True)
    compact = compact.reshape(-1, 3)
    if compact.shape != new_faces.shape:
        return None
    # the same triangles, maybe in another order
    a = np.sort(np.sort(compact, axis=1).view([("", compact.dtype)] * 3).ravel())
    b = np.sort(np.sort(new_faces, axis=1).astype(compact.dtype).view([("", compact.dtype)] * 3).ravel())
    return used if np.array_equal(a, b) else None


def decimate_part(part: Part, target: int, tol: float, diagonal: float,
                  max_error: float = DECIMATION_MAX_ERROR) -> Part:
    """``part`` with about ``target`` triangles: quadric decimation (``fast-simplification``) of its vertices
    welded by position; texture coordinates follow the surviving vertices (:func:`transfer_uvs`). When the
    result is further from the original than ``max_error`` x ``diagonal`` (:func:`surface_error`), twice the
    target is tried, and so on; the original is kept when nothing smaller passes."""
    import fast_simplification

    n = part.positions.shape[0]
    if n <= target:
        return part
    _, pid = weld(part.positions.reshape(-1, 3), tol)
    faces = pid.reshape(-1, 3)
    ok = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    if ok.sum() <= target:
        return part
    # compact: vertices used by the non-degenerate faces only (the decimation drops unused ones)
    used, first, faces = np.unique(faces[ok], return_index=True, return_inverse=True)
    faces = faces.reshape(-1, 3)
    points = part.positions[ok].reshape(-1, 3)[first]
    while target < n * 0.8:
        new_pts, new_faces, collapses = fast_simplification.simplify(
            points, faces.astype(np.int32), target_count=int(target), agg=7.0, return_collapses=True)
        candidate = new_pts[new_faces]
        if len(candidate):
            p98, worst = surface_error(part.positions, candidate)
            if worst <= 2.5 * max_error * diagonal and p98 <= 0.4 * max_error * diagonal:
                if part.uvs is None:
                    return Part(candidate, None, part.material)
                source = surviving_vertices(len(points), faces, collapses, new_faces)
                if source is not None:
                    uvs = transfer_uvs(faces, part.uvs[ok], source[new_faces])
                    return Part(candidate, uvs, part.material)
        target *= 2
    return part


def transfer_uvs(faces: np.ndarray, uvs: np.ndarray, new_corners: np.ndarray) -> np.ndarray:
    """Texture coordinates of decimated triangles.

    Args:
        faces: (F,3) original triangles as position ids. uvs: (F,3,2) their corners' coordinates.
        new_corners: (G,3) the decimated triangles as original position ids (surviving vertices).

    Each original UV island (triangles connected through corners with equal position and coordinates) gives a
    position at most one coordinate; a new triangle takes the island that most of its corners belong to, so it does
    not straddle a seam; a corner outside that island takes the coordinates of any island of its position.

    Returns:
        (G,3,2) coordinates.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    F = len(faces)
    key = np.concatenate([faces.reshape(-1, 1).astype(np.float64), np.round(uvs.reshape(-1, 2) * 1e6)], axis=1)
    _, vid = np.unique(key, axis=0, return_inverse=True)
    vid = vid.reshape(-1)
    corner_face = np.repeat(np.arange(F), 3)
    graph = coo_matrix((np.ones(3 * F), (corner_face, vid)), shape=(F, vid.max() + 1)).tocsr()
    _, island_of_face = connected_components(graph @ graph.T, directed=False)
    island = island_of_face[corner_face]
    table: dict[tuple[int, int], np.ndarray] = {}
    any_uv: dict[int, np.ndarray] = {}
    flat_pid = faces.reshape(-1)
    flat_uv = uvs.reshape(-1, 2)
    for c in range(3 * F):
        table.setdefault((int(flat_pid[c]), int(island[c])), flat_uv[c])
        any_uv.setdefault(int(flat_pid[c]), flat_uv[c])
    islands_of: dict[int, list[int]] = {}
    for p_, i_ in table:
        islands_of.setdefault(p_, []).append(i_)
    out = np.zeros(new_corners.shape + (2,))
    for g, corners in enumerate(new_corners):
        votes: dict[int, int] = {}
        for p_ in corners:
            for i_ in islands_of.get(int(p_), ()):
                votes[i_] = votes.get(i_, 0) + 1
        best = min(votes, key=lambda i_: (-votes[i_], i_)) if votes else -1
        for k, p_ in enumerate(corners):
            uv = table.get((int(p_), best))
            out[g, k] = uv if uv is not None else any_uv.get(int(p_), (0.0, 0.0))
    return out


def smooth_vertices(part: Part, tol: float, crease_deg: float = CREASE_DEG) -> tuple[np.ndarray, np.ndarray,
                                                                                     np.ndarray | None, np.ndarray]:
    """Indexed vertices of ``part`` with smooth normals.

    Each corner's normal is the angle-weighted mean of the normals of the faces around its (welded) position
    whose normal is within ``crease_deg`` of its own face's; corners then merge when position, UV and normal agree
    (so UV seams and creases keep separate vertices).

    Returns:
        ``(positions (V,3) float32, normals (V,3) float32 unit, uvs (V,2) float32 or None, indices (F,3))``.
    """
    tri = part.positions
    fn, area = face_normals(tri)
    keep = area > 1e-14
    tri, fn = tri[keep], fn[keep]
    uvs = part.uvs[keep] if part.uvs is not None else None
    F = tri.shape[0]
    if F == 0:
        return (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32),
                None if uvs is None else np.zeros((0, 2), np.float32), np.zeros((0, 3), np.int64))
    pts, pid = weld(tri.reshape(-1, 3), tol)
    # corner angles
    e1 = np.roll(tri, -1, axis=1) - tri
    e2 = np.roll(tri, 1, axis=1) - tri
    cosang = np.einsum("fcj,fcj->fc", e1, e2) / np.maximum(
        np.linalg.norm(e1, axis=2) * np.linalg.norm(e2, axis=2), 1e-20)
    ang = np.arccos(np.clip(cosang, -1, 1)).reshape(-1)
    corner_face = np.repeat(np.arange(F), 3)
    # all pairs of corners sharing a position
    order = np.argsort(pid, kind="stable")
    sorted_pid = pid[order]
    starts = np.flatnonzero(np.r_[True, sorted_pid[1:] != sorted_pid[:-1]])
    counts = np.diff(np.r_[starts, len(order)])
    group_of = np.repeat(np.arange(len(starts)), counts)  # per sorted corner
    per = counts[group_of]  # partners of each sorted corner
    i_sorted = np.repeat(np.arange(len(order)), per)
    offsets = np.arange(per.sum()) - np.repeat(np.cumsum(per) - per, per)
    j_sorted = starts[group_of[i_sorted]] + offsets
    ci, cj = order[i_sorted], order[j_sorted]
    fi, fj = corner_face[ci], corner_face[cj]
    dots = np.einsum("ij,ij->i", fn[fi], fn[fj])
    weight = ang[cj] * (dots >= np.cos(np.radians(crease_deg)))
    normals = np.zeros((3 * F, 3))
    np.add.at(normals, ci, weight[:, None] * fn[fj])
    length = np.linalg.norm(normals, axis=1)
    bad = length < 1e-12
    normals[bad] = fn[corner_face[bad]]
    normals /= np.maximum(np.linalg.norm(normals, axis=1), 1e-20)[:, None]
    # merge corners with equal position id, uv and normal
    cols = [pid[:, None].astype(np.float64), np.round(normals * 1e4)]
    if uvs is not None:
        cols.append(np.round(uvs.reshape(-1, 2) * 1e5))
    key = np.concatenate(cols, axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    positions = pts[pid[first]].astype(np.float32)
    out_normals = normals[first].astype(np.float32)
    out_uvs = uvs.reshape(-1, 2)[first].astype(np.float32) if uvs is not None else None
    return positions, out_normals, out_uvs, inverse.reshape(F, 3)


def texture_bytes(img, max_px: int = TEXTURE_MAX_PX, quality: int = JPEG_QUALITY,
                  scale: float = 1.0) -> tuple[bytes, str, int, int, bool]:
    """A texture downsized to at most ``max_px`` on its longer side, then by ``scale``: JPEG (quality
    ``quality``) when opaque, PNG when it has real transparency (cut-outs). Returns ``(bytes, mime, width,
    height, has_alpha)``."""
    from PIL import Image

    has_alpha = False
    if img.mode in ("RGBA", "LA", "PA") or (img.mode == "P" and "transparency" in img.info):
        rgba = img.convert("RGBA")
        alpha = np.asarray(rgba)[:, :, 3]
        has_alpha = bool((alpha < 128).mean() > 0.01)
        img = rgba if has_alpha else rgba.convert("RGB")
    else:
        img = img.convert("RGB")
    w, h = img.size
    scale = min(1.0, max_px / max(w, h)) * scale
    nw, nh = max(1, round(w * scale)), max(1, round(h * scale))
    if (nw, nh) != (w, h):
        img = img.resize((nw, nh), Image.LANCZOS)
    buf = io.BytesIO()
    if has_alpha:
        img.save(buf, format="PNG", optimize=True)
        return buf.getvalue(), "image/png", nw, nh, True
    img.save(buf, format="JPEG", quality=quality, optimize=True)
    return buf.getvalue(), "image/jpeg", nw, nh, False


def texture_scale(sizes: list[tuple[int, int]], max_px: int = TEXTURE_MAX_PX,
                  budget: int = TEXTURE_PIXELS_PER_ASSET) -> float:
    """The factor (≤ 1) that brings textures of ``sizes`` (already capped at ``max_px``) within ``budget``
    pixels together."""
    total = 0.0
    for w, h in sizes:
        f = min(1.0, max_px / max(w, h))
        total += w * f * h * f
    return min(1.0, (budget / total) ** 0.5) if total else 1.0


def mean_colour(img) -> tuple[float, float, float]:
    """The mean sRGB colour (0–1) of an image (opaque pixels)."""
    rgba = np.asarray(img.convert("RGBA"), dtype=np.float64) / 255
    mask = rgba[:, :, 3] > 0.5
    px = rgba[:, :, :3][mask] if mask.any() else rgba[:, :, :3].reshape(-1, 3)
    return tuple(float(x) for x in px.mean(axis=0))
