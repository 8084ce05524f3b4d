"""Sim-vs-real predictivity (``benchbot report --predictivity``): does the first setting (simulation) rank and
predict what the second (the real robot, or any other backend or setting) measures? (docs/report.md,
"Predictivity").

The run directories are given as two equal halves: runs 1..k in the first setting, runs k+1..2k in the second,
run i of one half paired with run i of the other (the same solution). The units compared are either

* ``solutions`` (k ≥ 2): one per pair, its performance the mean over the environments both runs cover of each
  environment's mean score, so that two settings are compared on the same environments; or
* ``environments``: one per environment both runs of a pair cover (with k > 1, per pair and environment), its
  performance that environment's mean score.

Statistics (:func:`benchbot.batch.stats.predictivity`): Spearman's ρ, Pearson's r (the SRCC of Kadian et al.
2020), and the mean maximum rank violation (MMRV, Li et al. 2024, as SimplerEnv's own function computes it), with
intervals from :data:`~benchbot.batch.stats.MIN_CORRELATION_N` units on.

What it can say depends on the second setting (:data:`LIMITS`): BenchBot ships no real-robot runs, and between two
simulator settings (two scene styles, say) these numbers only say whether the two settings rank the units alike —
nothing about a real robot. Every output says so.
"""

from __future__ import annotations

import base64
import html
import os
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from benchbot.batch import figures, stats
from benchbot.batch.paper import Table, to_csv, to_html, to_latex
from benchbot.batch.report import CSS, make_assets_dir, png_size
from benchbot.batch.run_conditions import condition_differences, provenance_rows, solution
from benchbot.batch.run_data import RunData
from benchbot.batch.run_stats import group, main_score
from benchbot.core import atomic
from benchbot.core.errors import UsageError

LIMITS = ("These numbers compare two settings over the same units. Only with a real robot as the second setting do "
          "they estimate how well the first predicts reality; BenchBot ships no real-robot runs. Between two "
          "simulator settings (scene styles, cameras, simulators) they say whether the two rank the units alike, "
          "and little more: agreement between two simulations is not evidence that either predicts a real robot.")
"""What predictivity can and cannot say, stated wherever it is offered (page, command line, docs/report.md)."""

ACROSS = ("auto", "solutions", "environments")
"""What ``--across`` takes; ``auto`` is ``solutions`` with two or more pairs of runs, else ``environments``."""


def split_halves(runs: list, flag: str = "--predictivity") -> tuple[list, list]:
    """The first and second half of ``runs`` (sim, real).

    Raises:
        UsageError: an odd number of runs, or none.
    """
    if not runs or len(runs) % 2:
        raise UsageError(f"{flag}: give an even number of run directories, the first setting's then the second's "
                         f"(got {len(runs)})", "e.g. benchbot report --predictivity runs/sim-a runs/sim-b runs/real-a runs/real-b")
    k = len(runs) // 2
    return runs[:k], runs[k:]


def units(sim: list[RunData], real: list[RunData], across: str = "auto", score: str | None = None) -> dict:
    """The paired units and their performance in each setting.

    Returns:
        ``{"across", "units": [name], "sim": [...], "real": [...], "episodes": [(n sim, n real)], "notes": [...]}``;
        notes name environments only one run of a pair covers and pairs whose solutions differ.

    Raises:
        UsageError: ``across`` unknown, ``solutions`` with a single pair, or no environment shared by a pair.
    """
    if across not in ACROSS:
        raise UsageError(f"--across: '{across}' is not one of {', '.join(ACROSS)}", "e.g. --across environments")
    score = score or main_score(sim)
    if across == "auto":
        across = "solutions" if len(sim) > 1 else "environments"
    if across == "solutions" and len(sim) < 2:
        raise UsageError("--across solutions needs at least 2 pairs of runs (one solution per pair)",
                         "give more runs, or --across environments")
    out: dict = {"across": across, "units": [], "sim": [], "real": [], "episodes": [], "notes": []}
    for s, r in zip(sim, real):
        if solution(s.manifest) != solution(r.manifest):
            out["notes"].append(f"{s.name} and {r.name} ran different solutions ({' '.join(solution(s.manifest))} vs "
                                f"{' '.join(solution(r.manifest))}): check the pairing")
        gs, gr = group(s.rows, "env", score), group(r.rows, "env", score)
        shared = [e for e in gs if e in gr]
        left_out = sorted(set(gs) ^ set(gr))
        if left_out:
            out["notes"].append(f"{s.name} / {r.name}: {', '.join(left_out)} covered by one setting only, left out")
        if not shared:
            raise UsageError(f"{s.run_dir} and {r.run_dir} share no environment", "pair runs of the same environments")
        if across == "solutions":
            out["units"].append(s.name if s.name == r.name else f"{s.name} / {r.name}")
            out["sim"].append(float(np.mean([np.mean(gs[e]) for e in shared])))
            out["real"].append(float(np.mean([np.mean(gr[e]) for e in shared])))
            out["episodes"].append((sum(len(gs[e]) for e in shared), sum(len(gr[e]) for e in shared)))
        else:
            for e in shared:
                out["units"].append(e if len(sim) == 1 else f"{s.name} {e}")
                out["sim"].append(float(np.mean(gs[e])))
                out["real"].append(float(np.mean(gr[e])))
                out["episodes"].append((len(gs[e]), len(gr[e])))
    return out


def analyse(sim: list[RunData], real: list[RunData], across: str = "auto", names: tuple[str, str] = ("sim", "real"),
            score: str | None = None) -> dict:
    """Units (:func:`units`) and their statistics (:func:`benchbot.batch.stats.predictivity`), JSON-able:
    ``{"settings": names, "score", "across", "units", "sim", "real", "episodes", "notes", "statistics", "policy",
    "pairs": [[sim label, real label]]}``."""
    score = score or main_score(sim)
    u = units(sim, real, across, score)

    differs = {}
    for s, r in zip(sim, real):
        for d in condition_differences([s, r]):
            differs.setdefault(d["what"], set()).add(" vs ".join(v or "not recorded" for v in d["values"].values()))
    return {"settings": list(names), "score": score, **u, "statistics": stats.predictivity(u["sim"], u["real"]),
            "pairs": [[s.name, r.name] for s, r in zip(sim, real)], "limits": LIMITS,
            "setting_differences": {k: sorted(v) for k, v in differs.items()},
            "policy": {"min_rank_n": stats.MIN_RANK_N, "min_correlation_n": stats.MIN_CORRELATION_N,
                       "confidence": stats.CONFIDENCE, "bootstrap_resamples": stats.BOOTSTRAP_RESAMPLES}}


def tables(result: dict) -> list[Table]:
    """The statistics table and the units table."""
    st = result["statistics"]
    sim_name, real_name = result["settings"]
    rows = [["Spearman ρ", st["spearman"], st["spearman"]["p"], st["spearman"]["method"] or st["spearman"]["reason"]],
            ["Pearson r (SRCC)", st["pearson"], st["pearson"]["p"], st["pearson"]["method"] or st["pearson"]["reason"]],
            ["MMRV", st["mmrv"], None, st["mmrv"]["method"] or st["mmrv"]["reason"]]]
    return [
        Table("predictivity", f"How well {sim_name} predicts {real_name} over n = {st['n']} {result['across']} "
                              f"({result['score']})", ["statistic", "value [95 % CI]", "p", "interval"], rows,
              f"No correlation below {stats.MIN_RANK_N} units; no interval or p-value below "
              f"{stats.MIN_CORRELATION_N}. MMRV in {result['score']} units (0: every pair ordered as in {real_name})."),
        Table("units", f"The paired {result['across']}", ["unit", sim_name, real_name, f"episodes {sim_name}",
                                                          f"episodes {real_name}"],
              [[u, s, r, e[0], e[1]] for u, s, r, e in zip(result["units"], result["sim"], result["real"],
                                                            result["episodes"])]),
    ]


def write_report(sim: list[RunData], real: list[RunData], output: Path, result: dict) -> None:
    """Write the predictivity page ``output`` and its assets folder (scatter plot as PNG/SVG/PDF, tables as
    CSV/LaTeX, ``predictivity.json``), atomically.

    Raises:
        UsageError: matplotlib is missing, or a file cannot be written.
    """
    esc = html.escape
    sim_name, real_name = result["settings"]
    folder = make_assets_dir(output)
    tabs = tables(result)
    fig = figures.render(figures.scatter_predictivity(result["units"], result["sim"], result["real"],
                                                      result["statistics"], sim_name, real_name, result["score"]))
    rel = os.path.relpath(folder, output.parent)

    def links(stem, formats):
        return " ".join(f"<a href='{esc(rel)}/{esc(stem)}.{f}'>{f.upper()}</a>" for f in formats)

    parts = ["<!doctype html><html lang='en'><meta charset='utf-8'>",
             "<meta name='viewport' content='width=device-width,initial-scale=1'>",
             f"<title>BenchBot predictivity: {esc(sim_name)} vs {esc(real_name)}</title><style>{CSS}</style><main>",
             f"<header><h1>Does {esc(sim_name)} predict {esc(real_name)}?</h1><p class='sub'>{result['statistics']['n']} "
             f"paired {esc(result['across'])} · {esc(result['score'])} · made "
             f"{datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}</p></header>",
             "<div class='box'><b>What these numbers are.</b> <b>Spearman ρ</b>: do the two settings rank the units "
             "alike (1: the same order). <b>Pearson r</b>: are the scores linearly related; over paired sim and real "
             "performances it is the Sim-vs-Real Correlation Coefficient (SRCC) of Kadian et al. 2020, <i>Sim2Real "
             "Predictivity: Does Evaluation in Simulation Predict Real-World Performance?</i> (IEEE RA-L). <b>MMRV</b>, "
             "the mean maximum rank violation of Li et al. 2024, <i>Evaluating Real-World Robot Manipulation Policies "
             f"in Simulation</i> (SimplerEnv): for each unit, the largest {esc(real_name)} gap to a unit that "
             f"{esc(sim_name)} orders the other way, averaged (0 is perfect; in score units). Intervals: Fisher z "
             "(Pearson), Bonett–Wright (Spearman), percentile bootstrap over units (MMRV); none below "
             f"{stats.MIN_CORRELATION_N} units. Details: docs/report.md.</div>",
             f"<div class='box warn'><b>What this can say.</b> {esc(LIMITS)}"
             + (" Here the two settings differ in: " + esc("; ".join(f"{k} ({', '.join(v)})" for k, v in
                                                                    result["setting_differences"].items())) + "."
                if result.get("setting_differences") else "") + "</div>"]
    for note in result["notes"]:
        parts.append(f"<div class='box warn'>{esc(note)}</div>")
    for t in tabs:
        parts.append(f"<h2>{esc(t.caption)}</h2><p class='note'>{links(t.name, ('csv', 'tex'))}</p>{to_html(t)}")
    png = base64.b64encode(fig["png"]).decode()
    parts.append(f"<h2>{esc(sim_name)} against {esc(real_name)}</h2><figure><img alt='scatter' "
                 f"{png_size(fig['png'])}src='data:image/png;base64,{png}'><figcaption>Each dot is one unit (its mean {esc(result['score'])} "
                 f"in each setting); dashed: y = x. {links('scatter', figures.FORMATS)}</figcaption></figure>")
    parts.append("<h2>Runs</h2>")
    for (s, r) in zip(sim, real):
        for run, setting in ((s, sim_name), (r, real_name)):
            rows = "".join(f"<tr><td>{esc(k)}</td><td>{esc(v)}</td></tr>" for k, v in provenance_rows(run))
            parts.append(f"<details><summary>{esc(setting)}: {esc(run.name)} <code>{esc(str(run.run_dir))}</code>"
                         f"</summary><div class='scroll'><table class='kv'>{rows}</table></div></details>")
    parts.append("</main></html>")
    try:
        for t in tabs:
            atomic.write_text(folder / f"{t.name}.csv", to_csv(t))
            atomic.write_text(folder / f"{t.name}.tex", to_latex(t))
        for f, data in fig.items():
            atomic.write_bytes(folder / f"scatter.{f}", data)
        atomic.write_json(folder / "predictivity.json", result)
        atomic.write_text(output, "\n".join(parts))
    except OSError as exc:
        raise UsageError(f"--output: cannot write {output} or {folder} ({exc.strerror or exc})",
                         "choose a writable path") from None
