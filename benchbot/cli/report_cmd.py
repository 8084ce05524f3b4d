"""``benchbot report``: the performance profile of batch runs, compared with the first; or, with
``--predictivity``, how well one setting's runs predict another's (docs/report.md)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from benchbot.cli.common import err, handle_errors, out, print_json, registry
from benchbot.core.errors import UsageError


def _print_report(result: dict) -> None:
    # the report's modules are imported where they are used: at the module's top every command paid 0.04 s for them
    from benchbot.batch import stats
    from benchbot.batch.figures import comparison_text, fmt, interval_text

    main = result["main_score"]
    pct = f"{int(stats.CONFIDENCE * 100)} % CI"
    for r in result["runs"]:
        table = Table("over", "n", f"mean {main}", pct, title=f"{r['label']} ({r['run_dir']})", title_justify="left")
        for env, e in r["environments"].items():
            table.add_row(f"{env}: episodes", str(e["n"]), fmt(e["value"]), interval_text(e))
        for score, e in r["summary"].items():
            table.add_row(f"[bold]all: {score}[/], environments", str(e["n"]), fmt(e["value"]), interval_text(e))
        e = r["summary_episodes"].get(main)
        if e:
            table.add_row(f"all: {main}, episodes (these environments only)", str(e["n"]), fmt(e["value"]),
                          interval_text(e))
        out.print(table)
        iqm, iqm_episodes = r["robust"]["iqm"], r["robust"]["iqm_episodes"]
        out.print(f"  IQM {main} over environments {fmt(iqm['value'])} {interval_text(iqm)}; of episodes "
                  f"(stratified bootstrap, these environments) {fmt(iqm_episodes['value'])} "
                  f"{interval_text(iqm_episodes)}", highlight=False, markup=False)
        if not r["verifiable"]:
            err.print(f"[yellow]not verifiable:[/] {r['label']} ran its solution without the sandbox (isolation "
                      f"{r['isolation']}): it could read the ground truth", highlight=False)
        if r["objects_note"]:
            err.print(f"note: {r['label']}: {r['objects_note']}", highlight=False)
    for c in result["comparisons"]:
        out.print(f"{c['b']} − {c['a']} ({c['score']}, environment means paired by environment; episodes paired by "
                  f"{c['pairing']}): {comparison_text(c)}", highlight=False, markup=False)
        poi = c.get("probability_of_improvement")
        if poi and poi.get("value") is not None:
            out.print(f"  P({c['b']} better than {c['a']} in an episode of the same environment) = {fmt(poi['value'])} "
                      f"{interval_text(poi)} (stratified bootstrap, these environments)", highlight=False, markup=False)
        if c.get("left_out"):
            out.print(f"  left out: {c['left_out']}", highlight=False, markup=False)
    plan = result.get("planning")
    if plan:
        for entry in plan["runs"]:
            for line in entry["lines"]:
                out.print(f"{entry['label']}: {line}", highlight=False, markup=False)
        for entry in plan["comparisons"]:
            for line in entry["lines"]:
                out.print(f"{entry['b']} − {entry['a']}: {line}", highlight=False, markup=False)
        if plan.get("note"):
            err.print(f"note: {plan['note']}", highlight=False)
    for d in result["differences"]:
        err.print(f"[yellow]warning:[/] the runs differ in {d['what']} ("
                  + "; ".join(f"{k}: {v or 'not recorded'}" for k, v in d["values"].items())
                  + "): the comparisons measure it too; name it with --factor if that is the point", highlight=False)
    for note in result["notes"]:
        err.print(f"[yellow]note:[/] {note}", highlight=False)


def _print_predictivity(result: dict) -> None:
    from benchbot.batch.figures import fmt, interval_text

    sim_name, real_name = result["settings"]
    table = Table(result["across"][:-1] if result["across"].endswith("s") else result["across"], sim_name, real_name,
                  title=f"{result['score']} per paired {result['across'][:-1]}", title_justify="left")
    for u, s, r in zip(result["units"], result["sim"], result["real"]):
        table.add_row(u, fmt(s), fmt(r))
    out.print(table)
    st = result["statistics"]
    for key, name in (("spearman", "Spearman ρ"), ("pearson", "Pearson r (SRCC)"), ("mmrv", "MMRV")):
        e = st[key]
        p = f", p = {fmt(e['p'])}" if e.get("p") is not None else ""
        out.print(f"{name} = {fmt(e['value'])} {interval_text(e)}{p} (n = {st['n']})", highlight=False, markup=False)
    for note in result["notes"]:
        err.print(f"note: {note}", highlight=False)
    differs = "; ".join(f"{k} ({', '.join(v)})" for k, v in result.get("setting_differences", {}).items())
    err.print(f"note: {result['limits']}" + (f" The two settings differ in: {differs}." if differs else ""),
              highlight=False)


def register(app: typer.Typer) -> None:
    @app.command("report")
    @handle_errors
    def report(
        runs: list[Path] = typer.Argument(..., help="Run directories; the first is the baseline the others are "
                                                    "compared with. With --predictivity: the first setting's runs, "
                                                    "then the second's, in the same order."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write the HTML report here, with its "
                                              "figures (PNG, SVG, PDF) and tables (CSV, LaTeX) in <stem>_files/."),
        as_json: bool = typer.Option(False, "--json", help="Print the analysis as JSON on stdout."),
        label: Optional[list[str]] = typer.Option(None, "--label", help="A name for each run, in order (repeat "
                                                  "the flag); default: the solution's name. With --predictivity: "
                                                  "one per pair, or one per run."),
        predictivity: bool = typer.Option(False, "--predictivity", help="How well the first half of the runs (e.g. "
                                          "simulation) predicts the second half (e.g. the real robot): Spearman ρ, "
                                          "Pearson r (SRCC), MMRV."),
        across: str = typer.Option("auto", "--across", help="With --predictivity, the paired units: solutions (one "
                                   "per pair of runs), environments, or auto (solutions from 2 pairs on)."),
        settings: str = typer.Option("sim,real", "--settings", help="With --predictivity, the two settings' names."),
        factor: Optional[list[str]] = typer.Option(None, "--factor", help="A condition the runs are meant to differ "
                                                   "in (repeat the flag): simulator style, camera, simulator, arch, "
                                                   "... (docs/report.md); other differences are warned about."),
        strict: bool = typer.Option(False, "--strict", help="Refuse (exit 2) instead of warning when the runs "
                                    "differ in a condition not named with --factor."),
        plan_width: Optional[float] = typer.Option(None, "--plan-width", help="With these runs as a pilot: how many "
                                                   "environments a 95 % interval this wide (in the score's units) "
                                                   "needs, from the SD of the environments' means."),
        plan_difference: Optional[float] = typer.Option(None, "--plan-difference", help="With these runs as a pilot: "
                                                        "how many environments detecting a mean difference this large "
                                                        "needs (paired t-test, 80 % power), from each comparison's "
                                                        "SD of the environments' differences."),
    ) -> None:
        """Summarise batch runs with the environment as the unit: each run's primary score as the mean of its
        environments' means with a 95 % interval over them (none below 5), the episode level beside it; runs
        compared with the first on their environment means paired by environment, tests over the environments
        (from 6, effect sizes, Holm-corrected), what was left out said; per-class results and, with -o, an HTML page with top-down maps of what was
        mapped and driven, figures as PNG/SVG/PDF and tables as CSV/LaTeX. Runs that differ in a condition the
        comparison does not name are warned about (--strict refuses). --predictivity measures how well one
        setting's runs predict another's."""
        from benchbot.batch import predictivity as pred
        from benchbot.batch.analysis import analyse
        from benchbot.batch.report import assets_dir, write_report
        from benchbot.batch.run_data import assign_labels, load_run
        from benchbot.cli.progress_lines import Steps

        reg = registry()
        with Steps() as say:  # what it is doing, until the numbers are printed
            data = []
            for k, r in enumerate(runs):
                say(f"reading run directory {k + 1} of {len(runs)}")
                data.append(load_run(r.resolve(), registry=reg))
        if predictivity:
            names = tuple(n.strip() for n in settings.split(","))
            if len(names) != 2 or not all(names):
                raise UsageError(f"--settings: '{settings}' is not two names separated by a comma", "e.g. --settings sim,real")
            sim, real = pred.split_halves(data)
            labels = list(label or [])
            if labels and len(labels) not in (len(sim), len(data)):
                raise UsageError(f"--label: {len(labels)} labels for {len(sim)} pairs of run directories",
                                 "give one --label per pair (the solution), or one per run directory")
            assign_labels(sim, labels[: len(sim)] or None)
            assign_labels(real, (labels[len(sim):] or labels) or None)
            result = pred.analyse(sim, real, across, names)
            if as_json:
                print_json(result)
            else:
                _print_predictivity(result)
            if output is not None:
                with Steps() as say:
                    say(f"writing {output} and its figures")
                    pred.write_report(sim, real, output, result)
                err.print(f"report written to {output} (figures and tables in {assets_dir(output)})")
            return
        for name, value in (("--plan-width", plan_width), ("--plan-difference", plan_difference)):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise UsageError(f"{name}: {value} is not a positive number",
                                 f"e.g. {name} 0.05 (in the score's units)")
        assign_labels(data, label)
        with Steps() as say:
            say(f"analysing {len(data)} run{'s' if len(data) != 1 else ''}")
            result = analyse(data, reg, factors=factor, plan={"width": plan_width, "difference": plan_difference})
        conditions = [d for d in result["differences"] if d["condition"]]
        if strict and conditions:
            d = conditions[0]
            raise UsageError(f"the runs differ in {d['what']} (" + "; ".join(f"{k}: {v}" for k, v in d["values"].items())
                             + ")", f"run them under the same {d['what']}, or name it: --factor '{d['what']}'")
        if as_json:
            print_json(result)
        else:
            _print_report(result)
        if output is not None:
            with Steps() as say:
                write_report(data, output, reg, result, on_step=say)
            err.print(f"report written to {output} (figures and tables in {assets_dir(output)})")
