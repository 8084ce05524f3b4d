"""A warm simulator worker of the service's pool: ``python -m benchbot.service.worker --socket PATH``
(:class:`benchbot.service.pool.WorkerPool` starts it, with its Taichi threads and its GPU in its environment).

It builds the registry once, then serves episodes one after another on its own Unix socket (in the service's private
folder, mode 0600), each exactly as the service serves one (:func:`benchbot.service.daemon.serve_episode`): Taichi
is initialised once in it, its kernels compiled once, and the scenes it loaded last stay loaded
(:func:`benchbot.service.set_resident`). Only the service talks to it (same user, same user namespace:
:func:`benchbot.service.protocol.peer_problem`). It exits when the service exits (its parent), when its socket is
taken away, and on SIGTERM.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import socket
import sys
import threading
import time
import traceback

from benchbot.service import protocol, set_resident

log = logging.getLogger("benchbot.service.worker")
#: Seconds between two looks at whether the service (this worker's parent) is still there.
PARENT_POLL_S = 0.5


def _exit_with_parent(parent: int) -> None:
    """Exit at once when the service that started this worker is gone (it was killed: nobody would stop us)."""
    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(0)

    threading.Thread(target=watch, name="benchbot-worker-parent", daemon=True).start()


def listen(path: str) -> socket.socket:
    """A pool worker's listening Unix socket at ``path`` (:func:`benchbot.service.location.listen_private`)."""
    from benchbot.service.location import listen_private

    return listen_private(path, backlog=4)


def serve(listener: socket.socket, registry) -> None:
    """Serve one episode connection after another, forever (each: the peer checked, one ``episode`` request)."""
    from benchbot.service.daemon import error_event, serve_episode

    while True:
        conn, _ = listener.accept()
        try:
            problem = protocol.peer_problem(conn)
            if problem:
                log.warning(problem)
                continue
            request = protocol.receive(conn)
            if request.get("op") != "episode":
                wrong = ValueError(f"a pool worker serves episodes, not {request.get('op')!r}")
                protocol.send(conn, error_event(wrong))
                continue
            port = protocol.receive_listener(conn) if request.get("tcp") else None  # benchbot run's TCP socket
            try:
                serve_episode(registry, conn, request, port)
            finally:
                if port is not None:
                    port.close()
        except protocol.ConnectionLost:
            pass
        except Exception:  # noqa: BLE001 - one episode's failure never stops the worker
            log.error("an episode failed:\n%s", traceback.format_exc())
        finally:
            conn.close()


def main(argv: list[str] | None = None) -> int:
    """Run the worker until its service goes away or it is told to stop; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m benchbot.service.worker")
    parser.add_argument("--socket", required=True, help="where to listen (in the service's private folder)")
    parser.add_argument("--parent", type=int, required=True, help="the service's pid: exit when it is gone")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, stream=sys.stderr,
                        format=f"%(asctime)s worker[{os.getpid()}] %(levelname)s %(message)s")
    _exit_with_parent(args.parent)
    signal.signal(signal.SIGTERM, lambda *_: os._exit(0))
    os.chdir("/")
    set_resident()
    listener = listen(args.socket)  # first: the service's connection waits in the backlog meanwhile
    from benchbot.core.registry import get_registry

    registry = get_registry()
    log.info("serving at %s (GPU %s)", args.socket, os.environ.get("CUDA_VISIBLE_DEVICES", "as the service's"))
    serve(listener, registry)
    return 0


if __name__ == "__main__":
    sys.stderr.flush()
    os._exit(main())
