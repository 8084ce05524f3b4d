"""``benchbot service start|status|stop``: the resident simulator service (docs/service.md)."""

from __future__ import annotations


import typer

from benchbot.cli.common import err, handle_errors, out, print_json


def _describe(status: dict, key: str) -> list[tuple[str, str]]:
    """The rows ``benchbot service status`` prints for a service's status answer."""
    mine = "yes" if status.get("key") == key else "no (other code or settings: the next command replaces it when idle)"
    return [("pid", str(status.get("pid"))), ("serves this installation", mine),
            ("up for", f"{status.get('uptime_s', 0):.0f} s"),
            ("idle for", f"{status.get('idle_for_s', 0):.0f} s of {status.get('idle_s', 0):g} s (then it stops)"),
            ("episodes", f"{status.get('episodes_served', 0)} served, {status.get('episodes_running', 0)} running"),
            ("memory", f"{status.get('rss_bytes', 0) / (1 << 20):.0f} MiB"),
            ("pool workers", _pool_row(status)), ("log", str(status.get("log", "")))]


def _pool_row(status: dict) -> str:
    """The warm worker processes of the service's pool, in a few words: ``2 of at most 32 (1 busy; GPU 0: 1, GPU
    1: 1)``."""
    pool = status.get("pool") or []
    on = {}
    for worker in pool:
        if worker.get("gpu"):
            on[worker["gpu"]["index"]] = on.get(worker["gpu"]["index"], 0) + 1
    where = "".join(f"; GPU {k}: {n}" for k, n in sorted(on.items()))
    busy = sum(1 for w in pool if w.get("busy"))
    return f"{len(pool)} of at most {status.get('pool_limit', '?')} ({busy} busy{where})"


def register(app: typer.Typer) -> None:
    service_app = typer.Typer(help="The resident simulator service: it keeps Taichi, its kernels and scenes loaded "
                                   "between commands (docs/service.md).", no_args_is_help=True)
    app.add_typer(service_app, name="service")

    @service_app.command("start")
    @handle_errors
    def start() -> None:
        """Start the simulator service for this installation (a command that needs it starts it by itself)."""
        from benchbot.service import client
        from benchbot.service.location import locate

        location = locate()
        said: list[str] = []
        sock = client.start(location, say=said.append)
        sock.close()
        err.print(said[0] if said else "the simulator service is already running", highlight=False)

    @service_app.command("status")
    @handle_errors
    def status(as_json: bool = typer.Option(False, "--json", help="Print JSON (for machines).")) -> None:
        """Whether the simulator service runs, for which installation, how long it has been idle, what it served."""
        from benchbot.service import client
        from benchbot.service.location import locate

        location = locate()
        answer = client.ask(location, "status")
        if as_json:
            shown = {"running": answer is not None, "this_installation": location.key}
            if answer is not None:
                shown.update({k: v for k, v in answer.items() if k != "event"})
            print_json(shown)
            return
        if answer is None:
            out.print("no simulator service is running (a command that needs it starts it)", highlight=False)
            return
        for name, value in _describe(answer, location.key):
            out.print(f"{name + ':':26} {value}", highlight=False)

    @service_app.command("stop")
    @handle_errors
    def stop() -> None:
        """Stop the simulator service (an episode it serves ends with a one-line error)."""
        from benchbot.core.errors import BackendError
        from benchbot.service import client
        from benchbot.service.location import locate

        location = locate()
        answer = client.ask(location, "stop")
        if answer is None:
            err.print("no simulator service is running")
            return
        pid = int(answer.get("pid", 0))
        if not client.wait_until_gone(location, pid):
            raise BackendError(f"the simulator service (pid {pid}) did not stop within 15 s", f"kill {pid}")
        err.print(f"stopped the simulator service (pid {pid})")
