"""Performance profiles of batch runs (``benchbot report``): statistics that say what they can, per-class and
per-object views, and paper output (docs/report.md).

Inputs are run directories written by ``benchbot batch`` (``manifest.json``, ``config.json``,
``episode_scores.json``, ``results/``). :func:`analyse` turns them into one JSON-able dict (what ``--json`` prints);
:func:`write_report` writes the HTML page and, next to it in ``<stem>_files/``, every figure as PNG, SVG and PDF and
every table as CSV and LaTeX.

Scores are what the run's evaluation method declares (:class:`benchbot.core.evaluation.ScoreSet`: names, the primary
one, direction, range), recorded in the manifest's ``scores`` or read from the installed method; nothing here knows
a method's score names.

Statistics (:mod:`benchbot.batch.stats`): the **environment is the unit of analysis**. A run's score is the mean over
its environments of each environment's mean, with an interval over the environments; runs are compared with the
first one (the baseline) on their environment means (over every episode of each) paired by environment (a robot or
noise preset that differs between the two runs is the factor compared, not a reason not to pair), with
the tests over the environments' mean differences (from :data:`~benchbot.batch.stats.MIN_TEST_PAIRS` environments
on), the p-values Holm-adjusted over the comparisons. The episode level is shown beside it, named as such: how
precisely these environments were measured, not how a solution does on others, with episodes paired by
environment and seed (common random numbers) or repetition; what a comparison leaves out is said (:func:`left_out`).
Runs that differ in a condition the comparison does not name (simulator style or version, camera, arch, ...) are
compared with a warning (:func:`condition_differences`).

Per-class and per-object views re-score each episode's results file with the run's evaluation method asking for
``per_class`` and ``matches`` (docs/evaluation.md), and check that the re-scored primary score equals the run's.
Maps draw the trajectory the robot drove (:func:`driven_path`: the batch's trajectory log, else its recording), the
planned one faintly.
"""

from __future__ import annotations

import base64
import html
import json
import os
import shlex
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

import numpy as np

from benchbot.batch import figures, stats
from benchbot.batch.figures import fmt
from benchbot.batch.paper import Table, to_csv, to_html, to_latex
from benchbot.batch.plan import read_manifest
from benchbot.core import atomic
from benchbot.core.errors import BenchbotError, UsageError
from benchbot.core.evaluation import ScoreSet, method_scores, observed_scores
from benchbot.solutions.sandbox import VERIFIABLE

ROW_FIELDS = ("index", "env", "robot", "repeat", "seed", "noise", "lighting", "results", "ground_truth_set")
"""The fields of an episode's row besides its scores (a score of one of these names is not read)."""

ROW_FACTORS = (("robot", "robot"), ("noise", "noise preset"))
"""Settings that vary by episode and that two runs may differ in (field, words): when each run has one value and
they differ, it is the factor under comparison and episodes pair without it."""

RESCORE_TOLERANCE = 1e-9
"""Largest difference between a run's primary score and the re-scored one that is not reported as a change."""


@dataclass
class RunData:
    """One run directory's episodes with their scores.

    Attributes:
        run_dir: the folder. manifest, config: its ``manifest.json`` and ``config.json``.
        rows: one dict per scored episode: ``index``, ``env``, ``robot``, ``repeat``, ``seed``, ``noise``
            (``"none"`` when not recorded), ``lighting`` (or ``""``), ``results`` (path relative to the run
            directory, or ``""``), ``ground_truth_set`` (the set of ground truths its scores used:
            :func:`episode_ground_truth_set`; ``""`` when not recorded) and every numeric score the method returned
            for it.
        score_set: what the scores are (:func:`resolve_score_set`).
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
    score_set: ScoreSet
    label: str = ""
    objects: dict[int, dict] = field(default_factory=dict)
    per_class: dict | None = None
    objects_note: str = ""

    @property
    def name(self) -> str:
        """The run's label, or its folder's name."""
        return self.label or self.run_dir.name

    @property
    def primary(self) -> str:
        """The name of its method's primary score."""
        return self.score_set.primary.name


class UnfinishedRun(UsageError):
    """A run directory whose batch did not finish (it was interrupted): nothing to report until it is resumed."""


class FailedRun(UsageError):
    """A run directory whose batch finished with every episode failed: nothing was scored (``leaderboard`` skips it
    as it skips an :class:`UnfinishedRun`)."""


def _read_json(path: Path, what: str):
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path}: {what} is unreadable or not JSON ({exc.__class__.__name__})",
                         "it is written by `benchbot batch`; was it edited or cut short?") from None


def resolve_score_set(manifest: dict, entries: list, registry=None) -> ScoreSet:
    """What a run's scores are: the declaration its manifest recorded (``scores``), else the one its evaluation
    method declares now (with ``registry``), else what its episodes' scores show (:func:`observed_scores`).

    Raises:
        UsageError: none of these gives a score (no numeric score in any episode).
    """
    recorded = manifest.get("scores")
    if isinstance(recorded, dict):
        try:
            return ScoreSet.from_json(recorded)
        except ValueError:
            pass
    method = str(manifest.get("evaluate_with") or "")
    if registry is not None and method:
        try:
            declared = method_scores(registry, method)
        except BenchbotError:
            declared = None
        if declared is not None:
            return declared
    try:
        return observed_scores(method, [e.get("scores") if isinstance(e, dict) and isinstance(e.get("scores"), dict)
                                        else {} for e in entries])
    except ValueError:
        raise UsageError(f"the episode scores of the run (method '{method or 'unknown'}') hold no numeric score",
                         "it is written by `benchbot batch`; was it edited?") from None


def unfinished(manifest: dict) -> str:
    """Why a run directory's batch is unfinished, in words ("3 of 10 episodes not run"), or "" when it finished
    (its manifest has ``finished``: :func:`benchbot.batch.runner.run_batch` writes it last)."""
    if manifest.get("finished"):
        return ""
    records = [e for e in manifest.get("episodes", []) if isinstance(e, dict)]
    left = sum(e.get("status") in ("pending", "running") for e in records)
    return f"{left} of {len(records)} episodes not run" if left else "it was stopped before its evaluation"


def load_run(run_dir: Path, label: str | None = None, registry=None) -> RunData:
    """Read a run directory.

    Args:
        registry: to read what the scores are from the installed evaluation method when the manifest did not
            record it (:func:`resolve_score_set`); None: from the manifest or the scores themselves.

    Raises:
        UnfinishedRun: the batch was interrupted (the hint names ``benchbot batch --resume``).
        FailedRun: the batch finished with every episode failed (the first one's reason and log named).
        UsageError: not a run directory, no scores (not evaluated), or a file is malformed (naming it and the
            field).
    """
    run_dir = Path(run_dir)
    manifest = read_manifest(run_dir)
    path = run_dir / "episode_scores.json"
    why = unfinished(manifest)
    if why and (not path.is_file() or "not run" in why):
        raise UnfinishedRun(f"{run_dir}: the batch did not finish ({why})",
                                f"finish it: benchbot batch --resume {shlex.quote(str(run_dir))}")
    records = [e for e in manifest.get("episodes", []) if isinstance(e, dict)]
    if records and not path.is_file() and not any(e.get("status") == "ok" for e in records):
        first = records[0]
        reason = first.get("error") or (f"exit status {first['returncode']}" if first.get("returncode") else
                                        first.get("status", "failed"))
        log = f" (first: {first.get('env', '?')}: {reason}; log {run_dir / first['log']})" if first.get("log") else ""
        raise FailedRun(f"{run_dir}: every episode failed, {len(records)} of {len(records)}{log}",
                        f"fix the cause, then benchbot batch --resume {shlex.quote(str(run_dir))} runs them again")
    if not path.is_file():
        if manifest.get("evaluation_error"):
            raise UsageError(f"{run_dir} has no episode_scores.json: its evaluation failed "
                             f"({manifest['evaluation_error']})", "fix the cause, then benchbot batch --resume "
                             f"{shlex.quote(str(run_dir))} evaluates it again")
        raise UsageError(f"{run_dir} has no episode_scores.json (the batch was not evaluated: --no-evaluate, no ground "
                         "truth, or no episode produced results)", "run a batch with an evaluation method "
                         "(--evaluate-with METHOD, `benchbot list evaluators`)")
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
            row["ground_truth_set"] = episode_ground_truth_set(manifest, entry)
            row.update({s: float(v) for s, v in (entry.get("scores") or {}).items()
                        if s not in ROW_FIELDS and isinstance(v, (int, float)) and not isinstance(v, bool)})
            rows.append(row)
    except (KeyError, TypeError, AttributeError, ValueError) as exc:
        detail = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        raise UsageError(f"{path}: malformed ({detail})", "it is written by `benchbot batch`; was it edited?") from None
    if not rows:
        raise UsageError(f"{run_dir} has no scored episodes", "every episode failed, or the batch ran with --no-evaluate")
    return RunData(run_dir, manifest, config, rows, resolve_score_set(manifest, entries, registry), label or "")


def episode_ground_truth_set(manifest: dict, entry: dict) -> str:
    """The set of ground truths an episode's scores used (``isaac_develop``, ``bear_develop``...): what its entry
    of ``episode_scores.json`` says (the evaluation writes ``ground_truth_set``), else the manifest's
    ``ground_truth_sets`` for its environment, else the manifest's ``ground_truth_set`` (``--ground-truths``); ""
    for a batch from before BenchBot recorded it."""
    for value in (entry.get("ground_truth_set"), (manifest.get("ground_truth_sets") or {}).get(entry.get("env")),
                  manifest.get("ground_truth_set")):
        if isinstance(value, str) and value:
            return value.removeprefix("ground_truths_")
    return ""


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


def worlds(manifest: dict) -> str:
    """The standing of the run's worlds (:func:`benchbot.batch.signing.worlds_standing`): ``held-out`` when every
    environment is a world of a held-out split (only the scoring host can build it), else ``development — ground
    truth public`` (BEAR, procedural train/val: a solution can carry their ground truth, so no score on them is
    evidence of anything but development)."""
    from benchbot.batch.signing import worlds_standing

    return worlds_standing(manifest.get("environments") or [])


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


def _distinct(values) -> str:
    """The distinct non-empty values, sorted, joined with " + " ("" when none)."""
    return " + ".join(sorted({str(v) for v in values if v not in (None, "")}))


def camera(run: RunData) -> str:
    """The camera size the run's episodes used, ``WIDTHxHEIGHT``: the plan's options (``--camera-size``), else the
    robots' own (their spec's ``sensors.camera``), else ""."""
    plan = [p for p in run.manifest.get("plan", []) if isinstance(p, dict)]
    sizes = set()
    robots = (run.config.get("robots") or {}) if isinstance(run.config, dict) else {}
    for p in plan:
        options = p.get("options") or {}
        if options.get("width") and options.get("height"):
            sizes.add(f"{options['width']}x{options['height']}")
            continue
        cam = (((robots.get(p.get("robot")) or {}).get("sensors") or {}).get("camera") or {})
        if cam.get("width") and cam.get("height"):
            sizes.add(f"{cam['width']}x{cam['height']}")
    return _distinct(sizes)


def backend(run: RunData) -> dict[str, str]:
    """What the run's episodes' backends were (their records' ``backend``, distinct values joined): ``simulator``
    (plugin distribution and version), ``style``, ``arch``, ``device``; a value is "" when no episode recorded it
    (batches from before BenchBot recorded it)."""
    records = [e.get("backend") or {} for e in run.manifest.get("episodes", []) if isinstance(e, dict)]
    return {"simulator": _distinct(f"{b.get('distribution') or b.get('plugin') or b.get('type')} {b.get('version') or ''}".strip()
                                   for b in records if b),
            "style": _distinct(b.get("style") for b in records),
            "arch": _distinct(b.get("arch") for b in records),
            "device": _distinct(b.get("device") for b in records)}


CONDITIONS = ("task", "robot", "environments", "noise preset", "camera", "simulator", "simulator style", "arch",
              "isolation", "evaluation", "ground truth")
"""What two runs must share for their scores to be comparable (the leaderboard's condition set; a report warns
when runs differ in one the comparison does not name). ``ground truth`` is the set of ground truths the scores
used (``isaac_develop``, ``bear_develop``: the same map scores differently against each)."""

CONTEXT = ("BenchBot", "lock", "device")
"""Provenance a report also compares (a difference is named, as it may change numbers, but is not a condition)."""


def conditions(run: RunData) -> dict[str, str]:
    """The run's :data:`CONDITIONS` and :data:`CONTEXT` as text (distinct values joined; "" where not recorded)."""
    m = run.manifest
    b = backend(run)
    lock = ((m.get("provenance") or {}).get("lock") or {}).get("sha256") or ""
    return {"task": str(m.get("task", "")), "robot": _distinct(r["robot"] for r in run.rows),
            "environments": ", ".join(sorted({r["env"] for r in run.rows})),
            "noise preset": _distinct(r["noise"] for r in run.rows), "camera": camera(run),
            "simulator": b["simulator"], "simulator style": b["style"], "arch": b["arch"],
            "isolation": isolation(m), "evaluation": str(m.get("evaluate_with") or ""),
            "ground truth": _distinct(r.get("ground_truth_set") for r in run.rows),
            "BenchBot": str((m.get("versions") or {}).get("benchbot", "")), "lock": lock[:12], "device": b["device"]}


def condition_differences(runs: list[RunData], mentioned: set[str] | None = None) -> list[dict]:
    """The conditions (and context) in which ``runs`` differ, except those in ``mentioned`` (the factors the
    comparison is about) and ``environments`` (comparisons pair environments both runs have):
    ``[{"what", "values": {label: value}, "condition": bool}]``. A value not recorded in one run is not a
    difference (older batches recorded less)."""
    out = []
    table = [conditions(run) for run in runs]
    for what in CONDITIONS + CONTEXT:
        if what in (mentioned or set()) or what == "environments":
            continue
        values = {run.name: c[what] for run, c in zip(runs, table)}
        if len({v for v in values.values() if v}) > 1:
            out.append({"what": what, "values": values, "condition": what in CONDITIONS})
    return out


def provenance(run: RunData) -> list[tuple[str, str]]:
    """``[(what, value)]``: where a run's numbers came from (solution, command, task, robots, environments,
    episodes, seeds, simulator, style, camera, arch and device, times, versions, lock file, git revisions, machine),
    as its manifest recorded them."""
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
    b = backend(run)
    lock = prov.get("lock") or {}
    command = prov.get("command") or (shlex.join(["benchbot"] + [str(w) for w in (m.get("command") or [])[1:]])
                                      if m.get("command") else "not recorded")
    rows = [
        ("solution", f"{kind} {what}".strip()),
        ("isolation", f"{level} ({'scores verifiable' if verifiable(m) else 'NOT VERIFIABLE: the solution could read the ground truth'})"
         + ("" if "sandbox" in m else "; not recorded (the batch ran before the sandbox)")),
        ("command", command),
        ("task", str(m.get("task", ""))),
        ("robots", ", ".join(m.get("robots") or [])),
        ("environments", ", ".join(m.get("environments") or [])),
        ("worlds", worlds(m)),
        ("episodes", f"{len(run.rows)} scored of {len(plan) or len(records)} planned ("
                     + ", ".join(f"{n} {s}" for s, n in sorted(statuses.items())) + ")"),
        ("seeds", _ranges(seeds) if seeds else "not recorded"),
        ("noise presets", ", ".join(sorted({str(p.get("noise", "none")) for p in plan})) or "none"),
        ("camera", camera(run) or "not recorded"),
        ("simulator", b["simulator"] or not_recorded),
        ("scene style", b["style"] or not_recorded),
        ("arch, device", f"{b['arch']}, {b['device'] or 'unknown device'}" if b["arch"] else not_recorded),
        ("ground truth", _distinct(r.get("ground_truth_set") for r in run.rows) or not_recorded),
        ("evaluation", str(m.get("evaluate_with") or "none")
         + (f" (primary score {run.primary}, {run.score_set.primary.direction} is better"
            + ("" if run.score_set.declared else "; not declared by the method: assumed") + ")")),
        ("started", str(m.get("started", "not recorded"))),
        ("wall time", f"{fmt(m.get('wall_s'))} s" if isinstance(m.get("wall_s"), (int, float)) else "not recorded"),
        ("BenchBot", str(versions.get("benchbot", "not recorded"))),
        ("BenchBot git revision", str(prov.get("benchbot_git") or (not_recorded if not prov else "not a git checkout"))),
        ("solution git revision", ", ".join(f"{v or 'not a git checkout'} ({k})" for k, v in (prov.get("solution_git") or {}).items())
         or not_recorded),
        ("lock file", f"{lock.get('file')} sha256 {lock.get('sha256')}" if lock else
         ("none (BenchBot installed, not a checkout)" if "lock" in prov else not_recorded)),
        ("machine", (f"{machine.get('cpu') or '?'}, {machine.get('cpus') or '?'} CPUs, {fmt(machine.get('memory_gib'))} GiB; "
                     f"{machine.get('system') or versions.get('platform', '')}") if machine else
         f"{versions.get('platform', '')} (CPU, cores, memory {not_recorded})"),
        ("Python", str(versions.get("python", "not recorded"))),
        ("plugins", ", ".join(f"{k} {v}" for k, v in versions.items() if k not in ("python", "platform", "benchbot"))
         or "not recorded"),
        ("packages", (f"{len(prov['packages'])} installed: " + ", ".join(f"{k} {v}" for k, v in prov["packages"].items()))
         if prov.get("packages") else not_recorded),
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
def group(rows: list[dict], key: str, score: str) -> dict[str, list[float]]:
    """``{value of key: [score of each row]}`` in first-seen order (rows without ``score`` left out)."""
    out: dict[str, list[float]] = {}
    for row in rows:
        if score in row:
            out.setdefault(str(row[key]), []).append(row[score])
    return out


def score_set(runs: list[RunData]) -> ScoreSet:
    """The scores a report of ``runs`` shows: the baseline's (the first run's) method's."""
    return runs[0].score_set


def main_score(runs: list[RunData]) -> str:
    """The score environments, comparisons and predictivity are computed on: the baseline's primary score."""
    return runs[0].primary


def present_scores(runs: list[RunData]) -> list[str]:
    """The real-valued scores (not counts) of the baseline's method that some episode of ``runs`` has, primary
    first, in the method's order."""
    return [s for s in score_set(runs).scores if any(s in r for run in runs for r in run.rows)]


def score_range(run: RunData, score: str, difference: bool = False) -> tuple[float | None, float | None]:
    """The range ``score`` declares in ``run``'s method (``(None, None)`` where unbounded or not declared); with
    ``difference``, the range of a difference of two such scores, ``(low − high, high − low)``."""
    info = run.score_set.get(score)
    low, high = info.range if info else (None, None)
    if difference:
        return (None, None) if low is None or high is None else (low - high, high - low)
    return low, high


def bounded(estimate: stats.Estimate, run: RunData, score: str, difference: bool = False) -> stats.Estimate:
    """``estimate`` (of ``score``, or of a difference of it) with its interval clipped to the score's declared range
    (:func:`benchbot.batch.stats.clip_to_range`)."""
    return stats.clip_to_range(estimate, *score_range(run, score, difference))


def summary(run: RunData, scores: list[str] | None = None) -> dict[str, stats.Estimate]:
    """Every score (default: the run's method's scores present) with the environment as the unit
    (:func:`benchbot.batch.stats.cluster_mean_ci`: the mean of the environments' means, its interval over them,
    clipped to the score's declared range, :func:`bounded`)."""
    names = scores if scores is not None else present_scores([run])
    out = {}
    for s in names:
        rows = [r for r in run.rows if s in r]
        out[s] = bounded(stats.cluster_mean_ci([r[s] for r in rows], [r["env"] for r in rows]), run, s)
    return out


def thresholds(runs: list[RunData], score: str, k: int = 101) -> np.ndarray:
    """``(k,)`` thresholds of a score distribution: evenly over ``score``'s declared range, else over the values
    the runs have."""
    low, high = score_range(runs[0], score)
    values = [r[score] for run in runs for r in run.rows if score in r]
    low = min(values, default=0.0) if low is None else low
    high = max(values, default=1.0) if high is None else high
    return np.linspace(low, high if high > low else low + 1.0, k)


def robust(run: RunData, score: str, taus: np.ndarray) -> dict:
    """The robust aggregates of Agarwal et al. 2021 (rliable) of ``run``'s ``score`` (:mod:`benchbot.batch.stats`):
    ``{"iqm": the IQM over environments (the unit, bootstrap over environments), "iqm_episodes": rliable's IQM of
    the episodes with the stratified bootstrap (these environments), "score_distribution": the fraction of
    episodes above each threshold, averaged over environments, with its stratified-bootstrap band}``; intervals
    clipped to the score's declared range."""
    groups = list(group(run.rows, "env", score).values())
    return {"iqm": bounded(stats.iqm_environments(groups), run, score).to_json(),
            "iqm_episodes": bounded(stats.iqm_stratified(groups), run, score).to_json(),
            "score_distribution": stats.score_distribution(groups, taus)}


def summary_episodes(run: RunData, scores: list[str] | None = None) -> dict[str, stats.Estimate]:
    """Every score over the run's episodes (:func:`benchbot.batch.stats.mean_ci`): how precisely these environments
    were measured, not how the solution does on other environments."""
    names = scores if scores is not None else present_scores([run])
    return {s: bounded(stats.mean_ci([r[s] for r in run.rows if s in r], level="episodes"), run, s) for s in names}


def comparison_factors(a: RunData, b: RunData) -> list[dict]:
    """The :data:`ROW_FACTORS` in which ``b`` differs from ``a`` as the factor compared: each run has one value and
    they differ (``[{"field", "what", "a", "b"}]``)."""
    out = []
    for f, words in ROW_FACTORS:
        va, vb = {r[f] for r in a.rows}, {r[f] for r in b.rows}
        if len(va) == 1 and len(vb) == 1 and va != vb:
            out.append({"field": f, "what": words, "a": next(iter(va)), "b": next(iter(vb))})
    return out


def _cell_fields(a: RunData, b: RunData) -> tuple[list[dict], tuple[str, ...], list[str]]:
    """``(factors compared, the row factors kept in the pairing, those of them that vary)`` of two runs."""
    factors = comparison_factors(a, b)
    kept = tuple(f for f, _ in ROW_FACTORS if f not in {x["field"] for x in factors})
    varied = [f for f in kept if len({r[f] for r in a.rows + b.rows}) > 1]
    return factors, kept, varied


def pair_environments(a: RunData, b: RunData, score: str) -> dict:
    """Pair two runs at the environment level: each run's mean of ``score`` over **all** its episodes of an
    environment (and of a robot or noise preset, where the runs vary one inside them), paired by environment. Every
    episode counts, whatever the seeds and however many repetitions each run had: two runs with ``--repeat 2`` and
    ``--repeat 1`` pair all their environments, where their episodes pair by seed in one environment at most
    (seeds are numbered across a batch).

    Returns:
        ``{"keys": [a name per paired cell], "envs": [its environment], "a": [run a's mean], "b": [run b's mean],
        "only_a": [cells only run a has], "only_b": [...], "episodes_a": {cell: n}, "episodes_b": {cell: n}}``;
        cells are environments unless the runs vary a robot or noise preset inside them.
    """
    _, kept, varied = _cell_fields(a, b)

    def cells(run: RunData) -> dict[str, tuple[str, list[float]]]:
        out: dict[str, tuple[str, list[float]]] = {}
        for row in run.rows:
            if score in row:
                key = " ".join([row["env"]] + [str(row[f]) for f in varied])
                out.setdefault(key, (row["env"], []))[1].append(row[score])
        return out

    ca, cb = cells(a), cells(b)
    shared = [k for k in ca if k in cb]
    return {"keys": shared, "envs": [ca[k][0] for k in shared],
            "a": [float(np.mean(ca[k][1])) for k in shared], "b": [float(np.mean(cb[k][1])) for k in shared],
            "only_a": [k for k in ca if k not in cb], "only_b": [k for k in cb if k not in ca],
            "episodes_a": {k: len(v[1]) for k, v in ca.items()}, "episodes_b": {k: len(v[1]) for k, v in cb.items()}}


def pair_episodes(a: RunData, b: RunData, score: str) -> dict:
    """Pair the episodes of two runs (the episode level): equal environment and seed (common random numbers), and
    equal robot and noise preset unless the runs differ in it as a whole (:func:`comparison_factors`: then it is
    the factor compared and not part of the pairing); when pairing by environment and repetition pairs more
    episodes (runs with different seeds or a different ``--repeat``, whose seeds are numbered across the batch),
    by repetition instead.

    Returns:
        ``{"pairing": how, in words, "by": "seed" or "repetition", "factors": comparison_factors, "keys": [a name
        per pair], "envs": [the environment of each pair], "a": [...], "b": [...], "unpaired": episodes of either
        run left out, "scored": episodes of both runs with the score}``.
    """
    def index(run: RunData, fields: tuple) -> dict:
        out = {}
        for row in run.rows:
            if score in row:
                out.setdefault(tuple(row[f] for f in fields), row)
        return out

    factors, kept, varied = _cell_fields(a, b)
    also = "".join(f", {dict(ROW_FACTORS)[f]}" for f in varied)
    by_seed = (index(a, ("env", *kept, "seed")), index(b, ("env", *kept, "seed")))
    by_repeat = (index(a, ("env", *kept, "repeat")), index(b, ("env", *kept, "repeat")))
    seed_pairs = [k for k in by_seed[0] if k in by_seed[1]]
    repeat_pairs = [k for k in by_repeat[0] if k in by_repeat[1]]
    if len(seed_pairs) >= len(repeat_pairs):
        (ia, ib), shared, by = by_seed, seed_pairs, "seed"
        how = f"environment{also} and seed"
    else:
        (ia, ib), shared, by = by_repeat, repeat_pairs, "repetition"
        how = f"environment{also} and repetition (the seeds differ)"
    if factors:
        how += "; factor compared: " + ", ".join(f"{x['what']} {x['a']} → {x['b']}" for x in factors)
    scored = sum(score in r for r in a.rows) + sum(score in r for r in b.rows)

    def label(row: dict) -> str:
        return " ".join([row["env"]] + [str(row[f]) for f in varied]) + (
            f" s{row['seed']}" if by == "seed" else f" r{row['repeat']}")

    return {"pairing": how, "by": by, "factors": factors, "keys": [label(ia[k]) for k in shared],
            "envs": [ia[k]["env"] for k in shared], "a": [ia[k][score] for k in shared],
            "b": [ib[k][score] for k in shared], "unpaired": scored - 2 * len(shared), "scored": scored}


def _per_environment(counts: dict[str, int]) -> str:
    """``{cell: episodes}`` → ``"2 episodes per environment"`` (or ``"1–3 episodes per environment"``)."""
    lo, hi = min(counts.values(), default=0), max(counts.values(), default=0)
    n = str(lo) if lo == hi else f"{lo}–{hi}"
    return f"{n} episode{'' if hi == 1 else 's'} per environment"


def left_out(a: RunData, b: RunData, cells: dict, pairs: dict) -> str:
    """What a comparison leaves out and why, in one line ("" when nothing): environments only one run has (the
    environment level pairs the others), and the episodes without a partner at the episode level."""
    parts = []
    for run, only in ((a, cells["only_a"]), (b, cells["only_b"])):
        if only:
            shown = ", ".join(only[:4]) + (f" and {len(only) - 4} more" if len(only) > 4 else "")
            parts.append(f"{len(only)} environment{'s' if len(only) > 1 else ''} only {run.name} ran ({shown}): "
                         "no partner")
    if pairs["unpaired"]:
        na, nb = _per_environment(cells["episodes_a"]), _per_environment(cells["episodes_b"])
        why = (f"{a.name} ran {na}, {b.name} {nb}" if na != nb else
               f"no episode of the other run with the same environment and {pairs['by']}")
        parts.append(f"at the episode level {pairs['unpaired']} of {pairs['scored']} episodes ({why}); the "
                     "environment level uses every episode")
    return "; ".join(parts)


TEST_KEYS = ("n", "level", "difference", "cohens_dz", "rank_biserial", "ttest_p", "wilcoxon_p", "reason")


def _test(result: dict) -> dict:
    return {k: (result[k].to_json() if isinstance(result[k], stats.Estimate) else result[k]) for k in TEST_KEYS}


def compare(a: RunData, b: RunData, score: str) -> dict:
    """Paired comparison of run ``b`` against run ``a`` on ``score``, with the environment as the unit: each run's
    environment means over all its episodes, paired by environment (:func:`pair_environments`,
    :func:`benchbot.batch.stats.cluster_paired_test`), and, beside it, over the episode pairs
    (:func:`pair_episodes`, :func:`benchbot.batch.stats.paired_test`).

    Returns:
        ``{"a", "b" (labels), "score", "direction", "pairing" (of the episodes), "factors", "unpaired" (episodes
        without a partner at the episode level), "unpaired_environments" (environments only one run has),
        "left_out" (:func:`left_out`: what was left out and why, one line, "" when nothing),
        "probability_of_improvement" (:func:`benchbot.batch.stats.probability_of_improvement` of b over a, over
        the environments both ran, better in the score's direction: an Estimate dict), "keys", "envs",
        "differences" (b − a per episode pair), "environments" (their order), "environment_differences", and the
        environment-level test: "n" (environments), "level", "difference" (Estimate dict), "cohens_dz",
        "rank_biserial", "ttest_p", "wilcoxon_p", "reason"; "episodes": the same keys over the episode pairs}``.
    """
    cells = pair_environments(a, b, score)
    pairs = pair_episodes(a, b, score)
    env = stats.cluster_paired_test(cells["a"], cells["b"], cells["envs"])
    episodes = stats.paired_test(pairs["a"], pairs["b"], level="pairs")
    for test in (env, episodes):
        bounded(test["difference"], a, score, difference=True)
    info = a.score_set.get(score)
    per_env_a, per_env_b = (group(run.rows, "env", score) for run in (a, b))
    shared = [e for e in per_env_a if e in per_env_b]
    improvement = stats.probability_of_improvement([per_env_a[e] for e in shared], [per_env_b[e] for e in shared],
                                                   a.score_set.sign(score) if info else 1)
    return {"a": a.name, "b": b.name, "score": score, "direction": info.direction if info else "higher",
            "pairing": pairs["pairing"], "factors": pairs["factors"], "unpaired": pairs["unpaired"],
            "unpaired_environments": cells["only_a"] + cells["only_b"], "left_out": left_out(a, b, cells, pairs),
            "keys": pairs["keys"], "envs": pairs["envs"],
            "differences": [float(y - x) for x, y in zip(pairs["a"], pairs["b"])],
            "environments": env["clusters"], "environment_differences": env["cluster_differences"],
            "probability_of_improvement": improvement.to_json(), **_test(env), "episodes": _test(episodes)}


def comparisons(runs: list[RunData], score: str | None = None) -> list[dict]:
    """Every run after the first compared with the first (:func:`compare`) on ``score`` (default: the baseline's
    primary score), the p-values of each test adjusted with Holm's method over these comparisons
    (``ttest_p_holm``, ``wilcoxon_p_holm``, at both levels)."""
    score = score or main_score(runs)
    out = [compare(runs[0], run, score) for run in runs[1:]]
    for test in ("ttest_p", "wilcoxon_p"):
        for c, p in zip(out, stats.holm([c[test] for c in out])):
            c[f"{test}_holm"] = p
        for c, p in zip(out, stats.holm([c["episodes"][test] for c in out])):
            c["episodes"][f"{test}_holm"] = p
    return out


# --------------------------------------------------------------------------------------------------------------------
# Per class and per object
# --------------------------------------------------------------------------------------------------------------------
def score_objects(run: RunData, registry) -> None:
    """Re-score the run's results files with its evaluation method asking for ``per_class`` and ``matches``, each
    against the set of ground truths its scores used (the row's ``ground_truth_set``; each environment's default
    where the run did not record one); fills ``run.objects``, ``run.per_class`` (the method's ``combine`` over
    every re-scored episode) and ``run.objects_note`` (why not, or that the re-scored primary score differs from
    the run's, naming the set it was re-scored against). Never raises: what cannot be done is noted."""
    from benchbot.core.evaluation import evaluate

    method = run.manifest.get("evaluate_with")
    if not method:
        run.objects_note = "the batch ran without an evaluation method: no per-class or per-object views"
        return
    by_set: dict[str, dict[str, dict]] = {}
    for row in run.rows:
        path = run.run_dir / row["results"] if row["results"] else None
        if path is not None and path.is_file():
            by_set.setdefault(row.get("ground_truth_set", ""), {})[str(path)] = row
    if not by_set:
        run.objects_note = "the results files are not in the run directory: no per-class or per-object views"
        return
    per_result, errors, combined = [], [], None
    for gt_set, by_path in by_set.items():
        evaluation = None
        for options in ({"per_class": True, "matches": True}, {"per_class": True}):
            try:
                evaluation = evaluate(list(by_path), method, registry, required_task=run.manifest.get("task"),
                                      options=options, keep_going=True, ground_truth_set=gt_set or None)
                break
            except UsageError:
                continue  # the method lacks the option: try with less
            except BenchbotError as exc:
                run.objects_note = f"re-scoring failed: {exc.message}"
                return
        if evaluation is None:
            run.objects_note = f"the evaluation method '{method}' gives no per-class scores"
            return
        per_result += [(source, result, by_path.get(source)) for source, result in evaluation.per_result]
        errors += evaluation.errors
        combined = evaluation.combined if len(by_set) == 1 else None
    if len(by_set) > 1:  # episodes scored against different sets: the method's combine over all of them
        try:
            combine = registry.functions("evaluators", method).get("combine")
            combined = combine([result for _, result, _ in per_result]) if combine else None
        except Exception:  # noqa: BLE001 - a method's own failure: the per-class view is left out, said below
            combined = None
    primary = run.primary
    differences = []
    used = set()
    for _source, result, row in per_result:
        if row is None:
            continue
        run.objects[row["index"]] = result
        used.add(str(result.get("ground_truth_set") or ""))
        new = (result.get("scores") or {}).get(primary)
        if new is not None and primary in row:
            differences.append(abs(float(new) - row[primary]))
    run.per_class = (combined or {}).get("per_class") if isinstance(combined, dict) else None
    notes = []
    if errors:
        notes.append(f"{len(errors)} results file(s) could not be re-scored ({errors[0][1].message})")
    if differences and max(differences) > RESCORE_TOLERANCE:
        sets = ", ".join(sorted(used - {""})) or "each environment's default"
        recorded = all(by_set)
        notes.append(f"re-scored {primary} differs from the run's by up to {fmt(max(differences))}: "
                     + (f"the ground truths of set {sets} or the evaluation method changed since the batch ran"
                        if recorded else
                        f"the run did not record its set of ground truths, and was re-scored against {sets}")
                     + "; per-class and per-object views show today's scoring")
    if not any("matches" in r for r in run.objects.values()):
        notes.append(f"the evaluation method '{method}' gives no per-object matches: no top-down maps")
    run.objects_note = "; ".join(notes)


def per_class_columns(run: RunData) -> tuple[list[str], list[str]]:
    """``(counts, scores)``: the method's declared counts and real-valued scores that its per-class entries hold
    (counts from each class's ``totals`` or ``scores``), in the method's order."""
    entries = list((run.per_class or {}).values())
    have = set()
    for e in entries:
        have |= set((e.get("totals") or {})) | set((e.get("scores") or {}))
    return ([c for c in run.score_set.counts if c in have], [s for s in run.score_set.scores if s in have])


def per_class_rows(run: RunData) -> list[dict]:
    """``[{class, <count>..., <score>...}]`` pooled over the run's episodes (:func:`per_class_columns`), classes by
    their counts' sum (most first); a score is None where the class has no value for it."""
    counts, scores = per_class_columns(run)
    rows = []
    for cls, entry in (run.per_class or {}).items():
        t, s = entry.get("totals") or {}, entry.get("scores") or {}
        row = {"class": cls}
        row.update({c: int(t.get(c, s.get(c, 0)) or 0) for c in counts})
        row.update({k: s.get(k) for k in scores})
        rows.append(row)
    return sorted(rows, key=lambda r: (-sum(r[c] for c in counts), r["class"]))


def trajectory(env: str, registry, fallback: list | None = None) -> np.ndarray | None:
    """The *planned* path: ``(k, 2)`` x, y (metres, map frame) of the environment's start pose then its trajectory
    poses (first scene), from the registry's environment spec, else from ``fallback`` (a results file's
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


def _stem(run: RunData, row: dict) -> str:
    plan = next((p for p in run.manifest.get("plan", []) if isinstance(p, dict) and p.get("index") == row["index"]), {})
    return Path(str(plan.get("results") or row.get("results") or "")).stem


def driven_path(run: RunData, row: dict) -> tuple[np.ndarray | None, str]:
    """What the robot drove in an episode's first scene: ``((k, 2) x, y in metres, map frame, from its start, source)``
    from the batch's trajectory log (``trajectories/NNN_<env>.json``, :func:`benchbot.batch.episode_runner.run_episode`
    writes it), else from its recording (``recordings/NNN_<env>.mcap``, the ``/tf`` map → robot transforms of
    ``--record``); ``(None, "")`` when the batch kept neither (batches from before the log, without ``--record``)."""
    stem = _stem(run, row)
    if not stem:
        return None, ""
    log = run.run_dir / "trajectories" / f"{stem}.json"
    if log.is_file():
        try:
            data = json.loads(log.read_text())
            scene = data["scenes"][0]
            xy = [scene["start"][:2]] + [p[:2] for p in scene["poses"]]
            return np.asarray(xy, dtype=float).reshape(-1, 2), "trajectory log"
        except (OSError, ValueError, KeyError, IndexError, TypeError):
            pass
    recording = run.run_dir / "recordings" / f"{stem}.mcap"
    if recording.is_file():
        xy = recorded_path(recording)
        if xy is not None:
            return xy, "recording"
    return None, ""


def recorded_path(path: Path) -> np.ndarray | None:
    """``(k, 2)`` x, y (metres) of the map → robot transforms on ``/tf`` of a ``--record`` MCAP file, in time
    order (the robot's pose at the start and after every action); None when it cannot be read."""
    try:
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory

        xy = []
        with open(path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _schema, _channel, _message, msg in reader.iter_decoded_messages(topics=["/tf"], log_time_order=True):
                if msg.transforms:
                    t = msg.transforms[0].transform.translation
                    xy.append((float(t.x), float(t.y)))
        return np.asarray(xy, dtype=float) if xy else None
    except Exception:  # noqa: BLE001 - a damaged or foreign recording: the map shows the plan instead
        return None


def map_episode(run: RunData, env: str) -> tuple[dict, dict, int] | None:
    """The episode of ``env`` a map shows: the one with the median primary score among those with matches (the
    lower one of the middle two) → ``(row, evaluation, how many there were)``; None when none has matches."""
    rows = [r for r in run.rows if r["env"] == env and "matches" in run.objects.get(r["index"], {})]
    if not rows:
        return None
    rows.sort(key=lambda r: (run.score_set.sign() * r.get(run.primary, 0.0), r["index"]))
    row = rows[(len(rows) - 1) // 2]
    return row, run.objects[row["index"]], len(rows)


# --------------------------------------------------------------------------------------------------------------------
# Factors: robots, noise presets, lighting
# --------------------------------------------------------------------------------------------------------------------
def factor_views(runs: list[RunData], score: str | None = None) -> list[dict]:
    """The factors a run varies, each as ``{"factor", "groups", "series", "note"}`` (``series`` one per run as
    :func:`benchbot.batch.figures.per_group` takes it; ``groups`` empty when the factor cannot be shown).

    Robots and noise presets run on the same environments and seeds, so their groups compare like with like.
    Lighting is a property of an environment variant (``house:3`` is ``night``) that also changes the objects and
    the trajectory: grouping by lighting across variants would measure the variants. It is shown only within an
    environment run under several lightings; otherwise the note says why it is not shown.
    """
    score = score or main_score(runs)
    out = []
    for factor in ("robot", "noise"):
        levels = list(dict.fromkeys(r[factor] for run in runs for r in run.rows))
        if len(levels) > 1:
            out.append({"factor": factor, "groups": levels, "note": "", "series": [
                {"label": run.name, "values": group(run.rows, factor, score),
                 "estimates": {g: bounded(stats.mean_ci(v, level="episodes"), run, score).to_json()
                               for g, v in group(run.rows, factor, score).items()}}
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
            series.append({"label": run.name, "values": g,
                           "estimates": {k: bounded(stats.mean_ci(v, level="episodes"), run, score).to_json()
                                         for k, v in g.items()}})
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
            "t_interval_below": stats.T_INTERVAL_BELOW, "min_correlation_n": stats.MIN_CORRELATION_N,
            "unit": "environment", "pair_key": ["env"], "episode_pair_key": ["env", "seed"], "pair_factors": [f for f, _ in ROW_FACTORS],
            "correction": "Holm"}


def plan_text(plan: dict, what: str, episodes: str) -> list[str]:
    """A plan (:func:`benchbot.batch.stats.plan_environments`) in words, one line per target: ``what`` the SD is of
    (e.g. "their means"), ``episodes`` how the pilot measured each environment."""
    if plan["reason"]:
        return [plan["reason"]]
    pilot = (f"pilot: {plan['n']} environments, SD of {what} {fmt(plan['sd'])}, its "
             f"{int(stats.PLAN_SD_LEVEL * 100)} % upper bound {fmt(plan['sd_upper'])}")

    def count(k):
        return f"more than {stats.PLAN_MAX}" if k is None else str(k)

    out = []
    if plan["width"]:
        w = plan["width"]
        out.append(f"a {int(stats.CONFIDENCE * 100)} % interval {fmt(w['target'])} wide needs "
                   f"{count(w['environments'])} environments on average, {count(w['cautious'])} at the SD's upper bound ({pilot}; {episodes} "
                   "as in the pilot)")
    if plan["difference"]:
        d = plan["difference"]
        out.append(f"detecting a mean difference of {fmt(d['target'])} with {int(d['power'] * 100)} % power (paired "
                   f"t-test over environments, two-sided α = {fmt(1 - stats.CONFIDENCE)}) needs "
                   f"{count(d['environments'])} environments, {count(d['cautious'])} at the SD's upper bound ({pilot};"
                   f" {episodes} as in the pilot)")
    return out


def planning(runs: list[RunData], comps: list[dict], score: str, width: float | None,
             difference: float | None) -> dict:
    """How many environments a study like these runs needs (``benchbot report --plan-width/--plan-difference``):
    per run, for an interval of ``width`` from the SD of its environments' means; per comparison, for a detectable
    ``difference`` from the SD of its environments' paired differences (:func:`benchbot.batch.stats.plan_environments`).

    Returns:
        ``{"runs": [{"label", "plan", "lines"}], "comparisons": [{"a", "b", "plan", "lines"}]}``.
    """
    out: dict = {"runs": [], "comparisons": []}
    for run in runs:
        means = list(stats.cluster_means([r[score] for r in run.rows if score in r],
                                         [r["env"] for r in run.rows if score in r]).values())
        plan = stats.plan_environments(means, width=width)
        episodes = _per_environment({e: n for e, n in _counts(run, score).items()})
        lines = plan_text(plan, "their means", episodes) if width is not None else []
        out["runs"].append({"label": run.name, "plan": plan, "lines": lines})
    for c in comps:
        plan = stats.plan_environments(c["environment_differences"], difference=difference)
        lines = (plan_text(plan, "their paired differences", "as many episodes per environment")
                 if difference is not None else [])
        out["comparisons"].append({"a": c["a"], "b": c["b"], "plan": plan, "lines": lines})
    if difference is not None and not comps:
        out["note"] = ("--plan-difference needs a comparison (two or more runs): the SD of the environments' paired "
                       "differences comes from it")
    return out


def _counts(run: RunData, score: str) -> dict[str, int]:
    counts: dict[str, int] = {}
    for r in run.rows:
        if score in r:
            counts[r["env"]] = counts.get(r["env"], 0) + 1
    return counts


def analyse(runs: list[RunData], registry=None, factors: list[str] | None = None,
            plan: dict | None = None) -> dict:
    """Everything a report says about ``runs`` (the first is the baseline of comparisons), JSON-able.

    Args:
        registry: to re-score results for per-class and per-object views (:func:`score_objects`); None skips them.
        factors: conditions (:data:`CONDITIONS`) the comparison is about (``--factor``): runs differing in them
            are not warned about.
        plan: ``{"width": W, "difference": D}`` (either may be None): how many environments an interval W wide or
            a detectable difference D needs, from these runs as a pilot (:func:`planning`, in ``"planning"``).

    Returns:
        ``{"policy", "scores" (the baseline method's ScoreSet), "main_score", "runs": [{label, run_dir, task,
        isolation, verifiable, provenance, conditions, environments_n, episodes_n, summary (environment level),
        summary_episodes, environments, per_class, objects_note, robust (:func:`robust`)}], "planning" (None
        without ``plan``), "comparisons",
        "factors", "tasks",
        "differences" (:func:`condition_differences`), "notes"}``; estimates are
        :class:`benchbot.batch.stats.Estimate` dicts.

    Raises:
        UsageError: ``factors`` names something that is not a condition.
    """
    unknown = [f for f in factors or [] if f not in CONDITIONS]
    if unknown:
        raise UsageError(f"--factor: '{unknown[0]}' is not a condition", f"one of: {', '.join(CONDITIONS)}")
    if registry is not None:
        for run in runs:
            if not run.objects and not run.objects_note:
                score_objects(run, registry)
    scores = present_scores(runs)
    main = main_score(runs)
    taus = thresholds(runs, main)
    out_runs = []
    for run in runs:
        out_runs.append({
            "label": run.name, "run_dir": str(run.run_dir), "task": run.manifest.get("task"),
            "isolation": isolation(run.manifest), "verifiable": verifiable(run.manifest),
            "worlds": worlds(run.manifest), "provenance": dict(provenance(run)), "conditions": conditions(run),
            "environments_n": len({r["env"] for r in run.rows}), "episodes_n": len(run.rows),
            "summary": {k: v.to_json() for k, v in summary(run, scores).items()},
            "summary_episodes": {k: v.to_json() for k, v in summary_episodes(run, scores).items()},
            "environments": {env: {"values": v, **bounded(stats.mean_ci(v, level="episodes"), run, main).to_json()}
                             for env, v in group(run.rows, "env", main).items()},
            "per_class": per_class_rows(run) if run.per_class else None,
            "objects_note": run.objects_note,
            "robust": robust(run, main, taus),
        })
    comps = comparisons(runs, main) if len(runs) > 1 else []
    mentioned = set(factors or []) | {dict(ROW_FACTORS)[x["field"]] if x["field"] != "noise" else "noise preset"
                                      for c in comps for x in c["factors"]}
    notes = []
    methods = {str(run.manifest.get("evaluate_with") or "") for run in runs}
    if len(methods) > 1:
        notes.append(f"these runs were scored by different evaluation methods ({', '.join(sorted(methods))}): "
                     f"they are compared on {main}, the baseline's primary score, where they have it")
    tasks = {run.manifest.get("task") for run in runs}
    wanted = {k: v for k, v in (plan or {}).items() if v is not None}
    return {"planning": planning(runs, comps, main, wanted.get("width"), wanted.get("difference")) if wanted else None,
            "policy": policy(), "scores": score_set(runs).to_json(), "main_score": main, "runs": out_runs,
            "comparisons": comps, "factors": factor_views(runs, main), "tasks": sorted(map(str, tasks)),
            "differences": condition_differences(runs, mentioned) if len(runs) > 1 else [], "notes": notes}


# --------------------------------------------------------------------------------------------------------------------
# Tables and figures
# --------------------------------------------------------------------------------------------------------------------
def interval_note() -> str:
    """How the tables' intervals are made, in one sentence."""
    return (f"Intervals: {int(stats.CONFIDENCE * 100)} %, Student t below {stats.T_INTERVAL_BELOW} values, BCa "
            f"bootstrap ({stats.BOOTSTRAP_RESAMPLES} resamples) from there; none below {stats.MIN_CI_N} values.")


def tables(runs: list[RunData], result: dict) -> list[Table]:
    """The report's tables (each also written as CSV and LaTeX); every caption names its unit (environments or
    episodes)."""
    scores = present_scores(runs)
    main = result["main_score"]
    out = [Table("summary", f"{main}: mean [95 % CI] over environments (the unit) and over episodes",
                 ["run", "environments", "episodes", f"{main} over environments", f"{main} over episodes"],
                 [[r["label"], r["environments_n"], r["episodes_n"], r["summary"].get(main),
                   r["summary_episodes"].get(main)] for r in result["runs"]],
                 "Environments: the mean of the environments' means, its interval over the environments (how the "
                 "solution does on environments like these). Episodes: the mean over episodes, its interval over "
                 "them (how precisely these environments were measured; episodes of one environment are not "
                 "independent). " + interval_note())]
    if len(scores) > 1:
        out.append(Table("scores", "Every score: mean over environments [95 % CI over environments]",
                         ["run"] + [(runs[0].score_set.get(s).heading if runs[0].score_set.get(s) else s)
                                    for s in scores],
                         [[r["label"]] + [r["summary"].get(s) for s in scores] for r in result["runs"]],
                         "; ".join(f"{i.heading}: {i.description or i.name} ({i.direction} is better)"
                                   for i in (runs[0].score_set.get(s) for s in scores) if i) + ". " + interval_note()))
    envs = list(dict.fromkeys(e for r in result["runs"] for e in r["environments"]))
    lit = {env: "/".join(sorted({row["lighting"] for run in runs for row in run.rows if row["env"] == env} - {""}))
           for env in envs}
    lighting = any(lit.values())
    rows = [[env] + ([lit[env]] if lighting else []) + [r["environments"].get(env) for r in result["runs"]]
            for env in envs]
    shorts = figures.short_labels([r["label"] for r in result["runs"]])
    key = "; ".join(f"{short}: {r['label']}" for short, r in zip(shorts, result["runs"]) if short != r["label"])
    out.append(Table("environments", f"{main} per environment: mean over its episodes [95 % CI over episodes]",
                     ["environment"] + (["lighting"] if lighting else []) + shorts, rows,
                     (f"Runs: {key}. " if key else "") + "Each cell's n (its episodes) is in the CSV. "
                     + interval_note()))
    comps = result["comparisons"]
    if comps:
        factors = any(c["factors"] for c in comps)
        short_b = dict(zip([r["label"] for r in result["runs"]], shorts))
        key = "; ".join(f"{short_b[c['b']]}: {c['b']}" for c in comps if short_b[c["b"]] != c["b"])
        key = f"Runs: {key}. " if key else ""
        out.append(Table("comparisons", f"Paired comparisons with {runs[0].name} ({main}, B − A), environments as "
                                        "the unit",
                         ["run", "envs"] + (["factor"] if factors else []) + [
                             "mean diff. [95 % CI]", "d_z", "t-test p", "Wilcoxon p", "r_rb"],
                         [[short_b[c["b"]], c["n"]] + (["; ".join(f"{x['what']} {x['a']} → {x['b']}" for x in c["factors"])
                                               or "solution"] if factors else [])
                          + [c["difference"], c["cohens_dz"], c["ttest_p_holm"], c["wilcoxon_p_holm"],
                             c["rank_biserial"]] for c in comps],
                         key + "Each run's environment means (over all its episodes there) paired by environment; "
                         f"tests over the environments' (envs) mean differences, none below {stats.MIN_TEST_PAIRS} "
                         "environments; "
                         + "".join(f"{short_b[c['b']]}: left out {c['left_out']}. " for c in comps if c["left_out"])
                         + f"p-values Holm-adjusted over the {len(comps)} comparison(s) (the raw ones are in "
                         "report.json); d_z = mean difference / SD of the differences; r_rb: the matched-pairs "
                         "rank-biserial correlation."))
        out.append(Table("comparisons_episodes", f"Paired comparisons with {runs[0].name} ({main}, B − A), "
                                                 "episode pairs (these environments only)",
                         ["run", "pairs", "mean diff. [95 % CI]", "d_z", "t-test p", "Wilcoxon p"],
                         [[short_b[c["b"]], c["episodes"]["n"], c["episodes"]["difference"],
                           c["episodes"]["cohens_dz"], c["episodes"]["ttest_p_holm"], c["episodes"]["wilcoxon_p_holm"]]
                          for c in comps],
                         key + "".join(f"{c['unpaired']} episode(s) of {short_b[c['b']]} or the baseline without a "
                                       f"partner ({c['pairing'].split(';')[0]}), left out. "
                                       for c in comps if c["unpaired"])
                         + "Over episode pairs: what these environments show, not what other environments would; "
                         "episodes of one environment are not independent, so these p-values are smaller than the "
                         f"environment level's. None below {stats.MIN_TEST_PAIRS} pairs; p-values Holm-adjusted."))
    improvement = {c["b"]: c["probability_of_improvement"] for c in comps}
    key = "; ".join(f"{short}: {r['label']}" for short, r in zip(shorts, result["runs"]) if short != r["label"])
    out.append(Table("robust", f"{main}: robust aggregates (Agarwal et al. 2021)",
                     ["run", "IQM over environments", "IQM of episodes (stratified)"]
                     + ([f"P(better than {shorts[0]})"] if comps else []),
                     [[short, r["robust"]["iqm"], r["robust"]["iqm_episodes"]]
                      + ([improvement.get(r["label"]) if k else None] if comps else [])
                      for k, (short, r) in enumerate(zip(shorts, result["runs"]))],
                     (f"Runs: {key}. " if key else "") + "IQM: the mean of the middle 50 %. Over environments: of the "
                     "environments' means, percentile bootstrap over environments (about environments like these). "
                     "Of episodes: rliable's, every episode pooled, stratified bootstrap of the episodes within each "
                     "environment (about these environments only). P(better): the probability that an episode of "
                     "the run scores better than one of the baseline in the same environment, averaged over "
                     "environments, stratified bootstrap. Intervals 95 %, percentile, "
                     f"{stats.BOOTSTRAP_RESAMPLES} resamples, clipped to the score's range."))
    for k, (run, r) in enumerate(zip(runs, result["runs"])):
        if r["per_class"]:
            counts, class_scores = per_class_columns(run)
            out.append(Table(f"per_class_{k + 1}", f"{r['label']}: per class, pooled over {len(run.objects)} episodes",
                             ["class"] + counts + [(run.score_set.get(s).heading if run.score_set.get(s) else s)
                                                   for s in class_scores],
                             [[c["class"]] + [c[x] for x in counts] + [c[x] for x in class_scores]
                              for c in r["per_class"]],
                             "Counts and scores as the evaluation method gives them per class (– where a class has "
                             "no value)."))
    return out


@dataclass
class Figure:
    """A rendered figure: its file stem, heading, caption and bytes per format."""

    name: str
    title: str
    caption: str
    data: dict[str, bytes]


def make_figures(runs: list[RunData], result: dict, registry=None) -> list[Figure]:
    """Render every figure of the report (PNG, SVG, PDF each); runs are drawn under short labels when their names
    are long (:func:`benchbot.batch.figures.short_labels`), the legend naming them."""
    out = []
    scores = present_scores(runs)
    main = result["main_score"]
    shorts = figures.short_labels([r["label"] for r in result["runs"]])
    series = [{"label": r["label"], "short": short,
               "values": {s: list(stats.cluster_means([x[s] for x in run.rows if s in x],
                                                      [x["env"] for x in run.rows if s in x]).values())
                          for s in scores},
               "estimates": r["summary"]} for run, r, short in zip(runs, result["runs"], shorts)]
    out.append(Figure("summary", "Scores over environments",
                      "Each dot is one environment's mean; the mean over environments is drawn with its 95 % interval "
                      f"over them where n allows (n ≥ {stats.MIN_CI_N} environments); every panel's axis is scaled "
                      "to its data.",
                      figures.render(figures.summary(scores, series, stats.MIN_CI_N))))
    envs = list(dict.fromkeys(e for r in result["runs"] for e in r["environments"]))
    env_series = [{"label": r["label"], "short": short, "values": {e: v["values"] for e, v in r["environments"].items()},
                   "estimates": r["environments"]} for r, short in zip(result["runs"], shorts)]
    out.append(Figure("environments", f"{main} per environment",
                      "Each dot is one episode (a repetition); the interval is over the environment's episodes; n under "
                      "each environment, one number per run.",
                      figures.render(figures.per_group(f"{main} per environment", main, envs, env_series,
                                                       stats.MIN_CI_N))))
    out.append(Figure("score_distribution", f"{main}: score distributions",
                      "The fraction of each run's episodes scoring above τ, averaged over its environments (each "
                      "counts once), with a 95 % band by the stratified bootstrap (episodes resampled within each "
                      "environment: about these environments). A curve above another everywhere is better everywhere.",
                      figures.render(figures.score_distribution(main, [
                          {"label": r["label"], "short": short, "distribution": r["robust"]["score_distribution"],
                           "n": r["environments_n"]} for r, short in zip(result["runs"], shorts)]))))
    for k, c in enumerate(result["comparisons"]):
        if c["episodes"]["n"]:
            out.append(Figure(f"comparison_{k + 1}", f"{c['b']} vs {c['a']}: paired differences",
                              f"Grey dots: episode pairs ({c['pairing']}); large dots: each environment's mean "
                              "difference, the unit of the test; the line is the mean over environments and the band "
                              "its interval.",
                              figures.render(figures.paired_differences(c, main, stats.MIN_TEST_PAIRS))))
    for view in result["factors"]:
        if view["groups"]:
            for s, short in zip(view["series"], shorts):
                s["short"] = short
            out.append(Figure(f"factor_{view['factor']}", f"{main} per {view['factor']}", view["note"],
                              figures.render(figures.per_group(f"{main} per {view['factor']}", main,
                                                               view["groups"], view["series"], stats.MIN_CI_N))))
    for k, (run, r) in enumerate(zip(runs, result["runs"])):
        if r["per_class"]:
            counts, class_scores = per_class_columns(run)
            directions = [(c, run.score_set.get(c).direction) for c in counts]
            out.append(Figure(f"per_class_{k + 1}", f"{r['label']}: per class",
                              "Left: the method's counts per class (those where lower is better to the left of 0). "
                              "Right: its per-class scores.",
                              figures.render(figures.per_class(r["label"], r["per_class"], len(run.objects),
                                                               directions, [s for s in class_scores if s != main]
                                                               or class_scores))))
    for env in envs:
        panels = []
        for run, short in zip(runs, shorts):
            chosen = map_episode(run, env)
            if chosen is None:
                continue
            row, evaluation, n = chosen
            s = evaluation.get("scores") or {}
            which = f"median-{run.primary} episode of {n}" if n > 1 else "its only episode"
            path, source = driven_path(run, row)
            counts = ", ".join(f"{c} {s.get(c)}" for c in run.score_set.counts if c in s)
            name = short if short == run.name else f"{short}: {run.name}"
            panels.append({"title": figures._wrap(f"{name}: episode {row['index']} (seed {row['seed']}, {which})", 60)
                                    + f"\n{run.primary} {fmt(s.get(run.primary))}" + (f", {counts}" if counts else "")
                                    + ("" if path is not None else "\nno driven path recorded: the plan only"),
                           "matches": evaluation["matches"], "path": path, "path_source": source,
                           "plan": trajectory(env, registry, evaluation.get("environment_details"))})
        if panels:
            out.append(Figure(f"map_{_slug(env)}", f"{env}: top-down map",
                              f"{len(panels)} panel{'s' if len(panels) > 1 else ''}, one per run; solid: the path the "
                              "robot drove (from the batch's trajectory log or its recording), dashed: the planned "
                              "path.",
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
    main = result["main_score"]
    primary = runs[0].score_set.primary
    parts = ["<!doctype html><html lang='en'><meta charset='utf-8'>",
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
    plan = result.get("planning")
    if plan:
        items = [f"<li>{esc(e['label'])}: {esc(line)}</li>" for e in plan["runs"] for line in e["lines"]]
        items += [f"<li>{esc(e['b'])} − {esc(e['a'])}: {esc(line)}</li>" for e in plan["comparisons"]
                  for line in e["lines"]]
        if plan.get("note"):
            items.append(f"<li>{esc(plan['note'])}</li>")
        parts.append("<div class='box'><b>How many environments</b> (these runs as a pilot; docs/report.md):<ul>"
                     + "".join(items) + "</ul></div>")
    parts.append(
        "<section id='statistics'><div class='box'><b>How to read the numbers.</b> The unit is the "
        f"<b>environment</b>: a run's {esc(main)} is the mean of its environments' means ({esc(primary.direction)} "
        f"is better; {esc(primary.description or main)}), its {int(p['confidence'] * 100)} % interval over the "
        f"environments (Student t below {p['t_interval_below']} values, BCa bootstrap from there; none below "
        f"{p['min_ci_n']}; clipped to the score's declared range). Episodes of one environment share its rooms and "
        "objects, so they are not independent: "
        "the episode-level numbers, shown beside and named as such, say how precisely these environments were "
        f"measured, not how a solution does elsewhere. Runs are compared with <b>{esc(labels[0])}</b> on their "
        "environments' means (over every episode of each), paired by environment (a robot or noise preset that "
        "differs between two runs is the factor compared); episodes pair by environment and seed (or repetition) "
        f"at the episode level; tests over the environments from {p['min_test_pairs']} on: mean "
        "difference with its interval, Cohen's d<sub>z</sub>, paired t-test and Wilcoxon signed-rank test (with "
        "its rank-biserial r), p-values Holm-adjusted over all comparisons. Every figure states its n. Details: "
        "docs/report.md.</div></section>")
    parts.append("<section id='runs'><h2>Runs and provenance</h2>")
    for run, r in zip(runs, result["runs"]):
        rows = "".join(f"<tr><td>{esc(k)}</td><td>{esc(v)}</td></tr>" for k, v in provenance(run))
        parts.append(f"<h3>{esc(r['label'])}</h3><p class='note'><code>{esc(str(run.run_dir))}</code></p>"
                     f"<details{' open' if len(runs) == 1 else ''}><summary>provenance</summary>"
                     f"<div class='scroll'><table class='kv'>{rows}</table></div></details>")
    parts.append("</section><section id='summary'><h2>Summary</h2>" + table("summary") + table("scores")
                 + figure("summary") + "</section>")
    parts.append("<section id='environments'><h2>Per environment</h2>" + table("environments") + figure("environments")
                 + "</section>")
    if result["comparisons"]:
        parts.append("<section id='comparisons'><h2>Comparisons</h2>" + table("comparisons"))
        for k, c in enumerate(result["comparisons"]):
            parts.append(f"<p class='note'><b>{esc(c['b'])}</b> − {esc(c['a'])}: "
                         f"{esc(figures.comparison_text(c))}.</p>")
            if c.get("left_out"):
                parts.append(f"<p class='note'>Left out: {esc(c['left_out'])}.</p>")
            parts.append(figure(f"comparison_{k + 1}"))
        parts.append("<details><summary>the same over episode pairs</summary>" + table("comparisons_episodes")
                     + "</details></section>")
    parts.append("<section id='robust'><h2>Robust aggregates</h2><p class='note'>The interquartile mean, the "
                 "probability of improvement and score distributions of Agarwal et al. 2021 (rliable): see "
                 "docs/report.md for when each holds.</p>" + table("robust") + figure("score_distribution")
                 + "</section>")
    parts.append("<section id='classes'><h2>Per class</h2>")
    for k, r in enumerate(result["runs"]):
        parts.append(f"<h3>{esc(r['label'])}</h3>")
        if r["objects_note"]:
            parts.append(f"<p class='note'>{esc(r['objects_note'])}</p>")
        parts.append(table(f"per_class_{k + 1}") + figure(f"per_class_{k + 1}"))
    parts.append("</section><section id='maps'><h2>Top-down maps</h2><p class='note'>Seen from above (x-y "
                 "footprints, metres, map frame): ground-truth boxes from the environment's ground truth (dark outline: "
                 "found; red: missed), predicted boxes (filled by the matched pair's quality; orange: false positive; "
                 "grey: inside a group box, neither), a line from each match to its ground truth, the path the robot "
                 "drove (solid, start ▲; from the batch's trajectory log or recording) and the planned one (faint, "
                 f"dashed). With several episodes of an environment a panel shows the median-{esc(main)} one. Click a "
                 "map for its SVG.</p>")
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
        keys = ["index", "env"] + [k for k in ("robot", "repeat", "seed", "noise", "lighting")
                                   if k in ("repeat", "seed") or len({str(r.get(k, "")) for r in run.rows}) > 1]
        rows = [[r.get(k, "") for k in keys] + [r.get(s) for s in scores] for r in run.rows]
        headings = keys + [(run.score_set.get(s).heading if run.score_set.get(s) else s) for s in scores]
        parts.append(f"<details><summary>{esc(run.name)}: {len(run.rows)} episodes</summary>"
                     + to_html(Table("episodes", "", headings, rows)) + "</details>")
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
