"""The scene where the kernels read it, and the launching of kernels by name.

:class:`SceneArrays` is the one home of the scene's arrays: every array (and count) that ``Renderer.set_scene``
leaves for the kernels, each field with its shape and dtype (``"(P, 11) f32"``: a number for a dimension fixed at
compile time, a letter for one that varies with the scene) and its meaning. The kernels' parameters are named as its
fields; :func:`launch` calls a Taichi kernel with each parameter taken BY NAME — the value given under that name,
else the scene's field of that name — from the kernel's own signature (read once per kernel), so no caller lists
the scene in a kernel's order, and a kernel may take the scene's arrays in any order it likes. What CUDA's sensors
kernels read packed (:mod:`~benchbot_sim_taichi.render.packed_scene`) and what ``Renderer.prepared_scene`` copies
back from the device are marked on the fields too.

Why one parameter per array and not a Taichi argument pack: Taichi 1.7 passes a ``ti.types.argpack`` holding
ndarrays to a kernel called from Python, but a compiled graph (``ti.graph``, through which the renderer launches
every frame) has no argument pack among its argument kinds (``ti.graph.ArgKind``: scalar, ndarray, matrix,
texture); so the kernels keep one parameter per array, launched by name.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import inspect
import re
import sys
from collections.abc import Mapping
from typing import NamedTuple, Union

import numpy as np

with contextlib.redirect_stdout(sys.stderr):
    import taichi as ti

from benchbot_sim_taichi.render.kernels import LIGHT_COLS, SHADE_COLS  # noqa: E402 - after Taichi's banner
from benchbot_sim_taichi.render.layouts import WORLD_LEN  # noqa: E402

#: Where a scene array lies: a Taichi ndarray (``device_buffers``: GPU memory on CUDA) or a NumPy array.
Array = Union[np.ndarray, ti.Ndarray]

_DTYPES = {"f32": np.float32, "i32": np.int32}


class Spec(NamedTuple):
    """A field's shape and dtype, parsed from its text (``"(6·S, R, R) f32"``)."""

    text: str
    dims: tuple  # each dim: an int when fixed at compile time, else None (it varies with the scene)
    dtype: str  # "f32" or "i32"

    @property
    def trailing(self) -> tuple:
        """The dims after the first (what a kernel's index arithmetic may take as constants)."""
        return self.dims[1:]

    @property
    def numpy_dtype(self) -> type:
        return _DTYPES[self.dtype]


def _parse(text: str) -> Spec:
    m = re.fullmatch(r"\(([^)]*)\) (f32|i32)", text)
    if m is None:
        raise ValueError(f"scene array spec {text!r}: write it as '(P, 11) f32'")
    dims = tuple(int(d) if d.isdigit() else None for d in (d.strip() for d in m.group(1).split(",")) if d)
    return Spec(text, dims, m.group(2))


def _array(text: str, *, packed: bool = True, computed: bool = False):
    """A field holding an array of shape and dtype ``text``. ``packed``: CUDA's sensors kernels read it from the
    packs. ``computed``: ``set_scene`` computes it (kernels, light lists), so where the kernels read it holds it,
    not the host's packed scene."""
    return dataclasses.field(metadata={"kind": "array", "spec": _parse(text), "packed": packed,
                                       "computed": computed})


def _count():
    """A field holding a count (a Python int, a kernel's ``ti.i32`` parameter)."""
    return dataclasses.field(metadata={"kind": "count"})


def _pack(text: str):
    """A field holding one of the packs of :mod:`~benchbot_sim_taichi.render.packed_scene` (None until made)."""
    return dataclasses.field(default=None, metadata={"kind": "pack", "spec": _parse(text)})


@dataclasses.dataclass(eq=False)
class SceneArrays:
    """The current scene as the kernels read it (``Renderer.set_scene`` makes it). Dims: P primitives, in BVH order
    (every per-primitive array has a row at least: a scene without primitives has one of zeros), I the BVH's
    interior nodes, C its clusters, L lights, S lamp-map slots and R a map's side (1 where there is no map), N texels,
    X textures, O occluders, A always-summed lights, NY × NX × W the light grid, Q baked lattice points. Counts are
    how many rows of the array beside them are in use (an array keeps one row when there is none)."""

    # The packed scene (renderer.pack_scene).
    nodes: Array = _array("(I, 16) f32")  # the BVH: each interior node with both children's boxes (bvh.wide_nodes)
    pf: Array = _array("(P, 11) f32")  # per primitive: box min xyz, max xyz, linear albedo rgb, roughness, metallic
    pi: Array = _array("(P, 4) i32")  # per primitive: kind (kernels.GLASS: a pane), axis or tris row, class, instance
    tris: Array = _array("(P, 9) f32")  # row k: triangle k's vertices (zeros where primitive k is no triangle)
    shade: Array = _array(f"(P, {SHADE_COLS}) f32")  # row k: vertex normals, UVs, texture, LOD offset (SHADE_COLS)
    texels: Array = _array("(N,) i32")  # every texture's texels and mip levels, sRGB r | g << 8 | b << 16
    tex_info: Array = _array("(X, 4) i32")  # per texture: first texel, width, height, levels
    tex_lut: Array = _array("(256,) f32")  # sRGB byte → linear value
    lights: Array = _array(f"(L, {LIGHT_COLS}) f32")  # kind, vector, colour, range, map slot, sun-map projection
    n_lights: int = _count()  # rows of lights in use
    world: Array = _array(f"({WORLD_LEN},) f32", packed=False)  # room box, shell albedos, ambient, background class
    # (layouts.WORLD_*; the sensors kernels read it from their frame constants)
    cluster_box: Array = _array("(C, 6) f32")  # per cluster of at most raster.CLUSTER_PRIMS primitives: its box
    cluster_prims: Array = _array("(C, 2) i32")  # per cluster: first primitive, count
    n_occluders: int = _count()  # entries of occluders in use
    occluders: Array = _array("(O,) i32")  # the triangles of raster.OCCLUDER_AREA_M2 or more, rasterised first
    is_occluder: Array = _array("(P,) i32")  # per primitive: 1 if an occluder
    # The lights' shadow maps and lists (set_scene).
    light_of_slot: Array = _array("(S,) i32")  # the light row of each lamp-map slot (one −1: no slot)
    lamp_maps: Array = _array("(6·S, R, R) f32", computed=True)  # the lamps' cube shadow maps: per texel, the
    # distance to the first primitive (kernels.lamp_map_kernel)
    sun_map: Array = _array("(R, R) f32", computed=True)  # the sun's map: per texel, the first primitive's height
    # along the light (kernels.sun_map_kernel)
    n_always: int = _count()  # entries of always in use
    always: Array = _array("(A,) i32", computed=True)  # the lights summed at every point (the others: light_grid's)
    light_grid: Array = _array("(NY, NX, W) i32", computed=True)  # per xy cell: a bit per lamp-map slot whose lamp
    # may light a point there (renderer._light_grid)
    grid_xform: Array = _array("(4,) f32", computed=True)  # light_grid's origin x, y (m), cells a metre, words W
    # The triangles' baked direct light (lightmap).
    baked: Array = _array("(Q,) i32", computed=True)  # per lattice point of each side of a triangle: RGB9E5 light
    baked_info: Array = _array("(P, 2) i32", computed=True)  # per primitive: first word in baked, divisions (0: none)
    # The arrays above but world in two packs, which CUDA's sensors kernels read (packed_scene; None until the first
    # launch that reads them makes them).
    scene_f32: Array | None = _pack("(F,) f32")  # the f32 arrays, one after the other
    scene_i32: Array | None = _pack("(J,) i32")  # a header (each array's offset and shape), then the i32 arrays

    @staticmethod
    def arrays(*, packed: bool | None = None, computed: bool | None = None) -> tuple[str, ...]:
        """Names of the array fields (not the packs), in order; ``packed``/``computed`` keep those so marked (or
        not)."""
        return _arrays(packed, computed)

    @staticmethod
    def counts() -> tuple[str, ...]:
        """Names of the count fields, in order."""
        return tuple(f.name for f in dataclasses.fields(SceneArrays) if f.metadata["kind"] == "count")

    @staticmethod
    def spec(name: str) -> Spec:
        """The shape and dtype of array (or pack) ``name``."""
        return _FIELDS[name].metadata["spec"]


@functools.cache
def _arrays(packed: bool | None, computed: bool | None) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(SceneArrays) if f.metadata["kind"] == "array"
                 and packed in (None, f.metadata["packed"]) and computed in (None, f.metadata["computed"]))


_FIELDS = {f.name: f for f in dataclasses.fields(SceneArrays)}


# ------------------------------------------------------------------------------------------------ launching by name
@functools.cache
def parameters(kernel) -> tuple[str, ...]:
    """The names of a Taichi kernel's parameters, in order (read from its signature once per kernel)."""
    return tuple(inspect.signature(kernel).parameters)


@functools.cache
def annotations(kernel) -> dict:
    """A Taichi kernel's parameters: name → annotation (``ti.types.ndarray(...)``, ``ti.i32``, a vector type)."""
    return {name: p.annotation for name, p in inspect.signature(kernel).parameters.items()}


_MISSING = object()


def arguments(names: tuple[str, ...], scene, named: dict) -> dict:
    """``{name: value}`` for each of ``names``: ``named[name]`` if given, else the field of that name of ``scene``
    (a :class:`SceneArrays`, a mapping of names to arrays, or None).

    Raises:
        TypeError: a name is neither given nor in ``scene``.
    """
    look = scene.get if isinstance(scene, Mapping) else (lambda name, default: getattr(scene, name, default))
    out = {}
    for name in names:
        value = named.get(name, _MISSING)
        if value is _MISSING:
            value = look(name, _MISSING)
            if value is _MISSING:
                raise TypeError(f"no value for the kernel parameter {name!r}: not given, and no scene array of "
                                f"that name")
        out[name] = value
    return out


def launch(kernel, scene=None, /, **named) -> None:
    """Call Taichi kernel ``kernel`` with each parameter by name: from ``named``, else from ``scene`` (see
    :func:`arguments`).

    Raises:
        TypeError: a parameter has no value, or ``named`` holds a name the kernel does not take.
    """
    names = parameters(kernel)
    unknown = set(named).difference(names)
    if unknown:
        raise TypeError(f"{kernel.__name__} takes no parameter {', '.join(sorted(unknown))}")
    kernel(*arguments(names, scene, named).values())
