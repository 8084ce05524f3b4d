"""``benchbot eval``: validate and score results files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from benchbot.cli.common import err, handle_errors, out, registry
from benchbot.core import atomic
from benchbot.core.errors import UsageError
from benchbot.core.evaluation import Evaluation, evaluate, load_results, validate_result

SCORE_ORDER = ["OMQ", "avg_pairwise", "avg_label", "avg_spatial", "avg_fp_quality", "avg_state_quality", "TP", "FP", "FN"]
SHORT = {"avg_pairwise": "pairwise", "avg_label": "label", "avg_spatial": "spatial", "avg_fp_quality": "fp_quality",
         "avg_state_quality": "state"}


def _fmt(value: object) -> str:
    return f"{value:.4f}" if isinstance(value, float) else str(value)


def print_scores(evaluation: Evaluation) -> None:
    """A table of the per-result scores and the combined scores on stdout."""
    keys: list[str] = []
    for _, s in evaluation.per_result:
        keys += [k for k in s.get("scores", {}) if k not in keys]
    keys = [k for k in SCORE_ORDER if k in keys] + [k for k in keys if k not in SCORE_ORDER]
    table = Table("environment", *[SHORT.get(k, k) for k in keys], title=f"{evaluation.method} scores")
    for source, s in evaluation.per_result:
        envs = s.get("environment_details") or []
        name = f"{envs[0]['name']}:" + ":".join(str(e["variant"]) for e in envs) if envs else Path(source).name
        table.add_row(name, *[_fmt(s["scores"].get(k, "")) for k in keys])
    if evaluation.combined is not None and len(evaluation.per_result) + len(evaluation.missing) > 1:
        combined = evaluation.combined.get("scores", {})
        table.add_row("[bold]combined[/]", *[_fmt(combined.get(k, "")) for k in keys])
    out.print(table)
    for source, why in evaluation.skipped:
        err.print(f"[yellow]skipped[/] {source}: {why}")
    for env in evaluation.missing:
        err.print(f"[yellow]missing[/] no results for required environment {env} (it counts as 0)")


def register(app: typer.Typer) -> None:
    @app.command("eval")
    @handle_errors
    def eval_(
        files: list[Path] = typer.Argument(..., help="Results JSON files and/or .zip archives of them."),
        method: str = typer.Option("omq", "--method", "-m", help="Evaluation method (`benchbot list evaluators`)."),
        output: Path = typer.Option(Path("scores.json"), "--output-location", "-o", help="Where to write the scores."),
        required_envs: Optional[str] = typer.Option(None, "--required-envs", help="Comma list of environments that must be covered, e.g. miniroom:1,house:1."),
        required_envs_batch: Optional[str] = typer.Option(None, "--required-envs-batch", help="Take the required environments from a batch."),
        required_task: Optional[str] = typer.Option(None, "--required-task", help="Only score results of this task."),
        validate_only: bool = typer.Option(False, "--validate-only", "-V", help="Validate the files, then exit."),
        as_json: bool = typer.Option(False, "--json", help="Print the scores as JSON on stdout."),
    ) -> None:
        """Validate results files and score them against the environments' ground truths.

        Missing required environments count as 0 in the combined score (as in the original BenchBot).
        """
        reg = registry()
        if required_envs and required_envs_batch:
            raise UsageError("give at most one of --required-envs and --required-envs-batch", "")
        envs = None
        if required_envs:
            envs = [e.strip() for e in required_envs.split(",") if e.strip()]
        elif required_envs_batch:
            envs = list(reg.get("batches", required_envs_batch)["environments"])
        if validate_only:
            for path in files:
                for result in load_results(path):
                    validate_result(result, reg)
                    err.print(f"[green]valid[/] {result.source}")
            return
        evaluation = evaluate(list(files), method, reg, required_envs=envs, required_task=required_task)
        atomic.write_json(output, evaluation.to_json())
        if as_json:
            out.print_json(json.dumps({"per_result": [{"source": s, **v} for s, v in evaluation.per_result],
                                       "combined": evaluation.combined}, default=lambda o: o.tolist()))
        else:
            print_scores(evaluation)
        err.print(f"scores written to {output}")
