"""The scene's arrays packed for the all-sensors kernels (``packed_scene``): the packs hold every array with its
shape in the header, bad input is refused with a message naming the array, and a Taichi kernel reading the views
reads what NumPy indexing of the arrays gives."""

import numpy as np
import pytest

from benchbot_sim_taichi.render import packed_scene
from benchbot_sim_taichi.render.scene_arrays import SceneArrays

PACKED = SceneArrays.arrays(packed=True)


def _arrays(rng, rows: int = 5) -> dict:
    """Random arrays of every packed name, of the shapes the kernels read (R = 3 for the maps, a 2×3×2 grid)."""
    out = {}
    for name in PACKED:
        n = rows + len(out)  # every array a different number of rows
        shape = (n,) + tuple(d if d is not None else 3 - k for k, d in enumerate(SceneArrays.spec(name).trailing))
        if SceneArrays.spec(name).dtype == "f32":
            out[name] = rng.standard_normal(shape).astype(np.float32)
        else:
            out[name] = rng.integers(-1000, 1000, shape).astype(np.int32)
    return out


def test_pack_holds_every_array_at_the_offset_and_with_the_shape_of_its_header():
    arrays = _arrays(np.random.default_rng(0))
    f32, i32 = packed_scene.pack(arrays)
    assert f32.dtype == np.float32 and i32.dtype == np.int32
    packs = {"f32": f32, "i32": i32}
    for slot, name in enumerate(PACKED):
        a = arrays[name]
        offset, *dims = i32[4 * slot:4 * slot + 4]
        assert tuple(dims[:a.ndim]) == a.shape and all(d == 1 for d in dims[a.ndim:]), name
        np.testing.assert_array_equal(packs[SceneArrays.spec(name).dtype][offset:offset + a.size].reshape(a.shape), a,
                                      err_msg=name)
    # the first array of each pack lies where the views expect it without reading the header
    first_f32, first_i32 = (next(n for n in PACKED if SceneArrays.spec(n).dtype == k) for k in ("f32", "i32"))
    assert (first_f32, first_i32) == ("nodes", "pi")  # the arrays read most
    assert i32[4 * PACKED.index("nodes")] == 0 and i32[4 * PACKED.index("pi")] == packed_scene.HEADER_LEN
    assert f32.size == sum(arrays[n].size for n in PACKED if SceneArrays.spec(n).dtype == "f32")


@pytest.mark.parametrize("change, message", [
    (lambda a: a.pop("tris"), "array 'tris' is missing"),
    (lambda a: a.update(pi=a["pi"].astype(np.int64)), "pi is int64, the kernels read it as int32"),
    (lambda a: a.update(nodes=np.zeros((3, 15), np.float32)), "nodes has shape (3, 15), the kernels read (rows, 16)"),
    (lambda a: a.update(texels=np.zeros((3, 2), np.int32)), "texels has shape (3, 2)"),
])
def test_pack_refuses_arrays_the_kernels_cannot_read(change, message):
    arrays = _arrays(np.random.default_rng(1))
    change(arrays)
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        packed_scene.pack(arrays)


def test_a_kernel_reads_through_the_views_what_numpy_indexing_gives():
    """Every view's shape and a sample of its entries (fixed and header-read trailing dims, first and later arrays
    of each pack) read inside a Taichi kernel on the CPU."""
    import taichi as ti

    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")
    rng = np.random.default_rng(2)
    arrays = _arrays(rng)
    f32, i32 = packed_scene.pack(arrays)
    probes = []  # (slot, index tuple): 4 random entries of each array
    for slot, name in enumerate(PACKED):
        a = arrays[name]
        for _ in range(4):
            probes.append((slot, tuple(int(rng.integers(0, n)) for n in a.shape) + (0,) * (3 - a.ndim)))
    where = np.array([[s, *idx] for s, idx in probes], np.int32)

    @ti.kernel
    def read(scene_f32: ti.types.ndarray(dtype=ti.f32, ndim=1), scene_i32: ti.types.ndarray(dtype=ti.i32, ndim=1),
             where: ti.types.ndarray(dtype=ti.i32, ndim=2), values: ti.types.ndarray(dtype=ti.f32, ndim=1),
             shapes: ti.types.ndarray(dtype=ti.i32, ndim=2)):
        v = ti.static(packed_scene.scene_views(scene_f32, scene_i32))
        for p in range(where.shape[0]):
            for slot in ti.static(range(len(PACKED))):
                if where[p, 0] == slot:
                    nd = ti.static(len(SceneArrays.spec(PACKED[slot]).dims))
                    if ti.static(nd == 1):
                        values[p] = ti.cast(v[slot][where[p, 1]], ti.f32)
                    elif ti.static(nd == 2):
                        values[p] = ti.cast(v[slot][where[p, 1], where[p, 2]], ti.f32)
                    else:
                        values[p] = ti.cast(v[slot][where[p, 1], where[p, 2], where[p, 3]], ti.f32)
                    for k in ti.static(range(nd)):
                        shapes[p, k] = v[slot].shape[k]

    values = np.zeros(len(probes), np.float32)
    shapes = np.zeros((len(probes), 3), np.int32)
    read(f32, i32, where, values, shapes)
    for p, (slot, idx) in enumerate(probes):
        a = arrays[PACKED[slot]]
        assert values[p] == np.float32(a[idx[:a.ndim]]), (PACKED[slot], idx)
        assert tuple(shapes[p, :a.ndim]) == a.shape, PACKED[slot]


@pytest.mark.slow  # builds a furnished room's scene, its BVH, shadow maps and baked light
def test_the_renderers_packs_hold_the_scene_and_the_maps_and_light_its_kernels_computed(bear_envs):
    """After ``set_scene`` of a furnished room (lamps with shadow maps, the sun's map, baked light), the packs that
    CUDA's all-sensors kernels read hold the arrays that the renderer's other kernels read: the packed scene, the
    maps and the baked light computed on the device, the light lists."""
    from benchbot_sim_taichi.render.renderer import Renderer
    from benchbot_worlds.scene.build import build_scene

    r = Renderer("cpu")
    r.set_scene(build_scene({**bear_envs["miniroom:1"], "style": "furnished"}))
    assert r._scene.scene_f32 is None  # the CPU's kernels take the arrays one by one: no packs unless asked for
    f32, i32 = r._fetch(dict(zip(("f32", "i32"), r._pack_for_sensors()))).values()
    expected = r._fetch({name: getattr(r._scene, name) for name in PACKED})  # where the other kernels read them
    assert r.baked_points > 0 and r.lamps_with_maps > 0 and r.sun_map
    for computed in ("lamp_maps", "sun_map", "baked"):  # not the zeros they start as
        assert expected[computed].any(), computed
    packs = {"f32": f32, "i32": i32}
    for slot, name in enumerate(PACKED):
        a = expected[name]
        offset = i32[4 * slot]
        np.testing.assert_array_equal(packs[SceneArrays.spec(name).dtype][offset:offset + a.size].reshape(a.shape), a,
                                      err_msg=name)
