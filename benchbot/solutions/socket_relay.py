"""Byte relays between a sandboxed solution and its backend, and the sandbox's first process.

A sandboxed solution (:mod:`benchbot.solutions.sandbox`) lives in a network namespace of its own that holds nothing but
its loopback device, so it cannot reach the backend's TCP port. It reaches the backend through one Unix socket that
the sandbox binds in:

* inside the sandbox, this file runs as a script, the sandbox's first process (``python -I -S socket_relay.py
  --socket PATH --port P [--port Q] [--rlimit NAME=SOFT:HARD ...] -- COMMAND...``): it listens on ``127.0.0.1:P``
  (and ``Q``) of the sandbox's loopback, relays every connection to the Unix socket, starts ``COMMAND`` once the
  ports listen, with those resource limits (``resource.RLIMIT_<NAME>``), and exits with the command's exit status
  (``128 + n`` when a signal ``n`` ended it);
* outside, the Unix socket is either served by the backend itself (a batch episode's server listens on it) or by a
  :class:`UnixToTcpRelay` that relays each connection to a backend's TCP address (``benchbot submit`` to the
  backend of ``benchbot run``).

Bytes are relayed as they are (HTTP, HTTPS, keep-alive): the relay reads nothing of them. Standard library only, so
that the script starts in milliseconds with ``-I -S`` and needs nothing of the environment it runs in.
"""

from __future__ import annotations

import resource
import signal
import socket
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

#: Bytes read from one side of a relayed connection at a time.
CHUNK = 1 << 20


def pump(source: socket.socket, sink: socket.socket) -> None:
    """Copy ``source`` to ``sink`` until ``source`` ends (or either fails), then end ``sink``'s sending side so the
    other end sees end-of-file; never raises."""
    buffer = bytearray(CHUNK)
    view = memoryview(buffer)
    try:
        while True:
            n = source.recv_into(buffer)
            if not n:
                break
            sink.sendall(view[:n])
    except OSError:
        pass
    try:
        sink.shutdown(socket.SHUT_WR)
    except OSError:
        pass


def join(a: socket.socket, b: socket.socket) -> None:
    """Relay ``a`` and ``b`` both ways on two daemon threads; both sockets are closed when both directions end."""

    def run(source: socket.socket, sink: socket.socket, done: threading.Event, other: threading.Event) -> None:
        pump(source, sink)
        done.set()
        if other.is_set():
            a.close()
            b.close()

    a_done, b_done = threading.Event(), threading.Event()
    threading.Thread(target=run, args=(a, b, a_done, b_done), daemon=True, name="relay").start()
    threading.Thread(target=run, args=(b, a, b_done, a_done), daemon=True, name="relay").start()


def serve(listener: socket.socket, connect) -> threading.Thread:
    """Accept connections on ``listener`` on a daemon thread, each joined (:func:`join`) with a new socket from
    ``connect()``; a connection whose ``connect()`` fails is closed. Returns the thread; it ends when ``listener``
    is closed."""

    def accept_loop() -> None:
        while True:
            try:
                client, _ = listener.accept()
            except OSError:
                return
            try:
                upstream = connect()
            except OSError:
                client.close()
                continue
            for sock in (client, upstream):
                if sock.family != socket.AF_UNIX:
                    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            join(client, upstream)

    thread = threading.Thread(target=accept_loop, daemon=True, name="relay-accept")
    thread.start()
    return thread


def connect_unix(path: str) -> socket.socket:
    """A stream socket connected to the Unix socket at ``path``.

    Raises:
        OSError: nothing listens there.
    """
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(path)
    except OSError:
        sock.close()
        raise
    return sock


class UnixToTcpRelay:
    """A Unix socket, in a new private folder (mode 0700), whose connections are relayed to ``host:port`` over TCP:
    how a sandboxed solution reaches a backend that another process serves (``benchbot submit``).

    Use as a context manager; :attr:`path` is the socket. Leaving it stops accepting and removes the folder
    (connections already relayed end with their peers).

    Args:
        host, port: the backend's TCP address.

    Raises:
        OSError: (on entering) the socket cannot be made.
    """

    def __init__(self, host: str, port: int) -> None:
        self.host, self.port = host, port
        self.folder = Path(tempfile.mkdtemp(prefix="benchbot-relay-"))
        self.path = self.folder / "backend.sock"
        self.listener: socket.socket | None = None

    def __enter__(self) -> "UnixToTcpRelay":
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.listener.bind(str(self.path))
        self.listener.listen(64)
        serve(self.listener, lambda: socket.create_connection((self.host, self.port), timeout=None))
        return self

    def __exit__(self, *exc: object) -> None:
        if self.listener is not None:
            try:
                self.listener.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            self.listener.close()
        self.path.unlink(missing_ok=True)
        try:
            self.folder.rmdir()
        except OSError:
            pass


def _listen_loopback(port: int) -> socket.socket:
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", port))
    listener.listen(64)
    return listener


def main(argv: list[str]) -> int:
    """The sandbox's first process: ``--socket PATH --port P [--port Q ...] [--rlimit ...] -- COMMAND...`` (the module
    docstring). SIGTERM and SIGINT are left to the command (they reach its process group too); this process exits
    when the command does. Exit status 125 with a line on stderr when the arguments are wrong, a port cannot be
    bound or the command cannot be started."""
    try:
        split = argv.index("--")
    except ValueError:
        split = len(argv)
    options, command = argv[:split], argv[split + 1:]
    socket_path, ports, limits = None, [], []
    for flag, value in zip(options[::2], options[1::2]):
        if flag == "--socket":
            socket_path = value
        elif flag == "--port":
            ports.append(int(value))
        elif flag == "--rlimit":  # NAME=SOFT:HARD, e.g. DATA=1073741824:1073741824 (resource.RLIMIT_DATA)
            name, _, values = value.partition("=")
            soft, _, hard = values.partition(":")
            limits.append((getattr(resource, f"RLIMIT_{name}"), int(soft), int(hard or soft)))
    if socket_path is None or not ports or not command or len(options) % 2:
        print("benchbot sandbox: usage: socket_relay.py --socket PATH --port P [--port Q] -- COMMAND...",
              file=sys.stderr)
        return 125
    try:
        for port in dict.fromkeys(ports):
            serve(_listen_loopback(port), lambda: connect_unix(socket_path))
    except OSError as exc:
        print(f"benchbot sandbox: cannot listen on 127.0.0.1 inside the sandbox: {exc}", file=sys.stderr)
        return 125
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, signal.SIG_IGN)
    try:
        child = subprocess.Popen(command, preexec_fn=lambda: _start_child(limits))
    except OSError as exc:
        print(f"benchbot sandbox: cannot start {command[0]}: {exc.strerror}", file=sys.stderr)
        return 127 if isinstance(exc, FileNotFoundError) else 126
    code = child.wait()
    return code if code >= 0 else 128 - code


def _start_child(limits: list[tuple[int, int, int]]) -> None:
    """In the command's process before it starts: default SIGTERM, SIGINT and SIGXFSZ (Python ignores the last; a
    program past its file size limit is then ended by it, as without Python in between), and the resource limits
    (soft and hard: with no capability, the command cannot raise them again). Set here, inside the sandbox's user
    namespace, ``RLIMIT_NPROC`` counts the sandbox's tasks only (docs/security.md, "Resource limits")."""
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGXFSZ):
        signal.signal(sig, signal.SIG_DFL)
    for which, soft, hard in limits:
        resource.setrlimit(which, (soft, hard))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
