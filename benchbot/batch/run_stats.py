"""The statistics of run directories (``benchbot report``): each run's scores with the environment as the unit and
beside it the episode level, the robust aggregates, and paired comparisons of runs, built on the methods of
:mod:`benchbot.batch.stats` (docs/report.md, "Statistics").

A run's score is the mean over its environments of each environment's mean, with an interval over the environments
(:func:`summary`); runs are compared with the first one (the baseline) on their environment means (over every
episode of each) paired by environment (a robot or noise preset that differs between the two runs is the factor
compared, not a reason not to pair, :data:`ROW_FACTORS`), with the tests over the environments' mean differences
(from :data:`~benchbot.batch.stats.MIN_TEST_PAIRS` environments on), the p-values Holm-adjusted over the
comparisons (:func:`comparisons`). The episode level is shown beside it, named as such: how precisely these
environments were measured, not how a solution does on others, with episodes paired by environment and seed
(common random numbers) or repetition; what a comparison leaves out is said (:func:`left_out`). Intervals are
clipped to the range each score declares (:func:`bounded`).
"""

from __future__ import annotations

import numpy as np

from benchbot.batch import stats
from benchbot.batch.run_data import RunData
from benchbot.core.evaluation import ScoreSet

ROW_FACTORS = (("robot", "robot"), ("noise", "noise preset"))
"""Settings that vary by episode and that two runs may differ in (field, words): when each run has one value and
they differ, it is the factor under comparison and episodes pair without it."""


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


def episodes_per_environment(counts: dict[str, int]) -> str:
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
        na, nb = episodes_per_environment(cells["episodes_a"]), episodes_per_environment(cells["episodes_b"])
        why = (f"{a.name} ran {na}, {b.name} {nb}" if na != nb else
               f"no episode of the other run with the same environment and {pairs['by']}")
        parts.append(f"at the episode level {pairs['unpaired']} of {pairs['scored']} episodes ({why}); the "
                     "environment level uses every episode")
    return "; ".join(parts)


TEST_KEYS = ("n", "level", "difference", "cohens_dz", "rank_biserial", "ttest_p", "wilcoxon_p", "reason")
"""What a comparison keeps of a paired test's result (:func:`benchbot.batch.stats.paired_test`)."""


def _test(result: dict) -> dict:
    """The :data:`TEST_KEYS` of a paired test's result, its estimates as dicts."""
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
