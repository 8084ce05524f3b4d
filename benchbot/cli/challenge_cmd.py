"""``benchbot challenge init`` / ``benchbot challenge evaluate``: host an evaluation whose results are signed
(docs/challenge.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from benchbot.cli.common import err, handle_errors, out, registry
from benchbot.cli.options import at_most, check_count
from benchbot.cli.run_cmd import DEFAULT_ROBOT, DEFAULT_TASK
from benchbot.core.errors import ExitCode
from benchbot.core.limits import MAX_GENERATED_HOMES, MAX_WORKERS


def register(app: typer.Typer) -> None:
    challenge = typer.Typer(help="Host an evaluation: held-out worlds, sandboxed runs, signed results "
                                 "(docs/challenge.md).", no_args_is_help=True)
    app.add_typer(challenge, name="challenge")

    @challenge.command("init")
    @handle_errors
    def init(
        folder: Path = typer.Argument(..., help="The challenge's folder (created): keys, conditions, runs."),
        task: str = typer.Option(DEFAULT_TASK, "--task", "-t", help="Task name (`benchbot list tasks`)."),
        robot: str = typer.Option(DEFAULT_ROBOT, "--robot", "-r", help="Robot name (`benchbot list robots`)."),
        split: Optional[str] = typer.Option(None, "--split", help="Procedural homes' split: test (held out: "
                                            "only this host can build them), val or train (public)."),
        count: int = typer.Option(10, "--count", help="How many homes of the split (variant 1 of each): "
                                  f"{at_most(MAX_GENERATED_HOMES, 1)}."),
        environments: Optional[str] = typer.Option(None, "--environments", help="Instead of --split: a comma list "
                                                   "of environments (a development challenge: ground truth public)."),
        evaluate_with: str = typer.Option("auto", "--evaluate-with", help="Evaluation method."),
        episode_timeout: Optional[float] = typer.Option(None, "--episode-timeout", help="Seconds per episode "
                                                        "(default: the task's)."),
        limit: Optional[list[str]] = typer.Option(None, "--limit", help="A limit on each solution, NAME=VALUE: "
                                                  "memory (bytes, K/M/G), processes, file (bytes), cpu (seconds), "
                                                  "tmp (bytes), outputs (bytes); repeat it. Default: this host's "
                                                  "sandbox limits (docs/security.md)."),
    ) -> None:
        """Make a challenge: the host's Ed25519 key pair (private key mode 0600), the test split's key when the
        split is test (as `benchbot worlds key`), and conditions.json (public)."""
        from benchbot.batch.challenge import init_challenge

        check_count("--count", count, MAX_GENERATED_HOMES, 1)
        reg = registry()
        reg.get("tasks", task)
        reg.get("robots", robot)
        envs = [e.strip() for e in environments.split(",") if e.strip()] if environments else None
        cond = init_challenge(folder, task=task, robot=robot, split=split, count=count, environments=envs,
                              evaluate_with=evaluate_with, episode_timeout_s=episode_timeout, limits=limit)
        out.print(f"challenge in {folder}: {cond['task']}, {cond['robot']}, {cond['count']} environments "
                  f"({cond['worlds']}); host key {cond['fingerprint']}", highlight=False, markup=False)
        err.print(f"publish {folder / 'conditions.json'} and {folder / cond['public_key']}; keep "
                  f"{folder / 'host_key.pem'} (and the worlds key) on this host", highlight=False, markup=False)

    @challenge.command("evaluate")
    @handle_errors
    def evaluate(
        submission: Path = typer.Argument(..., help="The solution's folder (its code and lock file)."),
        folder: Path = typer.Option(..., "--challenge", help="The challenge's folder (`benchbot challenge init`)."),
        native: Optional[str] = typer.Option(None, "--native", "-n", help="The solution's command, run in its folder; "
                                             "default: python FILE for its one top-level .py file."),
        workers: int = typer.Option(1, "--workers", "-w", help=f"Episodes run in parallel: {at_most(MAX_WORKERS, 1)}."),
        executor: str = typer.Option("local", "--executor", help="local, batched or ray (as `benchbot batch`)."),
        containerised: bool = typer.Option(False, "--containerised", "-c", help="Build the submission's Dockerfile "
                                           "and run it as a container (Podman or Docker; docs/containers.md) "
                                           "instead of the sandbox."),
    ) -> None:
        """Run a submission sandboxed on the challenge's environments with `benchbot batch --native` (or, with
        --containerised, its Dockerfile as a container: `benchbot batch --containerised`), then sign the run
        directory with the host's key (signature.json: the files' hashes, the scores, the conditions, the versions,
        the isolation). Anyone can check it with `benchbot verify RUN --key host_key.pub.pem`."""
        from benchbot.batch.challenge import evaluate_submission

        check_count("--workers", workers, MAX_WORKERS, 1)
        run_dir, signature, status = evaluate_submission(submission, folder, native=native, workers=workers,
                                                         executor=executor, containerised=containerised)
        if signature is None:
            err.print(f"nothing was scored, so nothing was signed; see {run_dir}", highlight=False, markup=False)
            raise typer.Exit(int(ExitCode.FAILURE))
        out.print(f"signed: {signature}", highlight=False, markup=False)
        if status:
            raise typer.Exit(int(ExitCode.FAILURE))
