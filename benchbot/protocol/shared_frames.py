"""The same-host fast path of the native step: observation arrays travel through shared memory instead of the HTTP
reply.

The backend keeps one *segment* per client: a file ``/dev/shm/benchbot-<32 hex digits>`` (mode 0600, in RAM:
``/dev/shm`` is a tmpfs) in :data:`SLOTS` slots, that it creates, maps and writes; the client maps it read-only and
hands out the arrays as read-only views of a slot no earlier array still uses (one ``memcpy``, on the backend's side;
the HTTP exchange carries a few kilobytes instead of megabytes). See :class:`ClientMapping` for when a slot is
reused.

Handshake (no step's data can be lost on the way):

1. the client sends ``shm: {"client": <32 hex, its own id>, "segment": <name of the segment it has mapped, or
   null>, "slot": <a slot it has free>}`` with each step;
2. when ``segment`` names the client's current segment and its slots are large enough, the backend writes each
   array of at least :data:`MIN_BYTES` into that slot and sends ``{"__shm__": dtype, "shape": [...], "offset":
   bytes}`` in its place;
3. otherwise (first step, the segment had to grow, was evicted) the reply carries every array inline, plus
   ``shm_segment: {"name", "size", "slots"}`` for the client to map before its next step. A client that cannot
   map it (its ``/dev/shm`` is not the backend's, e.g. in a container) stops asking (a segment missing from
   ``/dev/shm`` is asked for again up to :data:`MAP_ATTEMPTS` times in a row: the backend may have evicted it
   before the client mapped it); a reply is never unreadable.

Only loopback clients are offered segments, and the clients of a Unix socket the backend serves a sandboxed solution
on (:meth:`SegmentPool.serve_socket`): theirs are made in that socket's own episode folder
(:func:`episode_folder`, mode 0700, at most :data:`EPISODE_SEGMENTS` at once and :data:`EPISODE_SEGMENT_BYTES` over
the episode), which the sandbox binds read-only where its client looks (``$BENCHBOT_SHARED_MEMORY_DIR``,
:func:`client_folder`). The backend holds at most :data:`MAX_SEGMENTS` (the least recently used
is removed), removes a segment's file as soon as its client has mapped it (so a killed backend leaves no segment in
``/dev/shm``) and the rest when it closes or exits. A killed backend's episode folder (empty, or holding segments no
client mapped) and its owner file are removed by the next batch's start
(:func:`benchbot.solutions.leftovers.clean_leftovers`), never while their backend lives. Only the backend's user can
open them (0600). Linux only (``/dev/shm``); elsewhere :func:`available` is False and clients use the inline path.

Lifetime of the arrays a client holds: they stay valid and unchanged for as long as the caller keeps them, across
``BenchBot.close()`` and across an eviction. Each segment is its own file, so its memory is shared only by the
backend and the one client it was made for; the backend never writes to a segment again once it has evicted or
closed it, and unmaps its side; the client's mapping, whose ``mmap`` object is the base of every array read from
it, is unmapped only when the last of those arrays is garbage-collected (:meth:`ClientMapping.close`). The price: a
client that keeps arrays from an evicted segment keeps that segment's memory (``SLOTS`` × a step's arrays) until it
drops them.
"""

from __future__ import annotations

import ipaddress
import math
import mmap
import os
import re
import secrets
import socket
import threading
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
#: Slots of a segment, each holding one step's arrays. The client hands out the arrays of slots 0..SLOTS-2 as
#: read-only views (no copy) and asks for a slot only when no array from it is alive; slot SLOTS-1 is its scratch
#: slot, copied out, for when every other slot is still held.
SLOTS = 4
#: Announced segments a client may find gone from /dev/shm in a row (the backend evicted each before the client
#: mapped it) before it stops asking; any other failure to map stops it at once (its /dev/shm is not the backend's).
MAP_ATTEMPTS = 3
#: Environment variable that turns the path off in clients (``0``).
ENV_SWITCH = "BENCHBOT_SHARED_MEMORY"
#: Environment variable naming the folder where a client finds its segments (default :data:`SHM_DIR`); the sandbox
#: sets it to :data:`~benchbot.solutions.sandbox.INSIDE_FRAMES`, where its episode's folder is bound read-only.
ENV_FOLDER = "BENCHBOT_SHARED_MEMORY_DIR"
#: Segments the backend keeps in an episode's folder (:func:`episode_folder`): a sandboxed solution's clients.
EPISODE_SEGMENTS = 2
#: Bytes of segments the backend makes in an episode's folder over the whole episode; past them its clients get
#: inline replies. A sandboxed solution's mappings are charged to the backend, which wrote the pages, not to the
#: sandbox's memory limit: this bounds what it can hold that way (a 640x480 RGB-D step's segment is about 11 MB).
EPISODE_SEGMENT_BYTES = 64 << 20


def client_folder() -> str:
    """Where this client opens segments: ``$BENCHBOT_SHARED_MEMORY_DIR``, else :data:`SHM_DIR`."""
    from benchbot.core import settings

    return settings.get(ENV_FOLDER) or SHM_DIR


def unavailable_reason() -> str | None:
    """Why a client cannot use segments here, in one line naming the setting and the fix; ``None`` when it can.

    It cannot where ``$BENCHBOT_SHARED_MEMORY`` is ``0`` (or any value but ``0`` and ``1``, read as ``0``), or where
    :func:`client_folder` is no folder it can read (:data:`SHM_DIR` must also be writable: the backend may be this
    process's). Its frames then come in the HTTP reply: the same arrays, more copies."""
    from benchbot.core import settings

    switch = settings.get(ENV_SWITCH)
    if switch == "0":
        return f"{ENV_SWITCH}=0: frames come in the HTTP reply"
    if switch != "1":
        return (f"{ENV_SWITCH}={switch!r} is not 0 or 1, taken as 0: frames come in the HTTP reply (set it to 1, or "
                "unset it, for shared memory)")
    folder = client_folder()
    need = os.R_OK | os.X_OK if folder != SHM_DIR else os.W_OK | os.X_OK
    if os.path.isabs(folder) and os.path.isdir(folder) and os.access(folder, need):
        return None
    if settings.source(ENV_FOLDER) == "default":
        return f"{SHM_DIR} is not a folder this process can write (no shared memory): frames come in the HTTP reply"
    what = "an absolute path" if not os.path.isabs(folder) else "a folder this process can read" \
        if folder != SHM_DIR else "a folder this process can write"
    return (f"{ENV_FOLDER}={folder!r} is not {what}: frames come in the HTTP reply (unset it for {SHM_DIR}, or name "
            "the folder where the backend makes this client's segments)")


def available() -> bool:
    """True where a client can use segments (:func:`unavailable_reason` gives none)."""
    return unavailable_reason() is None


def episode_folder(unix_socket: str | os.PathLike) -> str:
    """The folder in :data:`SHM_DIR` (a tmpfs) that holds the segments of the clients that reach a backend through
    the Unix socket ``unix_socket`` (a sandboxed solution's way in): ``/dev/shm/benchbot-frames-<32 hex>``, named by
    the SHA-256 of the socket's absolute path, so that the backend that serves the socket and the sandbox that binds
    it find the same folder. The backend makes it (:func:`make_episode_folder`); the sandbox binds it read-only."""
    import hashlib

    from benchbot.solutions.leftovers import FRAMES_PREFIX

    digest = hashlib.sha256(os.path.abspath(os.fspath(unix_socket)).encode()).hexdigest()[:32]
    return os.path.join(SHM_DIR, f"{FRAMES_PREFIX}{digest}")


def is_private_folder(path: str) -> bool:
    """Whether ``path`` is a real directory (no symbolic link) owned by this process's user that no one else may
    enter (mode 0700 or stricter): an episode's folder that no other user made or can read."""
    try:
        info = os.lstat(path)
    except OSError:
        return False
    import stat

    return stat.S_ISDIR(info.st_mode) and info.st_uid == os.geteuid() and info.st_mode & 0o077 == 0


def make_episode_folder(path: str) -> tuple[str, int]:
    """Make the episode's folder ``path`` (mode 0700) with its owner file beside it, ``<path>.owner``, locked by this
    process (:func:`benchbot.solutions.leftovers.lock_owner_file`): while it is held, the folder is in use, and once
    this process is gone (killed) :func:`benchbot.solutions.leftovers.clean_leftovers` may remove both. A folder left
    by a killed backend of this user is emptied and kept.

    Returns:
        ``(path, descriptor of the locked owner file)``: :func:`remove_episode_folder` with it lets both go.

    Raises:
        OSError: it cannot be made; ``path`` exists and is not this user's private folder (someone else made it); or
            a live process owns it (another backend serving the same socket path).
    """
    from benchbot.solutions.leftovers import lock_owner_file, take_abandoned_lock

    owner = owner_file(path)
    previous = take_abandoned_lock(owner)
    if previous is None and os.path.lexists(owner):
        raise OSError(f"{path} is in use by a live backend, or its owner file {owner} is not this user's")
    if previous is not None:
        os.close(previous)
    fd = lock_owner_file(owner)
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        if not is_private_folder(path):
            _let_go(owner, fd)
            raise OSError(f"{path} exists and is not this user's private folder") from None
        remove_episode_folder(path, keep=True)
    except OSError:
        _let_go(owner, fd)
        raise
    return path, fd


def owner_file(path: str) -> str:
    """The owner file of the episode's folder ``path``: ``<path>.owner``, beside it (never inside: the sandbox that
    binds the folder sees only frames)."""
    from benchbot.solutions.leftovers import FRAMES_OWNER_SUFFIX

    return path + FRAMES_OWNER_SUFFIX


def _let_go(owner: str, fd: int) -> None:
    """Remove the owner file ``owner`` and release its lock (descriptor ``fd``)."""
    try:
        os.unlink(owner)
    except OSError:
        pass
    os.close(fd)


def remove_episode_folder(path: str, keep: bool = False, owner_fd: int | None = None) -> None:
    """Remove the files in an episode's folder (links are removed, never followed), and the folder unless ``keep``
    (missing: nothing to do); then, given ``owner_fd`` (the descriptor :func:`make_episode_folder` returned), its
    owner file and lock. Never raises."""
    try:
        names = os.listdir(path)
    except OSError:
        names = []
    for name in names:
        try:
            os.unlink(os.path.join(path, name))
        except OSError:  # gone, or a folder (the backend makes none)
            pass
    if not keep:
        try:
            os.rmdir(path)
        except OSError:
            pass
    if owner_fd is not None:
        _let_go(owner_file(path), owner_fd)


def is_loopback(host: str) -> bool:
    """True when ``host`` is a loopback address: an IP address in 127.0.0.0/8 or ``::1`` (also IPv4-mapped, in
    brackets, or with a zone), or the name ``localhost`` when every address it resolves to (``getaddrinfo``) is one.
    Decided by the parsed address, never by the text: ``127.evil.example`` is a name, not an address, and any name
    other than ``localhost`` is not loopback."""
    text = host.strip()
    if text.startswith("[") and text.endswith("]"):
        text = text[1:-1]
    address = _loopback_address(text)
    if address is not None:
        return address
    if text.lower().rstrip(".") != "localhost":
        return False
    try:
        resolved = {info[4][0] for info in socket.getaddrinfo(text, None)}
    except (OSError, UnicodeError):
        return False
    return bool(resolved) and all(_loopback_address(str(a)) is True for a in resolved)


def _loopback_address(text: str) -> bool | None:
    """Whether IP address ``text`` is loopback; None when ``text`` is not an IP address."""
    try:
        address = ipaddress.ip_address(text.split("%", 1)[0])
    except ValueError:
        return None
    mapped = getattr(address, "ipv4_mapped", None)
    return bool((mapped or address).is_loopback)


def aligned(n: int) -> int:
    """``n`` rounded up to a multiple of :data:`ALIGN`."""
    return (n + ALIGN - 1) // ALIGN * ALIGN


def is_shared(arr: np.ndarray) -> bool:
    """Whether ``arr`` travels through the segment: at least :data:`MIN_BYTES` and not an object array."""
    return arr.nbytes >= MIN_BYTES and not arr.dtype.hasobject


def large_arrays(obj) -> list[np.ndarray]:
    """The ndarrays in ``obj`` (nested dicts, lists, tuples) that :func:`is_shared` sends through the segment, in
    packing order."""
    if isinstance(obj, np.ndarray):
        return [obj] if is_shared(obj) else []
    if isinstance(obj, dict):
        return [a for v in obj.values() for a in large_arrays(v)]
    if isinstance(obj, (list, tuple)):
        return [a for v in obj for a in large_arrays(v)]
    return []


def _release(view: mmap.mmap, fd: int, path: str | None) -> None:
    try:
        view.close()  # the backend's side: it writes through slices, no array views it
    except BufferError:
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
        folder: where the file is made (an episode's folder, :func:`episode_folder`, for a sandboxed solution).

    Raises:
        OSError: the file cannot be made or mapped (no ``/dev/shm``, full).
    """

    def __init__(self, size: int, folder: str = SHM_DIR) -> None:
        self.name = f"benchbot-{secrets.token_hex(16)}"
        self.folder = folder
        path = os.path.join(folder, self.name)
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
    """The backend's segments by client id (the most recent :data:`MAX_SEGMENTS`), and, once :meth:`serve_socket`
    named an episode's folder, those of the clients on the backend's Unix socket in that folder (the most recent
    :data:`EPISODE_SEGMENTS`, and :data:`EPISODE_SEGMENT_BYTES` over the episode). Used from one thread (the backend
    thread, which packs each native step's reply)."""

    def __init__(self, capacity: int = MAX_SEGMENTS) -> None:
        self.capacity = capacity
        self.socket_folder: str | None = None
        self._socket_folder_owner: int | None = None  # the locked owner file's descriptor (make_episode_folder)
        self._by_client: OrderedDict[str, BackendSegment] = OrderedDict()
        self._by_socket_client: OrderedDict[str, BackendSegment] = OrderedDict()
        self._socket_bytes = 0  # made in the episode's folder so far (EPISODE_SEGMENT_BYTES)

    def serve_socket(self, unix_socket: str | os.PathLike) -> None:
        """Offer segments to the clients of the Unix socket ``unix_socket`` too, in its episode's folder
        (:func:`episode_folder`, made here, mode 0700, with its owner file locked by this process until
        :meth:`close` removes both: :func:`make_episode_folder`). A folder that cannot be made (no ``/dev/shm``,
        another user made it, a live process owns it) leaves those clients on the inline path."""
        if self.socket_folder is not None:  # a second socket: the first one's folder is let go
            remove_episode_folder(self.socket_folder, owner_fd=self._socket_folder_owner)
        try:
            self.socket_folder, self._socket_folder_owner = make_episode_folder(episode_folder(unix_socket))
        except OSError:
            self.socket_folder = None

    def pack(self, reply: dict, offer: tuple[str, str | None, int], via_socket: bool = False) -> bytes:
        """``reply`` packed for a client whose ``shm`` field is ``offer`` (as :func:`check_offer` returns it; see
        the module doc): large arrays in the requested slot of its segment when it has mapped it, else inline with
        ``shm_segment`` to map (or ``shm_error`` when none can be made). ``via_socket``: the client came through the
        Unix socket of :meth:`serve_socket` (its segment is made in that folder).

        Args:
            reply: the step's reply, nested dicts, lists and tuples; its NumPy arrays of at least :data:`MIN_BYTES`
                and of any dtype but ``object`` (``image_rgb`` (H, W, 3) uint8, ``image_depth`` (H, W) float32
                metres, ...) go into the segment as C-contiguous bytes, each at a :data:`ALIGN`-byte offset, and
                are sent as ``{"__shm__": dtype string, "shape", "offset": bytes}``; the rest inline.
            offer: ``(client id, mapped segment name or None, slot)``.

        Returns:
            The reply's bytes (:func:`benchbot.protocol.wire.pack`). Never raises for a segment that cannot be
            made: the reply then says why (``shm_error``).
        """
        from benchbot.protocol import wire

        client, mapped, slot = offer
        folder, segments, capacity = (self.socket_folder, self._by_socket_client, EPISODE_SEGMENTS) if via_socket \
            else (SHM_DIR, self._by_client, self.capacity)
        needed = sum(aligned(a.nbytes) for a in large_arrays(reply))
        segment = segments.pop(client, None)
        if segment is not None and needed > segment.size // SLOTS:
            segment.close()
            segment = None
        if segment is None:
            size = SLOTS * max(aligned(needed + needed // 4), 1 << 18)
            if via_socket and self._socket_bytes + size > EPISODE_SEGMENT_BYTES:
                return wire.pack({**reply, "shm_error": "the episode's shared-memory budget is spent "
                                                        f"({EPISODE_SEGMENT_BYTES} bytes of segments)"})
            try:
                segment = BackendSegment(size, folder) if via_socket else BackendSegment(size)
            except OSError as exc:
                return wire.pack({**reply, "shm_error": f"no shared-memory segment: {exc.strerror or exc}"})
            self._socket_bytes += size if via_socket else 0
        segments[client] = segment
        while len(segments) > capacity:
            segments.popitem(last=False)[1].close()
        if mapped != segment.name:
            return wire.pack({**reply, "shm_segment": {"name": segment.name, "size": segment.size, "slots": SLOTS}})
        segment.unlink()  # the client has it mapped
        offset = slot * (segment.size // SLOTS)

        def place(arr: np.ndarray) -> dict | None:
            nonlocal offset
            if not is_shared(arr):
                return None
            arr = np.ascontiguousarray(arr)
            segment.write(arr, offset)
            ref = {wire.SHM: arr.dtype.str, "shape": list(arr.shape), "offset": offset}
            offset = aligned(offset + arr.nbytes)
            return ref

        return wire.pack(reply, place)

    def close(self) -> None:
        """Remove every segment, and the episode's folder."""
        for segments in (self._by_client, self._by_socket_client):
            while segments:
                segments.popitem()[1].close()
        if self.socket_folder is not None:
            remove_episode_folder(self.socket_folder, owner_fd=self._socket_folder_owner)
            self.socket_folder = self._socket_folder_owner = None


def check_offer(offer: object) -> tuple[str, str | None, int]:
    """``(client id, mapped segment name or None, slot)`` of a request's ``shm`` field.

    Raises:
        BenchbotError: not ``{"client": <32 hex>, "segment": <segment name or null>, "slot": <0..SLOTS-1>}``
            (``slot`` may be left out: 0).
    """
    if not isinstance(offer, dict) or not isinstance(offer.get("client"), str) \
            or not CLIENT_PATTERN.fullmatch(offer["client"]):
        raise BenchbotError("'shm' must be {client: <32 hex digits>, segment: <name or null>}", "leave 'shm' out")
    mapped = offer.get("segment")
    if mapped is not None and not (isinstance(mapped, str) and NAME_PATTERN.fullmatch(mapped)):
        raise BenchbotError("'shm.segment' must be a segment name benchbot-<32 hex digits> or null",
                            "send the name from the last shm_segment reply")
    slot = offer.get("slot", 0)
    if not isinstance(slot, int) or isinstance(slot, bool) or not 0 <= slot < SLOTS:
        raise BenchbotError(f"'shm.slot' must be an integer in [0, {SLOTS})", "send the slot the client has free")
    return offer["client"], mapped, slot


class ClientMapping:
    """The client's read-only mapping of the segment the backend made for it, in ``slots`` equal slots.

    Arrays of slots ``0 .. slots-2`` are handed out as read-only views of the mapping (no copy); each slot counts its
    live arrays (and their views, which keep them alive) and :meth:`free_slot` offers the backend only a slot with
    none alive, so an array is never overwritten while anything refers to it. The last slot is the scratch slot:
    its arrays are copied out, for the steps when every other slot is still held. The arrays outlive the mapping's
    :meth:`close` (see there): the memory is unmapped only when the last of them is gone.

    Args:
        name: the segment name (``shm_segment.name`` of a reply). size: its size in bytes. slots: its slot count.

    Raises:
        OSError: it cannot be opened or mapped (e.g. this process's ``/dev/shm`` is not the backend's).
        BenchbotError: a malformed name, size or slot count.
    """

    def __init__(self, name: str, size: int, slots: int = 1) -> None:
        if not (isinstance(name, str) and NAME_PATTERN.fullmatch(name)) or not isinstance(size, int) or size <= 0 \
                or not isinstance(slots, int) or not 1 <= slots <= 64:
            raise BenchbotError(f"malformed shm_segment {name!r} ({size!r} bytes, {slots!r} slots)", "")
        fd = os.open(os.path.join(client_folder(), name), os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0)
                     | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NONBLOCK", 0))
        try:
            if os.fstat(fd).st_size < size:
                raise OSError(f"{name} is smaller than announced")
            view = mmap.mmap(fd, size, prot=mmap.PROT_READ)
        finally:
            os.close(fd)  # the mapping keeps the memory (and its own descriptor)
        self.name, self.size = name, size
        self.view: mmap.mmap | None = view
        self.slots, self.slot_size = slots, size // slots
        self._live = [0] * slots
        self._lock = threading.Lock()

    def free_slot(self) -> int:
        """The slot the backend may write next: the first view slot with no live array, else the scratch slot."""
        with self._lock:
            return next((k for k in range(self.slots - 1) if self._live[k] == 0), self.slots - 1)

    def _released(self, slot: int) -> None:
        with self._lock:
            self._live[slot] -= 1

    def read(self, dtype: str, shape: list, offset: int) -> np.ndarray:
        """The read-only array of ``dtype`` (a NumPy dtype string, e.g. ``'<f4'``) and ``shape`` at ``offset``: a
        view of the mapping in a view slot, a copy in the scratch slot.

        Raises:
            BenchbotError: the descriptor is malformed or lies outside the segment.
        """
        try:
            dt = np.dtype(dtype)
            if dt.hasobject:
                raise ValueError("object arrays are refused")
            shape = [int(n) for n in shape]
            if min(shape, default=0) < 0:
                raise ValueError(f"negative shape {shape}")
            count, offset = math.prod(shape), int(offset)
        except (TypeError, ValueError) as exc:
            raise BenchbotError(f"malformed shared-memory array descriptor: {exc}", "") from None
        end = offset + count * dt.itemsize
        view = self.view  # this call's own reference: a concurrent close() cannot unmap it under us
        if view is None:
            raise BenchbotError(f"shared-memory segment {self.name} was closed",
                                "the client was closed while this step was in flight")
        if offset < 0 or end > self.size:
            raise BenchbotError(f"shared-memory array [{offset}, {end}) lies outside the {self.size}-byte segment", "")
        slot = offset // self.slot_size
        if count == 0 or slot == self.slots - 1 or end > (slot + 1) * self.slot_size:
            out = np.empty(shape, dtype=dt)
            if count:
                out[...] = np.ndarray(shape, dtype=dt, buffer=view, offset=offset)
            out.flags.writeable = False
            return out
        # The array's base is the mmap object, and every view a caller takes of it has the array as its base (NumPy
        # stops the base chain at an array whose base is not an array): the slot stays busy, and the memory mapped,
        # until the last of them is gone.
        out = np.ndarray(shape, dtype=dt, buffer=view, offset=offset)
        with self._lock:
            self._live[slot] += 1
        weakref.finalize(out, self._released, slot)
        return out

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called (arrays read before may still hold the memory)."""
        return self.view is None

    def close(self) -> None:
        """Let go of the mapping (idempotent): it is unmapped as soon as no array read from it is alive, at once if
        none is. Never earlier: NumPy 2 does not pin an ``mmap`` that an array views (``mmap.close()`` would
        succeed and the array would then read unmapped memory, a SIGSEGV, or whatever is mapped there next), so
        the mapping is never closed explicitly; the ``mmap`` object, the base of every array :meth:`read` hands
        out, unmaps when the last of them is garbage-collected."""
        self.view = None
