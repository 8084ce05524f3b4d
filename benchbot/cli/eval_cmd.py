"""``benchbot eval``: validate and score results files."""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from benchbot.cli.common import err, handle_errors, out, print_json, registry, writing
from benchbot.core import atomic
from benchbot.core.errors import ExitCode, ResultsError, SpecError, UsageError
from benchbot.core.evaluation import COMBINE_MODES, Evaluation, evaluate, validate_all


def _fmt(value: object) -> str:
    return f"{value:.4f}" if isinstance(value, float) else str(value)


def _env_name(source: str, scores: dict) -> str:
    envs = scores.get("environment_details") or []
    return f"{envs[0]['name']}:" + ":".join(str(e["variant"]) for e in envs) if envs else Path(source).name


def _score_keys(entries: list[dict], declared=None) -> list[str]:
    """The score keys of ``entries`` in the method's declared order (``declared``: a
    :class:`~benchbot.core.evaluation.ScoreSet`; the primary score first), then any others in first-seen order."""
    keys: list[str] = []
    for s in entries:
        keys += [k for k in s if k not in keys]
    order = ([declared.primary.name] + [n for n in declared.names if n != declared.primary.name]) if declared else []
    return [k for k in order if k in keys] + [k for k in keys if k not in order]


def print_scores(evaluation: Evaluation, per_class: bool = False) -> None:
    """A table of the per-result scores and the combined scores on stdout (and, with ``per_class``, a table of
    the per-class scores of every result and of the combination); skipped results and missing environments on
    stderr. Counts (TP, FP, FN) are integers; rows of one environment are labelled by their results file
    (:mod:`benchbot.cli.tables`)."""
    from rich.markup import escape

    from benchbot.cli.tables import count_cell, fit, plural, row_labels

    declared = evaluation.score_set
    if declared is None:  # an Evaluation made by hand: what its scores show (numbers only ever whole are counts)
        from benchbot.core.evaluation import observed_scores

        try:
            declared = observed_scores(evaluation.method, [s.get("scores") or {} for _, s in evaluation.per_result])
        except ValueError:
            declared = None
    counts = set(declared.counts) if declared is not None else set()

    def cell(key: str, value: object) -> str:
        return count_cell(value) if key in counts else _fmt(value)

    def heading(key: str) -> str:
        info = declared.get(key) if declared is not None else None
        return info.heading if info is not None else key

    keys = _score_keys([s.get("scores", {}) for _, s in evaluation.per_result], declared)
    mode = getattr(evaluation, "combine_mode", "mean")
    labels = row_labels([(source, _env_name(source, s)) for source, s in evaluation.per_result])
    table = Table(title=f"{evaluation.method} scores")
    # the row names never wrap or shrink (a narrow terminal abbreviates the score headers instead)
    with_combined = evaluation.combined is not None and len(evaluation.per_result) + len(evaluation.missing) > 1
    counted = plural(len(evaluation.per_result), "result") + (
        f" + {len(evaluation.missing)} missing" if evaluation.missing else "")
    # environment names and numbers are never cut; a narrow terminal abbreviates the headers and wraps the
    # combined row's label instead
    table.add_column("environment", min_width=max([len("environment"), *map(len, labels)]))
    values = [s["scores"] for _, s in evaluation.per_result] + ([evaluation.combined.get("scores", {})] if with_combined else [])
    for k in keys:
        table.add_column(heading(k), overflow="ellipsis", no_wrap=True,
                         min_width=max([1, *(len(cell(k, v.get(k, ""))) for v in values)]))
    for label, (source, s) in zip(labels, evaluation.per_result):
        table.add_row(escape(label), *[cell(k, s["scores"].get(k, "")) for k in keys])
    if with_combined:
        combined = evaluation.combined.get("scores", {})
        table.add_row(f"[bold]combined[/] ({mode} of {counted})", *[cell(k, combined.get(k, "")) for k in keys])
    out.print(fit(table, out))
    if per_class:
        rows = [(label, s["per_class"]) for label, (src, s) in zip(labels, evaluation.per_result) if "per_class" in s]
        if evaluation.combined is not None and "per_class" in evaluation.combined and len(rows) > 1:
            rows.append(("combined (pooled)", evaluation.combined["per_class"]))
        class_keys = _score_keys([c["scores"] for _, pc in rows for c in pc.values()], declared)
        pc_table = Table("environment", "class", *[heading(k) for k in class_keys],
                         title=f"{evaluation.method} scores per class")  # fmt: skip
        for env, pc in rows:
            for cls, entry in pc.items():
                pc_table.add_row(escape(env), escape(str(cls)), *[cell(k, entry["scores"].get(k, "")) for k in class_keys])
        out.print(fit(pc_table, out))
    for source, why in evaluation.skipped:
        err.print(f"[yellow]skipped[/] {escape(str(source))}: {escape(str(why))}", highlight=False)
    for env in evaluation.missing:
        err.print(f"[yellow]missing[/] no results for required environment {escape(str(env))} (it counts as 0)",
                  highlight=False)


def _print_errors(errors: list) -> None:
    for _, exc in errors:
        err.print(f"[bold red]error:[/] {exc.message}", highlight=False)


EVAL_HELP = """Validate results files and score them against the environments' ground truths.

FILES are results JSON files and/or .zip archives of them (members named submission.json are skipped, as in the
original BenchBot). Every file must exist (checked first). The scores go to -o (default scores.json, written
atomically) and to stdout as a table (or JSON with --json).

A file that is not valid JSON, fails validation (the message names the file, the object index and the field, e.g.
"r.json: results.objects[3].extent: expected 3 numbers, got 2"), has no ground truth, or cannot be scored does NOT
stop the others: its one-line error goes to stderr, the other files are scored and written, a required
environment it was meant to cover counts as missing (0), and the command exits with code 4 (ExitCode.RESULTS).
If no file can be scored, nothing is written.

Combining (--combine): mean (default, the original) = each score averaged over the results, a missing required
environment counting as 0; pooled = TP, FP, FN and the quality sums added up over all results before dividing (a
missing required environment counts its ground-truth objects as FN).

The table's columns are the scores the method declares (`benchbot show evaluators NAME`), its primary score first.

--per-class adds the scores per ground-truth class (TPs and FNs by the GT object's class, FPs by
their most likely non-background class). --oriented turns on the oriented-cuboid extension: a result object's
optional "yaw" (radians about +z, map frame) rotates its box in the IoU; off (default) yaw is ignored, as in the
original. See docs/evaluation.md.
"""


def register(app: typer.Typer) -> None:
    @app.command("eval", help=EVAL_HELP)
    @handle_errors
    def eval_(
        files: list[Path] = typer.Argument(..., help="Results JSON files and/or .zip archives of them."),
        method: str = typer.Option("omq", "--method", "-m", help="Evaluation method (`benchbot list evaluators`)."),
        output: Path = typer.Option(Path("scores.json"), "--output-location", "--output", "-o", help="Where to write the scores."),
        required_envs: Optional[str] = typer.Option(None, "--required-envs", help="Comma list of environments that must be covered, e.g. miniroom:1,house:1:2."),
        required_envs_batch: Optional[str] = typer.Option(None, "--required-envs-batch", help="Take the required environments from a batch (`benchbot list batches`)."),
        required_task: Optional[str] = typer.Option(None, "--required-task", help="Only score results of this task."),
        validate_only: bool = typer.Option(False, "--validate-only", "-V", help="Validate the files, then exit (0 if all are valid)."),
        combine: str = typer.Option("mean", "--combine", help="How to combine several results: mean (default, the original) or pooled."),
        per_class: bool = typer.Option(False, "--per-class", help="Also report the scores per ground-truth class."),
        oriented: bool = typer.Option(False, "--oriented", help="Use result objects' optional yaw (radians about +z) in the IoU."),
        as_json: bool = typer.Option(False, "--json", help="Print the scores as JSON on stdout."),
        ground_truths: Optional[str] = typer.Option(None, "--ground-truths", help="Score against this set of ground truths (`benchbot list ground_truths`: isaac_develop, the default, or bear_develop, what the original's default install used); the scores say which set they used."),
    ) -> None:
        reg = registry()
        if ground_truths is not None:
            from benchbot.packs.original_addons import ground_truth_set_name

            if ground_truth_set_name(ground_truths) not in reg.ground_truth_sets():
                raise SpecError(f"--ground-truths: no set of ground truths named '{ground_truths}'",
                                f"sets: {', '.join(sorted(reg.ground_truth_sets()))} (benchbot list ground_truths)")
        if required_envs and required_envs_batch:
            raise UsageError("give at most one of --required-envs and --required-envs-batch", "")
        if combine not in COMBINE_MODES:
            raise UsageError(f"--combine '{combine}' is not one of {', '.join(COMBINE_MODES)}", "e.g. --combine pooled")
        envs = None
        if required_envs:
            envs = [e.strip() for e in required_envs.split(",") if e.strip()]
        elif required_envs_batch:
            if required_envs_batch not in reg.names("batches"):
                close = difflib.get_close_matches(required_envs_batch, reg.names("batches"), n=3)
                raise SpecError(f"no batch named '{required_envs_batch}'",
                                f"did you mean {', '.join(close)}?" if close else "see `benchbot list batches`")  # fmt: skip
            envs = list(reg.get("batches", required_envs_batch)["environments"])
        if validate_only:
            valid, errors = validate_all(list(files), reg)
            tasks = sorted({r.data["task_details"]["name"] for r in valid})
            if len(tasks) > 1:
                raise ResultsError(f"results name several tasks: {', '.join(tasks)}", "evaluate one task at a time")
            for result in valid:
                err.print(f"[green]valid[/] {result.source}", highlight=False)
            _print_errors(errors)
            if errors:
                raise typer.Exit(int(ExitCode.RESULTS))
            return
        evaluation = evaluate(
            list(files), method, reg, required_envs=envs, required_task=required_task, combine=combine,
            options={"per_class": per_class, "oriented": oriented}, keep_going=True, ground_truth_set=ground_truths,
        )  # fmt: skip
        _print_errors(evaluation.errors)
        if not evaluation.per_result and evaluation.errors:
            raise typer.Exit(int(ExitCode.RESULTS))
        used = sorted({s.get("ground_truth_set") for _, s in evaluation.per_result if isinstance(s, dict)} - {None})
        if used:
            err.print(f"ground truths: {', '.join(used)} (--ground-truths chooses the set)", highlight=False)
        with writing(output, "--output-location"):
            atomic.write_json(output, evaluation.to_json())
        if as_json:
            print_json({
                "per_result": [{"source": s, **v} for s, v in evaluation.per_result],
                "combined": evaluation.combined,
                "combine": evaluation.combine_mode,
                "skipped": [{"source": s, "reason": r} for s, r in evaluation.skipped],
                "missing": evaluation.missing,
                "errors": [{"source": s, "error": e.message} for s, e in evaluation.errors],
            }, default=lambda o: o.tolist())  # fmt: skip
        else:
            print_scores(evaluation, per_class=per_class)
        err.print(f"scores written to {output}", highlight=False)
        if evaluation.errors:
            raise typer.Exit(int(ExitCode.RESULTS))
