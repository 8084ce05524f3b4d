"""``benchbot submit``: run a solution against a running backend."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Optional

import typer

from benchbot.cli.common import err, handle_errors, registry
from benchbot.cli.eval_cmd import print_scores
from benchbot.core import atomic
from benchbot.core.errors import ExitCode, UsageError
from benchbot.core.evaluation import evaluate
from benchbot.core.submission import example_submission, native_submission, run_submission

DEFAULT_ADDRESS = "http://127.0.0.1:10000/"


def register(app: typer.Typer) -> None:
    @app.command("submit", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
    @handle_errors
    def submit(
        command: Optional[list[str]] = typer.Argument(None, help="With --native: the command and its arguments."),
        native: bool = typer.Option(False, "--native", "-n", help="Run COMMAND on this machine, in this folder."),
        example: Optional[str] = typer.Option(None, "--example", "-E", help="Run an installed example (`benchbot list examples`)."),
        args: str = typer.Option("", "--args", "-a", help="Arguments appended to the command."),
        evaluate_with: Optional[str] = typer.Option(None, "--evaluate-with", "-e", help="Evaluate the results afterwards (e.g. omq)."),
        results_location: Optional[Path] = typer.Option(None, "--results-location", "-r", help="Also copy the results here."),
        address: str = typer.Option(os.environ.get("BENCHBOT_SUPERVISOR_ADDRESS", DEFAULT_ADDRESS), "--address", help="The backend (`benchbot run`)."),
        scores: Path = typer.Option(Path("scores.json"), "--scores", "-o", help="Where --evaluate-with writes scores."),
    ) -> None:
        """Run a solution against the backend started by `benchbot run`.

        Examples: `benchbot submit --native python my_solution.py`, `benchbot submit --example hello_passive -e omq`.
        """
        reg = registry()
        if bool(native) == bool(example):
            raise UsageError("give exactly one of --native COMMAND... and --example NAME", "e.g. --native python my.py")
        if example and command:
            raise UsageError(f"unexpected arguments with --example: {' '.join(command)}", "use --args to pass arguments")
        if evaluate_with:
            reg.get("evaluators", evaluate_with)
        submission = example_submission(reg, example, args) if example else native_submission(command or [], args)
        with tempfile.TemporaryDirectory(prefix="benchbot-submit-") as tmp:
            result = Path(tmp) / "result.json"
            err.print(f"running {submission.label} against {address}")
            code = run_submission(submission, address=address, result_location=result)
            if code != 0:
                err.print(f"[red]the submission exited with status {code}[/]")
                raise typer.Exit(code if 0 < code < 256 else int(ExitCode.FAILURE))
            if not result.is_file():
                if not (evaluate_with or results_location):
                    return
                err.print("[yellow]warning:[/] the submission saved no results; using {}")
                atomic.write_text(result, "{}")
            if results_location is not None:
                atomic.write_text(results_location, result.read_text())
                err.print(f"results copied to {results_location}")
            if evaluate_with:
                evaluation = evaluate([result], evaluate_with, reg)
                atomic.write_json(scores, evaluation.to_json())
                print_scores(evaluation)
                err.print(f"scores written to {scores}")
