"""Performance profiles of batch runs (``benchbot report``): statistics that say what they can, per-class and
per-object views, and paper output (docs/report.md).

Inputs are run directories written by ``benchbot batch`` (``manifest.json``, ``config.json``,
``episode_scores.json``, ``results/``). :func:`analyse` turns them into one JSON-able dict (what ``--json`` prints);
:func:`write_report` writes the HTML page and, next to it in ``<stem>_files/``, every figure as PNG, SVG and PDF and
every table as CSV and LaTeX.

Statistics (:mod:`benchbot.batch.stats`): means with BCa bootstrap intervals from :data:`~benchbot.batch.stats.MIN_CI_N`
episodes on; runs compared with the first one (the baseline) on episodes paired by environment, robot, noise preset
and seed (common random numbers), from :data:`~benchbot.batch.stats.MIN_TEST_PAIRS` pairs on, with the mean
difference and its interval, Cohen's d_z, the paired t-test and the Wilcoxon signed-rank test with its rank-biserial
correlation, the p-values Holm-adjusted over the comparisons of the report.

Per-class and per-object views re-score each episode's results file with the run's evaluation method asking for
``per_class`` and ``matches`` (OMQ: docs/evaluation.md), and check that the re-scored OMQ equals the run's.
"""

from __future__ import annotations

import base64
import html
import json
import os
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from benchbot.batch import figures, stats
from benchbot.batch.figures import fmt
from benchbot.batch.paper import Table, to_csv, to_html, to_latex
from benchbot.batch.plan import read_manifest
from benchbot.core import atomic
from benchbot.core.errors import BenchbotError, UsageError
from benchbot.core.sandbox import VERIFIABLE

SCORES = ["OMQ", "avg_pairwise", "avg_label", "avg_spatial", "avg_fp_quality", "avg_state_quality"]
"""The scores a report shows, in order (those present in the runs)."""

MAIN_SCORE = "OMQ"
"""The score environments, comparisons and predictivity are computed on."""

PAIR_KEY = ("env", "robot", "noise", "seed")
"""Episodes of two runs pair up when all of these are equal (the same environment, robot, noise preset and seed)."""

RESCORE_TOLERANCE = 1e-9
"""Largest difference between a run's OMQ and the re-scored OMQ that is not reported as a change."""


@dataclass
class RunData:
    """One run directory's episodes with their scores.

    Attributes:
        run_dir: the folder. manifest, config: its ``manifest.json`` and ``config.json``.
        rows: one dict per scored episode: ``index``, ``env``, ``robot``, ``repeat``, ``seed``, ``noise``
            (``"none"`` when not recorded), ``lighting`` (or ``""``), ``results`` (path relative to the run
            directory, or ``""``) and every score of :data:`SCORES` it has.
        label: the name the report gives the run (``--label``, else :func:`default_label`).
        objects: per episode index, the re-scored evaluation with ``per_class`` and ``matches`` (after
            :func:`score_objects`).
        per_class: the run's per-class totals and scores pooled over its episodes, or None.
        objects_note: why there are no per-class or per-object views, or what re-scoring found; "" when all is well.
    """

    run_dir: Path
    manifest: dict
    config: dict
    rows: list[dict]
    label: str = ""
    objects: dict[int, dict] = field(default_factory=dict)
    per_class: dict | None = None
    objects_note: str = ""

    @property
    def name(self) -> str:
        """The run's label, or its folder's name."""
        return self.label or self.run_dir.name


def _read_json(path: Path, what: str):
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path}: {what} is unreadable or not JSON ({exc.__class__.__name__})",
                         "it is written by `benchbot batch`; was it edited or cut short?") from None


def load_run(run_dir: Path, label: str | None = None) -> RunData:
    """Read a run directory.

    Raises:
        UsageError: not a run directory, no scores (not evaluated yet), or a file is malformed (naming it and the
            field).
    """
    run_dir = Path(run_dir)
    manifest = read_manifest(run_dir)
    path = run_dir / "episode_scores.json"
    if not path.is_file():
        raise UsageError(f"{run_dir} has no episode_scores.json (the batch was not evaluated)", "run it with --evaluate-with omq")
    config = _read_json(run_dir / "config.json", "config.json") if (run_dir / "config.json").is_file() else {}
    entries = _read_json(path, "episode_scores.json")
    plan = {p.get("index"): p for p in manifest.get("plan", []) if isinstance(p, dict)}
    records = {e.get("index"): e for e in manifest.get("episodes", []) if isinstance(e, dict)}
    try:
        lighting = {env: "+".join(str(s.get("lighting", "")) for s in scenes)
                    for env, scenes in (config.get("environments") or {}).items()}
        if not isinstance(entries, list):
            raise TypeError("expected a list of episodes")
        rows = []
        for k, entry in enumerate(entries):
            missing = [f for f in ("index", "env", "robot", "repeat", "seed") if f not in entry]
            if missing:
                raise KeyError(f"[{k}].{missing[0]}")
            row = {f: entry[f] for f in ("index", "env", "robot", "repeat", "seed")}
            spec = plan.get(entry["index"], {})
            row["noise"] = str(entry.get("noise") or spec.get("noise") or "none")
            options = spec.get("options") or {}
            row["lighting"] = str(options.get("lighting") or lighting.get(entry["env"], ""))
            row["results"] = str((records.get(entry["index"]) or spec).get("results", ""))
            row.update({s: float(v) for s, v in (entry.get("scores") or {}).items() if s in SCORES})
            rows.append(row)
    except (KeyError, TypeError, AttributeError, ValueError) as exc:
        detail = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        raise UsageError(f"{path}: malformed ({detail})", "it is written by `benchbot batch`; was it edited?") from None
    if not rows:
        raise UsageError(f"{run_dir} has no scored episodes", "every episode failed, or the batch ran with --no-evaluate")
    return RunData(run_dir, manifest, config, rows, label or "")


# --------------------------------------------------------------------------------------------------------------------
# Labels and provenance
# --------------------------------------------------------------------------------------------------------------------
_SOLUTION_FLAGS = ((("--example", "-E"), "example"), (("--native", "-n"), "native"),
                   (("--containerised", "-c"), "container"))


def solution(manifest: dict) -> tuple[str, str]:
    """``(kind, what)`` of the run's solution from the ``benchbot batch`` command it recorded: ``("example",
    "semslam_geometric")``, ``("native", "python my.py")``, ``("container", "path/to/dir")``; else ``("native",
    <the first episode's command>)`` or ``("unknown", "")``."""
    command = [str(w) for w in manifest.get("command") or []]
    for flags, kind in _SOLUTION_FLAGS:
        for i, word in enumerate(command):
            if word in flags and i + 1 < len(command):
                return kind, command[i + 1]
            for flag in flags:
                if flag.startswith("--") and word.startswith(flag + "="):
                    return kind, word.split("=", 1)[1]
    plan = manifest.get("plan") or [{}]
    argv = plan[0].get("argv") if isinstance(plan[0], dict) else None
    return ("native", " ".join(map(str, argv))) if argv else ("unknown", "")


def isolation(manifest: dict) -> str:
    """How the run's solutions were isolated (its manifest's ``sandbox``: ``bwrap``, ``container`` or ``none``);
    ``none`` for a batch that ran before BenchBot recorded it (it ran unsandboxed)."""
    return str(manifest.get("sandbox") or "none")


def verifiable(manifest: dict) -> bool:
    """Whether the run's scores can be trusted: its solutions could not read the ground truth (they ran sandboxed
    or in a container, docs/security.md)."""
    return isolation(manifest) in VERIFIABLE


def default_label(manifest: dict, run_dir: Path) -> str:
    """A short name for a run: the example's name, a native command's script (``my_solution.py``) or program, a
    container folder's name; the folder's name when the manifest does not say."""
    kind, what = solution(manifest)
    if kind == "example":
        return what
    if kind == "container":
        return Path(what.rstrip("/")).name or what
    if kind == "native" and what:
        words = what.split()
        script = next((w for w in words if w.endswith((".py", ".sh", ".jl", ".R"))), words[0])
        return Path(script).name
    return run_dir.name


def assign_labels(runs: list[RunData], labels: list[str] | None) -> None:
    """Give every run its label: ``labels`` in order (``--label``), else :func:`default_label`; a label two runs
    share gets each run's folder name added (``semslam_geometric (batch-20261122-103519)``).

    Raises:
        UsageError: ``labels`` given, but not one per run, or empty.
    """
    if labels:
        if len(labels) != len(runs):
            raise UsageError(f"--label: {len(labels)} labels for {len(runs)} run directories",
                             "give one --label per run directory, in the same order")
        if any(not str(label).strip() for label in labels):
            raise UsageError("--label: a label is empty", "give each run a name, e.g. --label baseline")
    for k, run in enumerate(runs):
        run.label = str(labels[k]).strip() if labels else default_label(run.manifest, run.run_dir)
    seen: dict[str, int] = {}
    for run in runs:
        seen[run.label] = seen.get(run.label, 0) + 1
    for run in runs:
        if seen[run.label] > 1:
            run.label = f"{run.label} ({run.run_dir.name})"
    for k, run in enumerate(runs):  # still equal (same folder names): number them
        if sum(r.label == run.label for r in runs) > 1:
            run.label = f"{run.label} #{k + 1}"


def provenance(run: RunData) -> list[tuple[str, str]]:
    """``[(what, value)]``: where a run's numbers came from (solution, command, task, robots, environments,
    episodes, seeds, times, versions, git revisions, machine), as its manifest recorded them."""
    m = run.manifest
    kind, what = solution(m)
    plan = [p for p in m.get("plan", []) if isinstance(p, dict)]
    records = [e for e in m.get("episodes", []) if isinstance(e, dict)]
    seeds = sorted({int(p["seed"]) for p in plan if isinstance(p.get("seed"), int)})
    statuses: dict[str, int] = {}
    for e in records:
        statuses[str(e.get("status"))] = statuses.get(str(e.get("status")), 0) + 1
    versions = m.get("versions") or {}
    prov = m.get("provenance") or {}
    machine = prov.get("machine") or {}
    not_recorded = "not recorded (the batch ran before BenchBot recorded it)"
    level = isolation(m)
    rows = [
        ("solution", f"{kind} {what}".strip()),
        ("isolation", f"{level} ({'scores verifiable' if verifiable(m) else 'NOT VERIFIABLE: the solution could read the ground truth'})"
         + ("" if "sandbox" in m else "; not recorded (the batch ran before the sandbox)")),
        ("command", " ".join(map(str, m.get("command") or [])) or "not recorded"),
        ("task", str(m.get("task", ""))),
        ("robots", ", ".join(m.get("robots") or [])),
        ("environments", ", ".join(m.get("environments") or [])),
        ("episodes", f"{len(run.rows)} scored of {len(plan) or len(records)} planned ("
                     + ", ".join(f"{n} {s}" for s, n in sorted(statuses.items())) + ")"),
        ("seeds", _ranges(seeds) if seeds else "not recorded"),
        ("noise presets", ", ".join(sorted({str(p.get("noise", "none")) for p in plan})) or "none"),
        ("evaluation", str(m.get("evaluate_with") or "none")),
        ("started", str(m.get("started", "not recorded"))),
        ("wall time", f"{fmt(m.get('wall_s'))} s" if isinstance(m.get("wall_s"), (int, float)) else "not recorded"),
        ("BenchBot", str(versions.get("benchbot", "not recorded"))),
        ("BenchBot git revision", str(prov.get("benchbot_git") or (not_recorded if not prov else "not a git checkout"))),
        ("solution git revision", ", ".join(f"{v or 'not a git checkout'} ({k})" for k, v in (prov.get("solution_git") or {}).items())
         or not_recorded),
        ("machine", (f"{machine.get('cpu') or '?'}, {machine.get('cpus') or '?'} CPUs, {fmt(machine.get('memory_gib'))} GiB; "
                     f"{machine.get('system') or versions.get('platform', '')}") if machine else
         f"{versions.get('platform', '')} (CPU, cores, memory {not_recorded})"),
        ("Python", str(versions.get("python", "not recorded"))),
        ("packages", ", ".join(f"{k} {v}" for k, v in versions.items() if k not in ("python", "platform", "benchbot"))
         or "not recorded"),
    ]
    return rows


def _ranges(values: list[int]) -> str:
    """``[0, 1, 2, 5]`` → ``"0–2, 5"``."""
    out, start = [], None
    for k, v in enumerate(values):
        if start is None:
            start = v
        if k + 1 == len(values) or values[k + 1] != v + 1:
            out.append(str(start) if start == v else f"{start}–{v}")
            start = None
    return ", ".join(out)


# --------------------------------------------------------------------------------------------------------------------
# Statistics over runs
# --------------------------------------------------------------------------------------------------------------------
def group(rows: list[dict], key: str, score: str = MAIN_SCORE) -> dict[str, list[float]]:
    """``{value of key: [score of each row]}`` in first-seen order."""
    out: dict[str, list[float]] = {}
    for row in rows:
        if score in row:
            out.setdefault(str(row[key]), []).append(row[score])
    return out


def present_scores(runs: list[RunData]) -> list[str]:
    """The scores of :data:`SCORES` that some episode of ``runs`` has, in order."""
    return [s for s in SCORES if any(s in r for run in runs for r in run.rows)]


def summary(run: RunData) -> dict[str, stats.Estimate]:
    """Mean and interval (:func:`benchbot.batch.stats.mean_ci`) of every score present, over all episodes."""
    return {s: stats.mean_ci([r[s] for r in run.rows if s in r]) for s in present_scores([run])}


def per_environment(run: RunData, score: str = MAIN_SCORE) -> dict[str, stats.Estimate]:
    """Mean and interval of ``score`` per environment, over that environment's episodes."""
    return {env: stats.mean_ci(v) for env, v in group(run.rows, "env", score).items()}


def _pair_label(row: dict, robots: bool, noise: bool) -> str:
    parts = [row["env"]] + ([row["robot"]] if robots else []) + ([row["noise"]] if noise else [])
    return " ".join(parts) + f" s{row['seed']}"


def pair_episodes(a: RunData, b: RunData, score: str = MAIN_SCORE) -> dict:
    """Pair the episodes of two runs: equal environment, robot, noise preset and seed (:data:`PAIR_KEY`); when no
    episode pairs that way (the runs used different seeds), equal environment, robot, noise preset and repetition.

    Returns:
        ``{"pairing": how, in words, "keys": [a name per pair], "a": [...], "b": [...], "unpaired": episodes of
        either run left out}``.
    """
    def index(run: RunData, fields: tuple) -> dict:
        out = {}
        for row in run.rows:
            if score in row:
                out.setdefault(tuple(row[f] for f in fields), row)
        return out

    robots = len({r["robot"] for r in a.rows + b.rows}) > 1
    noise = len({r["noise"] for r in a.rows + b.rows}) > 1
    how = "environment and seed"
    ia, ib = index(a, PAIR_KEY), index(b, PAIR_KEY)
    shared = [k for k in ia if k in ib]
    if not shared:
        fields = ("env", "robot", "noise", "repeat")
        ia, ib = index(a, fields), index(b, fields)
        shared = [k for k in ia if k in ib]
        how = "environment and repetition (the seeds differ)"
    scored = sum(score in r for r in a.rows) + sum(score in r for r in b.rows)
    return {"pairing": how, "keys": [_pair_label(ia[k], robots, noise) for k in shared],
            "a": [ia[k][score] for k in shared], "b": [ib[k][score] for k in shared],
            "unpaired": scored - 2 * len(shared)}


def compare(a: RunData, b: RunData, score: str = MAIN_SCORE) -> dict:
    """Paired comparison of run ``b`` against run ``a`` (:func:`pair_episodes`, then
    :func:`benchbot.batch.stats.paired_test`).

    Returns:
        ``{"a", "b" (labels), "score", "pairing", "n", "unpaired", "keys", "differences" (b − a per pair),
        "difference" (Estimate dict), "cohens_dz", "rank_biserial", "ttest_p", "wilcoxon_p", "reason"}``.
    """
    pairs = pair_episodes(a, b, score)
    test = stats.paired_test(pairs["a"], pairs["b"])
    return {"a": a.name, "b": b.name, "score": score, "pairing": pairs["pairing"], "n": test["n"],
            "unpaired": pairs["unpaired"], "keys": pairs["keys"],
            "differences": [float(y - x) for x, y in zip(pairs["a"], pairs["b"])],
            "difference": test["difference"].to_json(), "cohens_dz": test["cohens_dz"],
            "rank_biserial": test["rank_biserial"], "ttest_p": test["ttest_p"], "wilcoxon_p": test["wilcoxon_p"],
            "reason": test["reason"]}


def comparisons(runs: list[RunData], score: str = MAIN_SCORE) -> list[dict]:
    """Every run after the first compared with the first (:func:`compare`), the p-values of each test adjusted
    with Holm's method over these comparisons (``ttest_p_holm``, ``wilcoxon_p_holm``)."""
    out = [compare(runs[0], run, score) for run in runs[1:]]
    for test in ("ttest_p", "wilcoxon_p"):
        for c, p in zip(out, stats.holm([c[test] for c in out])):
            c[f"{test}_holm"] = p
    return out


# --------------------------------------------------------------------------------------------------------------------
# Per class and per object
# --------------------------------------------------------------------------------------------------------------------
def score_objects(run: RunData, registry) -> None:
    """Re-score the run's results files with its evaluation method asking for ``per_class`` and ``matches``;
    fills ``run.objects``, ``run.per_class`` and ``run.objects_note`` (why not, or that the re-scored OMQ differs
    from the run's, e.g. because the ground truth changed since). Never raises: what cannot be done is noted."""
    from benchbot.core.evaluation import evaluate

    method = run.manifest.get("evaluate_with")
    if not method:
        run.objects_note = "the batch ran without an evaluation method: no per-class or per-object views"
        return
    by_path = {}
    for row in run.rows:
        path = run.run_dir / row["results"] if row["results"] else None
        if path is not None and path.is_file():
            by_path[str(path)] = row
    if not by_path:
        run.objects_note = "the results files are not in the run directory: no per-class or per-object views"
        return
    evaluation = None
    for options in ({"per_class": True, "matches": True}, {"per_class": True}):
        try:
            evaluation = evaluate(list(by_path), method, registry, required_task=run.manifest.get("task"),
                                  options=options, keep_going=True)
            break
        except UsageError:
            continue  # the method lacks the option: try with less
        except BenchbotError as exc:
            run.objects_note = f"re-scoring failed: {exc.message}"
            return
    if evaluation is None:
        run.objects_note = f"the evaluation method '{method}' gives no per-class scores"
        return
    differences = []
    for source, result in evaluation.per_result:
        row = by_path.get(source)
        if row is None:
            continue
        run.objects[row["index"]] = result
        new = (result.get("scores") or {}).get(MAIN_SCORE)
        if new is not None and MAIN_SCORE in row:
            differences.append(abs(float(new) - row[MAIN_SCORE]))
    combined = evaluation.combined or {}
    run.per_class = combined.get("per_class")
    notes = []
    if evaluation.errors:
        notes.append(f"{len(evaluation.errors)} results file(s) could not be re-scored ({evaluation.errors[0][1].message})")
    if differences and max(differences) > RESCORE_TOLERANCE:
        notes.append(f"re-scored {MAIN_SCORE} differs from the run's by up to {fmt(max(differences))}: the ground truth "
                     "or the evaluation method changed since the batch ran; per-class and per-object views show today's "
                     "scoring")
    if not any("matches" in r for r in run.objects.values()):
        notes.append(f"the evaluation method '{method}' gives no per-object matches: no top-down maps")
    run.objects_note = "; ".join(notes)


def per_class_rows(run: RunData) -> list[dict]:
    """``[{class, GT, TP, FN, FP, avg_label, avg_spatial, avg_pairwise, OMQ}]`` pooled over the run's episodes,
    classes by ground-truth count (most first); qualities None without a TP."""
    rows = []
    for cls, entry in (run.per_class or {}).items():
        t, s = entry.get("totals") or {}, entry.get("scores") or {}
        tp = int(t.get("TP", 0))
        rows.append({"class": cls, "GT": tp + int(t.get("FN", 0)), "TP": tp, "FN": int(t.get("FN", 0)),
                     "FP": int(t.get("FP", 0)), "avg_label": s.get("avg_label") if tp else None,
                     "avg_spatial": s.get("avg_spatial") if tp else None,
                     "avg_pairwise": s.get("avg_pairwise") if tp else None, "OMQ": s.get("OMQ")})
    return sorted(rows, key=lambda r: (-r["GT"], -r["FP"], r["class"]))


def trajectory(env: str, registry, fallback: list | None = None) -> np.ndarray | None:
    """``(k, 2)`` x, y (metres, map frame) of the environment's start pose then its trajectory poses (first
    scene), from the registry's environment spec, else from ``fallback`` (a results file's
    ``environment_details``); None when neither has poses."""
    scenes = None
    try:
        scenes = registry.scenes(env) if registry is not None else None
    except BenchbotError:
        scenes = None
    scenes = scenes or fallback or []
    if not scenes or not isinstance(scenes[0], dict):
        return None
    scene = scenes[0]
    poses = ([scene["start_pose"]] if scene.get("start_pose") else []) + list(scene.get("trajectory_poses") or [])
    xy = [(float(p[4]), float(p[5])) for p in poses if isinstance(p, (list, tuple)) and len(p) >= 6]
    return np.array(xy) if xy else None


def map_episode(run: RunData, env: str) -> tuple[dict, dict, int] | None:
    """The episode of ``env`` a map shows: the one with the median OMQ among those with matches (the lower one
    of the middle two) → ``(row, evaluation, how many there were)``; None when none has matches."""
    rows = [r for r in run.rows if r["env"] == env and "matches" in run.objects.get(r["index"], {})]
    if not rows:
        return None
    rows.sort(key=lambda r: (r.get(MAIN_SCORE, 0.0), r["index"]))
    row = rows[(len(rows) - 1) // 2]
    return row, run.objects[row["index"]], len(rows)


# --------------------------------------------------------------------------------------------------------------------
# Factors: robots, noise presets, lighting
# --------------------------------------------------------------------------------------------------------------------
def factor_views(runs: list[RunData], score: str = MAIN_SCORE) -> list[dict]:
    """The factors a run varies, each as ``{"factor", "groups", "series", "note"}`` (``series`` one per run as
    :func:`benchbot.batch.figures.per_group` takes it; ``groups`` empty when the factor cannot be shown).

    Robots and noise presets run on the same environments and seeds, so their groups compare like with like.
    Lighting is a property of an environment variant (``house:3`` is ``night``) that also changes the objects and
    the trajectory: grouping by lighting across variants would measure the variants. It is shown only within an
    environment run under several lightings; otherwise the note says why it is not shown.
    """
    out = []
    for factor in ("robot", "noise"):
        levels = list(dict.fromkeys(r[factor] for run in runs for r in run.rows))
        if len(levels) > 1:
            out.append({"factor": factor, "groups": levels, "note": "", "series": [
                {"label": run.name, "values": group(run.rows, factor, score),
                 "estimates": {g: stats.mean_ci(v).to_json() for g, v in group(run.rows, factor, score).items()}}
                for run in runs]})
    lit: dict[str, set] = {}
    for run in runs:
        for r in run.rows:
            lit.setdefault(r["env"], set()).add(r["lighting"])
    varied = [env for env, levels in lit.items() if len(levels) > 1]
    levels = sorted({level for levels in lit.values() for level in levels if level})
    if varied:
        def key(r):
            return f"{r['env']} {r['lighting']}"

        groups = [f"{env} {level}" for env in varied for level in sorted(lit[env])]
        series = []
        for run in runs:
            rows = [dict(r, _group=key(r)) for r in run.rows if r["env"] in varied]
            g = group(rows, "_group", score)
            series.append({"label": run.name, "values": g, "estimates": {k: stats.mean_ci(v).to_json() for k, v in g.items()}})
        out.append({"factor": "lighting", "groups": groups, "series": series,
                    "note": "lighting compared within each environment run under several lightings"})
    elif len(levels) > 1:
        per_level = {level: sorted(env for env, ls in lit.items() if level in ls) for level in levels}
        out.append({"factor": "lighting", "groups": [], "series": [], "note": (
            "not shown: every environment here has one lighting ("
            + "; ".join(f"{level}: {', '.join(envs)}" for level, envs in per_level.items())
            + "), and environment variants also differ in their objects and trajectory, so a per-lighting plot "
              "would compare variants, not lighting. Run one environment under several lightings to measure it.")})
    return out


# --------------------------------------------------------------------------------------------------------------------
# The analysis
# --------------------------------------------------------------------------------------------------------------------
def policy() -> dict:
    """The statistics' settings and minimums, as the report states them."""
    return {"confidence": stats.CONFIDENCE, "bootstrap_resamples": stats.BOOTSTRAP_RESAMPLES, "seed": stats.SEED,
            "min_ci_n": stats.MIN_CI_N, "min_test_pairs": stats.MIN_TEST_PAIRS,
            "min_correlation_n": stats.MIN_CORRELATION_N, "pair_key": list(PAIR_KEY), "correction": "Holm"}


def analyse(runs: list[RunData], registry=None) -> dict:
    """Everything a report says about ``runs`` (the first is the baseline of comparisons), JSON-able.

    Args:
        registry: to re-score results for per-class and per-object views (:func:`score_objects`); None skips them.

    Returns:
        ``{"policy", "runs": [{label, run_dir, task, provenance, summary, environments, per_class, objects_note}],
        "comparisons", "factors"}``; estimates are :class:`benchbot.batch.stats.Estimate` dicts.
    """
    if registry is not None:
        for run in runs:
            if not run.objects and not run.objects_note:
                score_objects(run, registry)
    out_runs = []
    for run in runs:
        out_runs.append({
            "label": run.name, "run_dir": str(run.run_dir), "task": run.manifest.get("task"),
            "isolation": isolation(run.manifest), "verifiable": verifiable(run.manifest),
            "provenance": dict(provenance(run)),
            "summary": {k: v.to_json() for k, v in summary(run).items()},
            "environments": {env: {"values": v, **stats.mean_ci(v).to_json()}
                             for env, v in group(run.rows, "env").items()},
            "per_class": per_class_rows(run) if run.per_class else None,
            "objects_note": run.objects_note,
        })
    tasks = {run.manifest.get("task") for run in runs}
    return {"policy": policy(), "runs": out_runs, "comparisons": comparisons(runs) if len(runs) > 1 else [],
            "factors": factor_views(runs), "tasks": sorted(map(str, tasks))}


# --------------------------------------------------------------------------------------------------------------------
# Tables and figures
# --------------------------------------------------------------------------------------------------------------------
def tables(runs: list[RunData], result: dict) -> list[Table]:
    """The report's tables (each also written as CSV and LaTeX)."""
    scores = present_scores(runs)
    n_note = (f"Intervals: {int(stats.CONFIDENCE * 100)} % BCa bootstrap ({stats.BOOTSTRAP_RESAMPLES} resamples); none "
              f"below n = {stats.MIN_CI_N} episodes.")
    out = [Table("summary", "Scores over all episodes: mean [95 % CI]", ["run", "episodes"] + scores,
                 [[r["label"], len(run.rows)] + [r["summary"].get(s) for s in scores] for run, r in zip(runs, result["runs"])],
                 n_note)]
    envs = list(dict.fromkeys(e for r in result["runs"] for e in r["environments"]))
    rows = []
    for env in envs:
        lighting = "/".join(sorted({row["lighting"] for run in runs for row in run.rows if row["env"] == env} - {""}))
        row = [env, lighting]
        for r in result["runs"]:
            e = r["environments"].get(env)
            row += [len(e["values"]) if e else 0, e]
        rows.append(row)
    out.append(Table("environments", f"{MAIN_SCORE} per environment: mean [95 % CI]",
                     ["environment", "lighting"] + [h for r in result["runs"] for h in (f"n {r['label']}", r["label"])],
                     rows, n_note))
    if result["comparisons"]:
        out.append(Table("comparisons", f"Paired comparisons with {runs[0].name} ({MAIN_SCORE})",
                         ["run", "pairs", "paired by", "mean difference [95 % CI]", "Cohen's d_z", "t-test p (Holm)",
                          "Wilcoxon p (Holm)", "rank-biserial r"],
                         [[c["b"], c["n"], c["pairing"], c["difference"], c["cohens_dz"], c["ttest_p_holm"],
                           c["wilcoxon_p_holm"], c["rank_biserial"]] for c in result["comparisons"]],
                         f"No test below {stats.MIN_TEST_PAIRS} pairs. p-values Holm-adjusted over the "
                         f"{len(result['comparisons'])} comparison(s); d_z = mean difference / SD of the differences."))
    for k, (run, r) in enumerate(zip(runs, result["runs"])):
        if r["per_class"]:
            out.append(Table(f"per_class_{k + 1}", f"{r['label']}: per class, pooled over {len(run.objects)} episodes",
                             ["class", "GT objects", "TP", "FN", "FP", "label quality", "spatial quality",
                              "pair quality", "OMQ"],
                             [[c["class"], c["GT"], c["TP"], c["FN"], c["FP"], c["avg_label"], c["avg_spatial"],
                               c["avg_pairwise"], c["OMQ"]] for c in r["per_class"]],
                             "Qualities are means over the class's true positives (– without one); an FP counts for "
                             "its most probable class."))
    return out


@dataclass
class Figure:
    """A rendered figure: its file stem, heading, caption and bytes per format."""

    name: str
    title: str
    caption: str
    data: dict[str, bytes]


def make_figures(runs: list[RunData], result: dict, registry=None) -> list[Figure]:
    """Render every figure of the report (PNG, SVG, PDF each)."""
    out = []
    scores = present_scores(runs)
    series = [{"label": run.name, "values": {s: [r[s] for r in run.rows if s in r] for s in scores},
               "estimates": r["summary"]} for run, r in zip(runs, result["runs"])]
    out.append(Figure("summary", "Scores over all episodes",
                      "Each dot is one episode; the mean is drawn with its 95 % BCa bootstrap interval where n allows "
                      f"(n ≥ {stats.MIN_CI_N}); every panel's axis is scaled to its data.",
                      figures.render(figures.summary(scores, series, stats.MIN_CI_N))))
    envs = list(dict.fromkeys(e for r in result["runs"] for e in r["environments"]))
    env_series = [{"label": r["label"], "values": {e: v["values"] for e, v in r["environments"].items()},
                   "estimates": r["environments"]} for r in result["runs"]]
    out.append(Figure("environments", f"{MAIN_SCORE} per environment",
                      "Each dot is one episode (a repetition); n under each environment, one number per run.",
                      figures.render(figures.per_group(f"{MAIN_SCORE} per environment", MAIN_SCORE, envs, env_series,
                                                       stats.MIN_CI_N))))
    for k, c in enumerate(result["comparisons"]):
        if c["n"]:
            out.append(Figure(f"comparison_{k + 1}", f"{c['b']} vs {c['a']}: paired differences",
                              f"Each dot is one pair of episodes ({c['pairing']}); the line is the mean difference "
                              "and the band its interval.",
                              figures.render(figures.paired_differences(c, MAIN_SCORE, stats.MIN_TEST_PAIRS))))
    for view in result["factors"]:
        if view["groups"]:
            out.append(Figure(f"factor_{view['factor']}", f"{MAIN_SCORE} per {view['factor']}", view["note"],
                              figures.render(figures.per_group(f"{MAIN_SCORE} per {view['factor']}", MAIN_SCORE,
                                                               view["groups"], view["series"], stats.MIN_CI_N))))
    for k, (run, r) in enumerate(zip(runs, result["runs"])):
        if r["per_class"]:
            out.append(Figure(f"per_class_{k + 1}", f"{r['label']}: per class",
                              "Left: ground-truth objects found (TP) and missed (FN) to the right, false positives to "
                              "the left. Right: mean label and spatial (3D IoU) quality of the class's TPs.",
                              figures.render(figures.per_class(r["label"], r["per_class"], len(run.objects)))))
    for env in envs:
        panels = []
        for run in runs:
            chosen = map_episode(run, env)
            if chosen is None:
                continue
            row, evaluation, n = chosen
            s = evaluation.get("scores") or {}
            which = f"median-{MAIN_SCORE} episode of {n}" if n > 1 else "its only episode"
            panels.append({"title": f"{run.name}: episode {row['index']} (seed {row['seed']}, {which})\n"
                                    f"{MAIN_SCORE} {fmt(s.get(MAIN_SCORE))}, TP {s.get('TP')}, FP {s.get('FP')}, FN {s.get('FN')}",
                           "matches": evaluation["matches"],
                           "path": trajectory(env, registry, evaluation.get("environment_details"))})
        if panels:
            out.append(Figure(f"map_{_slug(env)}", f"{env}: top-down map",
                              f"{len(panels)} panel{'s' if len(panels) > 1 else ''}, one per run; the key is above.",
                              figures.render(figures.topdown(env, panels))))
    return out


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text)


# --------------------------------------------------------------------------------------------------------------------
# HTML
# --------------------------------------------------------------------------------------------------------------------
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
th,td{border-bottom:1px solid var(--line);padding:4px 10px;white-space:nowrap}
th{background:var(--soft);text-align:left;position:sticky;top:0}
td.num{text-align:right;font-variant-numeric:tabular-nums}td.txt{text-align:left}
table.kv td{white-space:normal;vertical-align:top}table.kv td:first-child{color:var(--muted);white-space:nowrap}
figure{margin:1em 0 1.6em}figure img{max-width:100%;height:auto;border:1px solid var(--line);border-radius:4px}
figcaption{color:var(--muted);font-size:.88em;margin-top:.3em}
.note{color:var(--muted);font-size:.86em;margin:.2em 0 .8em}
.box{background:var(--soft);border-left:4px solid var(--accent);padding:.6em 1em;margin:1em 0;font-size:.92em}
.warn{border-left-color:#D55E00}
.files a{margin-right:.6em}
details{margin:.6em 0}summary{cursor:pointer;color:var(--accent)}
code{font-size:.9em;background:var(--soft);padding:0 .25em;border-radius:3px;word-break:break-all}
@media (max-width:600px){body{font-size:14px}main{padding:.7em}th,td{padding:3px 6px}h1{font-size:1.3em}}
"""


def png_size(png: bytes) -> str:
    """``width='…' height='…'`` attributes showing a PNG at its size in CSS pixels (the files are made at
    :data:`~benchbot.batch.figures.PNG_DPI`, about twice a screen's 96 dpi, so they stay sharp on dense screens)."""
    if png[:8] != b"\x89PNG\r\n\x1a\n" or len(png) < 24:
        return ""
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    scale = 96 / figures.PNG_DPI
    return f"width='{round(width * scale)}' height='{round(height * scale)}' "


def _files(assets: str, stem: str, formats: tuple[str, ...]) -> str:
    links = " ".join(f"<a href='{html.escape(assets)}/{html.escape(stem)}.{f}'>{f.upper()}</a>" for f in formats)
    return f"<span class='files'>{links}</span>"


def render_html(runs: list[RunData], result: dict, tables_: list[Table], figures_: list[Figure], assets: str) -> str:
    """The report page: one HTML file with the PNG figures embedded, linking the SVG/PDF figures and CSV/LaTeX
    tables in the folder ``assets`` (relative to the page)."""
    esc = html.escape
    by_table = {t.name: t for t in tables_}
    by_figure = {f.name: f for f in figures_}

    def table(name: str) -> str:
        t = by_table.get(name)
        if t is None:
            return ""
        return (f"<p class='note'>{esc(t.caption)} — {_files(assets, t.name, ('csv', 'tex'))}</p>" + to_html(t))

    def figure(name: str) -> str:
        f = by_figure.get(name)
        if f is None:
            return ""
        png = base64.b64encode(f.data["png"]).decode()
        return (f"<figure id='f-{esc(f.name)}'><a href='{esc(assets)}/{esc(f.name)}.svg' title='open the SVG'>"
                f"<img alt='{esc(f.title)}' {png_size(f.data['png'])}src='data:image/png;base64,{png}'></a>"
                f"<figcaption><b>{esc(f.title)}.</b> {esc(f.caption)} {_files(assets, f.name, figures.FORMATS)}"
                "</figcaption></figure>")

    labels = [run.name for run in runs]
    p = result["policy"]
    parts = ["<!doctype html><html lang='en'><meta charset='utf-8'>",
             "<meta name='viewport' content='width=device-width,initial-scale=1'>",
             f"<title>BenchBot report: {esc(', '.join(labels))}</title><style>{CSS}</style><main>",
             "<header><h1>BenchBot performance profile</h1>",
             f"<p class='sub'>{esc(' vs '.join(labels))} · task {esc(', '.join(result['tasks']))} · made "
             f"{datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}</p>",
             "<nav><a href='#statistics'>Statistics</a><a href='#runs'>Runs</a><a href='#summary'>Summary</a>"
             "<a href='#environments'>Environments</a>"
             + ("<a href='#comparisons'>Comparisons</a>" if result["comparisons"] else "")
             + "<a href='#classes'>Classes</a><a href='#maps'>Maps</a><a href='#factors'>Factors</a>"
               "<a href='#episodes'>Episodes</a></nav></header>"]
    unverified = [r["label"] for r in result["runs"] if not r["verifiable"]]
    if unverified:
        parts.append(f"<div class='box warn'><b>Not verifiable:</b> {esc(', '.join(unverified))} ran "
                     f"{'its' if len(unverified) == 1 else 'their'} solution without the sandbox (isolation "
                     "<code>none</code>), where it could read the ground truth: fine for development, not for "
                     "comparisons or publication (docs/security.md).</div>")
    if len(result["tasks"]) > 1:
        parts.append(f"<div class='box warn'>These runs are of different tasks ({esc(', '.join(result['tasks']))}): "
                     "their scores are not comparable.</div>")
    parts.append(
        "<section id='statistics'><div class='box'><b>How to read the numbers.</b> Means carry a "
        f"{int(p['confidence'] * 100)} % bias-corrected and accelerated bootstrap interval ({p['bootstrap_resamples']} "
        f"resamples, seed {p['seed']}) from n = {p['min_ci_n']} episodes on; below that the mean is given alone and "
        f"the table says why. Runs are compared with <b>{esc(labels[0])}</b> on episodes paired by "
        f"{esc(', '.join(p['pair_key']))}, from {p['min_test_pairs']} pairs on: mean difference with its interval, "
        "Cohen's d<sub>z</sub>, paired t-test and Wilcoxon signed-rank test (with its rank-biserial r), p-values "
        "Holm-adjusted over all comparisons. Every figure states its n. Details: docs/report.md.</div></section>")
    parts.append("<section id='runs'><h2>Runs and provenance</h2>")
    for run, r in zip(runs, result["runs"]):
        rows = "".join(f"<tr><td>{esc(k)}</td><td>{esc(v)}</td></tr>" for k, v in provenance(run))
        parts.append(f"<h3>{esc(r['label'])}</h3><p class='note'><code>{esc(str(run.run_dir))}</code></p>"
                     f"<details{' open' if len(runs) == 1 else ''}><summary>provenance</summary>"
                     f"<div class='scroll'><table class='kv'>{rows}</table></div></details>")
    parts.append("</section><section id='summary'><h2>Summary</h2>" + table("summary") + figure("summary") + "</section>")
    parts.append("<section id='environments'><h2>Per environment</h2>" + table("environments") + figure("environments")
                 + "</section>")
    if result["comparisons"]:
        parts.append("<section id='comparisons'><h2>Comparisons</h2>" + table("comparisons"))
        for k, c in enumerate(result["comparisons"]):
            if c["reason"]:
                parts.append(f"<p class='note'><b>{esc(c['b'])}</b>: {esc(c['reason'])}; mean difference "
                             f"{fmt(c['difference']['value'])} over {c['n']} pair(s) ({esc(c['pairing'])}).</p>")
            if c["unpaired"]:
                parts.append(f"<p class='note'>{c['unpaired']} episode(s) of {esc(c['a'])} or {esc(c['b'])} have no "
                             "partner and are left out of this comparison.</p>")
            parts.append(figure(f"comparison_{k + 1}"))
        parts.append("</section>")
    parts.append("<section id='classes'><h2>Per class</h2>")
    for k, r in enumerate(result["runs"]):
        parts.append(f"<h3>{esc(r['label'])}</h3>")
        if r["objects_note"]:
            parts.append(f"<p class='note'>{esc(r['objects_note'])}</p>")
        parts.append(table(f"per_class_{k + 1}") + figure(f"per_class_{k + 1}"))
    parts.append("</section><section id='maps'><h2>Top-down maps</h2><p class='note'>Seen from above (x-y "
                 "footprints, metres, map frame): ground-truth boxes from the environment's ground truth (dark outline: "
                 "found; red: missed), predicted boxes (filled by the matched pair's quality; orange: false positive; "
                 "grey: inside a group box, neither), a line from each match to its ground truth, and the robot's "
                 "trajectory from the environment spec (start ▲). With several episodes of an environment a panel "
                 "shows the median-OMQ one. Click a map for its SVG.</p>")
    maps = [f for f in figures_ if f.name.startswith("map_")]
    parts.append("".join(figure(f.name) for f in maps) if maps else
                 "<p class='note'>No maps: no run has per-object matches (see Per class).</p>")
    parts.append("</section><section id='factors'><h2>Robots, noise and lighting</h2>")
    if not result["factors"]:
        parts.append("<p class='note'>These runs vary no robot, noise preset or lighting.</p>")
    for view in result["factors"]:
        if view["groups"]:
            parts.append(figure(f"factor_{view['factor']}"))
        else:
            parts.append(f"<p class='note'><b>{esc(view['factor'])}</b>: {esc(view['note'])}</p>")
    parts.append("</section><section id='episodes'><h2>Episodes</h2>")
    scores = present_scores(runs)
    for run in runs:
        keys = ["index", "env", "robot", "repeat", "seed", "noise", "lighting"]
        rows = [[r.get(k, "") for k in keys] + [r.get(s) for s in scores] for r in run.rows]
        parts.append(f"<details><summary>{esc(run.name)}: {len(run.rows)} episodes</summary>"
                     + to_html(Table("episodes", "", keys + scores, rows)) + "</details>")
    parts.append("</section></main></html>")
    return "\n".join(parts)


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


def write_report(runs: list[RunData], output: Path, registry=None, result: dict | None = None) -> dict:
    """Analyse ``runs`` and write the report: ``output`` (HTML) and its assets folder (:func:`assets_dir`) with
    every figure as PNG, SVG and PDF, every table as CSV and LaTeX, and ``report.json`` (the analysis); each file
    written atomically.

    Returns:
        the analysis (:func:`analyse`).

    Raises:
        UsageError: matplotlib is missing, or a file cannot be written.
    """
    folder = make_assets_dir(output)
    result = result or analyse(runs, registry)
    tables_ = tables(runs, result)
    figures_ = make_figures(runs, result, registry)
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
