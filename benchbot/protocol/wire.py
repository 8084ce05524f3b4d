"""The native protocol's payload encoding: MessagePack with NumPy arrays as raw bytes.

An ndarray travels as ``{"__ndarray__": dtype str, "shape": [...], "data": raw C-order bytes}``, or, on the
same-host shared-memory path (:mod:`benchbot.protocol.shared_frames`), as ``{"__shm__": dtype str, "shape": [...],
"offset": bytes}`` pointing into the client's segment; tuples become lists; NumPy scalars become Python numbers.
No pickle: decoding never executes code.

Also the HTTP of a request on a connection of its own (:func:`request_once`, how a supervisor looks at a backend
without being its client) and the TLS context of an address (:func:`tls_context`), which the client
(:mod:`benchbot.api`) and the supervisor (:mod:`benchbot.solutions.solution_lease`, ``benchbot submit``) share.
"""

from __future__ import annotations

import http.client
import ssl
import urllib.parse
from typing import Any, Callable

import msgpack
import numpy as np

from benchbot.core import settings
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
        raise BenchbotError(f"malformed payload: {exc}", "send MessagePack made by benchbot.protocol.wire.pack") from None


def tls_context(address: str, ca_file: str | None = None) -> ssl.SSLContext | None:
    """The TLS context a client uses for ``address``: None for ``http://``; for ``https://`` one that trusts the
    certificate authorities in ``ca_file``, else in ``$BENCHBOT_CA_FILE``, else the system's.

    Raises:
        ValueError: the authorities' file is missing or holds no PEM certificate (the message names it).
    """
    if urllib.parse.urlsplit(address).scheme != "https":
        return None
    source, path = ("ca_file", ca_file) if ca_file else ("BENCHBOT_CA_FILE", settings.get("BENCHBOT_CA_FILE"))
    try:
        return ssl.create_default_context(cafile=path)
    except (OSError, ssl.SSLError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise ValueError(f"{source}={path} cannot be used as certificate authorities ({reason})") from None


class ConnectTimeout(TimeoutError):
    """:func:`request_once`: nothing accepted the connection in time."""


class ReadTimeout(TimeoutError):
    """:func:`request_once`: the connection was accepted but no answer came in time."""


def request_once(address: str, method: str, route: str, *, body: bytes | None = None,
                 headers: dict[str, str] | None = None, connect_timeout_s: float = 5.0,
                 read_timeout_s: float = 5.0) -> tuple[int, bytes]:
    """One request to the backend at ``address`` on a connection of its own, closed after it: how a supervisor
    looks at a backend without being its client (``benchbot submit``'s checks, the release of a solution that has
    ended). Over the standard library's :mod:`http.client`, as :class:`HttpTransport`; TLS as :func:`tls_context`.

    Args:
        address: ``http://host:port/`` or ``https://host:port/``. method, route: e.g. ``"GET"``, ``"robot/run_info"``.
        body, headers: the request's (add :data:`TOKEN_HEADER` where the backend wants a token).
        connect_timeout_s: seconds to connect (and, for HTTPS, to shake hands). read_timeout_s: seconds for each
            read of the answer.

    Returns:
        ``(HTTP status, body)``.

    Raises:
        ConnectTimeout, ReadTimeout: as named. OSError: refused, unreachable, TLS failures (``ssl.SSLError``) and
            other socket errors; ``http.client.HTTPException`` for a malformed answer. ValueError: a bad
            ``$BENCHBOT_CA_FILE``.
    """
    import socket

    url = urllib.parse.urlsplit(address)
    tls = tls_context(address)
    host, port = url.hostname or "127.0.0.1", url.port or (443 if tls else 80)
    conn: http.client.HTTPConnection = (http.client.HTTPSConnection(host, port, timeout=connect_timeout_s, context=tls)
                                        if tls else http.client.HTTPConnection(host, port, timeout=connect_timeout_s))
    try:
        try:
            conn.connect()
        except (socket.timeout, TimeoutError):
            raise ConnectTimeout(f"nothing at {address} accepted a connection within {connect_timeout_s:g} s") from None
        conn.sock.settimeout(read_timeout_s)
        try:
            conn.request(method, f"{url.path.rstrip('/')}/{route.lstrip('/')}", body=body, headers=headers or {})
            reply = conn.getresponse()
            return reply.status, reply.read()
        except (socket.timeout, TimeoutError):
            raise ReadTimeout(f"{address} accepted the connection but did not answer within {read_timeout_s:g} s") \
                from None
    finally:
        conn.close()
