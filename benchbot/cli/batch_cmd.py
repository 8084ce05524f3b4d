"""``benchbot batch``: run a solution over many environments, score it, print the table."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from benchbot.batch.local import EpisodeRecord, new_run_dir, parse_env_list, run_batch
from benchbot.cli.common import backend_options, err, handle_errors, out, registry
from benchbot.cli.eval_cmd import print_scores
from benchbot.cli.run_cmd import DEFAULT_ROBOT, DEFAULT_TASK
from benchbot.core.errors import ExitCode, UsageError
from benchbot.core.session import RunSpec
from benchbot.core.submission import example_submission, native_submission


def _expected_steps(run: RunSpec) -> int | None:
    if run.task["actions"] == ["move_next"]:
        return sum(len(e.get("trajectory_poses") or []) for e in run.environments)
    return None


def register(app: typer.Typer) -> None:
    @app.command("batch")
    @handle_errors
    def batch(
        envs: Optional[str] = typer.Option(None, "--envs", "-e", help="Comma list of environments, e.g. miniroom:1,house:1."),
        envs_batch: Optional[str] = typer.Option(None, "--envs-batch", "-E", help="A named batch of environments (`benchbot list batches`)."),
        task: str = typer.Option(DEFAULT_TASK, "--task", "-t", help="Task name."),
        robot: str = typer.Option(DEFAULT_ROBOT, "--robot", "-r", help="Robot name."),
        native: Optional[str] = typer.Option(None, "--native", "-n", help="A command to run as the solution, e.g. 'python my.py'."),
        example: Optional[str] = typer.Option(None, "--example", help="An installed example as the solution."),
        args: str = typer.Option("", "--args", "-a", help="Arguments appended to the solution's command."),
        prefix: str = typer.Option("batch", "--prefix", "-p", help="Name prefix of the run directory."),
        output_dir: Path = typer.Option(Path("runs"), "--output-dir", help="Where run directories are made."),
        evaluate_with: str = typer.Option("auto", "--evaluate-with", help="Evaluation method; 'auto' picks one when every environment has a ground truth."),
        no_evaluate: bool = typer.Option(False, "--no-evaluate", help="Do not evaluate."),
        seed: int = typer.Option(0, "--seed", help="Seed of the first episode (episode i uses seed + i)."),
        arch: str = typer.Option("cpu", "--arch", help="Simulator device: cpu or gpu."),
        camera_size: Optional[str] = typer.Option(None, "--camera-size", help="Camera resolution WIDTHxHEIGHT (default: the robot's, 640x480 for carter)."),
        timeout: Optional[float] = typer.Option(None, "--episode-timeout", help="Kill a solution after this many seconds."),
        as_json: bool = typer.Option(False, "--json", help="Print the outcome as JSON on stdout."),
    ) -> None:
        """Run a solution on every environment (each with its own backend on 127.0.0.1), then score the results.

        Results, scores, logs, the resolved configuration and a manifest are kept in a run directory under
        --output-dir, named on stderr. Exit status 0 when every episode produced results.
        """
        reg = registry()
        if bool(native) == bool(example):
            raise UsageError("give exactly one of --native COMMAND and --example NAME", "e.g. --example semslam_geometric")
        env_list = parse_env_list(envs, envs_batch, reg)
        submission = example_submission(reg, example, args) if example else native_submission([native], args)
        run_dir = new_run_dir(output_dir, prefix)
        err.print(f"run directory: {run_dir}")
        with Progress(
            TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("steps"),
            TimeElapsedColumn(), console=err, transient=False,
        ) as progress:
            current: dict = {}

            def started(record: EpisodeRecord, run: RunSpec) -> None:
                current["id"] = progress.add_task(f"[{record.index + 1}/{len(env_list)}] {record.env}", total=_expected_steps(run))

            def stepped(info: dict) -> None:
                progress.advance(current["id"])

            def ended(record: EpisodeRecord) -> None:
                colour = "green" if record.status == "ok" else "red"
                progress.update(current["id"], description=f"[{record.index + 1}/{len(env_list)}] {record.env} [{colour}]{record.status}[/]")

            outcome = run_batch(
                reg, task=task, robot=robot, envs=env_list, submission=submission, run_dir=run_dir,
                evaluate_with=None if no_evaluate else evaluate_with, seed=seed, options=backend_options(arch, camera_size),
                on_episode_start=started, on_step=stepped, on_episode_end=ended, episode_timeout_s=timeout,
            )
        for record in outcome.episodes:
            if record.status != "ok":
                err.print(f"[red]{record.env}: {record.status}[/] (exit status {record.returncode}); see {run_dir / record.log}")
        if as_json:
            out.print_json(json.dumps({
                "run_dir": str(run_dir),
                "episodes": [vars(e) for e in outcome.episodes],
                "scores": outcome.evaluation.to_json() if outcome.evaluation else None,
            }, default=lambda o: o.tolist()))
        elif outcome.evaluation is not None:
            print_scores(outcome.evaluation)
        err.print(f"results and scores in {run_dir}")
        if not outcome.ok:
            raise typer.Exit(int(ExitCode.FAILURE))
