"""The native protocol's payload encoding: MessagePack with NumPy arrays as raw bytes.

An ndarray travels as ``{"__ndarray__": dtype str, "shape": [...], "data": raw C-order bytes}``; tuples become
lists; NumPy scalars become Python numbers. No pickle: decoding never executes code.
"""

from __future__ import annotations

from typing import Any

import msgpack
import numpy as np

from benchbot.core.errors import BenchbotError

_ND = "__ndarray__"
MSGPACK_TYPE = "application/msgpack"


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


def pack(obj: Any) -> bytes:
    """MessagePack bytes of ``obj`` (dicts, lists, tuples, str, numbers, bool, None, bytes, ndarrays)."""
    return msgpack.packb(obj, default=_encode, use_bin_type=True)


def unpack(data: bytes) -> Any:
    """The object packed by :func:`pack`. Arrays come back read-only, sharing ``data``'s memory.

    Raises:
        BenchbotError: ``data`` is not a valid payload.
    """
    try:
        return msgpack.unpackb(data, object_hook=_decode, raw=False, strict_map_key=False)
    except Exception as exc:
        raise BenchbotError(f"malformed payload: {exc}", "send MessagePack made by benchbot.core.wire.pack") from None
