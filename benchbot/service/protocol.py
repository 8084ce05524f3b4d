"""The simulator service's wire format and its check of who connects.

A message is a 4-byte big-endian length followed by that many bytes of MessagePack: a map with ``op`` (a request,
client → service) or ``event`` (a reply or a report, service → client). Nothing is ever unpickled. Arrays in a
message (a pose in a step's report) become lists of floats (:func:`_plain`).

Requests: ``{op: "status"}`` → ``{event: "status", ...}``; ``{op: "stop"}`` → ``{event: "stopping"}``;
``{op: "episode", run, seed, options, world_seed, unix_socket}`` → ``stage``/``ready``/``step`` events, then, after
the client's ``{op: "finish"}``, ``{event: "finished", state, backend}`` (:mod:`benchbot.service.daemon`). Any
failure is ``{event: "error", message, hint, exit_code}``. An episode request with ``tcp: {host, token,
action_timeout_s, tls_cert, tls_key}`` (``benchbot run``) is followed by one byte carrying the command's listening
TCP socket (``SCM_RIGHTS``, :func:`send_listener`): the backend is served on that socket with those settings.
"""

from __future__ import annotations

import os
import socket
import struct
from typing import Any

import msgpack

from benchbot.core.errors import BackendError

#: Largest message either side accepts (a run's specs are a few kB; a step's report a few hundred bytes).
MAX_MESSAGE_BYTES = 16 << 20
_LENGTH = struct.Struct(">I")


class ConnectionLost(BackendError):
    """The other side closed the connection (or it broke) before a whole message arrived."""


def _plain(value: Any) -> Any:
    """MessagePack's fallback for what it cannot pack: NumPy arrays and scalars as lists and numbers, sets and tuples
    as lists, anything else as its ``str``."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, (set, frozenset, tuple)):
        return list(value)
    return str(value)


def pack(message: dict) -> bytes:
    """``message`` framed: its length (4 bytes, big-endian) and its MessagePack bytes.

    Raises:
        ValueError: the packed message is larger than :data:`MAX_MESSAGE_BYTES`."""
    body = msgpack.packb(message, default=_plain, use_bin_type=True)
    if len(body) > MAX_MESSAGE_BYTES:
        raise ValueError(f"a service message of {len(body)} bytes is larger than {MAX_MESSAGE_BYTES}")
    return _LENGTH.pack(len(body)) + body


def send(sock: socket.socket, message: dict) -> None:
    """Send one message (:func:`pack`).

    Raises:
        ConnectionLost: the connection is closed or broken."""
    try:
        sock.sendall(pack(message))
    except OSError as exc:
        raise ConnectionLost(f"the connection to the simulator service broke: {exc.strerror or exc}") from None


def _read_exactly(sock: socket.socket, count: int) -> bytes:
    chunks, left = [], count
    while left:
        try:
            chunk = sock.recv(min(left, 1 << 20))
        except OSError as exc:
            raise ConnectionLost(f"the connection to the simulator service broke: {exc.strerror or exc}") from None
        if not chunk:
            raise ConnectionLost("the simulator service closed the connection")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def receive(sock: socket.socket) -> dict:
    """Read one message.

    Raises:
        ConnectionLost: the connection closed or broke first, or the message is too large or not a map."""
    (length,) = _LENGTH.unpack(_read_exactly(sock, _LENGTH.size))
    if length > MAX_MESSAGE_BYTES:
        raise ConnectionLost(f"a service message announced {length} bytes, more than {MAX_MESSAGE_BYTES}")
    try:
        message = msgpack.unpackb(_read_exactly(sock, length), raw=False, strict_map_key=False)
    except (ValueError, msgpack.UnpackException) as exc:
        raise ConnectionLost(f"a service message could not be read: {exc}") from None
    if not isinstance(message, dict):
        raise ConnectionLost("a service message is not a map")
    return message


def peer_credentials(sock: socket.socket) -> tuple[int, int, int]:
    """``(pid, uid, gid)`` of the process at the other end of the Unix socket ``sock`` (``SO_PEERCRED``: what the
    kernel recorded when it connected, in this process's namespaces)."""
    creds = sock.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i"))
    return struct.unpack("3i", creds)


def _user_namespace(pid: int | str) -> str | None:
    try:
        return os.readlink(f"/proc/{pid}/ns/user")
    except OSError:
        return None


def peer_problem(sock: socket.socket) -> str:
    """Why the peer of ``sock`` may not use the service ("" when it may): it must be a process of this user
    (``SO_PEERCRED``'s uid) in this process's user namespace. A sandboxed solution runs in a user namespace of its
    own (``bwrap --unshare-user``), so it is refused even if it could reach the socket; a peer whose namespace cannot
    be read is refused too."""
    pid, uid, _ = peer_credentials(sock)
    if uid != os.geteuid():
        return f"refused a connection from user id {uid} (pid {pid}): the service serves only its owner"
    theirs, ours = _user_namespace(pid), _user_namespace("self")
    if theirs is None or theirs != ours:
        return (f"refused a connection from pid {pid}: it runs in another user namespace (a sandbox or a container), "
                "or its namespace cannot be read")
    return ""


def send_listener(sock: socket.socket, listener: socket.socket) -> None:
    """Pass ``listener`` (a listening TCP socket) to the other end of the Unix socket ``sock``: one byte with its file
    descriptor (``SCM_RIGHTS``); the other end gets its own descriptor of the same socket (:func:`receive_listener`).

    Raises:
        ConnectionLost: the connection is closed or broken."""
    try:
        socket.send_fds(sock, [b"L"], [listener.fileno()])
    except OSError as exc:
        raise ConnectionLost(f"the connection to the simulator service broke: {exc.strerror or exc}") from None


def receive_listener(sock: socket.socket) -> socket.socket:
    """The listening socket the other end passed with :func:`send_listener` (the next byte on ``sock``).

    Raises:
        ConnectionLost: the connection closed or broke first, or the byte carried no socket."""
    try:
        data, fds, _, _ = socket.recv_fds(sock, 1, 1)
    except OSError as exc:
        raise ConnectionLost(f"the connection to the simulator service broke: {exc.strerror or exc}") from None
    if data != b"L" or len(fds) != 1:
        for fd in fds:
            os.close(fd)
        raise ConnectionLost("the episode's listening socket did not arrive")
    return socket.socket(fileno=fds[0])
