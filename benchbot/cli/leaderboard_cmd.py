"""``benchbot leaderboard``: a static leaderboard site from run directories (docs/report.md, "Leaderboard")."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from benchbot.batch.leaderboard import slug, write_site
from benchbot.batch.report import assign_labels, load_run
from benchbot.cli.common import err, handle_errors, out, registry


def register(app: typer.Typer) -> None:
    @app.command("leaderboard")
    @handle_errors
    def leaderboard(
        runs: list[Path] = typer.Argument(..., help="Run directories, one entry each (any tasks: one page per task)."),
        output: Path = typer.Option(..., "--output", "-o", help="The folder the site is written to (created)."),
        label: Optional[list[str]] = typer.Option(None, "--label", help="A name for each entry, in order (repeat the "
                                                  "flag); default: the solution's name."),
        title: str = typer.Option("BenchBot leaderboard", "--title", help="The site's title."),
        reports: bool = typer.Option(True, "--reports/--no-reports", help="Also write each entry's report (its "
                                     "figures take a few seconds per entry)."),
        environments: Optional[str] = typer.Option(None, "--environments", help="The environments an entry must "
                                                   "cover to be ranked, a comma list; default: the set most entries "
                                                   "ran."),
    ) -> None:
        """Write a static leaderboard site: an index, one sortable page per task ranking its entries by mean OMQ
        with intervals, and each entry's manifest and report linked. Plain files, no server: copy the folder to
        any web host."""
        data = [load_run(r.resolve()) for r in runs]
        assign_labels(data, label)
        envs = [e.strip() for e in environments.split(",") if e.strip()] if environments else None
        site = write_site(data, output, title=title, registry=registry() if reports else None, reports=reports,
                          environments=envs)
        for task, rows in site["tasks"].items():
            out.print(f"{output / (slug(task) + '.html')}: {len(rows)} entries", highlight=False)
        err.print(f"site written to {output} (open {output / 'index.html'})")
