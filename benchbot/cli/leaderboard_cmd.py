"""``benchbot leaderboard``: a static leaderboard site from run directories (docs/report.md, "Leaderboard")."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from benchbot.cli.common import err, handle_errors, out, registry
from benchbot.core.errors import UsageError


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
        trusted_key: Optional[list[Path]] = typer.Option(None, "--trusted-key", help="A challenge host's public "
                                                         "key (host_key.pub.pem; repeat the flag): runs it signed on "
                                                         "held-out worlds are verified and ranked apart from "
                                                         "self-reported ones."),
    ) -> None:
        """Write a static leaderboard site: an index, one page per task with one sortable table per condition set
        (robot, noise preset, camera, simulator and version, scene style, isolation, evaluation method), entries
        ranked by the evaluation method's primary score over environments with intervals (entries the intervals do
        not tell apart share a rank), each entry's manifest and report linked. Every entry whose ground truth this
        host holds is re-scored from its results files: one whose recorded scores differ is not ranked. Unfinished
        batches are skipped with one line each, as are batches whose every episode failed. Plain files, no server:
        copy the folder to any web host."""
        from benchbot.batch.leaderboard import slug, write_site  # here: 0.05 s to import, which every command paid
        from benchbot.batch.run_data import FailedRun, UnfinishedRun, assign_labels, load_run
        from benchbot.batch.signing import load_public_key
        from benchbot.cli.progress_lines import Steps

        trusted = [load_public_key(k) for k in trusted_key or []]  # a bad key file: one line, before any work
        reg = registry()
        data, kept, skipped = [], [], []
        with Steps() as say:  # what it is doing, until the site is written
            for k, r in enumerate(runs):
                say(f"reading run directory {k + 1} of {len(runs)}")
                try:
                    data.append(load_run(r.resolve(), registry=reg))
                    kept.append(k)
                except (UnfinishedRun, FailedRun) as exc:  # left out with one line each, the rest is built
                    skipped.append(f"{exc.message}; {exc.hint}")
                    err.print(f"[yellow]skipped[/] {exc.message}; {exc.hint}", highlight=False)
            if data:
                assign_labels(data, [label[k] for k in kept] if label and len(label) == len(runs) else label)
                envs = [e.strip() for e in environments.split(",") if e.strip()] if environments else None
                site = write_site(data, output, title=title, registry=reg if reports else None, reports=reports,
                                  environments=envs, skipped=skipped, on_step=say,
                                  trusted=trusted, ground_truth=reg)
        if not data:
            raise UsageError(f"no finished run directory with scores among the {len(runs)} given", "finish or re-run "
                             "them with benchbot batch --resume RUN_DIR (it re-runs failed episodes too), or give "
                             "scored ones")
        for task, tables in site["tasks"].items():
            for e in (e for t in tables for e in t["entries"] if e["rescored"] == "differs"):
                err.print(f"[red]not ranked[/] {e['label']} ({e['run_dir']}): {e['rescore_reason']}",
                          highlight=False)
            n = sum(len(t["entries"]) for t in tables)
            out.print(f"{output / (slug(task) + '.html')}: {n} entries in {len(tables)} condition set"
                      f"{'s' if len(tables) != 1 else ''}", highlight=False)
        err.print(f"site written to {output} (open {output / 'index.html'})")
