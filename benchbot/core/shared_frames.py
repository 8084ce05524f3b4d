"""The same-host fast path of the native step: observation arrays travel through shared memory instead of the HTTP
reply.

The backend keeps one *segment* per client: a file ``/dev/shm/benchbot-<32 hex digits>`` (mode 0600, in RAM:
``/dev/shm`` is a tmpfs) that it creates, maps and writes; the client maps it read-only and copies each array out
(one ``memcpy`` on each side; the HTTP exchange carries a few hundred bytes instead of megabytes).

Handshake (no step's data can be lost on the way):

1. the client sends ``shm: {"client": <32 hex, its own id>, "segment": <name of the segment it has mapped, or
   null>}`` with each step;
2. when ``segment`` names the client's current segment and it is large enough, the backend writes each array of at
   least :data:`MIN_BYTES` into it and sends ``{"__shm__": dtype, "shape": [...], "offset": bytes}`` in its place;
3. otherwise (first step, the segment had to grow, was evicted) the reply carries every array inline, plus
   ``shm_segment: {"name", "size"}`` for the client to map before its next step. A client that cannot map it (its
   ``/dev/shm`` is not the backend's, e.g. in a container) stops asking; a reply is never unreadable.

Only loopback clients are offered segments; the backend holds at most :data:`MAX_SEGMENTS` (the least recently used
is removed), removes a segment's file as soon as its client has mapped it (so a killed backend leaves nothing in
``/dev/shm``) and the rest when it closes or exits. Only the backend's user can open them (0600). Linux only
(``/dev/shm``); elsewhere :func:`available` is False and clients use the inline path.
"""

from __future__ import annotations

import mmap
import os
import re
import secrets
import weakref
from collections import OrderedDict

import numpy as np

from benchbot.core.errors import BenchbotError

#: Where segments live (a tmpfs on Linux).
SHM_DIR = "/dev/shm"
#: Segment names and client ids.
NAME_PATTERN = re.compile(r"benchbot-[0-9a-f]{32}")
CLIENT_PATTERN = re.compile(r"[0-9a-f]{32}")
#: Arrays smaller than this stay inline (the laser scan, poses, infos).
MIN_BYTES = 64 * 1024
#: Offsets of arrays in a segment are multiples of this (cache lines).
ALIGN = 64
#: Segments the backend keeps (one per client).
MAX_SEGMENTS = 8
#: Environment variable that turns the path off in clients (``0``).
ENV_SWITCH = "BENCHBOT_SHARED_MEMORY"


def available() -> bool:
    """True where segments can be used: :data:`SHM_DIR` is a writable directory and ``$BENCHBOT_SHARED_MEMORY``
    is not ``0``."""
    if os.environ.get(ENV_SWITCH, "1").strip() == "0":
        return False
    return os.path.isdir(SHM_DIR) and os.access(SHM_DIR, os.W_OK | os.X_OK)


def is_loopback(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and localhost."""
    return host in ("localhost", "::1") or host.startswith("127.")


def aligned(n: int) -> int:
    """``n`` rounded up to a multiple of :data:`ALIGN`."""
    return (n + ALIGN - 1) // ALIGN * ALIGN


def large_arrays(obj) -> list[np.ndarray]:
    """The ndarrays of at least :data:`MIN_BYTES` in ``obj`` (nested dicts, lists, tuples), in packing order."""
    if isinstance(obj, np.ndarray):
        return [obj] if obj.nbytes >= MIN_BYTES and not obj.dtype.hasobject else []
    if isinstance(obj, dict):
        return [a for v in obj.values() for a in large_arrays(v)]
    if isinstance(obj, (list, tuple)):
        return [a for v in obj for a in large_arrays(v)]
    return []


def _release(view: mmap.mmap, fd: int, path: str | None) -> None:
    try:
        view.close()
    except BufferError:  # an array still borrows the mapping: it goes when that array does
        pass
    os.close(fd)
    if path is not None:
        try:
            os.unlink(path)
        except FileNotFoundError:
            pass


class BackendSegment:
    """A segment the backend made for one client: a new ``size``-byte file in :data:`SHM_DIR`, mapped read-write.

    Args:
        size: bytes (a tmpfs file takes memory only for the pages written).

    Raises:
        OSError: the file cannot be made or mapped (no ``/dev/shm``, full).
    """

    def __init__(self, size: int) -> None:
        self.name = f"benchbot-{secrets.token_hex(16)}"
        path = os.path.join(SHM_DIR, self.name)
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o600)
        try:
            os.ftruncate(fd, size)
            view = mmap.mmap(fd, size)
        except OSError:
            os.close(fd)
            os.unlink(path)
            raise
        self.size = size
        self.view = view
        self.path: str | None = path
        self._finalizer = weakref.finalize(self, _release, view, fd, path)

    def unlink(self) -> None:
        """Remove the file's name once the client has mapped it: the memory stays shared until both sides unmap,
        and nothing is left in /dev/shm even if the backend is killed."""
        if self.path is not None:
            try:
                os.unlink(self.path)
            except FileNotFoundError:
                pass
            self.path = None

    def write(self, arr: np.ndarray, offset: int) -> None:
        """Copy C-contiguous ``arr`` to ``offset`` (the caller keeps within :attr:`size`)."""
        self.view[offset:offset + arr.nbytes] = memoryview(arr).cast("B")

    def close(self) -> None:
        """Unmap and remove the file (idempotent)."""
        self._finalizer()


class SegmentPool:
    """The backend's segments by client id (the most recent :data:`MAX_SEGMENTS`). Used from one thread (the
    server's event loop)."""

    def __init__(self, capacity: int = MAX_SEGMENTS) -> None:
        self.capacity = capacity
        self._by_client: OrderedDict[str, BackendSegment] = OrderedDict()

    def pack(self, reply: dict, offer: object) -> bytes:
        """``reply`` packed for a client that sent ``shm: offer`` (see the module doc): large arrays in its segment
        when it has mapped it, else inline with ``shm_segment`` to map (or ``shm_error`` when none can be made).

        Raises:
            BenchbotError: ``offer`` is malformed (answer 400).
        """
        from benchbot.core import wire

        client, mapped = check_offer(offer)
        needed = sum(aligned(a.nbytes) for a in large_arrays(reply))
        segment = self._by_client.pop(client, None)
        if segment is not None and (needed > segment.size):
            segment.close()
            segment = None
        if segment is None:
            try:
                segment = BackendSegment(max(aligned(needed + needed // 4), 1 << 20))
            except OSError as exc:
                return wire.pack({**reply, "shm_error": f"no shared-memory segment: {exc.strerror or exc}"})
        self._by_client[client] = segment
        while len(self._by_client) > self.capacity:
            self._by_client.popitem(last=False)[1].close()
        if mapped != segment.name:
            return wire.pack({**reply, "shm_segment": {"name": segment.name, "size": segment.size}})
        segment.unlink()  # the client has it mapped
        offset = 0

        def place(arr: np.ndarray) -> dict | None:
            nonlocal offset
            if arr.nbytes < MIN_BYTES or arr.dtype.hasobject:
                return None
            arr = np.ascontiguousarray(arr)
            segment.write(arr, offset)
            ref = {wire.SHM: arr.dtype.str, "shape": list(arr.shape), "offset": offset}
            offset = aligned(offset + arr.nbytes)
            return ref

        return wire.pack(reply, place)

    def close(self) -> None:
        """Remove every segment."""
        while self._by_client:
            self._by_client.popitem()[1].close()


def check_offer(offer: object) -> tuple[str, str | None]:
    """``(client id, mapped segment name or None)`` of a request's ``shm`` field.

    Raises:
        BenchbotError: not ``{"client": <32 hex>, "segment": <segment name or null>}``.
    """
    if not isinstance(offer, dict) or not isinstance(offer.get("client"), str) \
            or not CLIENT_PATTERN.fullmatch(offer["client"]):
        raise BenchbotError("'shm' must be {client: <32 hex digits>, segment: <name or null>}", "leave 'shm' out")
    mapped = offer.get("segment")
    if mapped is not None and not (isinstance(mapped, str) and NAME_PATTERN.fullmatch(mapped)):
        raise BenchbotError("'shm.segment' must be a segment name benchbot-<32 hex digits> or null",
                            "send the name from the last shm_segment reply")
    return offer["client"], mapped


class ClientMapping:
    """The client's read-only mapping of the segment the backend made for it.

    Args:
        name: the segment name (``shm_segment.name`` of a reply). size: its size in bytes.

    Raises:
        OSError: it cannot be opened or mapped (e.g. this process's ``/dev/shm`` is not the backend's).
        BenchbotError: ``name`` is not a segment name.
    """

    def __init__(self, name: str, size: int) -> None:
        if not (isinstance(name, str) and NAME_PATTERN.fullmatch(name)) or not isinstance(size, int) or size <= 0:
            raise BenchbotError(f"malformed shm_segment {name!r} ({size!r} bytes)", "")
        fd = os.open(os.path.join(SHM_DIR, name), os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0)
                     | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NONBLOCK", 0))
        try:
            if os.fstat(fd).st_size < size:
                raise OSError(f"{name} is smaller than announced")
            view = mmap.mmap(fd, size, prot=mmap.PROT_READ)
        except OSError:
            os.close(fd)
            raise
        self.name, self.size, self.view = name, size, view
        self._finalizer = weakref.finalize(self, _release, view, fd, None)

    def read(self, dtype: str, shape: list, offset: int) -> np.ndarray:
        """A new (writeable, owned) array of ``dtype`` (a NumPy dtype string, e.g. ``'<f4'``) and ``shape`` copied
        from ``offset``.

        Raises:
            BenchbotError: the descriptor is malformed or lies outside the segment.
        """
        try:
            dt = np.dtype(dtype)
            if dt.hasobject:
                raise ValueError("object arrays are refused")
            shape = [int(n) for n in shape]
            count, offset = int(np.prod(shape, dtype=np.int64)), int(offset)
            if count < 0 or min(shape, default=0) < 0:
                raise ValueError(f"negative shape {shape}")
        except (TypeError, ValueError) as exc:
            raise BenchbotError(f"malformed shared-memory array descriptor: {exc}", "") from None
        if offset < 0 or offset + count * dt.itemsize > self.size:
            raise BenchbotError(f"shared-memory array [{offset}, {offset + count * dt.itemsize}) lies outside the "
                                f"{self.size}-byte segment", "")
        if count == 0:
            return np.empty(shape, dtype=dt)
        return np.frombuffer(self.view, dtype=dt, count=count, offset=offset).reshape(shape).copy()

    def close(self) -> None:
        """Unmap (idempotent)."""
        self._finalizer()
