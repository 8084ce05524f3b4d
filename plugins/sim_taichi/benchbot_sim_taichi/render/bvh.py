"""A bounding-volume hierarchy over axis-aligned boxes, built once per scene in NumPy (binned SAH), flattened for the
Taichi kernels. Pure NumPy; no Taichi.

Layout (depth-first): node ``n``'s left child is ``n + 1``; ``nodes_i[n] = [count, first]`` — a leaf has
``count > 0`` primitives ``order[first : first + count]``; an interior node has ``count == 0`` and ``first`` is its
right child; ``nodes_i[n, 2]`` is the node after n's subtree (where a stackless traversal goes when it misses
or leaves n). ``nodes_f[n] = [min xyz, max xyz]`` (float32, padded by :data:`PAD`).

:func:`build_bvh` builds level by level: every node of a level is binned, costed and partitioned at once in
vectorised NumPy (a few seconds for a million triangles on one core), then the nodes are laid out depth-first.
It makes the same decisions as the recursive :func:`build_bvh_reference` (the same tree, bit for bit) except where
that one would go deeper than :data:`MAX_DEPTH`: there the builder switches to median splits.

The kernels read the tree as :func:`wide_nodes` packs it: one 64-byte record per interior node with both children's
boxes, so that a traversal step reads one record (one H200, house:1, one camera 3,915 → 4,194 fps against the
depth-first arrays read node by node; the 2-core CPU unchanged).
"""

from __future__ import annotations

import numpy as np

#: Padding (metres) of node bounds (flat primitives such as triangles get a non-zero thickness).
PAD = 1e-5
#: Maximum primitives in a leaf; SAH bins; relative cost of a node traversal vs a primitive test.
MAX_LEAF = 8
BINS = 12
TRAVERSAL_COST = 1.0
#: Deepest tree :func:`build_bvh` makes (the root has depth 1), below the kernels' traversal stack (``STACK`` = 64
#: in :mod:`benchbot_sim_taichi.render.kernels`). Where an SAH split could not finish within it by halving, a node is cut
#: at its centroid median instead. Holds for up to ``MAX_LEAF · 2**(MAX_DEPTH - 1)`` primitives.
MAX_DEPTH = 48
#: Nodes binned together in one vectorised pass (each per-bin bounds array is ``NODE_CHUNK · BINS · 9`` float64,
#: 3.5 MB; a handful live at once).
NODE_CHUNK = 4096
#: Centroid extent (metres) below which an axis is not split by SAH.
MIN_EXTENT = 1e-9
#: Leaf references of :func:`wide_nodes`: the first primitive's index is shifted by LEAF_SHIFT bits, above the flag
#: TRI_ONLY (all the leaf's primitives are plain triangles) and the count (at most 15).
LEAF_SHIFT = 5
TRI_ONLY = 1 << 4


def _empty() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.array([[1, 1, 1, -1, -1, -1]], np.float32), np.array([[0, -1, 1]], np.int32), np.zeros(0, np.int32)


def _area(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Half the surface area of boxes ``a..b`` (..., 3); empty (inverted) boxes have area 0."""
    e = np.maximum(b - a, 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


def _halvings(count: np.ndarray) -> np.ndarray:
    """Median splits needed to bring ``count`` primitives down to leaves of at most MAX_LEAF (0 for a leaf)."""
    h = np.zeros(count.shape, np.int64)
    c = count.astype(np.int64)
    while True:
        big = c > MAX_LEAF
        if not big.any():
            return h
        h += big
        c = np.where(big, (c + 1) // 2, c)


def _exclusive_cumsum(x: np.ndarray) -> np.ndarray:
    out = np.zeros(x.size, np.int64)
    np.cumsum(x[:-1], out=out[1:])
    return out


def _sah_splits(cen, lo, hi, count, node_lo, node_hi, cen_lo, cen_hi):
    """Best binned SAH split of k nodes whose m primitives are consecutive, grouped by node.

    Args:
        cen, lo, hi: (3, m) float64 centroids and bounds of the primitives; count: (k,) primitives per node;
        node_lo, node_hi, cen_lo, cen_hi: (3, k) bounds of each node's boxes and of its centroids.

    Returns:
        ``(split (k,) bool, go_left (m,) bool, [left lo, left hi, right lo, right hi] (3, k) each)``: whether a
        node splits (its best cost beats a leaf, as in :func:`build_bvh_reference`), for a splitting node's
        primitives which go to its left child, and the bounds of its children.
    """
    k, m = count.size, cen.shape[1]
    ext = cen_hi - cen_lo
    valid = ext > MIN_EXTENT  # (3, k)
    d = cen - np.repeat(cen_lo, count, axis=1)
    d /= np.repeat(np.where(valid, ext, 1.0), count, axis=1)
    d *= BINS
    bins = d.astype(np.int64)  # (3, m): the same arithmetic as the reference, so the same bins
    del d
    np.minimum(bins, BINS - 1, out=bins)
    nb = k * BINS
    node_of = np.repeat(np.arange(k), count)
    bcount = np.empty((3, BINS, k), np.int64)
    bmin = np.full((3, 3, nb), np.inf)  # [split axis, coordinate, bin·k + node]: bins lead, for the scans below
    bmax = np.full((3, 3, nb), -np.inf)
    for ax in range(3):
        key = bins[ax] * k + node_of
        bcount[ax] = np.bincount(key, minlength=nb).reshape(BINS, k)
        for co in range(3):
            np.minimum.at(bmin[ax, co], key, lo[co])
            np.maximum.at(bmax[ax, co], key, hi[co])
    del key, node_of
    bmin = bmin.reshape(3, 3, BINS, k)
    bmax = bmax.reshape(3, 3, BINS, k)

    def area(a, b):  # (3 axes, 3 coordinates, BINS - 1, k) → (3, BINS - 1, k): _area's arithmetic, in place
        e = np.subtract(b, a)
        np.maximum(e, 0.0, out=e)
        out = np.multiply(e[:, 0], e[:, 1])
        tmp = np.multiply(e[:, 1], e[:, 2])
        out += tmp
        np.multiply(e[:, 2], e[:, 0], out=tmp)
        out += tmp
        return out

    def scan(b, op, reverse, out):  # inclusive prefix (or suffix) min/max over the bins (axis 2)
        out[...] = b
        for j in (range(BINS - 2, -1, -1) if reverse else range(1, BINS)):
            op(out[:, :, j + (1 if reverse else -1)], out[:, :, j], out=out[:, :, j])
        return out

    pre_lo = scan(bmin, np.minimum, False, np.empty_like(bmin))
    pre_hi = scan(bmax, np.maximum, False, np.empty_like(bmax))
    suf_lo, suf_hi = scan(bmin, np.minimum, True, bmin), scan(bmax, np.maximum, True, bmax)
    a_left = area(pre_lo[:, :, :-1], pre_hi[:, :, :-1])
    a_right = area(suf_lo[:, :, 1:], suf_hi[:, :, 1:])
    n_left = np.cumsum(bcount, axis=1)[:, :-1]  # (axis, BINS-1, node): split k puts bins < k on the left
    n_right = count - n_left
    parent = np.maximum(_area(node_lo.T, node_hi.T), 1e-12)
    a_left *= n_left  # cost = TRAVERSAL_COST + (a_left * n_left + a_right * n_right) / parent, in place
    a_right *= n_right
    a_left += a_right
    a_left /= parent
    a_left += TRAVERSAL_COST
    cost = a_left
    cost[(n_left == 0) | (n_right == 0) | ~valid[:, None, :]] = np.inf
    flat = cost.reshape(3 * (BINS - 1), k)  # the first minimum in (axis, k) order
    best = np.argmin(flat, axis=0)
    split = flat[best, np.arange(k)] < count
    axis, cut = best // (BINS - 1), best % (BINS - 1) + 1
    go_left = np.take(bins.reshape(-1), np.repeat(axis * m, count) + np.arange(m)) < np.repeat(cut, count)
    nodes = np.arange(k)
    children = [b[axis, :, j, nodes].T
                for b, j in ((pre_lo, cut - 1), (pre_hi, cut - 1), (suf_lo, cut), (suf_hi, cut))]
    return split, go_left, children


def _median_left(cen, count, cen_lo, cen_hi):
    """``go_left`` (m,) of nodes cut at the median: the first ``count // 2`` primitives of each node in a stable
    sort of the centroids (``cen`` (3, m), grouped by node) along the node's longest centroid axis."""
    m = cen.shape[1]
    axis = np.argmax((cen_hi - cen_lo).T, axis=1)
    node_of = np.repeat(np.arange(count.size), count)
    vals = np.take(cen.reshape(-1), np.repeat(axis * m, count) + np.arange(m))
    srt = np.lexsort((vals, node_of))  # by node, then centroid; stable
    rank = np.arange(m) - np.repeat(_exclusive_cumsum(count), count)
    go_left = np.empty(m, bool)
    go_left[srt] = rank < np.repeat(count // 2, count)
    return go_left


def _chunked_sah(cen, lo, hi, count, node_lo, node_hi, cen_lo, cen_hi):
    """:func:`_sah_splits` over at most :data:`NODE_CHUNK` nodes at a time (bounds memory)."""
    k = count.size
    if k <= NODE_CHUNK:
        return _sah_splits(cen, lo, hi, count, node_lo, node_hi, cen_lo, cen_hi)
    starts = np.concatenate([_exclusive_cumsum(count), [int(count.sum())]])
    split = np.empty(k, bool)
    go_left = np.empty(cen.shape[1], bool)
    children = [np.empty((3, k)) for _ in range(4)]
    for a in range(0, k, NODE_CHUNK):
        b = min(a + NODE_CHUNK, k)
        p, q = starts[a], starts[b]
        split[a:b], go_left[p:q], part = _sah_splits(cen[:, p:q], lo[:, p:q], hi[:, p:q], count[a:b],
                                                     node_lo[:, a:b], node_hi[:, a:b], cen_lo[:, a:b],
                                                     cen_hi[:, a:b])
        for whole, piece in zip(children, part):
            whole[:, a:b] = piece
    return split, go_left, children


def _subset(mask, count, *arrays):
    """The nodes where ``mask`` (k,) holds: their counts, and the (3, m) per-primitive ``arrays`` cut to them."""
    if mask.all():
        return (count, *arrays)
    pm = np.repeat(mask, count)
    return (count[mask], *(np.compress(pm, a, axis=1) for a in arrays))


def build_bvh(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Build a BVH over boxes ``lo``/``hi`` (N, 3) (binned SAH, :data:`BINS` bins per axis, leaves of at most
    :data:`MAX_LEAF` primitives, depth at most :data:`MAX_DEPTH`).

    Returns:
        ``(nodes_f (M, 6) float32, nodes_i (M, 3) int32, order (N,) int32)`` in the module's depth-first layout;
        with N = 0 a single empty leaf.

    Raises:
        ValueError: ``lo``/``hi`` do not have the same (N, 3) shape, or hold NaN or infinite values.
    """
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    if lo.size != hi.size or lo.size % 3:
        raise ValueError(f"build_bvh: lo {lo.shape} and hi {hi.shape} must both be (N, 3) bounds of the same N boxes")
    lo, hi = lo.reshape(-1, 3), hi.reshape(-1, 3)
    n = lo.shape[0]
    if n == 0:
        return _empty()
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise ValueError("build_bvh: primitive bounds hold NaN or infinite values; give every primitive finite bounds")
    # the primitives of the open nodes of a level, grouped by node (planar (3, m) for contiguous per-axis work)
    prim = np.arange(n, dtype=np.int64)
    p_lo, p_hi = np.ascontiguousarray(lo.T), np.ascontiguousarray(hi.T)
    p_cen = (p_lo + p_hi) * 0.5
    del lo, hi
    order = np.empty(n, np.int64)  # every node's primitives are order[first : first + count], left's before right's
    # per level (breadth-first): first primitive, count, bounds, child id (left; right = left + 1; -1: leaf)
    levels = []
    first = np.zeros(1, np.int64)
    count = np.full(1, n, np.int64)
    node_lo, node_hi = np.empty((3, 1)), np.empty((3, 1))  # each node's bounds, where ``known`` (from SAH scans)
    known = np.zeros(1, bool)
    depth, next_id = 1, 1
    while first.size:
        k, m = count.size, prim.size
        starts = _exclusive_cumsum(count)
        if not known.all():
            u_count, u_lo, u_hi = _subset(~known, count, p_lo, p_hi)
            u_starts = _exclusive_cumsum(u_count)
            node_lo[:, ~known] = np.minimum.reduceat(u_lo, u_starts, axis=1)
            node_hi[:, ~known] = np.maximum.reduceat(u_hi, u_starts, axis=1)
            del u_lo, u_hi
        cen_lo = np.minimum.reduceat(p_cen, starts, axis=1)
        cen_hi = np.maximum.reduceat(p_cen, starts, axis=1)
        # SAH where a split can still finish within MAX_DEPTH by halving; else a median cut (or a leaf)
        in_depth = depth + 1 + _halvings(count) <= MAX_DEPTH
        try_sah = (count > MAX_LEAF // 2) & in_depth
        split = np.zeros(k, bool)
        go_left = np.zeros(m, bool)
        child_lo, child_hi = np.empty((3, 2 * k)), np.empty((3, 2 * k))  # [left, right] of every node (if split)
        child_known = np.zeros(2 * k, bool)
        if try_sah.any():
            t_count, t_cen, t_lo, t_hi = _subset(try_sah, count, p_cen, p_lo, p_hi)
            t_split, t_left, (l_lo, l_hi, r_lo, r_hi) = _chunked_sah(
                t_cen, t_lo, t_hi, t_count, node_lo[:, try_sah], node_hi[:, try_sah], cen_lo[:, try_sah],
                cen_hi[:, try_sah])
            del t_cen, t_lo, t_hi
            split[try_sah] = t_split
            go_left[np.repeat(try_sah, count)] = t_left
            tried = np.flatnonzero(try_sah)
            child_lo[:, 2 * tried], child_hi[:, 2 * tried] = l_lo, l_hi
            child_lo[:, 2 * tried + 1], child_hi[:, 2 * tried + 1] = r_lo, r_hi
            child_known[2 * tried] = child_known[2 * tried + 1] = True
        median = ~split & (count > MAX_LEAF)
        if median.any():
            m_count, m_cen = _subset(median, count, p_cen)
            go_left[np.repeat(median, count)] = _median_left(m_cen, m_count, cen_lo[:, median], cen_hi[:, median])
            split |= median
            child_known[2 * np.flatnonzero(median)] = child_known[2 * np.flatnonzero(median) + 1] = False
        # leaves: their primitives take their final places
        moving = np.repeat(split, count)
        offset = np.arange(m) - np.repeat(starts, count)  # index within the node
        if not split.all():
            staying = ~moving
            order[(np.repeat(first, count) + offset)[staying]] = prim[staying]
        # split nodes: a stable partition (left primitives, then right ones) into the next level's arrays
        go_left &= moving
        left_before = np.cumsum(go_left) - go_left
        rank_left = left_before - np.repeat(left_before[starts], count)
        n_left = np.add.reduceat(go_left, starts, dtype=np.int64)
        s_nodes = np.flatnonzero(split)
        s_count = count[s_nodes]
        base = np.zeros(k, np.int64)
        base[s_nodes] = _exclusive_cumsum(s_count)
        dest = np.repeat(base, count) + np.where(go_left, rank_left,
                                                 np.repeat(n_left, count) + offset - rank_left)
        src = np.empty(int(s_count.sum()), np.int64)
        src[dest[moving]] = np.flatnonzero(moving)
        del dest, offset, left_before, rank_left, go_left, moving
        prim = prim[src]
        p_lo, p_hi, p_cen = (np.take(a, src, axis=1) for a in (p_lo, p_hi, p_cen))
        child = np.full(k, -1, np.int64)
        child[s_nodes] = next_id + 2 * np.arange(s_nodes.size)
        levels.append((first, count, node_lo, node_hi, child))
        next_id += 2 * s_nodes.size
        nl = n_left[s_nodes]
        first = np.stack([first[s_nodes], first[s_nodes] + nl], axis=1).reshape(-1)
        count = np.stack([nl, s_count - nl], axis=1).reshape(-1)
        pair = np.stack([2 * s_nodes, 2 * s_nodes + 1], axis=1).reshape(-1)
        node_lo, node_hi, known = child_lo[:, pair], child_hi[:, pair], child_known[pair]
        depth += 1
    return _layout(levels, order)


def _layout(levels: list, order: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Breadth-first ``levels`` of ``(first, count, lo (3, k), hi (3, k), left child id or -1)`` (node ids: level
    by level, in order) → the depth-first arrays of :func:`build_bvh`."""
    sizes = [lv[1].size for lv in levels]
    offs = np.concatenate([[0], np.cumsum(sizes)])
    m = int(offs[-1])
    child = np.concatenate([lv[4] for lv in levels])
    interior = child >= 0
    subtree = np.ones(m, np.int64)  # nodes in each subtree, bottom-up (children live on the next level)
    for lv in range(len(sizes) - 1, -1, -1):
        ids = np.arange(offs[lv], offs[lv + 1])[interior[offs[lv]:offs[lv + 1]]]
        subtree[ids] = 1 + subtree[child[ids]] + subtree[child[ids] + 1]
    dfs = np.zeros(m, np.int64)  # depth-first index, top-down: left = parent + 1, right = after the left subtree
    for lv in range(len(sizes)):
        ids = np.arange(offs[lv], offs[lv + 1])[interior[offs[lv]:offs[lv + 1]]]
        dfs[child[ids]] = dfs[ids] + 1
        dfs[child[ids] + 1] = dfs[ids] + 1 + subtree[child[ids]]
    count = np.concatenate([lv[1] for lv in levels])
    first = np.concatenate([lv[0] for lv in levels])
    nodes_f = np.empty((m, 6), np.float32)
    nodes_f[dfs, :3] = np.concatenate([lv[2] for lv in levels], axis=1).T - PAD
    nodes_f[dfs, 3:] = np.concatenate([lv[3] for lv in levels], axis=1).T + PAD
    nodes_i = np.empty((m, 3), np.int32)
    right = np.where(interior, child + 1, 0)
    nodes_i[dfs, 0] = np.where(interior, 0, count)
    nodes_i[dfs, 1] = np.where(interior, dfs[right], first)
    nodes_i[dfs, 2] = dfs + subtree
    return nodes_f, nodes_i, order.astype(np.int32)


def wide_nodes(nodes_f: np.ndarray, nodes_i: np.ndarray, tri_only: np.ndarray | None = None) -> np.ndarray:
    """The tree of :func:`build_bvh` as the kernels traverse it: one 64-byte record per interior node, holding both
    children's boxes, so that a step of the traversal reads one record.

    Args:
        nodes_f, nodes_i: :func:`build_bvh`'s depth-first arrays (M nodes).
        tri_only: (M,) bool, for each leaf whether all its primitives are plain triangles (the kernels then test
            them without reading their kinds); ``None``: none is.

    Returns:
        (max(I, 1), 16) float32 for the I interior nodes in depth-first order (the root first): [left child's box
        (min xyz, max xyz), right child's box, left child's reference, right child's reference (int32 bit patterns),
        0, 0]. A reference ≥ 0 is an interior child's record; a leaf's is ``~((first << LEAF_SHIFT) | (TRI_ONLY if
        tri_only) | count)`` (its primitives ``first .. first + count − 1``). A tree without an interior node (one
        leaf, or none) becomes one record of that leaf and an empty leaf (count 0).

    Raises:
        ValueError: a reference does not fit in 32 bits (more than about 67 million primitives).
    """
    count = nodes_i[:, 0].astype(np.int64)
    link = nodes_i[:, 1].astype(np.int64)
    interior = (count == 0) & (link > 0)
    tri = np.zeros(count.shape, bool) if tri_only is None else np.asarray(tri_only, bool)
    leaf_ref = ~((np.maximum(link, 0) << LEAF_SHIFT) | np.where(tri, TRI_ONLY, 0) | count)
    ref = np.where(interior, np.cumsum(interior) - 1, leaf_ref)
    if ref.max(initial=0) >= 2**31 or ref.min(initial=0) < -2**31:
        raise ValueError("BVH too large for 32-bit node references")
    ref = ref.astype(np.int32)
    ids = np.flatnonzero(interior)
    out = np.zeros((max(ids.size, 1), 16), np.float32)
    if ids.size:
        left, right = ids + 1, link[ids]
        out[:, 0:6], out[:, 6:12] = nodes_f[left], nodes_f[right]
        out[:, 12], out[:, 13] = ref[left].view(np.float32), ref[right].view(np.float32)
    else:  # one leaf (or an empty tree: a leaf of no primitive) and an empty leaf
        out[0, 0:6] = nodes_f[0]
        out[0, 12:14] = np.array([ref[0], ~np.int32(0)], np.int32).view(np.float32)
    return out


def clusters(nodes_f: np.ndarray, nodes_i: np.ndarray, max_prims: int) -> tuple[np.ndarray, np.ndarray]:
    """The largest subtrees of :func:`build_bvh`'s tree with at most ``max_prims`` primitives each: the clusters that
    the rasteriser culls against a camera's view before it sets up their primitives
    (:mod:`benchbot_sim_taichi.render.raster`).

    A subtree's primitives are consecutive (its leaves' ranges follow one another in depth-first order), so a
    cluster is a box and a range of primitives; the clusters hold every primitive once, in order.

    Args:
        nodes_f, nodes_i: :func:`build_bvh`'s depth-first arrays (M nodes). max_prims: at least 1.

    Returns:
        ``(boxes (C, 6) float32 [min xyz, max xyz], prims (C, 2) int32 [first, count])``; C = 0 for a tree without
        primitives.

    Raises:
        ValueError: ``max_prims`` below 1, or a tree whose leaves do not hold consecutive primitive ranges in
            depth-first order (not :func:`build_bvh`'s layout).
    """
    if max_prims < 1:
        raise ValueError(f"clusters: max_prims must be at least 1, got {max_prims}")
    count = np.asarray(nodes_i)[:, 0].astype(np.int64)
    link = np.asarray(nodes_i)[:, 1].astype(np.int64)
    skip = np.asarray(nodes_i)[:, 2].astype(np.int64)
    m = count.size
    before = np.concatenate([[0], np.cumsum(count)])  # primitives in the leaves of nodes 0 .. n-1
    leaves = np.flatnonzero(count > 0)
    if not np.array_equal(link[leaves], before[leaves]):
        raise ValueError("clusters: the leaves' primitive ranges are not consecutive in depth-first order")
    sub = before[skip] - before[:m]  # primitives in each node's subtree (nodes n .. skip[n] - 1)
    interior = (count == 0) & (link > 0)
    parent = np.full(m, -1, np.int64)
    ids = np.flatnonzero(interior)
    parent[ids + 1], parent[link[ids]] = ids, ids
    parent_sub = np.where(parent >= 0, sub[np.maximum(parent, 0)], max_prims + 1)
    roots = np.flatnonzero((sub > 0) & (sub <= max_prims) & (parent_sub > max_prims))
    boxes = np.ascontiguousarray(np.asarray(nodes_f, np.float32)[roots])
    prims = np.stack([before[roots], sub[roots]], axis=1).astype(np.int32)
    return boxes.reshape(-1, 6), prims.reshape(-1, 2)


def build_bvh_reference(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The recursive binned-SAH builder :func:`build_bvh` replaced (one node at a time, Python loops over the
    3 × (BINS - 1) candidate splits; about 40 s for 200k triangles). Same arguments, result and layout; kept as the
    reference the fast builder is tested and benchmarked against. It has no depth limit."""
    lo = np.asarray(lo, dtype=np.float64).reshape(-1, 3)
    hi = np.asarray(hi, dtype=np.float64).reshape(-1, 3)
    n = lo.shape[0]
    if n == 0:
        return _empty()
    cen = (lo + hi) * 0.5
    nodes_f: list = []
    nodes_i: list = []
    order: list = []

    def build(idx: np.ndarray) -> int:
        me = len(nodes_f)
        blo, bhi = lo[idx].min(axis=0), hi[idx].max(axis=0)
        nodes_f.append(np.concatenate([blo - PAD, bhi + PAD]))
        nodes_i.append([0, 0])
        split = None
        if idx.size > MAX_LEAF // 2:
            c = cen[idx]
            clo, chi = c.min(axis=0), c.max(axis=0)
            best = (float(idx.size), None)  # cost of a leaf (in primitive tests)
            parent = max(_area(blo, bhi), 1e-12)
            for ax in range(3):
                ext = chi[ax] - clo[ax]
                if ext <= MIN_EXTENT:
                    continue
                b = np.minimum(((c[:, ax] - clo[ax]) / ext * BINS).astype(int), BINS - 1)
                for k in range(1, BINS):
                    left = b < k
                    nl = int(left.sum())
                    if nl == 0 or nl == idx.size:
                        continue
                    il, ir = idx[left], idx[~left]
                    cost = TRAVERSAL_COST + (_area(lo[il].min(0), hi[il].max(0)) * nl
                                             + _area(lo[ir].min(0), hi[ir].max(0)) * (idx.size - nl)) / parent
                    if cost < best[0]:
                        best = (cost, left)
            split = best[1]
            if split is None and idx.size > MAX_LEAF:  # no good SAH split: median on the longest centroid axis
                ax = int(np.argmax(chi - clo))
                srt = np.argsort(c[:, ax], kind="stable")
                split = np.zeros(idx.size, dtype=bool)
                split[srt[: idx.size // 2]] = True
        if split is None:
            nodes_i[me] = [idx.size, len(order)]
            order.extend(idx.tolist())
            return me
        build(idx[split])
        nodes_i[me] = [0, build(idx[~split])]
        return me

    build(np.arange(n))
    ni = np.asarray(nodes_i, np.int64)
    skip = np.zeros(len(ni), np.int64)
    for k in range(len(ni) - 1, -1, -1):  # children come after their parent
        skip[k] = k + 1 if ni[k, 0] > 0 else skip[ni[k, 1]]
    ni = np.concatenate([ni, skip[:, None]], axis=1)
    return (np.asarray(nodes_f, np.float32), ni.astype(np.int32), np.asarray(order, np.int32))


def sah_cost(nodes_f: np.ndarray, nodes_i: np.ndarray) -> float:
    """SAH cost of a flattened BVH: ``Σ_interior TRAVERSAL_COST · A(n)/A(root) + Σ_leaves count · A(n)/A(root)``
    over the (padded) node boxes — the expected work of a random ray through the root; lower is better."""
    f = np.asarray(nodes_f, np.float64)
    cnt = np.asarray(nodes_i)[:, 0].astype(np.float64)
    area = _area(f[:, :3], f[:, 3:])
    root = max(float(area[0]), 1e-30)
    return float(np.sum(np.where(cnt > 0, cnt, TRAVERSAL_COST) * area) / root)


def bvh_depth(nodes_i: np.ndarray) -> int:
    """Depth of a flattened BVH (the root has depth 1), walked level by level (vectorised)."""
    links = np.asarray(nodes_i)[:, :2].astype(np.int64)
    inner = (links[:, 0] == 0) & (links[:, 1] > 0)
    depth, level = 0, np.zeros(1, np.int64)
    while level.size and depth <= links.shape[0]:  # a well-formed tree ends; a cyclic one stops here
        depth += 1
        level = level[inner[level]]
        level = np.concatenate([level + 1, links[level, 1]])
    return depth
