"""``benchbot run``: serve one task/robot/environment on 127.0.0.1 until Ctrl-C."""

from __future__ import annotations

import threading
from typing import Optional

import typer

from benchbot.cli.common import backend_options, err, handle_errors, registry
from benchbot.core.server import ServerThread, build_app
from benchbot.core.session import resolve_run, start_service

DEFAULT_TASK = "semantic_slam:passive:ground_truth"
DEFAULT_ROBOT = "carter"


def register(app: typer.Typer) -> None:
    @app.command("run")
    @handle_errors
    def run(
        env: str = typer.Option(..., "--env", "--environment", "-e", help="Environment, e.g. miniroom:1 (scene change detection: miniroom:1:2)."),
        task: str = typer.Option(DEFAULT_TASK, "--task", "-t", help="Task name (`benchbot list tasks`)."),
        robot: str = typer.Option(DEFAULT_ROBOT, "--robot", "-r", help="Robot name (`benchbot list robots`)."),
        port: int = typer.Option(10000, "--port", "-p", min=0, max=65535, help="TCP port on 127.0.0.1 (0: any free port)."),
        seed: int = typer.Option(0, "--seed", help="Seed of the scene and of sensor/odometry noise."),
        arch: str = typer.Option("cpu", "--arch", help="Simulator device: cpu or gpu."),
        camera_size: Optional[str] = typer.Option(None, "--camera-size", help="Camera resolution WIDTHxHEIGHT (default: the robot's, 640x480 for carter)."),
    ) -> None:
        """Start a backend for one task, robot and environment on 127.0.0.1, validating the combination first.

        A solution then connects with `benchbot submit` (or BenchBot(supervisor_address=...)). Ctrl-C stops it.
        """
        reg = registry()
        spec = resolve_run(reg, task, robot, env)
        err.print(f"task {task} | robot {robot} | environment {env} | results format {spec.task.get('results_format') or 'none'}")
        service = start_service(reg, spec, seed=seed, options=backend_options(arch, camera_size))
        server = ServerThread(build_app(service), port=port).start()
        err.print(f"[green]backend ready[/] at {server.address}  (BENCHBOT_SUPERVISOR_ADDRESS={server.address}); Ctrl-C stops it")
        try:
            threading.Event().wait()
        finally:
            server.stop()
            service.close()
