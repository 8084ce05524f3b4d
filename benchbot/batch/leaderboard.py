"""``benchbot leaderboard``: a static leaderboard site from run directories (docs/report.md, "Leaderboard").

The site is plain files — no server, no external scripts, fonts or styles — so it can be copied to any web host
(or opened from disk) and keeps working after a challenge ends::

    site/index.html                      the tasks, with their entry counts
    site/<task>.html                     one page per task: the entries, sortable by any column
    site/entries/<entry>/manifest.json   each entry's manifest, scores.json, episode_scores.json, config.json
    site/entries/<entry>/report.html     and its report (``benchbot report``), with report_files/
    site/leaderboard.json                every entry's numbers

Entries are comparable only under identical conditions (:data:`~benchbot.batch.run_conditions.CONDITIONS` but the
environments: robot, noise preset, camera, simulator and its version, scene style, isolation level, evaluation
method, the set of ground truths the scores used), so each task's page has one table per condition set (:func:`condition_key`). Within a table, entries are
ranked on one set of environments (:func:`benchmark_set`: ``--environments``, else the set most of its entries ran):
an entry that covers it is scored on its episodes of those environments and ranked; an entry that does not is
listed, marked, and not ranked (its mean is over other scenes); an entry that is not verifiable (run without the
sandbox) is never ranked. The score is the evaluation method's primary score, as it declares it (its direction
decides what is better), the environment the unit: the mean of the environments' means with its interval over the
environments (none below :data:`~benchbot.batch.stats.MIN_CI_N`). Entries that the intervals do not tell apart
share a rank (:func:`rank_entries`).

Verified and self-reported entries are never ranked together (:func:`standing`, docs/challenge.md): an entry is
**verified** when its run carries a valid signature (``signature.json``) by one of the trusted keys
(``--trusted-key``), every covered file is as signed, and it ran sandboxed on held-out worlds; verified entries have
tables of their own. Everything else is **self-reported** (not signed, signed by a key not trusted, or run on public
worlds: "development — ground truth public"), listed in tables apart and ranked only among themselves; an entry whose
signature fails (an edited signed run) is listed as failing verification and never ranked.

Where this host holds an entry's ground truth (BEAR, procedural train/val, and test homes when it holds the split's
key), every results file of the entry is re-scored with its evaluation method (:func:`rescore`): an entry whose
recorded scores (``episode_scores.json``, ``scores.json``) differ from the re-score is listed as "scores do not match
its results" and never ranked, verified or not; an entry whose ground truth this host lacks is listed as "not
re-scored".
"""

from __future__ import annotations

import html
import json
import re
import shutil
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

from benchbot.batch import stats
from benchbot.batch.figures import fmt
from benchbot.batch.object_views import RESCORE_TOLERANCE
from benchbot.batch.report import CSS, write_report
from benchbot.batch.run_conditions import CONDITIONS, conditions, provenance_rows, solution, verifiable, worlds
from benchbot.batch.run_data import RunData
from benchbot.batch.run_stats import bounded, present_scores
from benchbot.batch.signing import DEVELOPMENT, is_held_out
from benchbot.core import atomic
from benchbot.core.errors import UsageError

COPIED = ("manifest.json", "scores.json", "episode_scores.json", "config.json", "signature.json", "conditions.json")
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
table.sortable{font-size:.8em}table.sortable th,table.sortable td{padding:4px 6px}
@media (max-width:1100px){.opt{display:none}}
.tasks li{margin:.3em 0}
"""


def slug(text: str) -> str:
    """A file-name-safe form of ``text``: ``semantic_slam:passive:ground_truth`` → ``semantic_slam-passive-ground_truth``."""
    return re.sub(r"[^A-Za-z0-9_.]+", "-", text).strip("-") or "entry"


LEADERBOARD_CONDITIONS = tuple(c for c in CONDITIONS if c not in ("task", "environments", "arch"))
"""What entries of one table share besides the task (the environments are the table's benchmark set; the arch is
shown, not a condition: the CPU and the GPU render the same scenes)."""


def condition_key(run: RunData) -> tuple[tuple[str, str], ...]:
    """``((condition, value), ...)`` of :data:`LEADERBOARD_CONDITIONS`: runs with equal keys go in one table
    ("not recorded" where an older batch did not record it, so such runs are not mixed with runs that did)."""
    c = conditions(run)
    return tuple((k, c[k] or "not recorded") for k in LEADERBOARD_CONDITIONS)


def benchmark_set(runs: list[RunData], given: list[str] | None = None) -> list[str]:
    """The environments a table's entries are ranked on: ``given`` (``--environments``), else the set of
    environments most entries ran (a tie goes to the larger set, then to the earlier entry)."""
    if given:
        return sorted(dict.fromkeys(given))
    sets = [tuple(sorted({r["env"] for r in run.rows})) for run in runs]
    return list(max(dict.fromkeys(sets), key=lambda s: (sets.count(s), len(s))))


STANDINGS = ("verified", "self-reported")
"""The two groups of tables: verified entries are never ranked with self-reported ones."""


def standing(run: RunData, trusted=None) -> dict:
    """Whether ``run``'s scores are verified: ``{"status", "reason", "fingerprint"}``. ``status``:

    * ``verified``: a valid signature by one of ``trusted`` (Ed25519 public keys), every covered file as signed,
      sandboxed (or containerised), on held-out worlds;
    * ``development``: all that, but on public worlds (ground truth public: a solution can carry it);
    * ``failed``: it has a signature, and it fails (the reason names the file): never ranked;
    * ``self-reported``: no signature, a signature by a key not trusted (or no trusted key given), or unsandboxed.
    """
    from benchbot.batch.signing import check_run
    from benchbot.core.errors import UsageError

    try:
        v = check_run(run.run_dir, trusted)
    except UsageError as exc:
        return {"status": "self-reported", "reason": exc.message, "fingerprint": ""}
    if v.status == "failed":
        return {"status": "failed", "reason": f"fails verification: {v.message}", "fingerprint": v.fingerprint}
    if v.status == "unsigned":
        return {"status": "self-reported", "reason": "not signed", "fingerprint": ""}
    if v.status == "untrusted" or not v.trusted_checked:
        return {"status": "self-reported", "reason": f"signed by key {v.fingerprint}, not a trusted one "
                "(--trusted-key)", "fingerprint": v.fingerprint}
    if v.signed.get("isolation") not in ("bwrap", "container"):
        return {"status": "self-reported", "reason": "signed, but run without the sandbox",
                "fingerprint": v.fingerprint}
    if (v.signed.get("conditions") or {}).get("worlds") == DEVELOPMENT or worlds(run.manifest) == DEVELOPMENT:
        return {"status": "development", "reason": f"signed by a trusted key, on public worlds: {DEVELOPMENT}",
                "fingerprint": v.fingerprint}
    return {"status": "verified", "reason": f"signed by trusted key {v.fingerprint}", "fingerprint": v.fingerprint}


RESCORE_STATES = ("matches", "differs", "not re-scored")
"""What re-scoring an entry found (:func:`rescore`): its scores are its results' (``matches``), are not (``differs``:
"scores do not match its results", never ranked), or this host could not tell (``not re-scored``)."""

MISMATCH = "scores do not match its results"
"""How an entry whose recorded scores differ from its results' re-score is listed (never ranked)."""


def _leaves(value, path: str = "") -> dict[str, object]:
    """``{path: number or None}`` of every number in ``value`` (nested dicts and lists; strings and booleans are
    left out, None kept as a leaf so that a score replaced by null is a difference)."""
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in _leaves(item, f"{path}.{key}").items()}
    if isinstance(value, list):
        return {k: v for i, item in enumerate(value) for k, v in _leaves(item, f"{path}[{i}]").items()}
    if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)):
        return {path or ".": value}
    return {}


def _differs(recorded, rescored, tolerance: float) -> str:
    """The first number (its path, both values) that differs between ``recorded`` and ``rescored`` by more than
    ``tolerance`` (NaN equals NaN; a number on one side only is a difference); "" when none does."""
    a, b = _leaves(recorded), _leaves(rescored)
    for key in sorted(set(a) | set(b)):
        x, y = a.get(key, "missing"), b.get(key, "missing")
        if isinstance(x, (int, float)) and isinstance(y, (int, float)):
            if (x != x and y != y) or abs(float(x) - float(y)) <= tolerance:
                continue
        elif x is None and y is None:
            continue
        return f"{key.lstrip('.')} {x if x == 'missing' else fmt(x) if isinstance(x, float) else x} recorded, " \
               f"{y if y == 'missing' else fmt(y) if isinstance(y, float) else y} re-scored"
    return ""


def rescore(run: RunData, registry) -> dict:
    """Re-score every results file of ``run`` with its evaluation method against ``registry``'s ground truth, as
    ``benchbot batch`` scored it (:func:`benchbot.core.evaluation.evaluate` over its ``ok`` episodes' results, each
    against the environment of its plan, the run's ``--ground-truths`` set), and compare with what it records:
    every episode's scores (``episode_scores.json``) and the combined ones (``scores.json``), within
    :data:`~benchbot.batch.object_views.RESCORE_TOLERANCE`.

    Returns:
        ``{"status": "matches" | "differs" | "not re-scored", "reason": one line}``. ``differs`` (:data:`MISMATCH`)
        also when a scored episode has no results file, when a results file no longer scores, or when an ``ok``
        episode's results are scored but not recorded. ``not re-scored`` when ``registry`` is None, when this host
        lacks the ground truth of one of its environments (held-out worlds of another host: only their host builds
        them) or the evaluation method, or when the run recorded none. Never raises.
    """
    from benchbot.core.errors import BenchbotError
    from benchbot.core.evaluation import evaluate

    def result(status: str, reason: str) -> dict:
        return {"status": status, "reason": reason}

    if registry is None:
        return result("not re-scored", "not re-scored: no ground truth given to this leaderboard")
    manifest = run.manifest
    method = manifest.get("evaluate_with")
    if not method:
        return result("not re-scored", "not re-scored: the run recorded no evaluation method")
    envs = [str(e) for e in manifest.get("environments") or []] or sorted({r["env"] for r in run.rows})
    for env in envs:
        try:
            names = [f"{s['name']}:{s['variant']}" for s in registry.scenes(env)]
            lacking = [n for n in names if not registry.has("ground_truths", n)]
        except BenchbotError as exc:
            lacking, names = [env], [exc.message]
        if lacking:
            held = " (held-out worlds: only their host builds them)" if is_held_out(env) else ""
            return result("not re-scored", f"not re-scored: this host lacks the ground truth of {lacking[0]}{held}")
    try:
        registry.get("evaluators", method)
    except BenchbotError:
        return result("not re-scored", f"not re-scored: this host lacks the evaluation method '{method}'")
    plan = {p.get("index"): p for p in manifest.get("plan") or [] if isinstance(p, dict)}
    rows = {r["index"]: r for r in run.rows}
    ok = [e for e in manifest.get("episodes") or [] if isinstance(e, dict) and e.get("status") == "ok"]
    sources: dict[str, int] = {}
    for index in [e.get("index") for e in ok] + list(rows):
        path = (rows.get(index) or {}).get("results") or next((e.get("results") for e in ok if e.get("index") == index),
                                                               None)
        if not path or ".." in Path(str(path)).parts or Path(str(path)).is_absolute():
            return result("differs", f"{MISMATCH}: episode {index} names no results file in the run")
        full = run.run_dir / str(path)
        if full.is_symlink() or not full.is_file():
            return result("differs", f"{MISMATCH}: {path}, scored, is not in the run directory")
        sources.setdefault(str(full), index)
    try:
        evaluation = evaluate(list(sources), method, registry, required_envs=envs, required_task=manifest.get("task"),
                              keep_going=True, environments={p: str((plan.get(i) or rows.get(i) or {}).get("env"))
                                                             for p, i in sources.items()},
                              ground_truth_set=manifest.get("ground_truth_set"))
    except BenchbotError as exc:
        return result("differs", f"{MISMATCH}: its results do not score ({exc.message})")
    if evaluation.errors:
        source, exc = evaluation.errors[0]
        return result("differs", f"{MISMATCH}: {Path(source).name} does not score ({exc.message})")
    if evaluation.skipped:
        return result("differs", f"{MISMATCH}: {Path(evaluation.skipped[0][0]).name} is not scored "
                                 f"({evaluation.skipped[0][1]})")
    try:
        recorded_rows = {e.get("index"): e for e in json.loads((run.run_dir / "episode_scores.json").read_text())
                         if isinstance(e, dict)}
        recorded = json.loads((run.run_dir / "scores.json").read_text())
    except (OSError, ValueError, AttributeError, TypeError) as exc:
        return result("differs", f"{MISMATCH}: episode_scores.json or scores.json unreadable "
                                 f"({exc.__class__.__name__})")
    for source, scores in evaluation.per_result:
        index = sources.get(source)
        entry = recorded_rows.get(index)
        if entry is None:
            return result("differs", f"{MISMATCH}: episode {index}'s results score, but episode_scores.json "
                                     "does not hold it")
        why = _differs(entry.get("scores"), (scores or {}).get("scores") if isinstance(scores, dict) else scores,
                       RESCORE_TOLERANCE)
        if why:
            return result("differs", f"{MISMATCH}: episode_scores.json, episode {index}: {why}")
    combined = evaluation.to_json()
    if isinstance(recorded, dict) and isinstance(combined, dict):
        recorded = {k: v for k, v in recorded.items() if k != "excluded_episodes"}
    why = _differs(recorded, combined, RESCORE_TOLERANCE)
    if why:
        return result("differs", f"{MISMATCH}: scores.json: {why}")
    return result("matches", f"re-scored: {len(sources)} results file{'s' if len(sources) != 1 else ''} give its "
                             "scores")


def better(a: dict, b: dict, sign: int) -> bool:
    """Whether estimate ``a`` is distinguishably better than ``b`` (``sign`` +1: higher is better, −1: lower):
    both have intervals and ``a``'s lies wholly on the better side of ``b``'s; where either has none (fewer than
    :data:`~benchbot.batch.stats.MIN_CI_N` environments), the better mean."""
    if a.get("value") is None or b.get("value") is None:
        return a.get("value") is not None and b.get("value") is None
    if None not in (a.get("low"), a.get("high"), b.get("low"), b.get("high")):
        return a["low"] > b["high"] if sign > 0 else a["high"] < b["low"]
    return sign * a["value"] > sign * b["value"]


def rank_entries(rows: list[dict], score: str, sign: int) -> None:
    """Rank the rankable entries of one table (``covers`` and ``verifiable``, not failing verification, and not
    re-scored to other scores than it records: :func:`rescore`) in place: an entry's rank is 1 + the
    number of entries distinguishably better (:func:`better`), so entries the intervals do not tell apart share a
    rank (``tied`` True); the others get ``rank`` None. Sorts ``rows``: ranked first, by rank then mean."""
    ranked = [e for e in rows if e["covers"] and e["verifiable"] and e.get("status") != "failed"
              and e.get("rescored") != "differs"]
    for e in rows:
        e["rank"], e["tied"] = None, False
    for e in ranked:
        est = e["scores"].get(score, {})
        e["rank"] = 1 + sum(better(o["scores"].get(score, {}), est, sign) for o in ranked if o is not e)
    for e in ranked:
        e["tied"] = sum(o["rank"] == e["rank"] for o in ranked) > 1
    rows.sort(key=lambda e: (e["rank"] is None, e["rank"] or 0,
                             -sign * (e["scores"].get(score, {}).get("value") or 0.0)))


def entries(runs: list[RunData], environments: list[str] | None = None, trusted=None,
            ground_truth=None) -> dict[str, list[dict]]:
    """Each task's tables: ``{task: [{"standing": "verified" | "self-reported", "conditions": {condition: value},
    "benchmark": [env], "score", "direction", "entries": [{"run", "label", "slug", "scores": {score: Estimate dict
    (environment level)}, "episodes", "environments", "covers", "verifiable", "status", "status_reason", "worlds",
    "rescored", "rescore_reason", "rank", "tied", "benchmark"}]}]}``, one table per standing and condition set
    (:func:`standing` with ``trusted``, the public keys of ``--trusted-key``; :func:`condition_key`), verified tables
    first, entries best first (:func:`rank_entries`). Every entry is re-scored against ``ground_truth`` (a registry;
    None: none is, each ``not re-scored``) by :func:`rescore`: one whose scores differ from its results' is never
    ranked. An entry that ``covers`` its table's :func:`benchmark_set` is scored on its episodes of
    those environments and ranked (when verifiable and not failing verification); any other entry on all its
    episodes, with ``rank`` None."""
    by_task: dict[str, dict[tuple, list[RunData]]] = {}
    standings, rescored = {}, {}
    for run in runs:
        standings[id(run)] = standing(run, trusted)
        rescored[id(run)] = rescore(run, ground_truth)
        group = "verified" if standings[id(run)]["status"] == "verified" else "self-reported"
        by_task.setdefault(str(run.manifest.get("task", "unknown task")), {}).setdefault(
            (("standing", group),) + condition_key(run), []).append(run)
    out: dict[str, list[dict]] = {}
    used: set[str] = set()
    for task, groups in by_task.items():
        tables = []
        for key, group_runs in groups.items():
            bench = benchmark_set(group_runs, environments)
            declared = group_runs[0].score_set
            score, sign = declared.primary.name, declared.sign()
            rows = []
            for run in group_runs:
                name = slug(f"{run.name}-{run.run_dir.name}")
                while name in used:
                    name += "-x"
                used.add(name)
                envs = sorted({r["env"] for r in run.rows})
                covers = set(bench) <= set(envs)
                scored = [r for r in run.rows if r["env"] in bench] if covers else run.rows
                st = standings[id(run)]
                rows.append({"run": run, "label": run.name, "slug": name, "episodes": len(scored),
                             "environments": envs, "covers": covers, "benchmark": bench,
                             "verifiable": verifiable(run.manifest), "status": st["status"],
                             "status_reason": st["reason"], "worlds": worlds(run.manifest),
                             "rescored": rescored[id(run)]["status"], "rescore_reason": rescored[id(run)]["reason"],
                             "scores": {s: bounded(stats.cluster_mean_ci([r[s] for r in scored if s in r],
                                                                         [r["env"] for r in scored if s in r]),
                                                   run, s).to_json()
                                        for s in present_scores([run])}})
            rank_entries(rows, score, sign)
            tables.append({"standing": key[0][1], "conditions": dict(key[1:]), "benchmark": bench, "score": score,
                           "direction": declared.primary.direction, "entries": rows})
        tables.sort(key=lambda t: (t["standing"] != "verified", not any(e["rank"] for e in t["entries"]),
                                   -len(t["entries"])))
        out[task] = tables
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


def _table_html(table: dict, reports: bool, number: int) -> str:
    """One condition set's table: heading with its conditions and benchmark environments, the entries, notes."""
    esc = html.escape
    rows, bench, main = table["entries"], table["benchmark"], table["score"]
    scores = list(dict.fromkeys([main] + [s for e in rows for s in e["scores"]]))
    # (heading, optional): optional columns are hidden on narrow screens
    head = [("rank", False), ("entry", False)] + [(f"{s} [95 % CI]", s != main) for s in scores] + [
        ("solution", True), ("environments", False), ("episodes", True), ("date", True), ("BenchBot", True),
        ("git", True), ("files", False)]
    body = []
    for e in rows:
        run: RunData = e["run"]
        prov = dict(provenance_rows(run))
        git = (run.manifest.get("provenance") or {}).get("benchbot_git") or ""
        kind, what = solution(run.manifest)
        started = str(run.manifest.get("started", ""))[:10]
        links = [f"<a href='entries/{esc(e['slug'])}/manifest.json'>manifest</a>"]
        if reports:
            links.insert(0, f"<a href='entries/{esc(e['slug'])}/report.html'>report</a>")
        label = e["label"] + ("" if e["verifiable"] else " (not verifiable)") + (
            " (fails verification)" if e["status"] == "failed" else "") + (
            f" ({MISMATCH})" if e.get("rescored") == "differs" else "")
        tag = e["status"] + (f" · {DEVELOPMENT}" if e["worlds"] == DEVELOPMENT else "") + (
            " · not re-scored" if e.get("rescored") == "not re-scored" else " · re-scored" if e.get("rescored") ==
            "matches" else "")
        rank = f"{e['rank']}=" if e["tied"] else str(e["rank"]) if e["rank"] else "–"
        cells = [_cell(e["rank"], rank, "num rank",
                       title="not told apart from the entries of the same rank by the intervals" if e["tied"] else ""),
                 f"<td class='txt' data-v='{esc(label)}' title='{esc(e['status_reason'])}; "
                 f"{esc(e.get('rescore_reason') or '')}"
                 f"{'' if e['verifiable'] else '; run without the sandbox: its solution could read the ground truth'}'>"
                 f"{esc(label)}<br><small>{esc(tag)}</small></td>"]
        cells += [_estimate_cell(e["scores"].get(s), "num" if s == main else "num opt") for s in scores]
        cells.append(_cell(f"{kind} {what}", cls="txt opt"))
        covered = len(set(e["environments"]) & set(bench))
        cells += [_cell(covered, f"{covered} of {len(bench)}" + (f" (+{len(e['environments']) - covered})"
                                                                 if len(e["environments"]) > covered else ""),
                        title=", ".join(e["environments"])),
                  _cell(e["episodes"], cls="num opt"), _cell(started, cls="txt opt"),
                  _cell(prov.get("BenchBot"), cls="txt opt"),
                  _cell(git[:12] + ("+dirty" if git.endswith("+dirty") else ""), cls="txt opt", title=git),
                  f"<td class='txt' data-v=''>{' · '.join(links)}</td>"]
        body.append(f"<tr class='{'' if e['rank'] else 'partial'}'>{''.join(cells)}</tr>")
    notes = []
    partial = sum(not e["covers"] for e in rows)
    if partial:
        notes.append(f"{partial} entr{'y does' if partial == 1 else 'ies do'} not cover the ranked environments: "
                     "listed in grey, not ranked, scored on their own episodes (other scenes).")
    unverified = sum(not e["verifiable"] for e in rows)
    if unverified:
        notes.append(f"{unverified} entr{'y is' if unverified == 1 else 'ies are'} not verifiable: run without the "
                     "sandbox (<code>--no-sandbox</code>), where the solution could read the ground truth; listed in "
                     "grey and not ranked.")
    for e in rows:
        if e["status"] == "failed":
            notes.append(f"{esc(e['label'])} {esc(e['status_reason'])}: its files are not as the host signed them; "
                         "listed, not ranked.")
    for e in rows:
        if e.get("rescored") == "differs":
            notes.append(f"{esc(e['label'])}: <b>{esc(MISMATCH)}</b> ({esc(e['rescore_reason'].split(': ', 1)[-1])}):"
                         " re-scored against this host's ground truth, its recorded scores are not its results'; "
                         "listed, never ranked.")
    unchecked = [e for e in rows if e.get("rescored") == "not re-scored"]
    if unchecked:
        notes.append(f"{len(unchecked)} entr{'y is' if len(unchecked) == 1 else 'ies are'} <b>not re-scored</b>: "
                     + esc(unchecked[0]["rescore_reason"].removeprefix("not re-scored: "))
                     + ("" if len(unchecked) == 1 else " (hover an entry for each one's reason)")
                     + "; their scores are as recorded.")
    public = sum(e["worlds"] == DEVELOPMENT for e in rows)
    if public:
        notes.append(f"{public} entr{'y ran' if public == 1 else 'ies ran'} on public worlds "
                     f"(<b>{esc(DEVELOPMENT)}</b>): a solution could carry their ground truth in its own code.")
    if table["standing"] != "verified":
        notes.append("<b>Self-reported</b>: not verified by a trusted host's signature on held-out worlds (hover an "
                     "entry for why); ranked only among themselves, never with verified entries.")
    if any(e["tied"] for e in rows):
        notes.append("Entries whose intervals overlap share a rank (=): the data do not tell them apart.")
    if any(e["rank"] and e["scores"].get(main, {}).get("low") is None for e in rows):
        notes.append(f"Entries with fewer than {stats.MIN_CI_N} environments have no interval: they are ordered by "
                     "their mean alone.")
    conds = " · ".join(f"{esc(k)} <b>{esc(v)}</b>" for k, v in table["conditions"].items())
    heading = "Verified" if table["standing"] == "verified" else "Self-reported"
    return (f"<section id='set-{number}'><h2>{heading}: conditions {number}</h2><p class='sub'>{conds}</p>"
            f"<p class='sub'>{len(rows)} entr{'y' if len(rows) == 1 else 'ies'} · ranked by {esc(main)} "
            f"({esc(table['direction'])} is better), the mean over each entry's environments of "
            f"{len(bench)} environment{'s' if len(bench) != 1 else ''}: {esc(', '.join(bench))}</p>"
            "<div class='scroll'><table class='sortable'><thead><tr>"
            + "".join(f"<th scope='col'{' class=opt' if opt else ''}>{esc(h)}</th>" for h, opt in head)
            + "</tr></thead><tbody>" + "".join(body) + "</tbody></table></div>"
            + "".join(f"<p class='note'>{n}</p>" for n in notes) + "</section>")


def task_page(task: str, tables: list[dict], title: str, made: str, reports: bool) -> str:
    """One task's page: one sortable table per condition set (:func:`condition_key`), each entry linking its
    manifest (and report)."""
    esc = html.escape
    n = sum(len(t["entries"]) for t in tables)
    return _page(f"{title}: {task}", (
        f"<header><p class='sub'><a href='index.html'>{esc(title)}</a></p><h1>{esc(task)}</h1>"
        f"<p class='sub'>{n} entries in {len(tables)} condition set{'s' if len(tables) != 1 else ''} · updated "
        f"{esc(made)}</p></header>"
        "<div class='box'>Entries are ranked only against entries run under the same conditions (robot, noise "
        "preset, camera, simulator and its version, scene style, isolation, evaluation method): one table per "
        "set. Click a column heading to sort by it (on a screen narrower than 1100 px only the main columns are shown). Scores "
        f"are means over environments with {int(stats.CONFIDENCE * 100)} % intervals over the environments "
        f"(Student t below {stats.T_INTERVAL_BELOW}, none below {stats.MIN_CI_N}: then n is shown). Each entry's "
        "manifest records its command, seeds, versions, git revision and machine.</div>"
        + "".join(_table_html(t, reports, k + 1) for k, t in enumerate(tables))), script=True)


def write_site(runs: list[RunData], output: Path, *, title: str = "BenchBot leaderboard", registry=None,
               reports: bool = True, environments: list[str] | None = None, skipped: list[str] | None = None,
               on_step: Callable[[str], None] | None = None, trusted=None, ground_truth=None) -> dict:
    """Write the static site into the folder ``output`` (created; files of earlier runs of this command are
    replaced, nothing else is touched). Every file is written atomically.

    Args:
        runs: labelled runs (:func:`benchbot.batch.run_data.assign_labels`).
        registry: for the entries' reports (per-class views and maps); None leaves them out of those reports.
        reports: also write each entry's report (the slow part: its figures).
        environments: the environments entries are ranked on (:func:`benchmark_set`); None: the most common set.
        skipped: one line per run directory left out (unfinished batches, or every episode failed), listed on the index page.
        on_step: told each step as it starts ("writing entry 2 of 5's report: semslam_geometric").
        trusted: the hosts' Ed25519 public keys whose signatures make an entry verified (:func:`standing`).
        ground_truth: the registry whose ground truth re-scores every entry's results (:func:`rescore`); None:
            entries are not re-scored.

    Returns:
        ``{"title", "made", "tasks": {task: [{"conditions", "benchmark", "score", "direction", "entries":
        [entry summary]}]}, "skipped"}`` as written to ``leaderboard.json``.

    Raises:
        UsageError: ``output`` cannot be written, or is a file.
    """
    if output.exists() and not output.is_dir():
        raise UsageError(f"--output: {output} is a file", "give a folder for the site, e.g. -o site/")
    made = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    tasks = entries(runs, environments, trusted, ground_truth)
    data = {"title": title, "made": made, "tasks": {}, "skipped": list(skipped or [])}
    say = on_step or (lambda what: None)
    total, done = sum(len(t["entries"]) for tables in tasks.values() for t in tables), 0
    try:
        for task, tables in tasks.items():
            for t in tables:
                for e in t["entries"]:
                    done += 1
                    say(f"writing entry {done} of {total}" + ("'s report" if reports else "") + f": {e['label']}")
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
            atomic.write_text(output / f"{slug(task)}.html", task_page(task, tables, title, made, reports))
            data["tasks"][task] = [
                {k: t[k] for k in ("standing", "conditions", "benchmark", "score", "direction")}
                | {"entries": [{k: e[k] for k in ("rank", "tied", "label", "slug", "episodes", "environments", "covers",
                                                  "verifiable", "status", "status_reason", "worlds", "rescored",
                                                  "rescore_reason", "scores")} | {"run_dir": str(e["run"].run_dir)}
                               for e in t["entries"]]}
                for t in tables]
        items = []
        for task, tables in tasks.items():
            n = sum(len(t["entries"]) for t in tables)
            best = "; ".join(f"{html.escape(t['entries'][0]['label'])} ({html.escape(t['score'])} "
                             f"{fmt(t['entries'][0]['scores'].get(t['score'], {}).get('value'))})"
                             for t in tables if t["entries"] and t["entries"][0]["rank"])
            items.append(f"<li><a href='{html.escape(slug(task))}.html'>{html.escape(task)}</a> — {n} entr"
                         f"{'y' if n == 1 else 'ies'} in {len(tables)} condition set{'s' if len(tables) != 1 else ''}"
                         + (f"; best: {best}" if best else "") + "</li>")
        left_out = "".join(f"<li>{html.escape(line)}</li>" for line in skipped or [])
        atomic.write_text(output / "index.html", _page(title, (
            f"<header><h1>{html.escape(title)}</h1><p class='sub'>{len(runs)} entries · {len(tasks)} task"
            f"{'' if len(tasks) == 1 else 's'} · updated {html.escape(made)}</p></header>"
            f"<ul class='tasks'>{''.join(items)}</ul>"
            + (f"<p class='note'>Left out (unfinished, or every episode failed):</p><ul class='note'>{left_out}</ul>" if left_out else "")
            + "<p class='note'>A static site made by <code>benchbot leaderboard</code>: plain files, no server; copy "
              "the folder to any web host.</p>")))
        atomic.write_text(output / "leaderboard.json", json.dumps(data, indent=2) + "\n")
    except OSError as exc:
        raise UsageError(f"--output: cannot write the site in {output} ({exc.strerror or exc})",
                         "choose a writable folder") from None
    return data
