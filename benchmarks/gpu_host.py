"""GPU-side helpers of the render benchmarks (``render.py``, ``render_meshes.py``) on CUDA, through the CUDA driver
library (``libcuda``, via ctypes) that Taichi has already loaded and whose context Taichi made current on its thread.

* :func:`device_info`: the GPU's name and the device memory in use (``cuMemGetInfo``: the whole device, i.e. this
  process's Taichi context, memory pool and arrays when nothing else runs on the GPU).
* :class:`HostCopier`: copies a renderer's output ndarrays (Taichi ndarrays in GPU memory) into NumPy arrays that it
  allocates once and reuses — ``pinned=True``: page-locked (``cuMemHostAlloc``), else ordinary NumPy memory — after
  ``ti.sync()``, with one ``cuMemcpyDtoHAsync`` per array on the default stream and one stream synchronisation. A
  benchmark-only path, to measure what the copy itself costs; the renderer's own ``to_host=True`` path is Taichi's
  ``Ndarray.to_numpy`` (a new NumPy array per output and call).

Use from the thread that initialised Taichi (``Renderer``), after ``ti.init(arch=cuda)``. Every driver call's result
is checked; a failure raises ``RuntimeError`` naming the call and the CUDA error.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np

_LIB = None


def _cuda():
    global _LIB
    if _LIB is None:
        _LIB = ctypes.CDLL(ctypes.util.find_library("cuda") or "libcuda.so.1")
    return _LIB


def _check(name: str, code: int) -> None:
    if code != 0:
        msg = ctypes.c_char_p()
        _cuda().cuGetErrorString(code, ctypes.byref(msg))
        raise RuntimeError(f"{name} failed: CUDA error {code} ({(msg.value or b'?').decode()})")


def device_info() -> dict:
    """``{'gpu': name, 'gpu_mem_used_mb': device memory in use, 'gpu_mem_total_mb': …}`` of the current context's
    device (MiB)."""
    lib = _cuda()
    dev = ctypes.c_int()
    _check("cuCtxGetDevice", lib.cuCtxGetDevice(ctypes.byref(dev)))
    name = ctypes.create_string_buffer(256)
    _check("cuDeviceGetName", lib.cuDeviceGetName(name, 256, dev))
    free, total = ctypes.c_size_t(), ctypes.c_size_t()
    _check("cuMemGetInfo_v2", lib.cuMemGetInfo_v2(ctypes.byref(free), ctypes.byref(total)))
    return {"gpu": name.value.decode(), "gpu_mem_used_mb": round((total.value - free.value) / 2**20, 1),
            "gpu_mem_total_mb": round(total.value / 2**20, 1)}


def device_pointer(nd) -> int:
    """The device address of a Taichi ndarray's data (Taichi's ``get_ndarray_data_ptr_as_int``)."""
    import taichi as ti

    return int(ti.lang.impl.get_runtime().prog.get_ndarray_data_ptr_as_int(nd.arr))


class HostCopier:
    """Copies dicts of Taichi ndarrays (same keys, shapes and dtypes each call) into reused host NumPy arrays."""

    def __init__(self, pinned: bool) -> None:
        self.pinned = bool(pinned)
        self._host: dict = {}
        self._pinned_ptrs: list[int] = []

    def _array(self, key, shape: tuple, dtype) -> np.ndarray:
        k = (key, shape, np.dtype(dtype).str)
        if k not in self._host:
            n = int(np.prod(shape)) * np.dtype(dtype).itemsize
            if self.pinned:
                p = ctypes.c_void_p()
                _check("cuMemHostAlloc", _cuda().cuMemHostAlloc(ctypes.byref(p), ctypes.c_size_t(max(n, 1)), 0))
                self._pinned_ptrs.append(p.value)
                buf = (ctypes.c_uint8 * max(n, 1)).from_address(p.value)
                self._host[k] = np.frombuffer(buf, np.uint8, n).view(dtype).reshape(shape)
            else:
                self._host[k] = np.zeros(shape, dtype)  # touched once here, then reused
        return self._host[k]

    def copy(self, arrays: dict) -> dict:
        """NumPy copies of ``arrays`` (Taichi ndarrays on the GPU; NumPy arrays pass through), valid until the next
        call; waits for the copies (and so for the kernels before them)."""
        import taichi as ti

        lib = _cuda()
        ti.sync()  # the render's kernels first, whichever stream Taichi launched them on
        out = {}
        for key, nd in arrays.items():
            if isinstance(nd, np.ndarray):
                out[key] = nd
                continue
            host = self._array(key, tuple(nd.arr.total_shape()), _np_dtype(nd))
            _check("cuMemcpyDtoHAsync_v2", lib.cuMemcpyDtoHAsync_v2(
                ctypes.c_void_p(host.ctypes.data), ctypes.c_uint64(device_pointer(nd)), ctypes.c_size_t(host.nbytes),
                ctypes.c_void_p(0)))
            out[key] = host
        _check("cuStreamSynchronize", lib.cuStreamSynchronize(ctypes.c_void_p(0)))
        return out

    def close(self) -> None:
        for p in self._pinned_ptrs:
            _check("cuMemFreeHost", _cuda().cuMemFreeHost(ctypes.c_void_p(p)))
        self._pinned_ptrs, self._host = [], {}


def _np_dtype(nd) -> np.dtype:
    from taichi.lang.util import to_numpy_type

    return np.dtype(to_numpy_type(nd.dtype))
