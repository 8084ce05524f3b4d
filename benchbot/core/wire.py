"""The native protocol's payload encoding: MessagePack with NumPy arrays as raw bytes.

An ndarray travels as ``{"__ndarray__": dtype str, "shape": [...], "data": raw C-order bytes}``, or, on the
same-host shared-memory path (:mod:`benchbot.core.shared_frames`), as ``{"__shm__": dtype str, "shape": [...],
"offset": bytes}`` pointing into the client's segment; tuples become lists; NumPy scalars become Python numbers.
No pickle: decoding never executes code.
"""

from __future__ import annotations

from typing import Any, Callable

import msgpack
import numpy as np

from benchbot.core.errors import BenchbotError

_ND = "__ndarray__"
SHM = "__shm__"
MSGPACK_TYPE = "application/msgpack"
#: The header carrying the backend's access token (docs/security.md); HTTP header names are case-insensitive.
TOKEN_HEADER = "X-BenchBot-Token"
#: The header naming a client: the episode belongs to one client at a time (docs/protocol.md).
CLIENT_HEADER = "X-BenchBot-Client"


def _encode(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        if obj.dtype.hasobject:
            raise TypeError("object arrays cannot be sent")
        arr = np.ascontiguousarray(obj)
        data = memoryview(arr).cast("B") if arr.size else b""  # no copy: msgpack reads the buffer directly
        return {_ND: arr.dtype.str, "shape": list(arr.shape), "data": data}
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"cannot encode {type(obj).__name__}")


def _decode(obj: dict) -> Any:
    if _ND in obj:
        dtype = np.dtype(obj[_ND])
        if dtype.hasobject:
            raise ValueError("object arrays are refused")
        return np.frombuffer(obj["data"], dtype=dtype).reshape(obj["shape"])
    return obj


def pack(obj: Any, place: Callable[[np.ndarray], dict | None] | None = None) -> bytes:
    """MessagePack bytes of ``obj`` (dicts, lists, tuples, str, numbers, bool, None, bytes, ndarrays).

    ``place``: called with each ndarray; a dict it returns is sent instead of the array (a shared-memory
    descriptor), None sends the array inline.
    """
    if place is None:
        return msgpack.packb(obj, default=_encode, use_bin_type=True)

    def encode(value: Any) -> Any:
        if isinstance(value, np.ndarray):
            ref = place(value)
            if ref is not None:
                return ref
        return _encode(value)

    return msgpack.packb(obj, default=encode, use_bin_type=True)


def unpack(data: bytes, fetch: Callable[[str, list, int], np.ndarray] | None = None) -> Any:
    """The object packed by :func:`pack`. Inline arrays come back read-only, sharing ``data``'s memory; shared-memory
    descriptors are resolved by ``fetch(dtype, shape, offset)``.

    Raises:
        BenchbotError: ``data`` is not a valid payload, or holds a shared-memory descriptor and ``fetch`` is None.
    """

    def decode(obj: dict) -> Any:
        if SHM in obj:
            if fetch is None:
                raise ValueError("a shared-memory array arrived but no segment was offered")
            return fetch(obj[SHM], obj["shape"], obj["offset"])
        return _decode(obj)

    try:
        return msgpack.unpackb(data, object_hook=decode, raw=False, strict_map_key=False)
    except BenchbotError:
        raise
    except Exception as exc:
        raise BenchbotError(f"malformed payload: {exc}", "send MessagePack made by benchbot.core.wire.pack") from None
