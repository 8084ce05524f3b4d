"""``benchbot report``: the performance profile of one batch run, or two side by side."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from benchbot.batch.report import bootstrap_ci, compare, group, load_run, render_html, summary
from benchbot.cli.common import err, handle_errors, out, writing
from benchbot.core import atomic
from benchbot.core.errors import UsageError


def register(app: typer.Typer) -> None:
    @app.command("report")
    @handle_errors
    def report(
        runs: list[Path] = typer.Argument(..., help="One run directory, or two to compare (A then B)."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write an HTML report with plots here."),
        as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON on stdout."),
    ) -> None:
        """Summarise batch runs: per-environment tables, summary scores with 95% bootstrap confidence intervals,
        and (with -o) an HTML page with plots per environment, lighting variant, robot and repetition. Two runs are
        compared on their shared environments with a paired t-test and a Wilcoxon signed-rank test."""
        if len(runs) > 2:
            raise UsageError("give one run directory, or two to compare", "")
        data = [load_run(r.resolve()) for r in runs]
        result = {
            "runs": [{"run_dir": str(d.run_dir), "summary": {k: dict(zip(("mean", "ci_low", "ci_high"), v)) for k, v in summary(d).items()},
                      "environments": {e: dict(zip(("mean", "ci_low", "ci_high"), bootstrap_ci(v))) for e, v in group(d.rows, "env").items()}}
                     for d in data],
            "comparison": compare(*data) if len(data) == 2 else None,
        }
        if as_json:
            out.print_json(json.dumps(result))
        else:
            for d, r in zip(data, result["runs"]):
                table = Table("environment", "mean OMQ", "95% CI", title=d.name)
                for env, s in r["environments"].items():
                    table.add_row(env, f"{s['mean']:.4f}", f"[{s['ci_low']:.4f}, {s['ci_high']:.4f}]")
                for score, s in r["summary"].items():
                    table.add_row(f"[bold]all: {score}[/]", f"{s['mean']:.4f}", f"[{s['ci_low']:.4f}, {s['ci_high']:.4f}]")
                out.print(table)
            if result["comparison"]:
                c = result["comparison"]
                out.print(f"B − A on {len(c['environments'])} shared environments: {c['mean_difference']}; "
                          f"paired t-test p = {c['ttest_p']}, Wilcoxon p = {c['wilcoxon_p']}", highlight=False)
        if output is not None:
            html = render_html(data)
            with writing(output, "--output"):
                atomic.write_text(output, html)
            err.print(f"report written to {output}")
