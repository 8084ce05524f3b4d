"""``benchbot leaderboard``: a static leaderboard site from run directories (docs/report.md, "Leaderboard").

The site is plain files — no server, no external scripts, fonts or styles — so it can be copied to any web host
(or opened from disk) and keeps working after a challenge ends::

    site/index.html                      the tasks, with their entry counts
    site/<task>.html                     one page per task: the entries, sortable by any column
    site/entries/<entry>/manifest.json   each entry's manifest, scores.json, episode_scores.json, config.json
    site/entries/<entry>/report.html     and its report (``benchbot report``), with report_files/
    site/leaderboard.json                every entry's numbers

Entries are ranked on one set of environments per task (:func:`benchmark_set`: ``--environments``, else the set most
entries ran): an entry that covers it is scored on its episodes of those environments and ranked; an entry that does
not is listed, marked, and not ranked (its mean is over other scenes). Every mean carries its interval (none below
:data:`~benchbot.batch.stats.MIN_CI_N` episodes).
"""

from __future__ import annotations

import html
import json
import re
import shutil
from datetime import datetime, timezone
from pathlib import Path

from benchbot.batch import stats
from benchbot.batch.figures import fmt
from benchbot.batch.report import (
    CSS, MAIN_SCORE, RunData, present_scores, provenance, solution, verifiable, write_report,
)
from benchbot.core import atomic
from benchbot.core.errors import UsageError

COPIED = ("manifest.json", "scores.json", "episode_scores.json", "config.json")
"""The files of a run directory an entry links (those present are copied)."""

SORT_JS = """
document.querySelectorAll('table.sortable').forEach(function (table) {
  table.querySelectorAll('th').forEach(function (th, col) {
    th.tabIndex = 0;
    function sort() {
      var asc = th.getAttribute('aria-sort') !== 'ascending';
      table.querySelectorAll('th').forEach(function (h) { h.removeAttribute('aria-sort'); });
      th.setAttribute('aria-sort', asc ? 'ascending' : 'descending');
      var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
      rows.sort(function (a, b) {
        var x = a.cells[col].dataset.v, y = b.cells[col].dataset.v;
        var nx = parseFloat(x), ny = parseFloat(y), c;
        if (x === '' && y === '') c = 0; else if (x === '') c = 1; else if (y === '') c = -1;
        else if (!isNaN(nx) && !isNaN(ny)) c = asc ? nx - ny : ny - nx;
        else c = asc ? x.localeCompare(y) : y.localeCompare(x);
        return c;
      });
      rows.forEach(function (r) { body.appendChild(r); });
    }
    th.addEventListener('click', sort);
    th.addEventListener('keydown', function (e) { if (e.key === 'Enter' || e.key === ' ') { e.preventDefault(); sort(); } });
  });
});
"""
"""Click (or Enter on) a column heading to sort by it; again to reverse. Empty cells sort last."""

EXTRA_CSS = """
table.sortable th{cursor:pointer;user-select:none}
table.sortable th[aria-sort=ascending]::after{content:" ▲"}table.sortable th[aria-sort=descending]::after{content:" ▼"}
td.rank{font-weight:600}tr.partial td{color:#777}main.wide{max-width:1500px}td small{color:#777}
@media (max-width:700px){.opt{display:none}}
.tasks li{margin:.3em 0}
"""


def slug(text: str) -> str:
    """A file-name-safe form of ``text``: ``semantic_slam:passive:ground_truth`` → ``semantic_slam-passive-ground_truth``."""
    return re.sub(r"[^A-Za-z0-9_.]+", "-", text).strip("-") or "entry"


def benchmark_set(runs: list[RunData], given: list[str] | None = None) -> list[str]:
    """The environments a task's entries are ranked on: ``given`` (``--environments``), else the set of
    environments most entries ran (a tie goes to the larger set, then to the earlier entry)."""
    if given:
        return sorted(dict.fromkeys(given))
    sets = [tuple(sorted({r["env"] for r in run.rows})) for run in runs]
    return list(max(dict.fromkeys(sets), key=lambda s: (sets.count(s), len(s))))


def entries(runs: list[RunData], environments: list[str] | None = None) -> dict[str, list[dict]]:
    """Each task's entries, best first: ``{task: [{"run", "label", "slug", "scores": {score: Estimate dict},
    "episodes", "environments", "covers", "rank", "benchmark"}]}``. An entry that ``covers`` the task's
    :func:`benchmark_set` is scored on its episodes of those environments and ranked; any other entry on all its
    episodes, with ``rank`` None."""
    by_task: dict[str, list[RunData]] = {}
    for run in runs:
        by_task.setdefault(str(run.manifest.get("task", "unknown task")), []).append(run)
    out: dict[str, list[dict]] = {}
    used: set[str] = set()
    for task, task_runs in by_task.items():
        bench = benchmark_set(task_runs, environments)
        rows = []
        for run in task_runs:
            name = slug(f"{run.name}-{run.run_dir.name}")
            while name in used:
                name += "-x"
            used.add(name)
            envs = sorted({r["env"] for r in run.rows})
            covers = set(bench) <= set(envs)
            scored = [r for r in run.rows if r["env"] in bench] if covers else run.rows
            rows.append({"run": run, "label": run.name, "slug": name, "episodes": len(scored),
                         "environments": envs, "covers": covers, "benchmark": bench,
                         "verifiable": verifiable(run.manifest),
                         "scores": {s: stats.mean_ci([r[s] for r in scored if s in r]).to_json()
                                    for s in present_scores([run])}})
        rows.sort(key=lambda e: (not (e["covers"] and e["verifiable"]),
                                 -(e["scores"].get(MAIN_SCORE, {}).get("value") or 0.0)))
        rank = 0
        for e in rows:
            e["rank"] = (rank := rank + 1) if e["covers"] and e["verifiable"] else None
        out[task] = rows
    return out


def _cell(value, text: str | None = None, cls: str = "num", title: str = "") -> str:
    v = "" if value is None else str(value)
    t = f" title='{html.escape(title)}'" if title else ""
    if text is None:
        text = fmt(value) if value is None or isinstance(value, (int, float)) else str(value)
    return f"<td class='{cls}' data-v='{html.escape(v)}'{t}>{html.escape(text)}</td>"


def _estimate_cell(e: dict | None, cls: str = "num") -> str:
    """The mean over its interval (or its n when it has none), the raw mean for sorting."""
    if not e or e.get("value") is None:
        return _cell(None, "–", cls)
    below = f"[{fmt(e['low'])}, {fmt(e['high'])}]" if e.get("low") is not None else f"n = {e['n']}"
    title = html.escape(e.get("reason") or e.get("method", ""))
    return (f"<td class='{cls}' data-v='{e['value']}' title='{title}'>{html.escape(fmt(e['value']))}"
            f"<br><small>{html.escape(below)}</small></td>")


def _page(title: str, body: str, script: bool = False) -> str:
    return ("<!doctype html><html lang='en'><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width,initial-scale=1'>"
            f"<title>{html.escape(title)}</title><style>{CSS}{EXTRA_CSS}</style>"
            f"<main class='{'wide' if script else ''}'>{body}</main>"
            + (f"<script>{SORT_JS}</script>" if script else "") + "</html>")


def task_page(task: str, rows: list[dict], title: str, made: str, reports: bool) -> str:
    """One task's page: the entries as a sortable table, each linking its manifest (and report)."""
    esc = html.escape
    scores = [s for s in ("OMQ", "avg_pairwise", "avg_label", "avg_spatial", "avg_fp_quality", "avg_state_quality")
              if any(s in e["scores"] for e in rows)]
    bench = rows[0]["benchmark"] if rows else []
    # (heading, optional): optional columns are hidden on narrow screens
    head = [("rank", False), ("entry", False)] + [(f"{s} [95 % CI]", s != MAIN_SCORE) for s in scores] + [
        ("solution", True), ("environments", False), ("episodes", True), ("date", True), ("BenchBot", True),
        ("git", True), ("files", False)]
    body = []
    for e in rows:
        run: RunData = e["run"]
        prov = dict(provenance(run))
        git = (run.manifest.get("provenance") or {}).get("benchbot_git") or ""
        kind, what = solution(run.manifest)
        started = str(run.manifest.get("started", ""))[:10]
        links = [f"<a href='entries/{esc(e['slug'])}/manifest.json'>manifest</a>"]
        if reports:
            links.insert(0, f"<a href='entries/{esc(e['slug'])}/report.html'>report</a>")
        label = e["label"] + ("" if e["verifiable"] else " (not verifiable)")
        cells = [_cell(e["rank"], str(e["rank"]) if e["rank"] else "–", "num rank"),
                 _cell(label, cls="txt", title="" if e["verifiable"] else
                       "run without the sandbox: its solution could read the ground truth")]
        cells += [_estimate_cell(e["scores"].get(s), "num" if s == MAIN_SCORE else "num opt") for s in scores]
        cells.append(_cell(f"{kind} {what}", cls="txt opt"))
        covered = len(set(e["environments"]) & set(bench))
        cells += [_cell(covered, f"{covered} of {len(bench)}" + (f" (+{len(e['environments']) - covered})"
                                                                 if len(e["environments"]) > covered else ""),
                        title=", ".join(e["environments"])),
                  _cell(e["episodes"], cls="num opt"), _cell(started, cls="txt opt"),
                  _cell(prov.get("BenchBot"), cls="txt opt"),
                  _cell(git[:12] + ("+dirty" if git.endswith("+dirty") else ""), cls="txt opt", title=git),
                  f"<td class='txt' data-v=''>{' · '.join(links)}</td>"]
        body.append(f"<tr class='{'' if e['covers'] and e['verifiable'] else 'partial'}'>{''.join(cells)}</tr>")
    partial = sum(not e["covers"] for e in rows)
    note = (f"<p class='note'>{partial} entr{'y does' if partial == 1 else 'ies do'} not cover the ranked "
            "environments: listed in grey, not ranked, scored on their own episodes (other scenes).</p>"
            if partial else "")
    unverified = sum(not e["verifiable"] for e in rows)
    if unverified:
        note += (f"<p class='note'>{unverified} entr{'y is' if unverified == 1 else 'ies are'} not verifiable: run "
                 "without the sandbox (<code>--no-sandbox</code>), where the solution could read the ground truth; "
                 "listed in grey and not ranked.</p>")
    return _page(f"{title}: {task}", (
        f"<header><p class='sub'><a href='index.html'>{esc(title)}</a></p><h1>{esc(task)}</h1>"
        f"<p class='sub'>{len(rows)} entries · ranked by mean {MAIN_SCORE} over each entry's episodes of "
        f"{len(bench)} environment{'s' if len(bench) != 1 else ''}: {esc(', '.join(bench))} · updated {esc(made)}</p>"
        "</header>"
        f"<div class='box'>Click a column heading to sort by it (on a narrow screen only the main columns are "
        f"shown). Intervals are {int(stats.CONFIDENCE * 100)} % BCa "
        f"bootstrap intervals over episodes, none below {stats.MIN_CI_N} episodes (then n is shown). Each entry's "
        "manifest records its command, seeds, versions, git revision and machine.</div>"
        "<div class='scroll'><table class='sortable'><thead><tr>"
        + "".join(f"<th scope='col'{' class=opt' if opt else ''}>{esc(h)}</th>" for h, opt in head)
        + "</tr></thead><tbody>" + "".join(body)
        + f"</tbody></table></div>{note}"), script=True)


def write_site(runs: list[RunData], output: Path, *, title: str = "BenchBot leaderboard", registry=None,
               reports: bool = True, environments: list[str] | None = None) -> dict:
    """Write the static site into the folder ``output`` (created; files of earlier runs of this command are
    replaced, nothing else is touched). Every file is written atomically.

    Args:
        runs: labelled runs (:func:`benchbot.batch.report.assign_labels`).
        registry: for the entries' reports (per-class views and maps); None leaves them out of those reports.
        reports: also write each entry's report (the slow part: its figures).
        environments: the environments entries are ranked on (:func:`benchmark_set`); None: the most common set.

    Returns:
        ``{"tasks": {task: [entry summary]}, "made": ...}`` as written to ``leaderboard.json``.

    Raises:
        UsageError: ``output`` cannot be written, or is a file.
    """
    if output.exists() and not output.is_dir():
        raise UsageError(f"--output: {output} is a file", "give a folder for the site, e.g. -o site/")
    made = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    tasks = entries(runs, environments)
    data = {"title": title, "made": made, "tasks": {}}
    try:
        for task, rows in tasks.items():
            for e in rows:
                folder = output / "entries" / e["slug"]
                folder.mkdir(parents=True, exist_ok=True)
                for name in COPIED:
                    if (e["run"].run_dir / name).is_file():
                        atomic.write_bytes(folder / name, (e["run"].run_dir / name).read_bytes())
                if reports:
                    stale = folder / "report_files"
                    if stale.is_dir():
                        shutil.rmtree(stale)
                    write_report([e["run"]], folder / "report.html", registry)
            atomic.write_text(output / f"{slug(task)}.html", task_page(task, rows, title, made, reports))
            data["tasks"][task] = [{k: e[k] for k in ("rank", "label", "slug", "episodes", "environments", "covers",
                                                      "benchmark", "scores")} | {"run_dir": str(e["run"].run_dir)}
                                   for e in rows]
        items = "".join(
            f"<li><a href='{html.escape(slug(task))}.html'>{html.escape(task)}</a> — {len(rows)} entr"
            f"{'y' if len(rows) == 1 else 'ies'}; best: {html.escape(rows[0]['label'])} "
            f"({MAIN_SCORE} {fmt(rows[0]['scores'].get(MAIN_SCORE, {}).get('value'))})</li>"
            for task, rows in tasks.items())
        atomic.write_text(output / "index.html", _page(title, (
            f"<header><h1>{html.escape(title)}</h1><p class='sub'>{len(runs)} entries · {len(tasks)} task"
            f"{'' if len(tasks) == 1 else 's'} · updated {html.escape(made)}</p></header>"
            f"<ul class='tasks'>{items}</ul><p class='note'>A static site made by <code>benchbot leaderboard</code>: "
            "plain files, no server; copy the folder to any web host.</p>")))
        atomic.write_text(output / "leaderboard.json", json.dumps(data, indent=2) + "\n")
    except OSError as exc:
        raise UsageError(f"--output: cannot write the site in {output} ({exc.strerror or exc})",
                         "choose a writable folder") from None
    return data
