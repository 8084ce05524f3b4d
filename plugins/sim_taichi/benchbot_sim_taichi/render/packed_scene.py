"""The scene's arrays for the all-sensors kernels (:mod:`benchbot_sim_taichi.render.sensors`) packed into two 1-D arrays,
one float32 and one int32, and the views through which the kernels read them as the arrays they were.

Why: Taichi 1.7 spends host time on every ndarray argument of every launch (hash-map work for each argument in its
C++ launcher; 1.7–4.9 µs each on the H200's hosts, ``benchmarks/one_camera.py``), and a one-camera frame on a GPU
is limited by the host's launch work. The scene's 21 arrays, which do not change while a scene is loaded, were 35
of the all-sensors graph's 41 ndarray arguments on CUDA; packed, they are 4 (two in each kernel). The CPU's
kernels take the arrays one by one (:func:`~benchbot_sim_taichi.render.sensors.sensors_kernels`).

Layout: the packed arrays are the fields of :class:`~benchbot_sim_taichi.render.scene_arrays.SceneArrays` marked
packed (``SceneArrays.arrays(packed=True)``), each in the pack of its dtype, in the order of the fields. The int32 pack
starts with a header of :data:`HEADER_LEN` int32 entries, four for each packed array in order: its offset in its pack
(elements), then its shape's first three entries (1 where it has fewer). The first array of each pack lies at a fixed
offset (0 in the float32 pack, :data:`HEADER_LEN` in the int32 pack), so reading it costs no header read; the others'
offsets are read from the header where they are used. A trailing dim that the field's shape fixes (``"(P, 11) f32"``)
is a constant of the kernels' index arithmetic; the others are read from the header. Entries are indexed with int32,
so a pack holds fewer than 2³¹ entries (:func:`pack` checks).

The views emit their reads with ``taichi.lang.impl.subscript``, the call Taichi 1.7 itself makes for ``a[i]`` in a
kernel; it is not public API, so a Taichi upgrade must keep ``test_packed_scene.py`` passing (a kernel there reads
every view).
"""

import collections

import numpy as np
from taichi.lang import impl

from benchbot_sim_taichi.render.scene_arrays import SceneArrays

#: int32 entries of the header at the start of the int32 pack.
HEADER_LEN = 4 * len(SceneArrays.arrays(packed=True))
_LIMIT = 2**31 - 1


def pack(arrays: dict) -> tuple[np.ndarray, np.ndarray]:
    """The packed arrays (``SceneArrays.arrays(packed=True)``) in their two packs.

    Args:
        arrays: every packed array's name → a NumPy array of its dtype (float32 or int32, as its pack), with the
            trailing dims that its field's shape fixes and at most 3 dims.

    Returns:
        ``(scene_f32, scene_i32)``: (F,) float32 and (I,) int32, the int32 one starting with the header.

    Raises:
        ValueError: an array is missing, has another dtype, other fixed dims or more than 3 dims, or a pack would
            hold 2³¹ entries or more (int32 indexing).
    """
    parts = {"f32": [], "i32": [np.zeros(HEADER_LEN, np.int32)]}
    sizes = {"f32": 0, "i32": HEADER_LEN}
    header = parts["i32"][0]
    for k, name in enumerate(SceneArrays.arrays(packed=True)):
        if name not in arrays:
            raise ValueError(f"packed_scene.pack: array {name!r} is missing")
        a = np.asarray(arrays[name])
        spec = SceneArrays.spec(name)
        kind, trailing = spec.dtype, spec.trailing
        if a.dtype != spec.numpy_dtype:
            raise ValueError(f"packed_scene.pack: {name} is {a.dtype}, the kernels read it as "
                             f"{spec.numpy_dtype.__name__}")
        if a.ndim != 1 + len(trailing) or any(d is not None and d != n for d, n in zip(trailing, a.shape[1:])):
            raise ValueError(f"packed_scene.pack: {name} has shape {a.shape}, the kernels read (rows, "
                             f"{', '.join('any' if d is None else str(d) for d in trailing)})")
        header[4 * k] = sizes[kind]
        header[4 * k + 1:4 * k + 1 + a.ndim] = a.shape
        header[4 * k + 1 + a.ndim:4 * k + 4] = 1
        parts[kind].append(np.ascontiguousarray(a).reshape(-1))
        sizes[kind] += a.size
        if sizes[kind] > _LIMIT:
            raise ValueError(f"packed_scene.pack: the {kind} pack would hold {sizes[kind]} entries, more than "
                             f"int32 indexing reaches ({_LIMIT}); render a smaller scene")
    return np.concatenate(parts["f32"]), np.concatenate(parts["i32"])


class PackedView:
    """One packed array, read from its pack inside a Taichi kernel as the array itself: ``view[i, j]`` and
    ``view.shape`` (made at compile time by :func:`scene_views`; read-only use).

    Args:
        data: the pack (a Taichi kernel's 1-D ndarray argument). header: the int32 pack (holds the header).
        name: the array's name. slot: its index among the packed arrays (its header row). trailing: its trailing
            dims (``SceneArrays.spec(name).trailing``: a number fixed at compile time, or None: read from the header).
        offset: its offset when fixed at compile time, else ``None`` (read from the header).
    """

    def __init__(self, data, header, name: str, slot: int, trailing: tuple, offset: int | None):
        self._data, self._header, self._name, self._slot = data, header, name, slot
        self._trailing, self._offset = trailing, offset

    def _entry(self, k: int):
        """Entry k of the array's header row: 0 its offset, 1 + d its shape's dim d."""
        return impl.subscript(None, self._header, 4 * self._slot + k)

    def _dim(self, d: int):
        """The array's dim d ≥ 1: fixed, or read from the header."""
        fixed = self._trailing[d - 1]
        return self._entry(1 + d) if fixed is None else fixed

    def __getitem__(self, index):
        index = index if isinstance(index, tuple) else (index,)
        if len(index) != 1 + len(self._trailing):
            raise IndexError(f"{self._name} has {1 + len(self._trailing)} dims, indexed with "
                             f"{len(index)}")
        flat = index[0]
        for k, i in enumerate(index[1:], start=1):
            flat = flat * self._dim(k) + i
        start = self._entry(0) if self._offset is None else self._offset
        return impl.subscript(None, self._data, start + flat)

    @property
    def shape(self) -> tuple:
        """The array's shape: its rows (read from the header) and its trailing dims."""
        return (self._entry(1),) + tuple(self._dim(k) for k in range(1, 1 + len(self._trailing)))


#: Every packed array as a :class:`PackedView`, by name (``views.nodes``...): a named tuple, which ``ti.static``
#: accepts.
SceneViews = collections.namedtuple("SceneViews", SceneArrays.arrays(packed=True))


def scene_views(scene_f32, scene_i32) -> SceneViews:
    """The views of the packs ``scene_f32`` (F,) float32 and ``scene_i32`` (I,) int32 (a kernel's ndarray
    arguments, as :func:`pack` made them); call it in a kernel inside ``ti.static(...)``."""
    views, first = [], set()
    for slot, name in enumerate(SceneArrays.arrays(packed=True)):
        kind, trailing = SceneArrays.spec(name).dtype, SceneArrays.spec(name).trailing
        offset = None if kind in first else (0 if kind == "f32" else HEADER_LEN)
        first.add(kind)
        views.append(PackedView(scene_f32 if kind == "f32" else scene_i32, scene_i32, name, slot, trailing, offset))
    return SceneViews(*views)
