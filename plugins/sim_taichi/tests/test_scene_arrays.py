"""The scene's arrays in one bundle (``scene_arrays.SceneArrays``) and kernels launched by name: every kernel that
takes a scene array declares it as its field says, the arrays a renderer makes have the fields' shapes and dtypes,
:func:`~benchbot_sim_taichi.render.scene_arrays.launch` takes each parameter by name, and every ndarray parameter of
a kernel carries its shape in a comment."""

import inspect
import re

import numpy as np
import pytest
import taichi as ti

from benchbot_sim_taichi.render import kernels, lightmap, pathtrace, sensors
from benchbot_sim_taichi.render.scene_arrays import SceneArrays, annotations, arguments, launch, parameters

#: The modules that define the renderer's kernels.
MODULES = (kernels, lightmap, pathtrace, sensors)


def _kernels() -> list:
    """Every Taichi kernel defined in :data:`MODULES`."""
    return [obj for module in MODULES for obj in vars(module).values()
            if isinstance(getattr(obj, "_primal", None), ti.lang.kernel_impl.Kernel)]


def test_the_kernels_are_found():
    names = {k.__name__ for k in _kernels()}
    assert {"occluders_packed_kernel", "shade_kernel", "shade_maps_packed_kernel", "occluders_kernel", "quality_kernel",
            "bake_kernel", "lamp_map_kernel", "sun_map_kernel", "light_grid_kernel"} <= names


def test_every_kernel_parameter_named_as_a_scene_field_is_declared_as_the_field_says():
    """A kernel's parameter of a scene array's name is that array (launch passes the field): same dtype, same
    number of dims; a count's is an i32."""
    checked = 0
    for kernel in _kernels():
        for name, annotation in annotations(kernel).items():
            if name in SceneArrays.counts():
                assert annotation == ti.i32, (kernel.__name__, name)
            elif name in SceneArrays.arrays() or name in ("scene_f32", "scene_i32"):
                spec = SceneArrays.spec(name)
                assert isinstance(annotation, ti.types.ndarray_type.NdarrayType), (kernel.__name__, name)
                assert str(annotation.dtype) == spec.dtype and annotation.ndim == len(spec.dims), \
                    (kernel.__name__, name, annotation, spec.text)
            else:
                continue
            checked += 1
    assert checked > 100


def test_every_ndarray_parameter_of_a_kernel_has_its_shape_in_a_comment():
    """``name: ti.types.ndarray(...),  # (B, H, W) f32 …`` in every kernel's signature."""
    bare = []
    for kernel in _kernels():
        source = inspect.getsource(kernel._primal.func)
        signature = source[:source.index("):")]
        for line in signature.splitlines():
            if "ti.types.ndarray(" in line and not re.search(r"#.*\(.*\)", line):
                bare.append(f"{kernel.__name__}: {line.strip()}")
    assert bare == []


@pytest.mark.slow  # builds a furnished room's scene, its BVH, shadow maps and baked light
@pytest.mark.parametrize("device_buffers", [True, False])
def test_a_renderers_scene_arrays_have_their_fields_shapes_and_dtypes(bear_envs, device_buffers):
    from benchbot_sim_taichi.render.renderer import Renderer
    from benchbot_worlds.scene.build import build_scene

    r = Renderer("cpu", device_buffers=device_buffers)
    r.set_scene(build_scene({**bear_envs["miniroom:1"], "style": "furnished"}))
    assert r.lamps_with_maps > 0 and r.sun_map and r.baked_points > 0  # every kind of array is made
    scene = r._scene
    for name in SceneArrays.arrays():
        a = getattr(scene, name)
        spec = SceneArrays.spec(name)
        assert np.dtype(a.dtype if isinstance(a, np.ndarray) else ti.lang.util.to_numpy_type(a.dtype)) \
            == spec.numpy_dtype, name
        assert len(a.shape) == len(spec.dims) and all(d is None or d == n for d, n in zip(spec.dims, a.shape)), \
            (name, a.shape, spec.text)
    for name in SceneArrays.counts():
        assert type(getattr(scene, name)) is int, name
    assert scene.n_lights == r._packed["n_lights"] and scene.n_always <= scene.always.shape[0]


def test_launch_takes_each_parameter_by_name_given_or_from_the_scene():
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")

    @ti.kernel
    def add(
        b: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (N,) f32
        k: ti.i32,
        a: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (N,) f32
        out: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (N,) f32
    ):
        for i in range(out.shape[0]):
            out[i] = a[i] * k + b[i]

    a, b, out = np.arange(4, dtype=np.float32), np.full(4, 10, np.float32), np.zeros(4, np.float32)
    assert parameters(add) == ("b", "k", "a", "out")
    launch(add, {"a": a, "b": b, "k": 7}, out=out)  # the scene is any mapping of names
    np.testing.assert_array_equal(out, a * 7 + b)
    launch(add, {"a": a, "b": b, "k": 7}, k=2, out=out)  # a given value wins over the scene's
    np.testing.assert_array_equal(out, a * 2 + b)
    with pytest.raises(TypeError, match="no value for the kernel parameter 'b'"):
        launch(add, {"a": a}, k=1, out=out)
    with pytest.raises(TypeError, match="add takes no parameter c"):
        launch(add, {"a": a, "b": b}, k=1, out=out, c=1)
    assert list(arguments(("k", "a"), {"a": a}, {"k": 3}).items()) == [("k", 3), ("a", a)]


def test_the_sensors_launch_takes_every_kernels_parameters_once():
    for arch in ("cpu", "cuda"):
        for rays in (True, False):
            names = sensors.launch_parameters(arch, rays)
            assert len(set(names)) == len(names)
            assert set(names) == {n for k in sensors.sensors_kernels(arch, rays) for n in parameters(k)}
            assert ("scene_f32" in names) == (arch == "cuda") and ("nodes" in names) == (arch == "cpu")
