"""Performance profiles of batch runs (``benchbot report``): the page and its files (docs/report.md).

Inputs are run directories written by ``benchbot batch`` (``manifest.json``, ``config.json``,
``episode_scores.json``, ``results/``), read by :func:`benchbot.batch.run_data.load_run`.
:func:`benchbot.batch.analysis.analyse` turns them into one JSON-able dict (what ``--json`` prints);
:func:`write_report` writes the HTML page (:func:`render_html`) and, next to it in ``<stem>_files/``, every figure
(:mod:`benchbot.batch.report_figures`) as PNG, SVG and PDF and every table (:mod:`benchbot.batch.report_tables`)
as CSV and LaTeX.

Where the rest lives: the runs as data and their labels, :mod:`benchbot.batch.run_data`; what their manifests
recorded and the conditions runs are compared under, :mod:`benchbot.batch.run_conditions`; the statistics over runs
(the environment as the unit, comparisons), :mod:`benchbot.batch.run_stats` on :mod:`benchbot.batch.stats`;
per-class and per-object views and the maps' paths, :mod:`benchbot.batch.object_views`.
"""

from __future__ import annotations

import base64
import html
import os
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

from benchbot.batch import figures
from benchbot.batch.analysis import analyse
from benchbot.batch.paper import Table, to_csv, to_html, to_latex
from benchbot.batch.report_figures import Figure, make_figures
from benchbot.batch.report_tables import tables
from benchbot.batch.run_conditions import provenance_rows
from benchbot.batch.run_data import RunData
from benchbot.batch.run_stats import present_scores
from benchbot.core import atomic
from benchbot.core.errors import UsageError

CSS = """
:root{--ink:#1d1d1f;--muted:#5f6368;--line:#d0d4d9;--soft:#f5f7fa;--accent:#0072B2}
*{box-sizing:border-box}
body{font:15px/1.5 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;color:var(--ink);margin:0;background:#fff}
main{max-width:1100px;margin:0 auto;padding:1.2em 1.2em 4em}
header{border-bottom:1px solid var(--line);margin-bottom:1em}
h1{font-size:1.6em;margin:.2em 0}h2{font-size:1.25em;margin:1.8em 0 .4em;border-bottom:1px solid var(--line)}
h3{font-size:1.05em;margin:1.2em 0 .3em}
.sub{color:var(--muted);margin:.2em 0 .8em}
nav{display:flex;flex-wrap:wrap;gap:.3em .9em;font-size:.92em;margin:.6em 0}
nav a{color:var(--accent);text-decoration:none}
.scroll{overflow-x:auto;max-width:100%;margin:.5em 0}
table{border-collapse:collapse;font-size:.88em}
th,td{border-bottom:1px solid var(--line);padding:4px 10px;white-space:nowrap;vertical-align:top}
th{background:var(--soft);text-align:left;position:sticky;top:0;white-space:normal;min-width:4em}
td.num{text-align:right;font-variant-numeric:tabular-nums}
td.txt{text-align:left;white-space:normal;min-width:6em;max-width:22em;overflow-wrap:break-word}
table.kv td{white-space:normal;vertical-align:top}table.kv td:first-child{color:var(--muted);white-space:nowrap}
figure{margin:1em 0 1.6em}figure img{max-width:100%;height:auto;border:1px solid var(--line);border-radius:4px}
figcaption{color:var(--muted);font-size:.88em;margin-top:.3em}
.note{color:var(--muted);font-size:.86em;margin:.2em 0 .8em}
.box{background:var(--soft);border-left:4px solid var(--accent);padding:.6em 1em;margin:1em 0;font-size:.92em}
.warn{border-left-color:#D55E00}
.files a{margin-right:.6em}
details{margin:.6em 0}summary{cursor:pointer;color:var(--accent)}details table{font-size:.8em}
details th,details td{padding:3px 7px}
code{font-size:.9em;background:var(--soft);padding:0 .25em;border-radius:3px;word-break:break-all}
@media (max-width:600px){body{font-size:14px}main{padding:.7em}th,td{padding:3px 6px}h1{font-size:1.3em}}
"""


PAGE_ZOOM = 1.35
"""The page shows a figure this much larger than it prints (a two-column figure, 7.14 in, as 925 CSS px: its 7 pt
text as 12.6 px), shrunk to the window where that is narrower."""


def png_size(png: bytes) -> str:
    """``width='…' height='…'`` attributes showing a PNG at :data:`PAGE_ZOOM` times its print size in CSS pixels
    (the files are made at :data:`~benchbot.batch.figures.PNG_DPI`, so they stay sharp on dense screens)."""
    if png[:8] != b"\x89PNG\r\n\x1a\n" or len(png) < 24:
        return ""
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    scale = 96 * PAGE_ZOOM / figures.PNG_DPI
    return f"width='{round(width * scale)}' height='{round(height * scale)}' "



def _files(assets: str, stem: str, formats: tuple[str, ...]) -> str:
    """Links to a table's or figure's files (``stem.<format>`` in ``assets``), one per format."""
    links = " ".join(f"<a href='{html.escape(assets)}/{html.escape(stem)}.{f}'>{f.upper()}</a>" for f in formats)
    return f"<span class='files'>{links}</span>"


@dataclass
class _Exhibits:
    """A page's tables and figures by name, written as HTML that links their files in ``assets`` (relative to the
    page); a name the report did not make is written as ""."""

    tables: dict[str, Table]
    figures: dict[str, Figure]
    assets: str

    def table(self, name: str) -> str:
        """The table's caption, links to its CSV and LaTeX files, and the table."""
        t = self.tables.get(name)
        if t is None:
            return ""
        return (f"<p class='note'>{html.escape(t.caption)} — {_files(self.assets, t.name, ('csv', 'tex'))}</p>"
                + to_html(t))

    def figure(self, name: str) -> str:
        """The figure's PNG embedded (linking its SVG) with its caption and links to its files."""
        f = self.figures.get(name)
        if f is None:
            return ""
        esc, assets = html.escape, self.assets
        png = base64.b64encode(f.data["png"]).decode()
        return (f"<figure id='f-{esc(f.name)}'><a href='{esc(assets)}/{esc(f.name)}.svg' title='open the SVG'>"
                f"<img alt='{esc(f.title)}' {png_size(f.data['png'])}src='data:image/png;base64,{png}'></a>"
                f"<figcaption><b>{esc(f.title)}.</b> {esc(f.caption)} {_files(assets, f.name, figures.FORMATS)}"
                "</figcaption></figure>")


def render_html(runs: list[RunData], result: dict, tables_: list[Table], figures_: list[Figure], assets: str) -> str:
    """The report page: one HTML file with the PNG figures embedded, linking the SVG/PDF figures and CSV/LaTeX
    tables in the folder ``assets`` (relative to the page)."""
    page = _Exhibits({t.name: t for t in tables_}, {f.name: f for f in figures_}, assets)
    parts = _head(runs, result) + _warnings(result) + [_how_to_read(runs, result)] + _runs_section(runs, result)
    parts.append("</section><section id='summary'><h2>Summary</h2>" + page.table("summary") + page.table("scores")
                 + page.figure("summary") + "</section>")
    parts.append("<section id='environments'><h2>Per environment</h2>" + page.table("environments")
                 + page.figure("environments") + "</section>")
    parts += _comparisons_section(result, page)
    parts.append("<section id='robust'><h2>Robust aggregates</h2><p class='note'>The interquartile mean, the "
                 "probability of improvement and score distributions of Agarwal et al. 2021 (rliable): see "
                 "docs/report.md for when each holds.</p>" + page.table("robust") + page.figure("score_distribution")
                 + "</section>")
    parts += (_classes_section(result, page) + _maps_section(result, figures_, page) + _factors_section(result, page)
              + _episodes_section(runs))
    parts.append("</section></main></html>")
    return "\n".join(parts)


def _head(runs: list[RunData], result: dict) -> list[str]:
    """The page's head, title, date and navigation."""
    esc = html.escape
    labels = [run.name for run in runs]
    return ["<!doctype html><html lang='en'><meta charset='utf-8'>",
            "<meta name='viewport' content='width=device-width,initial-scale=1'>",
            f"<title>BenchBot report: {esc(', '.join(labels))}</title><style>{CSS}</style><main>",
            "<header><h1>BenchBot performance profile</h1>",
            f"<p class='sub'>{esc(' vs '.join(labels))} · task {esc(', '.join(result['tasks']))} · made "
            f"{datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}</p>",
            "<nav><a href='#statistics'>Statistics</a><a href='#runs'>Runs</a><a href='#summary'>Summary</a>"
            "<a href='#environments'>Environments</a>"
            + ("<a href='#comparisons'>Comparisons</a>" if result["comparisons"] else "")
            + "<a href='#robust'>Robust</a><a href='#classes'>Classes</a><a href='#maps'>Maps</a>"
              "<a href='#factors'>Factors</a>"
              "<a href='#episodes'>Episodes</a></nav></header>"]


def _warnings(result: dict) -> list[str]:
    """The boxes above the numbers: runs not verifiable, on public worlds, of different tasks, differing in
    conditions the comparison does not name, the analysis's notes, and the planning asked for."""
    esc = html.escape
    parts = []
    unverified = [r["label"] for r in result["runs"] if not r["verifiable"]]
    if unverified:
        parts.append(f"<div class='box warn'><b>Not verifiable:</b> {esc(', '.join(unverified))} ran "
                     f"{'its' if len(unverified) == 1 else 'their'} solution without the sandbox (isolation "
                     "<code>none</code>), where it could read the ground truth: fine for development, not for "
                     "comparisons or publication (docs/security.md).</div>")
    public = [r["label"] for r in result["runs"] if r.get("worlds", "").startswith("development")]
    if public:
        parts.append(f"<div class='box warn'><b>Development — ground truth public:</b> {esc(', '.join(public))} ran "
                     "on public worlds (BEAR, procedural train/val), whose ground truth anyone can build, so a "
                     "solution could carry it in its own code: a score here measures development, not what a "
                     "held-out evaluation would (docs/challenge.md).</div>")
    if len(result["tasks"]) > 1:
        parts.append(f"<div class='box warn'>These runs are of different tasks ({esc(', '.join(result['tasks']))}): "
                     "their scores are not comparable.</div>")
    if result["differences"]:
        items = "".join(f"<li><b>{esc(d['what'])}</b>: " + "; ".join(f"{esc(k)}: {esc(v or 'not recorded')}"
                                                                      for k, v in d["values"].items()) + "</li>"
                        for d in result["differences"])
        parts.append("<div class='box warn'><b>These runs differ in more than the comparison names.</b> Their "
                     "differences below measure these too:<ul>" + items + "</ul>If that is the point, say so with "
                     "<code>--factor WHAT</code>; otherwise run them under the same conditions.</div>")
    for note in result["notes"]:
        parts.append(f"<div class='box warn'>{esc(note)}</div>")
    return parts + _planning_box(result.get("planning"))


def _planning_box(plan: dict | None) -> list[str]:
    """How many environments a study needs (:func:`benchbot.batch.analysis.planning`), when it was asked for."""
    if not plan:
        return []
    esc = html.escape
    items = [f"<li>{esc(e['label'])}: {esc(line)}</li>" for e in plan["runs"] for line in e["lines"]]
    items += [f"<li>{esc(e['b'])} − {esc(e['a'])}: {esc(line)}</li>" for e in plan["comparisons"]
              for line in e["lines"]]
    if plan.get("note"):
        items.append(f"<li>{esc(plan['note'])}</li>")
    return ["<div class='box'><b>How many environments</b> (these runs as a pilot; docs/report.md):<ul>"
            + "".join(items) + "</ul></div>"]


def _how_to_read(runs: list[RunData], result: dict) -> str:
    """The statistics section: the unit, the intervals, the pairing and the tests, in a box."""
    esc = html.escape
    p, main = result["policy"], result["main_score"]
    primary = runs[0].score_set.primary
    return (
        "<section id='statistics'><div class='box'><b>How to read the numbers.</b> The unit is the "
        f"<b>environment</b>: a run's {esc(main)} is the mean of its environments' means ({esc(primary.direction)} "
        f"is better; {esc(primary.description or main)}), its {int(p['confidence'] * 100)} % interval over the "
        f"environments (Student t below {p['t_interval_below']} values, BCa bootstrap from there; none below "
        f"{p['min_ci_n']}; clipped to the score's declared range). Episodes of one environment share its rooms and "
        "objects, so they are not independent: "
        "the episode-level numbers, shown beside and named as such, say how precisely these environments were "
        f"measured, not how a solution does elsewhere. Runs are compared with <b>{esc(runs[0].name)}</b> on their "
        "environments' means (over every episode of each), paired by environment (a robot or noise preset that "
        "differs between two runs is the factor compared); episodes pair by environment and seed (or repetition) "
        f"at the episode level; tests over the environments from {p['min_test_pairs']} on: mean "
        "difference with its interval, Cohen's d<sub>z</sub>, paired t-test and Wilcoxon signed-rank test (with "
        "its rank-biserial r), p-values Holm-adjusted over all comparisons. Every figure states its n. Details: "
        "docs/report.md.</div></section>")


def _runs_section(runs: list[RunData], result: dict) -> list[str]:
    """Each run's label, folder and provenance (open when there is one run); the section is closed by the next."""
    esc = html.escape
    parts = ["<section id='runs'><h2>Runs and provenance</h2>"]
    for run, r in zip(runs, result["runs"]):
        rows = "".join(f"<tr><td>{esc(k)}</td><td>{esc(v)}</td></tr>" for k, v in provenance_rows(run))
        parts.append(f"<h3>{esc(r['label'])}</h3><p class='note'><code>{esc(str(run.run_dir))}</code></p>"
                     f"<details{' open' if len(runs) == 1 else ''}><summary>provenance</summary>"
                     f"<div class='scroll'><table class='kv'>{rows}</table></div></details>")
    return parts


def _comparisons_section(result: dict, page: _Exhibits) -> list[str]:
    """The comparisons with the baseline: the table, each one in words with its figure, the episode level folded
    (nothing when there is one run)."""
    if not result["comparisons"]:
        return []
    esc = html.escape
    parts = ["<section id='comparisons'><h2>Comparisons</h2>" + page.table("comparisons")]
    for k, c in enumerate(result["comparisons"]):
        parts.append(f"<p class='note'><b>{esc(c['b'])}</b> − {esc(c['a'])}: "
                     f"{esc(figures.comparison_text(c))}.</p>")
        if c.get("left_out"):
            parts.append(f"<p class='note'>Left out: {esc(c['left_out'])}.</p>")
        parts.append(page.figure(f"comparison_{k + 1}"))
    parts.append("<details><summary>the same over episode pairs</summary>" + page.table("comparisons_episodes")
                 + "</details></section>")
    return parts


def _classes_section(result: dict, page: _Exhibits) -> list[str]:
    """Per run, why there are no per-class views, or its per-class table and figure; closed by the next section."""
    parts = ["<section id='classes'><h2>Per class</h2>"]
    for k, r in enumerate(result["runs"]):
        parts.append(f"<h3>{html.escape(r['label'])}</h3>")
        if r["objects_note"]:
            parts.append(f"<p class='note'>{html.escape(r['objects_note'])}</p>")
        parts.append(page.table(f"per_class_{k + 1}") + page.figure(f"per_class_{k + 1}"))
    return parts


def _maps_section(result: dict, figures_: list[Figure], page: _Exhibits) -> list[str]:
    """The top-down maps, with what they draw; closed by the next section."""
    maps = [f for f in figures_ if f.name.startswith("map_")]
    return ["</section><section id='maps'><h2>Top-down maps</h2><p class='note'>Seen from above (x-y "
            "footprints, metres, map frame): ground-truth boxes from the environment's ground truth (dark outline: "
            "found; red: missed), predicted boxes (filled by the matched pair's quality; orange: false positive; "
            "grey: inside a group box, neither), a line from each match to its ground truth, the path the robot "
            "drove (solid, start ▲; from the batch's trajectory log or recording) and the planned one (faint, "
            "dashed). With several episodes of an environment a panel shows the "
            f"median-{html.escape(result['main_score'])} one. Click a map for its SVG.</p>",
            "".join(page.figure(f.name) for f in maps) if maps else
            "<p class='note'>No maps: no run has per-object matches (see Per class).</p>"]


def _factors_section(result: dict, page: _Exhibits) -> list[str]:
    """The robots, noise presets and lightings the runs vary: a figure each, or why it is not shown."""
    parts = ["</section><section id='factors'><h2>Robots, noise and lighting</h2>"]
    if not result["factors"]:
        parts.append("<p class='note'>These runs vary no robot, noise preset or lighting.</p>")
    for view in result["factors"]:
        if view["groups"]:
            parts.append(page.figure(f"factor_{view['factor']}"))
        else:
            parts.append(f"<p class='note'><b>{html.escape(view['factor'])}</b>: {html.escape(view['note'])}</p>")
    return parts


def _episodes_section(runs: list[RunData]) -> list[str]:
    """Every run's episodes and scores, folded; the settings that vary within a run get a column."""
    parts = ["</section><section id='episodes'><h2>Episodes</h2>"]
    scores = present_scores(runs)
    for run in runs:
        keys = ["index", "env"] + [k for k in ("robot", "repeat", "seed", "noise", "lighting")
                                   if k in ("repeat", "seed") or len({str(r.get(k, "")) for r in run.rows}) > 1]
        rows = [[r.get(k, "") for k in keys] + [r.get(s) for s in scores] for r in run.rows]
        headings = keys + [(run.score_set.get(s).heading if run.score_set.get(s) else s) for s in scores]
        parts.append(f"<details><summary>{html.escape(run.name)}: {len(run.rows)} episodes</summary>"
                     + to_html(Table("episodes", "", headings, rows)) + "</details>")
    return parts


def assets_dir(output: Path) -> Path:
    """Where a report's figures and tables go: ``report.html`` → ``report_files/`` next to it."""
    return output.with_name(output.stem + "_files")


def make_assets_dir(output: Path) -> Path:
    """Make :func:`assets_dir` of ``output`` (before the slow part, so that an unwritable place fails first).

    Raises:
        UsageError: the folder cannot be made.
    """
    folder = assets_dir(output)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--output: cannot write {output} or {folder} ({exc.strerror or exc})",
                         "choose a writable path") from None
    return folder


def write_report(runs: list[RunData], output: Path, registry=None, result: dict | None = None,
                 on_step: Callable[[str], None] | None = None) -> dict:
    """Analyse ``runs`` and write the report: ``output`` (HTML) and its assets folder (:func:`assets_dir`) with
    every figure as PNG, SVG and PDF, every table as CSV and LaTeX, and ``report.json`` (the analysis); each file
    written atomically. ``on_step`` is told each step as it starts ("drawing the figures and maps").

    Returns:
        the analysis (:func:`analyse`).

    Raises:
        UsageError: matplotlib is missing, or a file cannot be written.
    """
    say = on_step or (lambda what: None)
    folder = make_assets_dir(output)
    if result is None:
        say("analysing the runs")
        result = analyse(runs, registry)
    tables_ = tables(runs, result)
    say("drawing the figures and maps (PNG, SVG, PDF)")
    figures_ = make_figures(runs, result, registry)
    say(f"writing {output} and its files")
    try:
        for t in tables_:
            atomic.write_text(folder / f"{t.name}.csv", to_csv(t))
            atomic.write_text(folder / f"{t.name}.tex", to_latex(t))
        for f in figures_:
            for fmt_, data in f.data.items():
                atomic.write_bytes(folder / f"{f.name}.{fmt_}", data)
        atomic.write_json(folder / "report.json", result)
        atomic.write_text(output, render_html(runs, result, tables_, figures_, os.path.relpath(folder, output.parent)))
    except OSError as exc:
        raise UsageError(f"--output: cannot write {output} or {folder} ({exc.strerror or exc})",
                         "choose a writable path") from None
    return result
