"""``benchbot tui PATH``: watch a batch run directory (running or finished) or a live-state folder of ``benchbot run``."""

from __future__ import annotations

from pathlib import Path

import typer

from benchbot.cli.common import handle_errors
from benchbot.core.errors import UsageError


def register(app: typer.Typer) -> None:
    @app.command("tui")
    @handle_errors
    def tui(
        path: Path = typer.Argument(..., help="A run directory of `benchbot batch` (with manifest.json), or a live-state folder (state.json)."),
        poll: float = typer.Option(0.5, "--poll", help="Seconds between checks of the files (their size and time: a file is read only when it changed)."),
    ) -> None:
        """Open the live view of a batch (its episode table) or of a running episode; it only reads files.

        Works for a batch running in another process and for a finished one. q quits (the batch goes on).
        """
        if (path / "manifest.json").is_file():
            from benchbot.tui.batch_app import BatchApp

            BatchApp(path, poll_s=poll).run()
        elif (path / "state.json").is_file():
            from benchbot.tui.run_app import RunApp

            RunApp(path, poll_s=poll).run()
        else:
            raise UsageError(f"{path} has neither manifest.json nor state.json",
                             "give the run directory `benchbot batch` named")
