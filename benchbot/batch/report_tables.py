"""The tables of a report (``benchbot report``): what each one shows of the analysis
(:func:`benchbot.batch.analysis.analyse`) and its caption, which names its unit (environments or episodes). How a
:class:`~benchbot.batch.paper.Table` is written (HTML, CSV, LaTeX) is :mod:`benchbot.batch.paper`'s.
"""

from __future__ import annotations

from benchbot.batch import figures, stats
from benchbot.batch.object_views import per_class_columns
from benchbot.batch.paper import Table
from benchbot.batch.run_data import RunData
from benchbot.batch.run_stats import present_scores


def interval_note() -> str:
    """How the tables' intervals are made, in one sentence."""
    return (f"Intervals: {int(stats.CONFIDENCE * 100)} %, Student t below {stats.T_INTERVAL_BELOW} values, BCa "
            f"bootstrap ({stats.BOOTSTRAP_RESAMPLES} resamples) from there; none below {stats.MIN_CI_N} values.")


def tables(runs: list[RunData], result: dict) -> list[Table]:
    """The report's tables (each also written as CSV and LaTeX), in the page's order: ``summary``, ``scores``
    (with several scores), ``environments``, ``comparisons`` and ``comparisons_episodes`` (with several runs),
    ``robust``, ``per_class_K`` (per run with per-class scores)."""
    shorts = figures.short_labels([r["label"] for r in result["runs"]])
    out = _summary_tables(runs, result) + [_environments_table(runs, result, shorts)]
    if result["comparisons"]:
        out += _comparison_tables(runs, result, shorts)
    out.append(_robust_table(result, shorts))
    return out + _per_class_tables(runs, result)


def _heading(run: RunData, score: str) -> str:
    """The heading of ``score``'s column: its short name as the run's method declares it, else the name."""
    info = run.score_set.get(score)
    return info.heading if info else score


def _runs_key(shorts: list[str], labels: list[str]) -> str:
    """``"Runs: A: long name; B: other. "`` for the runs drawn under a short label ("" when none is)."""
    key = "; ".join(f"{short}: {label}" for short, label in zip(shorts, labels) if short != label)
    return f"Runs: {key}. " if key else ""


def _summary_tables(runs: list[RunData], result: dict) -> list[Table]:
    """``summary`` (the primary score at both levels) and, when the method has several scores, ``scores``."""
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
                         ["run"] + [_heading(runs[0], s) for s in scores],
                         [[r["label"]] + [r["summary"].get(s) for s in scores] for r in result["runs"]],
                         "; ".join(f"{i.heading}: {i.description or i.name} ({i.direction} is better)"
                                   for i in (runs[0].score_set.get(s) for s in scores) if i) + ". " + interval_note()))
    return out


def _environments_table(runs: list[RunData], result: dict, shorts: list[str]) -> Table:
    """``environments``: the primary score per environment and run (with the lighting, where one is recorded)."""
    main = result["main_score"]
    envs = list(dict.fromkeys(e for r in result["runs"] for e in r["environments"]))
    lit = {env: "/".join(sorted({row["lighting"] for run in runs for row in run.rows if row["env"] == env} - {""}))
           for env in envs}
    lighting = any(lit.values())
    rows = [[env] + ([lit[env]] if lighting else []) + [r["environments"].get(env) for r in result["runs"]]
            for env in envs]
    return Table("environments", f"{main} per environment: mean over its episodes [95 % CI over episodes]",
                 ["environment"] + (["lighting"] if lighting else []) + shorts, rows,
                 _runs_key(shorts, [r["label"] for r in result["runs"]]) + "Each cell's n (its episodes) is in the "
                 "CSV. " + interval_note())


def _comparison_tables(runs: list[RunData], result: dict, shorts: list[str]) -> list[Table]:
    """``comparisons`` (environments as the unit) and ``comparisons_episodes`` (over episode pairs)."""
    main, comps = result["main_score"], result["comparisons"]
    factors = any(c["factors"] for c in comps)
    short_b = dict(zip([r["label"] for r in result["runs"]], shorts))
    key = "; ".join(f"{short_b[c['b']]}: {c['b']}" for c in comps if short_b[c["b"]] != c["b"])
    key = f"Runs: {key}. " if key else ""
    environments = Table(
        "comparisons", f"Paired comparisons with {runs[0].name} ({main}, B − A), environments as the unit",
        ["run", "envs"] + (["factor"] if factors else []) + [
            "mean diff. [95 % CI]", "d_z", "t-test p", "Wilcoxon p", "r_rb"],
        [[short_b[c["b"]], c["n"]] + (["; ".join(f"{x['what']} {x['a']} → {x['b']}" for x in c["factors"])
                                      or "solution"] if factors else [])
         + [c["difference"], c["cohens_dz"], c["ttest_p_holm"], c["wilcoxon_p_holm"], c["rank_biserial"]]
         for c in comps],
        key + "Each run's environment means (over all its episodes there) paired by environment; "
        f"tests over the environments' (envs) mean differences, none below {stats.MIN_TEST_PAIRS} environments; "
        + "".join(f"{short_b[c['b']]}: left out {c['left_out']}. " for c in comps if c["left_out"])
        + f"p-values Holm-adjusted over the {len(comps)} comparison(s) (the raw ones are in "
        "report.json); d_z = mean difference / SD of the differences; r_rb: the matched-pairs "
        "rank-biserial correlation.")
    episodes = Table(
        "comparisons_episodes", f"Paired comparisons with {runs[0].name} ({main}, B − A), episode pairs (these "
                                "environments only)",
        ["run", "pairs", "mean diff. [95 % CI]", "d_z", "t-test p", "Wilcoxon p"],
        [[short_b[c["b"]], c["episodes"]["n"], c["episodes"]["difference"], c["episodes"]["cohens_dz"],
          c["episodes"]["ttest_p_holm"], c["episodes"]["wilcoxon_p_holm"]] for c in comps],
        key + "".join(f"{c['unpaired']} episode(s) of {short_b[c['b']]} or the baseline without a "
                      f"partner ({c['pairing'].split(';')[0]}), left out. " for c in comps if c["unpaired"])
        + "Over episode pairs: what these environments show, not what other environments would; "
        "episodes of one environment are not independent, so these p-values are smaller than the "
        f"environment level's. None below {stats.MIN_TEST_PAIRS} pairs; p-values Holm-adjusted.")
    return [environments, episodes]


def _robust_table(result: dict, shorts: list[str]) -> Table:
    """``robust``: the IQM at both levels and, with comparisons, the probability of improvement."""
    main, comps = result["main_score"], result["comparisons"]
    improvement = {c["b"]: c["probability_of_improvement"] for c in comps}
    return Table(
        "robust", f"{main}: robust aggregates (Agarwal et al. 2021)",
        ["run", "IQM over environments", "IQM of episodes (stratified)"]
        + ([f"P(better than {shorts[0]})"] if comps else []),
        [[short, r["robust"]["iqm"], r["robust"]["iqm_episodes"]]
         + ([improvement.get(r["label"]) if k else None] if comps else [])
         for k, (short, r) in enumerate(zip(shorts, result["runs"]))],
        _runs_key(shorts, [r["label"] for r in result["runs"]]) + "IQM: the mean of the middle 50 %. Over "
        "environments: of the environments' means, percentile bootstrap over environments (about environments like "
        "these). Of episodes: rliable's, every episode pooled, stratified bootstrap of the episodes within each "
        "environment (about these environments only). P(better): the probability that an episode of "
        "the run scores better than one of the baseline in the same environment, averaged over "
        "environments, stratified bootstrap. Intervals 95 %, percentile, "
        f"{stats.BOOTSTRAP_RESAMPLES} resamples, clipped to the score's range.")


def _per_class_tables(runs: list[RunData], result: dict) -> list[Table]:
    """``per_class_K`` for the K-th run (from 1) that has per-class scores."""
    out = []
    for k, (run, r) in enumerate(zip(runs, result["runs"])):
        if r["per_class"]:
            counts, class_scores = per_class_columns(run)
            out.append(Table(f"per_class_{k + 1}", f"{r['label']}: per class, pooled over {len(run.objects)} episodes",
                             ["class"] + counts + [_heading(run, s) for s in class_scores],
                             [[c["class"]] + [c[x] for x in counts] + [c[x] for x in class_scores]
                              for c in r["per_class"]],
                             "Counts and scores as the evaluation method gives them per class (– where a class has "
                             "no value)."))
    return out
