"""A bounding-volume hierarchy over axis-aligned boxes, built once per scene in NumPy (binned SAH), flattened for the
Taichi kernels. Pure NumPy; no Taichi.

Layout (depth-first): node ``n``'s left child is ``n + 1``; ``nodes_i[n] = [count, first]`` — a leaf has
``count > 0`` primitives ``order[first : first + count]``; an interior node has ``count == 0`` and ``first`` is its
right child; ``nodes_i[n, 2]`` is the node after n's subtree (where a stackless traversal goes when it misses
or leaves n). ``nodes_f[n] = [min xyz, max xyz]`` (float32, padded by :data:`PAD`).
"""

from __future__ import annotations

import numpy as np

#: Padding (metres) of node bounds (flat primitives such as triangles get a non-zero thickness).
PAD = 1e-5
#: Maximum primitives in a leaf; SAH bins; relative cost of a node traversal vs a primitive test.
MAX_LEAF = 8
BINS = 12
TRAVERSAL_COST = 1.0


def build_bvh(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Build a BVH over boxes ``lo``/``hi`` (N, 3).

    Returns:
        ``(nodes_f (M, 6) float32, nodes_i (M, 3) int32, order (N,) int32)``; with N = 0 a single empty leaf.
    """
    lo = np.asarray(lo, dtype=np.float64).reshape(-1, 3)
    hi = np.asarray(hi, dtype=np.float64).reshape(-1, 3)
    n = lo.shape[0]
    if n == 0:
        return np.array([[1, 1, 1, -1, -1, -1]], np.float32), np.array([[0, -1, 1]], np.int32), np.zeros(0, np.int32)
    cen = (lo + hi) * 0.5
    nodes_f: list = []
    nodes_i: list = []
    order: list = []

    def area(a, b):
        e = np.maximum(b - a, 0.0)
        return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]

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
            parent = max(area(blo, bhi), 1e-12)
            for ax in range(3):
                ext = chi[ax] - clo[ax]
                if ext <= 1e-9:
                    continue
                b = np.minimum(((c[:, ax] - clo[ax]) / ext * BINS).astype(int), BINS - 1)
                for k in range(1, BINS):
                    left = b < k
                    nl = int(left.sum())
                    if nl == 0 or nl == idx.size:
                        continue
                    il, ir = idx[left], idx[~left]
                    cost = TRAVERSAL_COST + (area(lo[il].min(0), hi[il].max(0)) * nl
                                             + area(lo[ir].min(0), hi[ir].max(0)) * (idx.size - nl)) / parent
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


def bvh_depth(nodes_i: np.ndarray) -> int:
    """Depth of a flattened BVH (the root has depth 1)."""
    depth = 0
    stack = [(0, 1)]
    while stack:
        n, d = stack.pop()
        depth = max(depth, d)
        if nodes_i[n, 0] == 0 and nodes_i[n, 1] > 0:
            stack += [(n + 1, d + 1), (int(nodes_i[n, 1]), d + 1)]
    return depth
