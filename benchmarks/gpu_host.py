"""GPU-side helpers of the render benchmarks (``render.py``, ``render_meshes.py``) on CUDA, through the CUDA driver
library that Taichi has already loaded (``benchbot_sim_taichi.render.host_copy``: the driver calls' one home).

* :func:`device_info`: the GPU's name and the device memory in use (``cuMemGetInfo``: the whole device, i.e. this
  process's Taichi context, memory pool and arrays when nothing else runs on the GPU).
* :class:`CudaEvents`: CUDA events on the stream Taichi launches on, to time GPU work (``one_camera.py``).
* :class:`HostCopier`: the renderer's copier (``benchbot_sim_taichi.render.host_copy.HostCopier``, re-exported here), which
  ``render.py --host-copy reused`` drives with ordinary memory.

Use from the thread that initialised Taichi (``Renderer``), after ``ti.init(arch=cuda)``. Every driver call's result
is checked; a failure raises ``RuntimeError`` naming the call and the CUDA error.
"""

from __future__ import annotations

import ctypes

from benchbot_sim_taichi.render.host_copy import HostCopier, check, cuda_driver

__all__ = ["CudaEvents", "HostCopier", "device_info"]


def device_info() -> dict:
    """``{'gpu': name, 'gpu_mem_used_mb': device memory in use, 'gpu_mem_total_mb': …}`` of the current context's
    device (MiB)."""
    lib = cuda_driver()
    dev = ctypes.c_int()
    check("cuCtxGetDevice", lib.cuCtxGetDevice(ctypes.byref(dev)))
    name = ctypes.create_string_buffer(256)
    check("cuDeviceGetName", lib.cuDeviceGetName(name, 256, dev))
    free, total = ctypes.c_size_t(), ctypes.c_size_t()
    check("cuMemGetInfo_v2", lib.cuMemGetInfo_v2(ctypes.byref(free), ctypes.byref(total)))
    return {"gpu": name.value.decode(), "gpu_mem_used_mb": round((total.value - free.value) / 2**20, 1),
            "gpu_mem_total_mb": round(total.value / 2**20, 1)}


class CudaEvents:
    """CUDA events on the legacy default stream (where Taichi launches its kernels), through the driver library.

    ``new()`` makes an event, ``record(e)`` records it after the work launched so far, ``done(e)`` says whether the
    GPU has reached it (without waiting), ``ms(a, b)`` waits for ``b`` and gives the GPU time between the two
    (milliseconds, float). Each call raises ``RuntimeError`` naming the driver call when it fails.
    """

    def __init__(self):
        self.lib = cuda_driver()

    def new(self) -> ctypes.c_void_p:
        e = ctypes.c_void_p()
        check("cuEventCreate", self.lib.cuEventCreate(ctypes.byref(e), 0))
        return e

    def record(self, e) -> None:
        check("cuEventRecord", self.lib.cuEventRecord(e, None))

    def done(self, e) -> bool:
        code = self.lib.cuEventQuery(e)
        if code not in (0, 600):  # 600: CUDA_ERROR_NOT_READY
            check("cuEventQuery", code)
        return code == 0

    def ms(self, a, b) -> float:
        check("cuEventSynchronize", self.lib.cuEventSynchronize(b))
        out = ctypes.c_float()
        check("cuEventElapsedTime", self.lib.cuEventElapsedTime(ctypes.byref(out), a, b))
        return out.value
