"""Quality mode's denoiser: Intel Open Image Denoise (``pyoidn``'s bundled library) on the CPU or an NVIDIA GPU.

One :class:`Denoiser` holds an OIDN device, its ``RT`` filter (HDR, albedo and normal guides) and one device buffer for
the four images of one size, committed once; a call then only copies the three inputs in, runs the filter and copies the
output back. :func:`denoise_radiance` keeps such denoisers per (device, height, width, quality), so a renderer that
denoises frame after frame pays the filter's set-up (loading the network, the GPU's context) once.
:func:`denoise_shared` (:class:`SharedImageDenoiser`) denoises images that are already in the device's memory — the
path tracer's output on the GPU — without copying them at all.
"""

from __future__ import annotations

import atexit
import ctypes
import threading
from collections import OrderedDict

import numpy as np

DEVICES = ("cpu", "cuda")
QUALITIES = {"fast": 4, "balanced": 5, "high": 6}  # OIDN_QUALITY_*
_DEVICE_TYPES = {"cpu": 1, "cuda": 3}  # OIDN_DEVICE_TYPE_*
_FLOAT3 = 3  # OIDN_FORMAT_FLOAT3
_IMAGES = ("color", "albedo", "normal", "output")  # in this order in a denoiser's buffer
_MAX_CACHED = 4  # denoisers kept by denoise_radiance (each holds its images and the filter's scratch memory)


def _capi():
    from pyoidn.capi import oidn_Capi, oidn_ffi

    return oidn_Capi, oidn_ffi


def _error(device) -> tuple[int, str]:
    """(OIDN error code, message) of ``device``'s last error, or of the last failed device creation when ``device``
    is NULL; reading it clears it."""
    capi, ffi = _capi()
    message = ffi.new("const char**")
    code = int(capi.oidnGetDeviceError(device, message))
    text = ffi.string(message[0]).decode("utf-8", "replace") if message[0] != ffi.NULL else ""
    return code, " ".join(text.split()) or f"OIDN error {code}"


def _cuda_driver_problem() -> str | None:
    """Why the CUDA driver cannot serve a device here, or None if it has at least one GPU."""
    try:
        cuda = ctypes.CDLL("libcuda.so.1")
    except OSError as e:
        return f"the NVIDIA driver (libcuda.so.1) cannot be loaded: {e}"
    if (rc := cuda.cuInit(0)) != 0:
        return f"the NVIDIA driver's cuInit failed with CUDA error {rc}"
    count = ctypes.c_int(0)
    if cuda.cuDeviceGetCount(ctypes.byref(count)) != 0 or count.value < 1:
        return "the NVIDIA driver sees no GPU"
    return None


_DEVICE_HANDLES: dict[str, object] = {}  # one committed OIDN device per name, shared by that device's denoisers


def _device(name: str):
    """The process's committed OIDN device ``name`` ("cpu" | "cuda"), created on first use.

    Raises:
        RuntimeError: one line naming the device and why it cannot be created (e.g. no NVIDIA driver or GPU).
    """
    if name in _DEVICE_HANDLES:
        return _DEVICE_HANDLES[name]
    capi, ffi = _capi()
    handle = capi.oidnNewDevice(_DEVICE_TYPES[name])
    if handle == ffi.NULL:
        reason = _error(ffi.NULL)[1]
        if name == "cuda" and (driver := _cuda_driver_problem()):
            reason = f"{reason}; {driver}"
        raise RuntimeError(f"Open Image Denoise device {name!r} cannot be created: {reason}")
    capi.oidnCommitDevice(handle)
    code, message = _error(handle)
    if code:
        capi.oidnReleaseDevice(handle)
        raise RuntimeError(f"Open Image Denoise device {name!r} cannot be created: {message}")
    _DEVICE_HANDLES[name] = handle
    return handle


def _check_arguments(device: str, height: int, width: int, quality: str) -> None:
    """Raise ValueError for an unknown device or quality, or an image size below 1×1."""
    if device not in DEVICES:
        raise ValueError(f"device must be one of {DEVICES}, not {device!r}")
    if quality not in QUALITIES:
        raise ValueError(f"quality must be one of {tuple(QUALITIES)}, not {quality!r}")
    if height < 1 or width < 1:
        raise ValueError(f"image size must be at least 1x1, not {width}x{height}")


def _check(handle, name: str, what: str) -> None:
    """Raise ``RuntimeError("Open Image Denoise (<name>) failed <what>: <OIDN's message>")`` if the device ``handle``
    has an error (reading it clears it)."""
    code, message = _error(handle)
    if code:
        raise RuntimeError(f"Open Image Denoise ({name}) failed {what}: {message}")


def _release(filter_handle, buffer_handle) -> None:
    """Release an OIDN filter and buffer (either may be NULL, the buffer None)."""
    capi, ffi = _capi()
    if filter_handle != ffi.NULL:
        capi.oidnReleaseFilter(filter_handle)
    if buffer_handle is not None and buffer_handle != ffi.NULL:
        capi.oidnReleaseBuffer(buffer_handle)


def _commit_rt_filter(filter_handle, quality: str) -> None:
    """Set an ``RT`` filter's options (HDR input, ``quality``) and commit it; the caller checks the device's error."""
    capi, _ = _capi()
    capi.oidnSetFilterBool(filter_handle, b"hdr", True)
    capi.oidnSetFilterInt(filter_handle, b"quality", QUALITIES[quality])
    capi.oidnCommitFilter(filter_handle)


class Denoiser:
    """OIDN's ``RT`` filter (HDR input, albedo and normal guides) for (H, W) images on one device, set up once.

    Args:
        device: "cpu" or "cuda" (the first CUDA GPU, through pyoidn's bundled CUDA device library).
        height, width: image size in pixels, both ≥ 1.
        quality: "high" (the default, best), "balanced" or "fast" (OIDN's smaller, quicker networks).

    Raises:
        ValueError: unknown device or quality, or a size < 1.
        RuntimeError: the device cannot be created (one line naming it and why), or OIDN rejected the filter.
        ImportError: pyoidn is not installed.
    """

    def __init__(self, device: str, height: int, width: int, quality: str = "high"):
        _check_arguments(device, height, width, quality)
        capi, ffi = _capi()
        self.device, self.shape, self.quality = device, (int(height), int(width), 3), quality
        self._nbytes = int(height) * int(width) * 3 * 4
        self._device = _device(device)
        self._buffer = self._filter = ffi.NULL
        try:
            self._buffer = capi.oidnNewBuffer(self._device, 4 * self._nbytes)
            self._filter = capi.oidnNewFilter(self._device, b"RT")
            for i, name in enumerate(_IMAGES):
                capi.oidnSetFilterImage(self._filter, name.encode(), self._buffer, _FLOAT3, int(width), int(height),
                                        i * self._nbytes, 0, 0)
            _commit_rt_filter(self._filter, quality)
            _check(self._device, self.device, "setting up the filter")
        except BaseException:
            self.close()
            raise

    def __call__(self, radiance: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Denoise one image; see :func:`denoise_radiance` for the arguments, the result and the errors."""
        if self._filter is None:
            raise RuntimeError("this Denoiser was closed")
        for name, a in (("radiance", radiance), ("albedo", albedo), ("normal", normal)):
            if np.shape(a) != self.shape:
                raise ValueError(f"{name} must have shape {self.shape}, not {np.shape(a)}")
        capi, ffi = _capi()
        inputs = [np.ascontiguousarray(np.maximum(radiance, 0.0), dtype=np.float32),
                  np.ascontiguousarray(np.clip(albedo, 0.0, 1.0), dtype=np.float32),
                  np.ascontiguousarray(np.clip(normal, -1.0, 1.0), dtype=np.float32)]
        out = np.empty(self.shape, np.float32)
        for i, a in enumerate(inputs):  # async: one synchronisation for the copies, the filter and the read-back
            capi.oidnWriteBufferAsync(self._buffer, i * self._nbytes, self._nbytes, ffi.from_buffer(a))
        capi.oidnExecuteFilterAsync(self._filter)
        capi.oidnReadBufferAsync(self._buffer, 3 * self._nbytes, self._nbytes,
                                 ffi.from_buffer(out, require_writable=True))
        capi.oidnSyncDevice(self._device)
        del inputs  # kept alive until the device has read them
        _check(self._device, self.device, "denoising")
        return out

    def close(self) -> None:
        """Release the filter and the buffer (the device stays, shared); idempotent."""
        if self._filter is not None:
            _release(self._filter, self._buffer)
        self._filter = self._buffer = None


class SharedImageDenoiser:
    """OIDN's ``RT`` filter reading and writing images that already lie in memory its device can use — CUDA device
    memory for "cuda" (e.g. a Taichi ndarray on CUDA: Taichi and OIDN share the device's primary context), host memory
    for "cpu" — with no copies: the GPU path of quality mode keeps the path tracer's output on the GPU.

    Layout (float32, rows packed): ``color`` and ``output`` (H, W, 3); ``guides`` (H, W, 6), per pixel the albedo (3)
    then the shading normal (3), as ``pathtrace.quality_kernel`` writes them. The inputs must already be in range
    (colour ≥ 0, albedo 0..1, normal −1..1: ``pathtrace.prepare_denoiser_inputs`` clamps them in place).

    Args and Raises: as :class:`Denoiser`.
    """

    def __init__(self, device: str, height: int, width: int, quality: str = "high"):
        _check_arguments(device, height, width, quality)
        capi, ffi = _capi()
        self.device, self.quality = device, quality
        self.height, self.width = int(height), int(width)
        self._device = _device(device)
        self._filter = capi.oidnNewFilter(self._device, b"RT")
        self._bound: tuple | None = None  # the addresses the filter was last committed with
        try:
            _check(self._device, self.device, "creating the filter")
        except BaseException:
            self.close()
            raise

    def __call__(self, color: int, guides: int, output: int) -> None:
        """Denoise the image at address ``color`` into ``output``, with the guides at ``guides`` (see the class doc);
        returns when the output is written. Committing the filter again (a few milliseconds) happens only when the
        addresses change.

        Raises:
            RuntimeError: the filter was closed, or Open Image Denoise failed (its message).
        """
        if self._filter is None:
            raise RuntimeError("this SharedImageDenoiser was closed")
        capi, ffi = _capi()
        addresses = (int(color), int(guides), int(output))
        if addresses != self._bound:
            images = (("color", color, 0, 12), ("albedo", guides, 0, 24), ("normal", guides, 12, 24),
                      ("output", output, 0, 12))
            for name, address, offset, stride in images:
                capi.oidnSetSharedFilterImage(self._filter, name.encode(), ffi.cast("void*", int(address)), _FLOAT3,
                                              self.width, self.height, offset, stride, 0)
            _commit_rt_filter(self._filter, self.quality)
            _check(self._device, self.device, "setting up the filter")
            self._bound = addresses
        capi.oidnExecuteFilterAsync(self._filter)
        capi.oidnSyncDevice(self._device)
        _check(self._device, self.device, "denoising")

    def close(self) -> None:
        """Release the filter (the device stays, shared); idempotent."""
        if self._filter is not None:
            _release(self._filter, None)
        self._filter = None


_CACHE: OrderedDict[tuple, Denoiser | SharedImageDenoiser] = OrderedDict()
_LOCK = threading.Lock()


def cached_denoiser(device: str, height: int, width: int, quality: str = "high",
                    shared: bool = False) -> Denoiser | SharedImageDenoiser:
    """The process's :class:`Denoiser` (or, with ``shared``, :class:`SharedImageDenoiser`) for these arguments, made
    on first use; the last 4 used are kept.

    Not thread-safe by itself: :func:`denoise_radiance` and :func:`denoise_shared` call it, and the denoiser, under
    one lock.

    Raises:
        as :class:`Denoiser`.
    """
    key = (device, int(height), int(width), quality, bool(shared))
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    denoiser = _CACHE[key] = (SharedImageDenoiser if shared else Denoiser)(device, height, width, quality)
    while len(_CACHE) > _MAX_CACHED:
        _CACHE.popitem(last=False)[1].close()
    return denoiser


def denoise_radiance(radiance: np.ndarray, albedo: np.ndarray, normal: np.ndarray, device: str = "cpu",
                     quality: str = "high") -> np.ndarray:
    """Intel Open Image Denoise (``pyoidn``: its ``RT`` filter, HDR) of a path-traced image, on the CPU or a GPU.

    The first call for a (device, size, quality) sets the filter up (it loads the network: most of that call's time);
    later calls reuse it (:func:`cached_denoiser`). Thread-safe: calls are serialised. Deterministic on one device;
    "cpu" and "cuda" agree only within the network's precision (the GPU computes in half precision).

    Args:
        radiance: (H, W, 3) float32 linear radiance (HDR: values above 1 are kept; negatives are clamped to 0).
        albedo: (H, W, 3) float32 albedo at the camera's hits, 0..1 (the guide that keeps textures sharp; clipped).
        normal: (H, W, 3) float32 shading normals at those hits, any frame, components in −1..1 (keeps edges;
            clipped).
        device: "cpu" (default) or "cuda" (the first NVIDIA GPU).
        quality: "high" (default), "balanced" or "fast".

    Returns:
        (H, W, 3) float32 denoised linear radiance, non-negative, in the input's units.

    Raises:
        ValueError: shapes that are not one (H, W, 3), or an unknown device or quality.
        RuntimeError: the device cannot be created (one line naming it and why: no NVIDIA driver, no GPU), or Open
            Image Denoise failed (its message).
        ImportError: pyoidn is not installed.
    """
    shape = np.shape(radiance)
    if len(shape) != 3 or shape[2] != 3:
        raise ValueError(f"radiance must have shape (H, W, 3), not {shape}")
    with _LOCK:
        return cached_denoiser(device, shape[0], shape[1], quality)(radiance, albedo, normal)


def denoise_shared(color: int, guides: int, output: int, height: int, width: int, device: str = "cpu",
                   quality: str = "high") -> None:
    """:func:`denoise_radiance` for images already in the OIDN device's memory (:class:`SharedImageDenoiser`: CUDA
    device memory for "cuda", host memory for "cpu"), given by address: no copies. Thread-safe: calls are serialised.
    For the same inputs it writes what :func:`denoise_radiance` returns on the same device.

    Args:
        color, guides, output: addresses of the (H, W, 3), (H, W, 6) and (H, W, 3) float32 images (layout and ranges
            in :class:`SharedImageDenoiser`).
        height, width: image size in pixels. device, quality: as :func:`denoise_radiance`.

    Raises:
        ValueError, RuntimeError, ImportError: as :func:`denoise_radiance`.
    """
    with _LOCK:
        cached_denoiser(device, height, width, quality, shared=True)(color, guides, output)


@atexit.register
def _release_all() -> None:
    """Filters and buffers first, then the devices they belong to."""
    with _LOCK:
        while _CACHE:
            _CACHE.popitem()[1].close()
        if _DEVICE_HANDLES:
            capi, _ = _capi()
            for handle in _DEVICE_HANDLES.values():
                capi.oidnReleaseDevice(handle)
            _DEVICE_HANDLES.clear()
