"""The renderer's GPU outputs handed to array libraries without a copy: DLPack and ``__cuda_array_interface__``.

Taichi 1.7's ndarrays export neither protocol, so :class:`DeviceArray` exports a Taichi ndarray itself; one in CUDA
memory is taken by ``torch.from_dlpack(a)``, ``jax.dlpack.from_dlpack(a)``, ``cupy.from_dlpack(a)`` (DLPack) and
``torch.as_tensor(a, device="cuda")``, ``cupy.asarray(a)`` (``__cuda_array_interface__``, version 3), all without
copying; one in host memory (Taichi on the CPU) by ``numpy.from_dlpack(a)``. Formats: the DLPack C header, ``dlpack.h`` (v0.8, the unversioned ``DLManagedTensor`` in a
capsule named ``"dltensor"``: https://dmlc.github.io/dlpack/latest/c_api.html), and Numba's CUDA Array Interface
(https://numba.readthedocs.io/en/stable/cuda/cuda_array_interface.html).

The memory stays the renderer's: the next frame of the same sizes is written into it, so a consumer that keeps a
frame copies it (``tensor.clone()``). Whoever makes a :class:`DeviceArray` first waits for the kernels that write it
(``Renderer.sync()``, on Taichi's thread: the CUDA context is current there only), so the data is complete on any
stream a consumer names.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

#: DLPack device types (``DLDeviceType``) and data type codes (``DLDataTypeCode``) of dlpack.h.
KDL_CPU, KDL_CUDA = 1, 2
_DTYPE_CODES = {"i": 0, "u": 1, "f": 2}


class _DLDevice(ctypes.Structure):
    _fields_ = [("device_type", ctypes.c_int32), ("device_id", ctypes.c_int32)]


class _DLDataType(ctypes.Structure):
    _fields_ = [("code", ctypes.c_uint8), ("bits", ctypes.c_uint8), ("lanes", ctypes.c_uint16)]


class _DLTensor(ctypes.Structure):
    _fields_ = [("data", ctypes.c_void_p), ("device", _DLDevice), ("ndim", ctypes.c_int32),
                ("dtype", _DLDataType), ("shape", ctypes.POINTER(ctypes.c_int64)),
                ("strides", ctypes.POINTER(ctypes.c_int64)), ("byte_offset", ctypes.c_uint64)]


class _DLManagedTensor(ctypes.Structure):
    pass


_DELETER = ctypes.CFUNCTYPE(None, ctypes.POINTER(_DLManagedTensor))
_DLManagedTensor._fields_ = [("dl_tensor", _DLTensor), ("manager_ctx", ctypes.c_void_p), ("deleter", _DELETER)]

#: what each exported tensor keeps alive until its consumer (or the unconsumed capsule) calls the deleter:
#: ``{address of the DLManagedTensor: (the struct, its shape array, the exporting DeviceArray)}``
_LIVE: dict[int, tuple] = {}


@_DELETER
def _delete(managed) -> None:
    _LIVE.pop(ctypes.addressof(managed.contents), None)


_CAPSULE_DESTRUCTOR = ctypes.CFUNCTYPE(None, ctypes.c_void_p)
_capsule_new = ctypes.pythonapi.PyCapsule_New
_capsule_new.restype = ctypes.py_object
_capsule_new.argtypes = [ctypes.c_void_p, ctypes.c_char_p, _CAPSULE_DESTRUCTOR]
_capsule_is_valid = ctypes.pythonapi.PyCapsule_IsValid
_capsule_is_valid.restype = ctypes.c_int
_capsule_is_valid.argtypes = [ctypes.c_void_p, ctypes.c_char_p]
_capsule_pointer = ctypes.pythonapi.PyCapsule_GetPointer
_capsule_pointer.restype = ctypes.c_void_p
_capsule_pointer.argtypes = [ctypes.c_void_p, ctypes.c_char_p]


@_CAPSULE_DESTRUCTOR
def _destroy_capsule(capsule: int) -> None:
    """A capsule no consumer took (still named ``"dltensor"``; a consumer renames it ``"used_dltensor"``) frees its
    tensor; a consumed one leaves that to the consumer's call of the deleter."""
    if _capsule_is_valid(capsule, b"dltensor"):
        _LIVE.pop(_capsule_pointer(capsule, b"dltensor"), None)


class DeviceArray:
    """A Taichi ndarray (one of the renderer's output buffers), exported without a copy.

    Args:
        ndarray: the Taichi ndarray (``taichi.ndarray``; element dimensions last in :attr:`shape`); None for an
            array mapped from another process (:func:`open_shared` builds those).
        device_id: the CUDA device ordinal (Taichi's, 0; a mapped array's: the device it lives on).
        device_type: :data:`KDL_CUDA` (default: the ndarray is in CUDA memory) or :data:`KDL_CPU` (Taichi on the
            CPU; NumPy views, :func:`~benchbot_sim_taichi.render.host_copy.host_view`, are simpler there, and the
            CUDA Array Interface is not offered).

    Attributes:
        shape: tuple of ints (the ndarray's shape, element dimensions last). dtype: its ``numpy.dtype``.

    Raises:
        TypeError: (on export) an element type DLPack cannot describe here (not int, uint or float).
    """

    def __init__(self, ndarray: Any, device_id: int = 0, device_type: int = KDL_CUDA) -> None:
        from benchbot_sim_taichi.render.host_copy import device_pointer
        from taichi.lang.util import to_numpy_type

        self.ndarray = ndarray
        self.device_id = int(device_id)
        if device_type not in (KDL_CPU, KDL_CUDA):
            raise ValueError(f"DeviceArray: device_type must be KDL_CPU (1) or KDL_CUDA (2), got {device_type!r}")
        self.device_type = int(device_type)
        self.dtype = np.dtype(to_numpy_type(ndarray.dtype))
        element = tuple(getattr(ndarray, "element_shape", ()) or ())
        self.shape = tuple(int(n) for n in ndarray.shape) + tuple(int(n) for n in element)
        self.pointer = device_pointer(ndarray)

    def __repr__(self) -> str:
        where = f"cuda:{self.device_id}" if self.device_type == KDL_CUDA else "cpu"
        return f"DeviceArray(shape={self.shape}, dtype={self.dtype}, {where})"

    def __dlpack_device__(self) -> tuple[int, int]:
        """``(device_type, device_id)``: ``(2, 0)`` for CUDA device 0 (DLPack's ``kDLCUDA``), ``(1, 0)`` on the CPU."""
        return self.device_type, self.device_id if self.device_type == KDL_CUDA else 0

    def __dlpack__(self, *, stream: Any = None, max_version: Any = None, dl_device: Any = None,
                   copy: bool | None = None) -> Any:
        """A ``"dltensor"`` capsule of this memory (row-major, no copy; ``stream`` is not needed: see the module
        docstring).

        Raises:
            BufferError: a copy or another device was asked for (neither is offered).
            TypeError: the element type has no DLPack code here.
        """
        if copy:
            raise BufferError("DeviceArray exports its memory without copying: copy=True is not offered")
        if dl_device is not None and tuple(dl_device) != self.__dlpack_device__():
            raise BufferError(f"{self!r} cannot be exported to DLPack device {tuple(dl_device)}")
        if self.dtype.kind not in _DTYPE_CODES:
            raise TypeError(f"DeviceArray: no DLPack type code for {self.dtype}")
        managed = _DLManagedTensor()
        shape = (ctypes.c_int64 * len(self.shape))(*self.shape)
        tensor = managed.dl_tensor
        tensor.data = self.pointer
        tensor.device = _DLDevice(*self.__dlpack_device__())
        tensor.ndim = len(self.shape)
        tensor.dtype = _DLDataType(_DTYPE_CODES[self.dtype.kind], self.dtype.itemsize * 8, 1)
        tensor.shape = shape
        tensor.strides = None  # row-major (compact)
        tensor.byte_offset = 0
        managed.manager_ctx = None
        managed.deleter = _delete
        address = ctypes.addressof(managed)
        _LIVE[address] = (managed, shape, self)
        return _capsule_new(address, b"dltensor", _destroy_capsule)

    @property
    def __cuda_array_interface__(self) -> dict:
        """Version 3 of the CUDA Array Interface (``stream`` None: the data is complete, see the module docstring).

        Raises:
            AttributeError: the array is not in CUDA memory (so ``hasattr`` is False there, as consumers expect).
        """
        if self.device_type != KDL_CUDA:
            raise AttributeError("__cuda_array_interface__: the array is in host memory")
        return {"shape": self.shape, "typestr": self.dtype.str, "data": (self.pointer, False), "version": 3,
                "strides": None, "stream": None}

    def numpy(self) -> np.ndarray:
        """A new host copy, (shape) of :attr:`dtype` (Taichi's ``to_numpy``: call it on the backend thread,
        :func:`benchbot.server.service.backend_worker`, as :meth:`BenchBotVectorEnv.render
        <benchbot.gym_vector.BenchBotVectorEnv.render>` does; on CUDA Taichi's context is current there only). An
        array mapped from another process (:func:`open_shared`) is copied through its device's primary context, from
        any thread."""
        if self.ndarray is None:
            from benchbot_sim_taichi.render.host_copy import copy_device_to_host

            return copy_device_to_host(self.pointer, np.empty(self.shape, self.dtype), self.device_id)
        return self.ndarray.to_numpy()

    # --- sharing with another process (CUDA IPC: a vector environment over several GPUs, benchbot.gym_devices) ---
    def share(self) -> tuple[str, tuple]:
        """How another process maps this memory: ``(opener, args)``, where ``opener`` names :func:`open_shared`
        (``"module:function"``, so that the receiving side needs no import of this plugin up front) and ``args`` are
        ``(IPC handle bytes, byte offset, shape, dtype str)``; ``open_shared(*args, device_id=k)`` there gives a
        :class:`DeviceArray` over the same memory. Call it on the thread where Taichi's CUDA context is current (the
        backend thread), after the kernels that write the array, for every frame: the description is made once per
        buffer. Where the driver refuses to share the renderer's own memory — it does for Taichi 1.7's ndarrays
        (``cuIpcGetMemHandle``: "invalid argument", seen on H200s) — the frame is copied into a shareable
        ``cuMemAlloc`` buffer of the same size instead, device to device (about 1.1 GB a step for 512 RGB-D frames
        of 640×480: well under a millisecond at the GPU's copy rate), synchronised before this returns.

        Raises:
            BufferError: the array is in host memory (share it through shared memory instead).
            RuntimeError: the driver refused (its CUDA error in the message).
        """
        if self.device_type != KDL_CUDA:
            raise BufferError("DeviceArray.share: the array is in host memory; CUDA IPC shares device memory only")
        from benchbot_sim_taichi.render.host_copy import ipc_export

        key = (self.pointer, self.shape, self.dtype.str)
        if key not in _SHARED:
            try:
                _SHARED[key] = (None, ipc_export(self.pointer))
            except RuntimeError:  # Taichi 1.7's ndarrays: cuIpcGetMemHandle answers "invalid argument"
                staging = _Staging(self.dtype.itemsize * int(np.prod(self.shape)))
                _SHARED[key] = (staging, ipc_export(staging.pointer))
        staging, (handle, offset) = _SHARED[key]
        if staging is not None:
            staging.fill(self.pointer)
        return f"{__name__}:open_shared", (handle, offset, self.shape, self.dtype.str)

    def release(self) -> None:
        """Unmap an array made by :func:`open_shared` (idempotent; nothing for the renderer's own arrays). Exported
        DLPack tensors of it must not be used afterwards."""
        handle, self._ipc_handle = getattr(self, "_ipc_handle", None), None
        if handle is not None:
            from benchbot_sim_taichi.render.host_copy import ipc_close

            ipc_close(handle, self.device_id)

    def wait_for_readers(self) -> None:
        """Wait for all work this process queued on the array's device in its primary context (a consumer's reads
        on any of its streams), so that the process that owns the memory may write the next frame into it."""
        from benchbot_sim_taichi.render.host_copy import synchronize_primary

        synchronize_primary(self.device_id)


class _Staging:
    """A shareable device buffer (``cuMemAlloc``) of ``nbytes`` in the current context, into which a frame is
    copied when its own memory cannot be shared; freed with the process."""

    def __init__(self, nbytes: int) -> None:
        from benchbot_sim_taichi.render.host_copy import check, cuda_driver

        self.nbytes = int(nbytes)
        p = ctypes.c_uint64()
        check("cuMemAlloc_v2", cuda_driver().cuMemAlloc_v2(ctypes.byref(p), ctypes.c_size_t(max(self.nbytes, 1))))
        self.pointer = p.value

    def fill(self, source: int) -> None:
        """Copy ``nbytes`` from device address ``source`` and wait for the copy (``cuCtxSynchronize``)."""
        from benchbot_sim_taichi.render.host_copy import check, cuda_driver

        lib = cuda_driver()
        check("cuMemcpyDtoD_v2", lib.cuMemcpyDtoD_v2(ctypes.c_uint64(self.pointer), ctypes.c_uint64(int(source)),
                                                     ctypes.c_size_t(self.nbytes)))
        check("cuCtxSynchronize", lib.cuCtxSynchronize())


#: ``{(pointer, shape, dtype): (staging buffer or None, (IPC handle, offset))}`` of the arrays this process shared
_SHARED: dict[tuple, tuple] = {}


def open_shared(handle: bytes, offset: int, shape: tuple, dtype: str, *, device_id: int) -> DeviceArray:
    """A :class:`DeviceArray` over memory another process shared (:meth:`DeviceArray.share`), mapped into CUDA
    device ``device_id``'s primary context of this process (``device_id``: this process's ordinal of the device the
    other process renders on). Its DLPack and CUDA Array Interface exports name that device;
    :meth:`~DeviceArray.release` unmaps it.

    Args:
        handle: the 64-byte CUDA IPC handle of the shared allocation. offset: the array's start in it, in bytes.
        shape: the array's shape, element dimensions last (e.g. ``(n, H, W, 3)`` for colour images). dtype: a NumPy
            dtype string (``'|u1'`` colour, ``'<f4'`` depth in metres), as :meth:`DeviceArray.share` gave them.
        device_id: keyword only, as above.

    Raises:
        RuntimeError: the driver refused (its CUDA error in the message).
    """
    from benchbot_sim_taichi.render.host_copy import ipc_open

    array = DeviceArray.__new__(DeviceArray)
    array.ndarray = None
    array.device_id, array.device_type = int(device_id), KDL_CUDA
    array.dtype, array.shape = np.dtype(dtype), tuple(int(n) for n in shape)
    array.pointer = ipc_open(handle, device_id) + int(offset)
    array._ipc_handle = bytes(handle)
    return array
