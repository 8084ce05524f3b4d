"""What a report says about run directories (``benchbot report``, ``--json``): :func:`analyse` turns runs into one
JSON-able dict — per run its provenance, conditions, summaries at the environment and episode levels, per
environment and per class, robust aggregates; the comparisons with the baseline (the first run); the factors the
runs vary (:func:`factor_views`); the conditions they differ in; and, on request, how many environments a study
like these needs (:func:`planning`). The statistics are :mod:`benchbot.batch.run_stats`'s, the per-class views
:mod:`benchbot.batch.object_views`'s; runs that differ in a condition the comparison does not name (simulator
style or version, camera, arch, ...) are compared with a warning
(:func:`benchbot.batch.run_conditions.condition_differences`).
"""

from __future__ import annotations

from benchbot.batch import stats
from benchbot.batch.figures import fmt
from benchbot.batch.object_views import per_class_rows, score_objects
from benchbot.batch.run_conditions import (CONDITIONS, condition_differences, conditions, isolation,
                                           provenance_rows, verifiable, worlds)
from benchbot.batch.run_data import RunData
from benchbot.batch.run_stats import (ROW_FACTORS, bounded, comparisons, episodes_per_environment, group, main_score,
                                      present_scores, robust, score_set, summary, summary_episodes, thresholds)
from benchbot.core.errors import UsageError


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
        episodes = episodes_per_environment({e: n for e, n in _counts(run, score).items()})
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
    """``{environment: episodes with score}`` of a run."""
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
            "worlds": worlds(run.manifest), "provenance": dict(provenance_rows(run)), "conditions": conditions(run),
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
