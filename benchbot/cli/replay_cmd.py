"""``benchbot replay FILE.mcap``: serve a recorded passive episode as a backend (no simulator)."""

from __future__ import annotations

from pathlib import Path

import typer

from benchbot.cli.common import err, handle_errors, registry, wait_until_interrupted


def register(app: typer.Typer) -> None:
    @app.command("replay")
    @handle_errors
    def replay(
        file: Path = typer.Argument(..., help="A recording written by `benchbot run/batch --record` (.mcap)."),
        port: int = typer.Option(10000, "--port", min=0, max=65535, help="TCP port on 127.0.0.1 (0: any free port)."),
    ) -> None:
        """Serve a recorded episode on 127.0.0.1 as if it were the simulator: the same task, robot and environment,
        the recorded observations at every step. A solution of the passive task can be re-run and re-scored
        (`benchbot submit`). Ctrl-C stops it.
        """
        from benchbot.server import ServerThread, build_app  # here, not with the module: --help stays light
        from benchbot.plugins.replay import start_replay_service

        service, spec = start_replay_service(file, registry())
        try:
            server = ServerThread(build_app(service), port=port).start()
            err.print(f"replaying {file}: task {spec.task['name']} | robot {spec.robot['name']} | environment "
                      f"{spec.env_string}")
            err.print(f"[green]backend ready[/] at {server.address}  (BENCHBOT_SUPERVISOR_ADDRESS={server.address}); Ctrl-C stops it")
            try:
                wait_until_interrupted()
            finally:
                server.stop()
        finally:
            service.close()
