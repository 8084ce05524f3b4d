"""The BVH builder (benchbot_sim_taichi.render.bvh): the level-by-level builder makes the same tree as the recursive reference
builder; structure invariants of the depth-first layout (every primitive in one leaf, bounds contain children and
primitives, skip links, leaf sizes, depth); nearest hits through a NumPy stackless traversal equal brute force."""

from __future__ import annotations

import numpy as np
import pytest

from benchbot_sim_taichi.render import bvh


def soup(n: int, seed: int = 0, size: float = 0.05, dtype=np.float64) -> np.ndarray:
    """(n, 3, 3) random thin triangles in a 20 × 20 × 3 m room (edges ~ ``size`` m)."""
    rng = np.random.default_rng(seed)
    c = rng.uniform([-10, -10, 0], [10, 10, 3], (n, 3))
    return (c[:, None, :] + rng.normal(0.0, size, (n, 3, 3))).astype(dtype)


def boxes(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    a, b = rng.random((n, 3)) * 4, rng.random((n, 3)) * 4
    return np.minimum(a, b), np.maximum(a, b)


def tri_bounds(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return t.min(axis=1), t.max(axis=1)


def check_invariants(nodes_f, nodes_i, order, lo, hi) -> int:
    """Assert the layout's guarantees; return the depth."""
    n, m = lo.shape[0], nodes_f.shape[0]
    assert nodes_f.dtype == np.float32 and nodes_f.shape == (m, 6)
    assert nodes_i.dtype == np.int32 and nodes_i.shape == (m, 3)
    assert order.dtype == np.int32 and np.array_equal(np.sort(order), np.arange(n))
    count, link, skip = (nodes_i[:, j].astype(np.int64) for j in range(3))
    leaf = count > 0
    assert (count >= 0).all() and count[leaf].max() <= bvh.MAX_LEAF
    # leaves' ranges tile order exactly: every primitive in exactly one leaf
    first = link[leaf]
    srt = np.argsort(first)
    ends = first[srt] + count[leaf][srt]
    assert first[srt][0] == 0 and ends[-1] == n and np.array_equal(first[srt][1:], ends[:-1])
    # interior nodes: left child n + 1, right child after it; skip links: leaf → n + 1, left's skip = right child,
    # right's skip = parent's skip, root's skip = M (together: skip[n] is the node after n's subtree)
    inner = np.flatnonzero(~leaf)
    right = link[inner]
    assert (right > inner + 1).all() and (right < m).all()
    assert np.array_equal(skip[leaf], np.flatnonzero(leaf) + 1)
    assert np.array_equal(skip[inner + 1], right) and np.array_equal(skip[right], skip[inner]) and skip[0] == m
    # every node is the child of exactly one interior node (or the root)
    children = np.concatenate([[0], inner + 1, right])
    assert np.array_equal(np.sort(children), np.arange(m))
    # bounds: parents contain children; leaves contain their primitives
    for c in (inner + 1, right):
        assert (nodes_f[inner, :3] <= nodes_f[c, :3]).all() and (nodes_f[inner, 3:] >= nodes_f[c, 3:]).all()
    leaf_of = np.repeat(np.flatnonzero(leaf)[srt], count[leaf][srt])  # the leaf holding order[i]
    assert (nodes_f[leaf_of, :3] <= lo[order]).all() and (nodes_f[leaf_of, 3:] >= hi[order]).all()
    # depth from the links, level by level
    depth, level = 0, np.array([0])
    while level.size:
        depth += 1
        level = np.concatenate([level[~leaf[level]] + 1, link[level[~leaf[level]]]])
    return depth


CASES = {
    "random boxes": lambda: boxes(1000, 1),
    "triangle soup": lambda: tri_bounds(soup(1500, 2)),
    "float32 soup": lambda: tri_bounds(soup(1000, 3, dtype=np.float32)),
    "flat (z = 0)": lambda: tuple(a * [1, 1, 0] for a in tri_bounds(soup(1000, 4))),
    "duplicates": lambda: tuple(np.repeat(a, 7, axis=0) for a in tri_bounds(soup(150, 5))),
    "coincident centroids": lambda: (np.zeros((100, 3)), np.ones((100, 3))),
    "one": lambda: (np.zeros((1, 3)), np.ones((1, 3))),
    "five": lambda: tri_bounds(soup(5, 6)),
    "nine": lambda: tri_bounds(soup(9, 7)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_same_tree_as_the_recursive_reference_builder(case):
    lo, hi = CASES[case]()
    fast, ref = bvh.build_bvh(lo, hi), bvh.build_bvh_reference(lo, hi)
    for a, b in zip(fast, ref):
        assert a.dtype == b.dtype and a.shape == b.shape
        assert np.array_equal(a, b)
    assert bvh.sah_cost(fast[0], fast[1]) == bvh.sah_cost(ref[0], ref[1])
    check_invariants(*fast, np.asarray(lo, np.float64), np.asarray(hi, np.float64))


def test_nodes_binned_in_chunks_give_the_same_tree(monkeypatch):
    lo, hi = tri_bounds(soup(800, 13))
    monkeypatch.setattr(bvh, "NODE_CHUNK", 7)  # every level of more than 7 nodes is binned in several passes
    fast, ref = bvh.build_bvh(lo, hi), bvh.build_bvh_reference(lo, hi)
    assert all(np.array_equal(a, b) for a, b in zip(fast, ref))


def test_empty_input_is_one_empty_leaf():
    f, i, o = bvh.build_bvh(np.zeros((0, 3)), np.zeros((0, 3)))
    assert f.shape == (1, 6) and i.tolist() == [[0, -1, 1]] and o.shape == (0,) and o.dtype == np.int32
    assert bvh.bvh_depth(i) == 1


def test_bad_bounds_are_refused_with_a_clear_error():
    lo, hi = boxes(10)
    lo[3, 1] = np.nan
    with pytest.raises(ValueError, match="NaN or infinite"):
        bvh.build_bvh(lo, hi)
    for bad_lo, bad_hi in ((np.zeros((4, 3)), np.zeros((5, 3))), (np.zeros(10), np.zeros(10))):
        with pytest.raises(ValueError, match=r"must both be \(N, 3\)"):
            bvh.build_bvh(bad_lo, bad_hi)


def test_structure_of_a_large_random_soup():
    lo, hi = tri_bounds(soup(20000, 8, size=0.2))
    nodes_f, nodes_i, order = bvh.build_bvh(lo, hi)
    depth = check_invariants(nodes_f, nodes_i, order, lo, hi)
    assert depth == bvh.bvh_depth(nodes_i) <= bvh.MAX_DEPTH


def test_coincident_centroids_still_give_small_leaves():
    lo, hi = np.zeros((5000, 3)), np.ones((5000, 3))
    nodes_f, nodes_i, order = bvh.build_bvh(lo, hi)
    assert check_invariants(nodes_f, nodes_i, order, lo, hi) <= 1 + int(np.ceil(np.log2(5000 / bvh.MAX_LEAF)))


@pytest.mark.slow
def test_a_million_thin_triangles_stay_within_the_kernels_stack():
    from benchbot_sim_taichi.render.kernels import STACK

    assert bvh.MAX_DEPTH < STACK
    rng = np.random.default_rng(9)
    c = rng.uniform([-10, -10, 0], [10, 10, 3], (1_000_000, 3)).astype(np.float32)
    long_axis = np.eye(3, dtype=np.float32)[rng.integers(0, 3, c.shape[0])]  # slivers 1 m long, 1 mm wide
    lo, hi = c - 0.5 * long_axis - 5e-4, c + 0.5 * long_axis + 5e-4
    nodes_f, nodes_i, order = bvh.build_bvh(lo, hi)
    assert check_invariants(nodes_f, nodes_i, order, lo.astype(np.float64), hi.astype(np.float64)) < STACK


def test_depth_limit_switches_to_median_splits(monkeypatch):
    lo, hi = tri_bounds(soup(3000, 10, size=0.3))
    free = bvh.bvh_depth(bvh.build_bvh(lo, hi)[1])
    monkeypatch.setattr(bvh, "MAX_DEPTH", 10)  # 1 + ceil(log2(3000 / 8)) = 10 levels are enough by halving
    assert free > 10
    nodes_f, nodes_i, order = bvh.build_bvh(lo, hi)
    assert check_invariants(nodes_f, nodes_i, order, lo, hi) == bvh.bvh_depth(nodes_i) <= 10


def test_sah_cost_of_a_hand_made_tree():
    # root [0,2]×[0,1]×[0,1] (half area 5) over two unit-cube leaves (half area 3) of 2 and 1 primitives
    f = np.array([[0, 0, 0, 2, 1, 1], [0, 0, 0, 1, 1, 1], [1, 0, 0, 2, 1, 1]], np.float32)
    i = np.array([[0, 2, 3], [2, 0, 2], [1, 2, 3]], np.int32)
    assert bvh.sah_cost(f, i) == pytest.approx(1.0 + (2 * 3 + 1 * 3) / 5)


def _ray_triangle(o, d, t):
    """Möller–Trumbore, broadcast: o, d (..., 3), t (..., 3, 3) → distance (...) (inf: miss)."""
    e1, e2 = t[..., 1, :] - t[..., 0, :], t[..., 2, :] - t[..., 0, :]
    p = np.cross(d, e2)
    det = np.einsum("...i,...i", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o - t[..., 0, :]
    u = np.einsum("...i,...i", s, p) * inv
    q = np.cross(s, e1)
    v = np.einsum("...i,...i", d, q) * inv
    dist = np.einsum("...i,...i", e2, q) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (dist > 0)
    return np.where(hit, dist, np.inf)


def traverse(nodes_f, nodes_i, order, tris, o, d):
    """Nearest hit of every ray by a stackless walk of the skip links (all rays in lockstep): (distance, triangle)."""
    m, r = nodes_f.shape[0], o.shape[0]
    lo, hi = nodes_f[:, :3].astype(np.float64), nodes_f[:, 3:].astype(np.float64)
    inv = 1.0 / np.where(d == 0, 1e-300, d)
    node = np.zeros(r, np.int64)
    best, best_id = np.full(r, np.inf), np.full(r, -1)
    while True:
        ray = np.flatnonzero(node < m)
        if ray.size == 0:
            return best, best_id
        k = node[ray]
        t1, t2 = (lo[k] - o[ray]) * inv[ray], (hi[k] - o[ray]) * inv[ray]
        near, far = np.minimum(t1, t2).max(axis=1), np.maximum(t1, t2).min(axis=1)
        hit = (near <= far) & (far >= 0) & (near <= best[ray])
        count, link, skip = nodes_i[k, 0], nodes_i[k, 1], nodes_i[k, 2]
        for j in range(bvh.MAX_LEAF):
            test = hit & (count > j)
            if not test.any():
                break
            rr = ray[test]
            prim = order[link[test] + j]
            dist = _ray_triangle(o[rr], d[rr], tris[prim])
            closer = dist < best[rr]
            best[rr[closer]], best_id[rr[closer]] = dist[closer], prim[closer]
        node[ray] = np.where(hit & (count == 0), k + 1, skip)


def test_nearest_hits_through_the_bvh_equal_brute_force():
    tris = soup(3000, 11, size=0.4)
    nodes_f, nodes_i, order = bvh.build_bvh(*tri_bounds(tris))
    rng = np.random.default_rng(12)
    o = rng.uniform([-12, -12, -1], [12, 12, 4], (400, 3))
    target = rng.uniform([-10, -10, 0], [10, 10, 3], (400, 3))
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:20] = [1.0, 0.0, 0.0]  # axis-aligned rays too
    dist, ids = traverse(nodes_f, nodes_i, order, tris, o, d)
    brute = _ray_triangle(o[:, None, :], d[:, None, :], tris[None])
    assert np.isfinite(dist).sum() > 100  # most rays hit something
    np.testing.assert_allclose(dist, brute.min(axis=1), rtol=1e-12)
    hit = np.isfinite(dist)
    np.testing.assert_array_equal(ids[hit], brute.argmin(axis=1)[hit])


def traverse_wide(records, order, tris, o, d):
    """Nearest hit of every ray through :func:`bvh.wide_nodes`'s records, one ray at a time with a stack as the
    kernels do (both children's boxes read from the parent's record; leaves decoded from their references)."""
    refs = records[:, 12:14].view(np.int32)
    best, best_id = np.full(o.shape[0], np.inf), np.full(o.shape[0], -1)
    for r in range(o.shape[0]):
        inv = 1.0 / np.where(d[r] == 0, 1e-300, d[r])
        stack = [0]
        while stack:
            ref = stack.pop()
            if ref < 0:
                code = ~int(ref)
                first, count = code >> bvh.LEAF_SHIFT, code & (bvh.TRI_ONLY - 1)
                prims = order[first:first + count]
                if prims.size:
                    dist = _ray_triangle(o[r], d[r], tris[prims])
                    j = int(np.argmin(dist))
                    if dist[j] < best[r]:
                        best[r], best_id[r] = dist[j], prims[j]
                continue
            for c in (0, 1):
                box = records[ref, 6 * c:6 * c + 6].astype(np.float64)
                t1, t2 = (box[:3] - o[r]) * inv, (box[3:] - o[r]) * inv
                near, far = np.minimum(t1, t2).max(), np.maximum(t1, t2).min()
                if near <= far and far >= 0 and near <= best[r]:
                    stack.append(int(refs[ref, c]))
    return best, best_id


def test_wide_records_hold_both_children_and_find_the_nearest_hits():
    """Each record holds its node's children's boxes and references (interior children by record, leaves by first
    primitive, count and the plain-triangles flag), and a walk of the records finds the brute-force nearest hits."""
    tris = soup(2000, 5, size=0.4)
    nodes_f, nodes_i, order = bvh.build_bvh(*tri_bounds(tris))
    leaf = nodes_i[:, 0] > 0
    records = bvh.wide_nodes(nodes_f, nodes_i, tri_only=leaf)
    interior = np.flatnonzero(~leaf)
    assert records.shape == (interior.size, 16) and records.dtype == np.float32
    refs = records[:, 12:14].view(np.int32)
    for i, n in enumerate(interior[:50]):
        for c, child in enumerate((n + 1, nodes_i[n, 1])):
            assert np.array_equal(records[i, 6 * c:6 * c + 6], nodes_f[child])
            if leaf[child]:
                code = ~int(refs[i, c])
                assert (code >> bvh.LEAF_SHIFT, code & (bvh.TRI_ONLY - 1)) == tuple(nodes_i[child, 1::-1])
                assert code & bvh.TRI_ONLY
            else:
                assert refs[i, c] == np.searchsorted(interior, child)
    rng = np.random.default_rng(3)
    o = rng.uniform([-12, -12, -1], [12, 12, 4], (150, 3))
    d = rng.uniform([-10, -10, 0], [10, 10, 3], (150, 3)) - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    dist, ids = traverse_wide(records, order, tris, o, d)
    brute = _ray_triangle(o[:, None, :], d[:, None, :], tris[None])
    assert np.isfinite(dist).sum() > 40
    np.testing.assert_allclose(dist, brute.min(axis=1), rtol=1e-12)
    hit = np.isfinite(dist)
    np.testing.assert_array_equal(ids[hit], brute.argmin(axis=1)[hit])


def test_a_tree_without_interior_nodes_is_one_record_of_its_leaf_and_an_empty_one():
    tris = soup(3, 1, size=0.4)
    nodes_f, nodes_i, order = bvh.build_bvh(*tri_bounds(tris))
    records = bvh.wide_nodes(nodes_f, nodes_i)
    refs = records[0, 12:14].view(np.int32)
    assert records.shape == (1, 16) and np.array_equal(records[0, :6], nodes_f[0])
    assert [~int(x) for x in refs] == [3, 0]  # first 0, count 3, not flagged; then first 0, count 0
    empty = bvh.wide_nodes(*bvh.build_bvh(np.zeros((0, 3)), np.zeros((0, 3)))[:2])
    assert [~int(x) for x in empty[0, 12:14].view(np.int32)] == [0, 0]
