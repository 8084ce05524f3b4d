"""Sweeps (``benchbot batch --sweep FACTOR=LEVEL,LEVEL,...``) and their robustness curves: a score against the
levels of one factor, with confidence intervals (docs/noise.md, *Sweeps*).

Factors: ``noise`` (the presets of :mod:`benchbot.core.noise`), ``robot`` (robot names), ``variant`` (environment
variants of every ``--envs`` name) and ``lighting`` (the variants of every ``--envs`` name whose ``lighting`` is the
level). Every level runs the whole batch (robots × environments × repetitions) and reuses the same seeds (common
random numbers: level k's j-th episode has seed ``--seed + j`` whatever k), so two levels differ only by the factor
and their episodes pair up.

Statistics (:func:`robustness`): those of ``benchbot report``, from :mod:`benchbot.batch.stats` (docs/report.md,
*Statistics*), with the environment as the unit. Per level, the mean of the environments' means with its interval
over the environments (:func:`~benchbot.batch.stats.cluster_mean_ci`, none below
:data:`~benchbot.batch.stats.MIN_CI_N` environments) and, beside it, the mean over episodes with its interval over
them (about these environments only); for ``noise`` and ``robot``, each level against the first over paired
episodes (matched by robot or noise, environment and repetition), averaged per environment, the tests over the
environments (:func:`~benchbot.batch.stats.cluster_paired_test`, none below
:data:`~benchbot.batch.stats.MIN_TEST_PAIRS` environments) and over the episode pairs, the p-values
Holm-adjusted over the levels (:func:`~benchbot.batch.stats.holm`). The score is the batch's evaluation method's
primary score unless another is named.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchbot.batch import stats
from benchbot.batch.plan import EpisodeSpec, plan_episodes, read_manifest
from benchbot.core import atomic
from benchbot.core.errors import UsageError
from benchbot.core.noise import get_preset

#: What ``--sweep`` can vary.
FACTORS = ("noise", "robot", "variant", "lighting")

#: Files a sweep's run directory gets besides the batch's own.
ROBUSTNESS_JSON, ROBUSTNESS_PLOT = "robustness.json", "robustness"

SWEEP_HINT = "e.g. --sweep noise=none,low,realistic,high (factors: noise, robot, variant, lighting)"


@dataclass(frozen=True)
class Sweep:
    """One factor and its levels, in the order given (the first is the baseline of the differences)."""

    factor: str
    levels: tuple[str, ...]


def parse_sweep(text: str) -> Sweep:
    """``FACTOR=LEVEL,LEVEL,...`` → :class:`Sweep` (levels stripped of spaces; noise levels checked).

    Raises:
        UsageError: not of that form, an unknown factor, fewer than 2 levels, a level given twice, or an unknown
            noise preset; one line naming ``--sweep`` and the fix.
    """
    m = re.fullmatch(r"\s*([A-Za-z_]+)\s*=(.*)", text or "")
    if not m:
        raise UsageError(f"--sweep '{text}' is not FACTOR=LEVEL,LEVEL,...", SWEEP_HINT)
    factor, levels = m.group(1), [v.strip() for v in m.group(2).split(",")]
    if factor not in FACTORS:
        raise UsageError(f"--sweep factor '{factor}' is not one of {', '.join(FACTORS)}", SWEEP_HINT)
    if any(not v for v in levels) or len(levels) < 2:
        raise UsageError(f"--sweep '{text}' needs at least 2 non-empty levels separated by commas", SWEEP_HINT)
    twice = sorted({v for v in levels if levels.count(v) > 1})
    if twice:
        raise UsageError(f"--sweep '{text}' gives level '{twice[0]}' twice", "give each level once")
    if factor == "noise":
        for level in levels:
            get_preset(level, flag="--sweep noise level")
    return Sweep(factor, tuple(levels))


def level_envs(sweep: Sweep, level: str, envs: list[str], registry) -> list[str]:
    """The environment strings of ``level`` of a ``variant`` or ``lighting`` sweep: for every distinct name of
    ``envs`` (``miniroom`` or ``miniroom:1``: the variant is replaced), ``name:level`` or every ``name:variant``
    whose spec's ``lighting`` is ``level``. Other factors: ``envs`` unchanged.

    Raises:
        UsageError: an environment name with no variant of that lighting (naming the lightings it has).
        SpecError: an unknown environment or variant (raised when the plan is validated).
    """
    if sweep.factor not in ("variant", "lighting"):
        return list(envs)
    names = list(dict.fromkeys(e.partition(":")[0] for e in envs))
    if sweep.factor == "variant":
        return [f"{name}:{level}" for name in names]
    out = []
    for name in names:
        variants = [n for n in registry.names("environments") if n.partition(":")[0] == name]
        lit = [n for n in variants if str(registry.get("environments", n).get("lighting", "")) == level]
        if not lit:
            have = sorted({str(registry.get("environments", n).get("lighting", "")) for n in variants})
            raise UsageError(f"--sweep lighting={level}: environment '{name}' has no variant lit '{level}'",
                             f"its lightings: {', '.join(have) or 'none (unknown environment)'}")
        out += lit
    return out


def plan_sweep(sweep: Sweep, *, robots: list[str], envs: list[str], noise: str, registry, **plan) -> tuple[
        list[EpisodeSpec], dict[str, str]]:
    """The episodes of every level of ``sweep`` (level after level, each a whole batch of
    :func:`~benchbot.batch.plan.plan_episodes` with the same seeds) and ``{str(index): level}``.

    Args:
        robots, envs, noise: the batch's, which the factor's level replaces. plan: the other arguments of
            :func:`~benchbot.batch.plan.plan_episodes` (task, repeat, seed, argv, cwd, options, timeout_s, ...).

    Raises:
        UsageError: as :func:`level_envs` and :func:`~benchbot.batch.plan.plan_episodes`.
    """
    specs: list[EpisodeSpec] = []
    level_of: dict[str, str] = {}
    for level in sweep.levels:
        block = plan_episodes(
            robots=[level] if sweep.factor == "robot" else robots,
            envs=level_envs(sweep, level, envs, registry),
            noise=level if sweep.factor == "noise" else noise,
            start=len(specs), tag=f"{sweep.factor}-{level}" if sweep.factor in ("noise", "robot") else "", **plan)
        level_of.update({str(s.index): level for s in block})
        specs += block
    return specs, level_of


# ------------------------------------------------------------------------------------------------------ statistics
def policy() -> dict:
    """The statistics' settings and minimums (those of :mod:`benchbot.batch.stats`, as ``benchbot report`` states
    them), for ``robustness.json``."""
    return {"confidence": stats.CONFIDENCE, "bootstrap_resamples": stats.BOOTSTRAP_RESAMPLES, "seed": stats.SEED,
            "min_ci_n": stats.MIN_CI_N, "min_test_pairs": stats.MIN_TEST_PAIRS,
            "t_interval_below": stats.T_INTERVAL_BELOW, "unit": "environment",
            "interval": "mean of the environments' means, interval over them (benchbot.batch.stats.cluster_mean_ci); "
                        "beside it over episodes (mean_ci)",
            "test": "paired t-test and Wilcoxon signed-rank test over the environments' mean differences "
                    "(benchbot.batch.stats.cluster_paired_test); beside them over the episode pairs",
            "correction": "Holm, over the levels compared with the baseline"}


def robustness(rows: list[dict], factor: str, levels: list[str], *, score: str = "score",
               score_range: tuple[float | None, float | None] = (None, None)) -> dict:
    """A robustness curve: ``score`` against the ``levels`` of ``factor``, with the statistics of
    :mod:`benchbot.batch.stats` (the same as ``benchbot report``'s, docs/report.md, *Statistics*): the environment
    as the unit, the episode level beside it.

    Args:
        rows: one per scored episode: ``level`` (str), ``score`` (float; None or NaN rows are left out), and
            ``robot``, ``env``, ``repeat``, ``noise`` (what pairs episodes across levels).
        factor: one of :data:`FACTORS`. levels: in plot order; the first is the baseline of the differences.
        score: the score's name (for the labels).
        score_range: the range the score declares (``(None, None)``: unbounded): every interval is clipped to it,
            a difference's to ``(low − high, high − low)`` (:func:`benchbot.batch.stats.clip_to_range`).

    Returns:
        ``{factor, score, policy, levels, differences}``:

        * ``policy``: :func:`policy`.
        * ``levels``: per level, ``{level, n, value, low, high, reason, method, level_of_n: "environments",
          episodes: {...}}``: the mean of its environments' means with its interval over the ``n`` environments
          (:func:`benchbot.batch.stats.cluster_mean_ci`, an :class:`~benchbot.batch.stats.Estimate` dict whose
          ``level`` key is renamed ``level_of_n``), ``low``/``high`` None and ``reason`` saying why below
          :data:`~benchbot.batch.stats.MIN_CI_N` environments; ``episodes``: the mean over its episodes with its
          interval over them (:func:`~benchbot.batch.stats.mean_ci`).
        * ``differences``: for ``noise`` and ``robot``, per level after the first, ``{level, baseline, n, level_of_n,
          unpaired, difference, cohens_dz, rank_biserial, ttest_p, ttest_p_holm, wilcoxon_p, wilcoxon_p_holm,
          reason, episodes}``: the level's episodes paired with the baseline's of the same robot (or noise),
          environment and repetition, averaged per environment and compared over the ``n`` environments
          (:func:`benchbot.batch.stats.cluster_paired_test`; ``difference``: the mean of level − baseline, an
          Estimate dict; Cohen's d_z; matched-pairs rank-biserial r; p-values), the same over the episode pairs in
          ``episodes`` (:func:`~benchbot.batch.stats.paired_test`; ``unpaired`` episodes of the two levels without
          a partner), the p-values Holm-adjusted (:func:`benchbot.batch.stats.holm`) over the levels at each
          level of analysis; below :data:`~benchbot.batch.stats.MIN_TEST_PAIRS` no test, no interval and
          ``reason`` says why. Empty for ``variant`` and ``lighting``: their levels are different environments,
          so no episodes pair up.
    """
    out = {"factor": factor, "score": score, "policy": policy(), "levels": [], "differences": []}
    by_level: dict[str, list[dict]] = {lv: [] for lv in levels}
    for row in rows:
        value = row.get("score")
        if row.get("level") in by_level and value is not None and math.isfinite(value):
            by_level[row["level"]].append(row)
    for lv in levels:
        values, envs = [r["score"] for r in by_level[lv]], [r.get("env") for r in by_level[lv]]
        est = stats.clip_to_range(stats.cluster_mean_ci(values, envs), *score_range).to_json()
        est["level_of_n"] = est.pop("level")
        out["levels"].append({"level": lv, **est, "episodes": stats.clip_to_range(
            stats.mean_ci(values, level="episodes"), *score_range).to_json()})
    if factor not in ("noise", "robot") or not levels:
        return out
    keys = ("env", "repeat", "noise" if factor == "robot" else "robot")
    base = {tuple(r.get(k) for k in keys): r["score"] for r in by_level[levels[0]]}
    for lv in levels[1:]:
        pairs = [(base[key], r["score"], r.get("env")) for r in by_level[lv]
                 if (key := tuple(r.get(k) for k in keys)) in base]
        a, b, envs = [p[0] for p in pairs], [p[1] for p in pairs], [p[2] for p in pairs]
        env = stats.cluster_paired_test(a, b, envs)
        episodes = stats.paired_test(a, b, level="pairs")
        low, high = score_range
        if low is not None and high is not None:
            for test in (env, episodes):
                stats.clip_to_range(test["difference"], low - high, high - low)
        out["differences"].append({
            "level": lv, "baseline": levels[0], "n": env["n"], "level_of_n": env["level"],
            "unpaired": len(by_level[lv]) + len(by_level[levels[0]]) - 2 * episodes["n"],
            "difference": env["difference"].to_json(), "cohens_dz": env["cohens_dz"],
            "rank_biserial": env["rank_biserial"], "ttest_p": env["ttest_p"], "wilcoxon_p": env["wilcoxon_p"],
            "reason": env["reason"],
            "episodes": {"n": episodes["n"], "level": "pairs", "difference": episodes["difference"].to_json(),
                         **{k: episodes[k] for k in ("cohens_dz", "rank_biserial", "ttest_p", "wilcoxon_p", "reason")}}})
    for name in ("ttest_p", "wilcoxon_p"):
        for d, p in zip(out["differences"], stats.holm([d[name] for d in out["differences"]])):
            d[f"{name}_holm"] = p
        for d, p in zip(out["differences"], stats.holm([d["episodes"][name] for d in out["differences"]])):
            d["episodes"][f"{name}_holm"] = p
    return out


def primary_score(manifest: dict, episode_scores: list[dict]) -> str:
    """The name of the primary score of the batch's evaluation method (its manifest's declaration, else what its
    scores show: :func:`benchbot.batch.run_data.resolve_score_set`)."""
    from benchbot.batch.run_data import resolve_score_set

    return resolve_score_set(manifest, episode_scores).primary.name


def sweep_rows(manifest: dict, episode_scores: list[dict], score: str | None = None) -> list[dict]:
    """The rows of :func:`robustness` from a sweep's manifest and its ``episode_scores.json`` entries (episodes
    without ``score``, default the primary score, are left out)."""
    score = score or primary_score(manifest, episode_scores)
    level_of = (manifest.get("sweep") or {}).get("level_of", {})
    plan = {p["index"]: p for p in manifest.get("plan", [])}
    rows = []
    for entry in episode_scores:
        value = (entry.get("scores") or {}).get(score)
        if str(entry["index"]) not in level_of or not isinstance(value, (int, float)):
            continue
        rows.append({"level": level_of[str(entry["index"])], "score": float(value), "env": entry["env"],
                     "robot": entry["robot"], "repeat": entry["repeat"],
                     "noise": plan.get(entry["index"], {}).get("noise", "none")})
    return rows


def robustness_from_run(run_dir: Path, score: str | None = None) -> dict:
    """:func:`robustness` of a sweep's run directory (``manifest.json`` and ``episode_scores.json``), for the
    batch and for ``benchbot report``; ``score`` defaults to the method's primary score.

    Raises:
        UsageError: not a run directory, not a sweep (no ``sweep`` in its manifest), or not evaluated.
    """
    return _robustness_and_rows(run_dir, score)[0]


def _robustness_and_rows(run_dir: Path, score: str | None) -> tuple[dict, list[dict]]:
    """:func:`robustness_from_run` and the :func:`sweep_rows` it summarises (read once, for the plot too).

    Raises:
        UsageError: as :func:`robustness_from_run`.
    """
    manifest = read_manifest(run_dir)
    sweep = manifest.get("sweep")
    if not sweep:
        raise UsageError(f"{run_dir} is not a sweep (its manifest has no 'sweep')", "run benchbot batch --sweep ...")
    path = run_dir / "episode_scores.json"
    try:
        entries = json.loads(path.read_text())
        score = score or primary_score(manifest, entries)
        rows = sweep_rows(manifest, entries, score)
    except FileNotFoundError:
        raise UsageError(f"{run_dir} has no episode_scores.json (the batch was not evaluated)",
                         "run a sweep with an evaluation method (--evaluate-with METHOD)") from None
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise UsageError(f"{path}: unreadable or malformed ({exc!r})", "it is written by `benchbot batch`") from None
    return robustness(rows, sweep["factor"], list(sweep["levels"]), score=score,
                      score_range=_declared_range(manifest, score)), rows


def _declared_range(manifest: dict, score: str) -> tuple[float | None, float | None]:
    """The range ``score`` declares in the manifest's ``scores`` (``(None, None)`` where it declares none)."""
    from benchbot.core.evaluation import ScoreSet

    try:
        info = ScoreSet.from_json(manifest["scores"]).get(score) if isinstance(manifest.get("scores"), dict) else None
    except ValueError:
        info = None
    return info.range if info else (None, None)


def plot_robustness(summary: dict, stem: Path, rows: list[dict] | None = None) -> list[Path]:
    """Plot ``summary`` (:func:`robustness`) as ``STEM.png`` and ``STEM.svg``: the mean score per level with its
    interval as an error bar where it has one (a hollow marker where it has none, below
    :data:`~benchbot.batch.stats.MIN_CI_N` episodes), ``rows``' episodes as dots, n under each level.

    Raises:
        UsageError: matplotlib is not installed.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UsageError("the robustness plot needs matplotlib", "install benchbot[vis]") from None
    levels = summary["levels"]
    fig, ax = plt.subplots(figsize=(2.0 + 1.3 * len(levels), 3.8), layout="constrained")
    xs = np.arange(len(levels))
    for x, lv in zip(xs, levels):
        if rows:
            ys = [r["score"] for r in rows if r["level"] == lv["level"]]
            jitter = np.linspace(-0.12, 0.12, len(ys)) if len(ys) > 1 else np.zeros(len(ys))
            ax.plot(x + jitter, ys, ".", color="0.6", zorder=1)
        if lv["value"] is None:
            continue
        ep = lv.get("episodes") or {}
        if lv["low"] is not None and lv["high"] is not None:
            ax.errorbar(x, lv["value"], yerr=[[lv["value"] - lv["low"]], [lv["high"] - lv["value"]]], fmt="o",
                        color="C0", capsize=5, zorder=2)
        elif ep.get("low") is not None and ep.get("high") is not None:  # the episodes' interval, drawn as such
            ax.errorbar(x + 0.18, ep["value"], yerr=[[ep["value"] - ep["low"]], [ep["high"] - ep["value"]]],
                        fmt="s", mfc="none", color="C1", capsize=3, zorder=2)
            ax.plot(x, lv["value"], "o", mfc="none", color="C0", zorder=2)
        else:
            ax.plot(x, lv["value"], "o", mfc="none", color="C0", zorder=2)
    ax.set_xticks(xs, [f"{lv['level']}\n{lv['n']} env., {(lv.get('episodes') or {}).get('n', '?')} ep."
                       for lv in levels])
    ax.set_xlabel(summary["factor"])
    ax.set_ylabel(summary["score"])
    policy = summary["policy"]
    pct = round(policy["confidence"] * 100)
    ax.set_title(f"{summary['score']} vs {summary['factor']}: mean over environments, {pct} % interval over them\n"
                 f"(none below {policy['min_ci_n']} environments: hollow circle; square: the interval over episodes, "
                 "these environments only)", fontsize=8)
    ax.grid(alpha=0.3)
    paths = [stem.with_suffix(".png"), stem.with_suffix(".svg")]
    for path in paths:
        fig.savefig(path, dpi=120)
    plt.close(fig)
    return paths


def write_robustness(run_dir: Path, score: str | None = None) -> dict:
    """Write ``robustness.json`` and ``robustness.png``/``.svg`` (:func:`plot_robustness`) into a sweep's run
    directory; returns the summary, with ``plots`` (file names) or ``plot_error`` (why there is none).

    Raises:
        UsageError: as :func:`robustness_from_run`.
    """
    summary, rows = _robustness_and_rows(run_dir, score)
    try:
        summary["plots"] = [p.name for p in plot_robustness(summary, run_dir / ROBUSTNESS_PLOT, rows)]
    except UsageError as exc:
        summary["plot_error"] = f"{exc.message} ({exc.hint})"
    atomic.write_json(run_dir / ROBUSTNESS_JSON, summary)
    return summary
