"""``benchbot submit``: run a solution against a running backend (reference §1.3)."""

from __future__ import annotations

import datetime as _dt
import os
import tempfile
from pathlib import Path
from typing import Optional

import httpx
import typer

from benchbot.api.benchbot import tls_context
from benchbot.cli.common import err, handle_errors, registry, writing
from benchbot.cli.eval_cmd import print_scores
from benchbot.cli.options import native_words, refused
from benchbot.core import atomic
from benchbot.core.errors import ExitCode, UsageError
from benchbot.core.evaluation import evaluate
from benchbot.core.submission import (
    container_engine,
    container_files,
    example_submission,
    make_submission_archive,
    native_submission,
    run_container_submission,
    run_submission,
)

DEFAULT_ADDRESS = "http://127.0.0.1:10000/"


def _run_info(address: str) -> dict:
    """Task, robot, environments and seed of the backend, or ``{}`` when none answers."""
    token = os.environ.get("BENCHBOT_TOKEN")
    try:
        reply = httpx.get(address.rstrip("/") + "/robot/run_info", timeout=5.0,
                          headers={"X-BenchBot-Token": token} if token else {}, verify=tls_context(address) or True)
        return reply.json() if reply.status_code == 200 else {}
    except (httpx.HTTPError, ValueError):
        return {}


def register(app: typer.Typer) -> None:
    @app.command("submit", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
    @handle_errors
    def submit(
        command: Optional[list[str]] = typer.Argument(None, callback=native_words, help="With --native CMD: more words of the command (--native python my.py runs python my.py)."),
        native: Optional[str] = typer.Option(None, "--native", "-n", help="Run CMD (and the words after it) on this machine, in this folder, e.g. --native python my.py."),
        containerised: Optional[Path] = typer.Option(None, "--containerised", "-c", help="Build and run DIR/Dockerfile (or a Dockerfile) with Docker or Podman; the build context is its folder."),
        submission: Optional[Path] = typer.Option(None, "--submission", "-s", help="Package DIR as a .tgz plus a manifest (--args: output path; default ../submission.tgz relative to DIR)."),
        example: Optional[str] = typer.Option(None, "--example", "-E", help="Run an installed example (`benchbot list examples`)."),
        example_containerised: bool = typer.Option(False, "--example-containerised", help="Run the example in a container."),
        args: str = typer.Option("", "--args", "-a", help="Arguments appended to the command (containers: the variable `args`; -s: output path)."),
        evaluate_with: Optional[str] = typer.Option(None, "--evaluate-with", help="Evaluate the results afterwards (e.g. omq; the original's -e, which is --env in every command now)."),
        results_location: Optional[Path] = typer.Option(None, "--results-location", help="Also copy the results here (the original's -r, which is --robot in every command now)."),
        address: str = typer.Option(os.environ.get("BENCHBOT_SUPERVISOR_ADDRESS", DEFAULT_ADDRESS), "--address", help="The backend (`benchbot run`)."),
        scores: Path = typer.Option(Path("scores.json"), "--scores", "--output", "-o", help="Where --evaluate-with writes scores."),
        timeout: Optional[float] = typer.Option(None, "--timeout", min=1.0, help="Kill the submission (native, or the container once built) after this many seconds."),
        _env: Optional[str] = typer.Option(None, "--env", "-e", hidden=True, help="Refused: benchbot run chooses the environment.", callback=refused("-e", "submit runs against the environment `benchbot run --env` chose; to evaluate, use --evaluate-with METHOD (the original's -e)")),
        _robot: Optional[str] = typer.Option(None, "--robot", "-r", hidden=True, help="Refused: benchbot run chooses the robot.", callback=refused("-r", "submit runs against the robot `benchbot run --robot` chose; to copy the results, use --results-location FILE (the original's -r)")),
    ) -> None:
        """Run a solution against the backend started by `benchbot run`.

        Examples: `benchbot submit --native python my_solution.py`, `benchbot submit --example hello_passive --evaluate-with omq`,
        `benchbot submit --containerised my_dir/`, `benchbot submit --submission my_dir/`.
        """
        reg = registry()
        modes = [m for m, on in (("--native", native), ("--containerised", containerised is not None),
                                 ("--submission", submission is not None)) if on]
        if example and modes:
            raise UsageError(f"give either --example or {modes[0]}, not both", "e.g. --example hello_passive --example-containerised")
        if example_containerised and not example:
            raise UsageError("--example-containerised needs --example NAME", "e.g. --example hello_passive --example-containerised")
        if len(modes) > 1:
            raise UsageError(f"give one mode, not {' and '.join(modes)}", "one of --native, --containerised, --submission")
        if not modes and not example:
            raise UsageError("give exactly one of --native COMMAND..., --containerised DIR, --submission DIR or --example NAME", "e.g. --native python my.py")
        if command and not native:
            raise UsageError(f"unexpected arguments: {' '.join(command)}", "use --args to pass arguments")
        if submission is not None and (evaluate_with or results_location):
            raise UsageError("--submission only packages: it cannot be combined with -e/-r", "submit natively to evaluate")
        if evaluate_with:
            reg.get("evaluators", evaluate_with)
        try:
            tls_context(address)  # a bad BENCHBOT_CA_FILE is said here, not in the solution's traceback
        except ValueError as exc:
            raise UsageError(str(exc), "give a PEM file of the authorities that signed the backend's certificate") \
                from None

        if submission is not None:
            output = Path(args) if args else submission / ".." / "submission.tgz"
            info = _run_info(address)
            archive, manifest = make_submission_archive(submission, output, manifest={
                "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                "task": info.get("task"), "robot": info.get("robot"), "environments": info.get("environments"),
                "seeds": [info["seed"]] if "seed" in info else [],
            })
            err.print(f"submission archive {archive}; manifest {manifest}")
            return

        with tempfile.TemporaryDirectory(prefix="benchbot-submit-") as tmp:
            result = Path(tmp) / "result.json"
            if containerised is not None or example_containerised:
                dockerfile, context = container_files(reg, path=containerised, example=example if example_containerised else None)
                engine = container_engine()
                err.print(f"building and running {dockerfile} with {engine} against {address}")
                code = run_container_submission(engine, dockerfile, context, address=address, result_location=result,
                                                args=args, token=os.environ.get("BENCHBOT_TOKEN"), timeout_s=timeout)
            else:
                sub = example_submission(reg, example, args) if example else native_submission(command or [], args)
                err.print(f"running {sub.label} against {address}")
                code = run_submission(sub, address=address, result_location=result, timeout_s=timeout)
            if code != 0:
                err.print(f"[red]the submission exited with status {code}[/]")
                raise typer.Exit(code if 0 < code < 256 else int(ExitCode.FAILURE))
            if not result.is_file():
                if not (evaluate_with or results_location):
                    return
                err.print("[yellow]warning:[/] the submission saved no results; using {}")
                atomic.write_text(result, "{}")
            if results_location is not None:
                with writing(results_location, "--results-location"):
                    atomic.write_text(results_location, result.read_text())
                err.print(f"results copied to {results_location}")
            if evaluate_with:
                evaluation = evaluate([result], evaluate_with, reg)
                with writing(scores, "--scores"):
                    atomic.write_json(scores, evaluation.to_json())
                print_scores(evaluation)
                err.print(f"scores written to {scores}")
