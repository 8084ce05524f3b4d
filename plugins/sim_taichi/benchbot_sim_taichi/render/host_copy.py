"""Copies of the renderer's GPU outputs into reused host NumPy arrays, through the CUDA driver library (``libcuda``,
via ctypes) that Taichi has already loaded and whose context Taichi made current on its thread; and, on the CPU,
:func:`host_view`: NumPy arrays over Taichi ndarrays' own host memory.

Taichi's ``Ndarray.to_numpy`` makes new NumPy arrays on every call and copies through pageable memory (about 3 ms
for a 640×480 frame of all four sensors on an H200). :class:`HostCopier` allocates the host arrays once — page-locked
(``cuMemHostAlloc``) or ordinary NumPy memory — and fills them with one ``cuMemcpyDtoHAsync`` per output after
``ti.sync()`` and one stream synchronisation (about 0.09 ms for such a frame, 49–51 GB/s). The renderer's
``render_sensors(..., to_host="pinned")`` uses it; ``benchmarks/render.py --host-copy reused`` uses it with ordinary
memory.

Use from the thread that initialised Taichi on CUDA. Every driver call's result is checked; a failure raises
``RuntimeError`` naming the call and the CUDA error.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np

_LIB = None


def cuda_driver():
    """The CUDA driver library (``ctypes.CDLL`` of ``libcuda``), loaded once.

    Raises:
        OSError: no CUDA driver on this machine.
    """
    global _LIB
    if _LIB is None:
        _LIB = ctypes.CDLL(ctypes.util.find_library("cuda") or "libcuda.so.1")
    return _LIB


def check(name: str, code: int) -> None:
    """Raise ``RuntimeError("<name> failed: CUDA error <code> (<message>)")`` unless the driver call returned 0."""
    if code != 0:
        msg = ctypes.c_char_p()
        cuda_driver().cuGetErrorString(code, ctypes.byref(msg))
        raise RuntimeError(f"{name} failed: CUDA error {code} ({(msg.value or b'?').decode()})")


def device_pointer(nd) -> int:
    """The device address (int) of a Taichi ndarray's data (Taichi's ``get_ndarray_data_ptr_as_int``)."""
    import taichi as ti

    return int(ti.lang.impl.get_runtime().prog.get_ndarray_data_ptr_as_int(nd.arr))


def host_view(nd) -> np.ndarray:
    """A NumPy array over the memory of a Taichi ndarray that lives in host memory (Taichi on the CPU): no copy; it
    keeps ``nd`` alive, and shows what the kernels write there next (``.copy()`` it to keep a frame). Taichi's own
    ``Ndarray.to_numpy`` runs a copy kernel (compiled on its first call) for each array instead.

    Returns:
        an array of ``nd``'s shape (element dimensions last) and the NumPy dtype of its element type.

    Raises:
        ValueError: ``nd`` is not in host memory (Taichi runs on another arch).
    """
    import taichi as ti

    if ti.lang.impl.current_cfg().arch != ti.cpu:
        raise ValueError("host_view: the ndarray is in GPU memory; copy it with HostCopier")
    dtype = _np_dtype(nd)
    shape = tuple(nd.arr.total_shape())
    n = int(np.prod(shape)) * dtype.itemsize
    buf = (ctypes.c_uint8 * max(n, 1)).from_address(device_pointer(nd))
    buf.owner = nd  # the view's base holds the ndarray: its memory outlives every view
    return np.frombuffer(buf, np.uint8, n).view(dtype).reshape(shape)


def _np_dtype(nd) -> np.dtype:
    from taichi.lang.util import to_numpy_type

    return np.dtype(to_numpy_type(nd.dtype))


class HostCopier:
    """Copies dicts of Taichi ndarrays (on the GPU) into host NumPy arrays made once per (key, shape, dtype) and
    reused by every later call.

    Args:
        pinned: page-locked host memory (``cuMemHostAlloc``: the fastest copies), else ordinary NumPy memory.
    """

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
                check("cuMemHostAlloc", cuda_driver().cuMemHostAlloc(ctypes.byref(p), ctypes.c_size_t(max(n, 1)), 0))
                self._pinned_ptrs.append(p.value)
                buf = (ctypes.c_uint8 * max(n, 1)).from_address(p.value)
                self._host[k] = np.frombuffer(buf, np.uint8, n).view(dtype).reshape(shape)
            else:
                self._host[k] = np.zeros(shape, dtype)  # touched once here, then reused
        return self._host[k]

    def copy(self, arrays: dict) -> dict:
        """Host copies of ``arrays`` (``{key: Taichi ndarray on the GPU}``; NumPy arrays pass through unchanged).

        Returns:
            ``{key: NumPy array}`` of the same shapes and dtypes, valid until the next call with the same key, shape
            and dtype (which overwrites it). Waits for the copies, and so for every kernel launched before.

        Raises:
            RuntimeError: a CUDA driver call failed.
        """
        import taichi as ti

        lib = cuda_driver()
        ti.sync()  # the render's kernels first, whichever stream Taichi launched them on
        out = {}
        for key, nd in arrays.items():
            if isinstance(nd, np.ndarray):
                out[key] = nd
                continue
            host = self._array(key, tuple(nd.arr.total_shape()), _np_dtype(nd))
            check("cuMemcpyDtoHAsync_v2", lib.cuMemcpyDtoHAsync_v2(
                ctypes.c_void_p(host.ctypes.data), ctypes.c_uint64(device_pointer(nd)), ctypes.c_size_t(host.nbytes),
                ctypes.c_void_p(0)))
            out[key] = host
        check("cuStreamSynchronize", lib.cuStreamSynchronize(ctypes.c_void_p(0)))
        return out

    def close(self) -> None:
        """Free the page-locked memory (the arrays handed out become invalid); idempotent."""
        for p in self._pinned_ptrs:
            check("cuMemFreeHost", cuda_driver().cuMemFreeHost(ctypes.c_void_p(p)))
        self._pinned_ptrs, self._host = [], {}


# --- device memory shared between processes (CUDA IPC), for vector environments over several GPUs -------------------
# (benchbot.gym_devices: a worker process per extra GPU exports its renderer's output buffers once; the main process
# maps them and hands them to the user as DLPack arrays of that GPU). Driver API: cuIpcGetMemHandle,
# cuIpcOpenMemHandle, cuDevicePrimaryCtxRetain (CUDA Driver API reference, "Memory Management" and "Primary Context
# Management").

#: ``CU_IPC_HANDLE_SIZE`` of cuda.h: an IPC memory handle is 64 opaque bytes.
IPC_HANDLE_SIZE = 64
_CU_IPC_MEM_LAZY_ENABLE_PEER_ACCESS = 1


class _IpcMemHandle(ctypes.Structure):
    _fields_ = [("reserved", ctypes.c_char * IPC_HANDLE_SIZE)]


_PRIMARY: dict[int, int] = {}  # CUDA ordinal -> its primary context (retained once per process)
_OPENED: dict[tuple[int, bytes], list] = {}  # (ordinal, handle) -> [mapped base address, references]


def primary_context(ordinal: int) -> int:
    """The primary context (``CUcontext`` as int) of CUDA device ``ordinal`` (of this process's visible devices),
    retained once per process: the context PyTorch, CuPy and JAX use on that device.

    Raises:
        RuntimeError: a driver call failed (e.g. no such device).
    """
    if ordinal not in _PRIMARY:
        lib = cuda_driver()
        check("cuInit", lib.cuInit(0))
        dev, ctx = ctypes.c_int(), ctypes.c_void_p()
        check("cuDeviceGet", lib.cuDeviceGet(ctypes.byref(dev), int(ordinal)))
        check("cuDevicePrimaryCtxRetain", lib.cuDevicePrimaryCtxRetain(ctypes.byref(ctx), dev))
        _PRIMARY[ordinal] = ctx.value
    return _PRIMARY[ordinal]


class in_primary_context:
    """``with in_primary_context(k):`` runs driver calls in CUDA device ``k``'s primary context (pushed on this
    thread, popped after).

    Args:
        ordinal: the CUDA device ordinal, of this process's visible devices (``CUDA_VISIBLE_DEVICES`` applied).

    Raises:
        RuntimeError: a driver call failed (no such device, on making it; pushing or popping the context, on
            entering or leaving the block).
    """

    def __init__(self, ordinal: int) -> None:
        self.ctx = primary_context(ordinal)

    def __enter__(self) -> "in_primary_context":
        check("cuCtxPushCurrent_v2", cuda_driver().cuCtxPushCurrent_v2(ctypes.c_void_p(self.ctx)))
        return self

    def __exit__(self, *exc) -> None:
        popped = ctypes.c_void_p()
        check("cuCtxPopCurrent_v2", cuda_driver().cuCtxPopCurrent_v2(ctypes.byref(popped)))


def device_count() -> int:
    """The number of CUDA devices this process sees (``CUDA_VISIBLE_DEVICES`` applied); 0 without a driver or GPU."""
    try:
        lib = cuda_driver()
    except OSError:
        return 0
    if lib.cuInit(0) != 0:
        return 0
    n = ctypes.c_int()
    return n.value if lib.cuDeviceGetCount(ctypes.byref(n)) == 0 else 0


def ipc_export(pointer: int) -> tuple[bytes, int]:
    """What another process needs to map the device memory at ``pointer``: ``(handle, offset)``, the 64-byte IPC
    handle of the allocation holding it (``cuMemGetAddressRange`` finds its base: Taichi sub-allocates ndarrays from
    larger blocks) and ``pointer``'s offset in it. Call it where the memory's context is current (Taichi's thread).

    Raises:
        RuntimeError: a driver call failed (e.g. memory that cannot be shared: managed memory).
    """
    lib = cuda_driver()
    base, size = ctypes.c_uint64(), ctypes.c_size_t()
    check("cuMemGetAddressRange_v2", lib.cuMemGetAddressRange_v2(ctypes.byref(base), ctypes.byref(size),
                                                                 ctypes.c_uint64(int(pointer))))
    handle = _IpcMemHandle()
    check("cuIpcGetMemHandle", lib.cuIpcGetMemHandle(ctypes.byref(handle), ctypes.c_uint64(base.value)))
    return ctypes.string_at(ctypes.addressof(handle), IPC_HANDLE_SIZE), int(pointer) - base.value


def ipc_open(handle: bytes, ordinal: int) -> int:
    """The address, in CUDA device ``ordinal``'s primary context of this process, of the allocation another process
    exported as ``handle`` (:func:`ipc_export`); mapped once per process and counted: pair each call with
    :func:`ipc_close`.

    Raises:
        RuntimeError: the driver refused (its CUDA error in the message).
    """
    key = (int(ordinal), bytes(handle))
    if key not in _OPENED:
        lib = cuda_driver()
        h = _IpcMemHandle.from_buffer_copy(bytes(handle))
        ptr = ctypes.c_uint64()
        open_fn = getattr(lib, "cuIpcOpenMemHandle_v2", None) or lib.cuIpcOpenMemHandle
        with in_primary_context(ordinal):
            flags = ctypes.c_uint(_CU_IPC_MEM_LAZY_ENABLE_PEER_ACCESS)
            check("cuIpcOpenMemHandle", open_fn(ctypes.byref(ptr), h, flags))
        _OPENED[key] = [ptr.value, 0]
    _OPENED[key][1] += 1
    return _OPENED[key][0]


def ipc_close(handle: bytes, ordinal: int) -> None:
    """Drop one reference taken by :func:`ipc_open`; the last unmaps the allocation (``cuIpcCloseMemHandle``). A
    ``handle`` not open on ``ordinal`` is nothing to do.

    Raises:
        RuntimeError: the driver refused to unmap it (its CUDA error in the message).
    """
    key = (int(ordinal), bytes(handle))
    entry = _OPENED.get(key)
    if entry is None:
        return
    entry[1] -= 1
    if entry[1] <= 0:
        del _OPENED[key]
        with in_primary_context(ordinal):
            check("cuIpcCloseMemHandle", cuda_driver().cuIpcCloseMemHandle(ctypes.c_uint64(entry[0])))


def synchronize_primary(ordinal: int) -> None:
    """Wait for all work this process queued in CUDA device ``ordinal``'s primary context, on every stream (a
    consumer's reads of mapped frames: PyTorch's, CuPy's).

    Raises:
        RuntimeError: a driver call failed (its CUDA error in the message, e.g. an earlier kernel's fault).
    """
    with in_primary_context(ordinal):
        check("cuCtxSynchronize", cuda_driver().cuCtxSynchronize())


def copy_device_to_host(pointer: int, out: np.ndarray, ordinal: int) -> np.ndarray:
    """Fill ``out`` from device memory at ``pointer`` of CUDA device ``ordinal`` (primary context; synchronous):
    ``out.nbytes`` bytes, copied as they are, so ``out`` is a C-contiguous NumPy array of the device array's shape
    and dtype (e.g. ``(n, H, W, 3)`` uint8 colour images); returns ``out``.

    Raises:
        RuntimeError: the driver refused (its CUDA error in the message, e.g. ``pointer`` is not device memory).
    """
    with in_primary_context(ordinal):
        check("cuMemcpyDtoH_v2", cuda_driver().cuMemcpyDtoH_v2(ctypes.c_void_p(out.ctypes.data),
                                                                ctypes.c_uint64(int(pointer)),
                                                                ctypes.c_size_t(out.nbytes)))
    return out
