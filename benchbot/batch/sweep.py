"""Sweeps (``benchbot batch --sweep FACTOR=LEVEL,LEVEL,...``) and their robustness curves: a score against the
levels of one factor, with confidence intervals (docs/noise.md, *Sweeps*).

Factors: ``noise`` (the presets of :mod:`benchbot.core.noise`), ``robot`` (robot names), ``variant`` (environment
variants of every ``--envs`` name) and ``lighting`` (the variants of every ``--envs`` name whose ``lighting`` is the
level). Every level runs the whole batch (robots × environments × repetitions) and reuses the same seeds (common
random numbers: level k's j-th episode has seed ``--seed + j`` whatever k), so two levels differ only by the factor
and their episodes pair up.

Statistics (:func:`robustness`): those of ``benchbot report``, from :mod:`benchbot.batch.stats` (docs/report.md,
*Statistics*). Per level, the mean score with its BCa bootstrap interval (:func:`~benchbot.batch.stats.mean_ci`,
none below :data:`~benchbot.batch.stats.MIN_CI_N` episodes); for ``noise`` and ``robot``, each level against the
first over paired episodes (matched by robot or noise, environment and repetition) with
:func:`~benchbot.batch.stats.paired_test` (none below :data:`~benchbot.batch.stats.MIN_TEST_PAIRS` pairs), the
p-values Holm-adjusted over the levels (:func:`~benchbot.batch.stats.holm`).
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
            "interval": "BCa bootstrap of the mean (benchbot.batch.stats.mean_ci)",
            "test": "paired t-test and Wilcoxon signed-rank test (benchbot.batch.stats.paired_test)",
            "correction": "Holm, over the levels compared with the baseline"}


def robustness(rows: list[dict], factor: str, levels: list[str], *, score: str = "OMQ") -> dict:
    """A robustness curve: ``score`` against the ``levels`` of ``factor``, with the statistics of
    :mod:`benchbot.batch.stats` (the same as ``benchbot report``'s, docs/report.md, *Statistics*).

    Args:
        rows: one per scored episode: ``level`` (str), ``score`` (float; None or NaN rows are left out), and
            ``robot``, ``env``, ``repeat``, ``noise`` (what pairs episodes across levels).
        factor: one of :data:`FACTORS`. levels: in plot order; the first is the baseline of the differences.

    Returns:
        ``{factor, score, policy, levels, differences}``:

        * ``policy``: :func:`policy`.
        * ``levels``: per level, ``{level, n, value, low, high, reason, method}``: the mean score over its ``n``
          episodes with its BCa bootstrap interval (:func:`benchbot.batch.stats.mean_ci`, an
          :class:`~benchbot.batch.stats.Estimate` dict); ``low``/``high`` None and ``reason`` saying why below
          :data:`~benchbot.batch.stats.MIN_CI_N` episodes.
        * ``differences``: for ``noise`` and ``robot``, per level after the first, ``{level, baseline, n, unpaired,
          difference, cohens_dz, rank_biserial, ttest_p, ttest_p_holm, wilcoxon_p, wilcoxon_p_holm, reason}``:
          the level's episodes paired with the baseline's of the same robot (or noise), environment and
          repetition (``n`` pairs; ``unpaired`` episodes of the two levels without a partner), compared with
          :func:`benchbot.batch.stats.paired_test` (``difference``: the mean of level − baseline, an Estimate
          dict; Cohen's d_z; matched-pairs rank-biserial r; p-values), the p-values Holm-adjusted
          (:func:`benchbot.batch.stats.holm`) over the levels; below :data:`~benchbot.batch.stats.MIN_TEST_PAIRS`
          pairs no test, no interval and ``reason`` says why. Empty for ``variant`` and ``lighting``: their
          levels are different environments, so no episodes pair up.
    """
    out = {"factor": factor, "score": score, "policy": policy(), "levels": [], "differences": []}
    by_level: dict[str, list[dict]] = {lv: [] for lv in levels}
    for row in rows:
        value = row.get("score")
        if row.get("level") in by_level and value is not None and math.isfinite(value):
            by_level[row["level"]].append(row)
    for lv in levels:
        out["levels"].append({"level": lv, **stats.mean_ci([r["score"] for r in by_level[lv]]).to_json()})
    if factor not in ("noise", "robot") or not levels:
        return out
    keys = ("env", "repeat", "noise" if factor == "robot" else "robot")
    base = {tuple(r.get(k) for k in keys): r["score"] for r in by_level[levels[0]]}
    for lv in levels[1:]:
        pairs = [(base[key], r["score"]) for r in by_level[lv] if (key := tuple(r.get(k) for k in keys)) in base]
        test = stats.paired_test([a for a, _ in pairs], [b for _, b in pairs])
        out["differences"].append({
            "level": lv, "baseline": levels[0], "n": test["n"],
            "unpaired": len(by_level[lv]) + len(by_level[levels[0]]) - 2 * test["n"],
            "difference": test["difference"].to_json(), "cohens_dz": test["cohens_dz"],
            "rank_biserial": test["rank_biserial"], "ttest_p": test["ttest_p"], "wilcoxon_p": test["wilcoxon_p"],
            "reason": test["reason"]})
    for name in ("ttest_p", "wilcoxon_p"):
        for d, p in zip(out["differences"], stats.holm([d[name] for d in out["differences"]])):
            d[f"{name}_holm"] = p
    return out


def sweep_rows(manifest: dict, episode_scores: list[dict], score: str = "OMQ") -> list[dict]:
    """The rows of :func:`robustness` from a sweep's manifest and its ``episode_scores.json`` entries (episodes
    without ``score`` are left out)."""
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


def robustness_from_run(run_dir: Path, score: str = "OMQ") -> dict:
    """:func:`robustness` of a sweep's run directory (``manifest.json`` and ``episode_scores.json``), for the
    batch and for ``benchbot report``.

    Raises:
        UsageError: not a run directory, not a sweep (no ``sweep`` in its manifest), or not evaluated.
    """
    manifest = read_manifest(run_dir)
    sweep = manifest.get("sweep")
    if not sweep:
        raise UsageError(f"{run_dir} is not a sweep (its manifest has no 'sweep')", "run benchbot batch --sweep ...")
    path = run_dir / "episode_scores.json"
    try:
        entries = json.loads(path.read_text())
        rows = sweep_rows(manifest, entries, score)
    except FileNotFoundError:
        raise UsageError(f"{run_dir} has no episode_scores.json (the batch was not evaluated)",
                         "run it with --evaluate-with omq") from None
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise UsageError(f"{path}: unreadable or malformed ({exc!r})", "it is written by `benchbot batch`") from None
    return robustness(rows, sweep["factor"], list(sweep["levels"]), score=score)


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
    fig, ax = plt.subplots(figsize=(1.6 + 1.3 * len(levels), 3.6))
    xs = np.arange(len(levels))
    for x, lv in zip(xs, levels):
        if rows:
            ys = [r["score"] for r in rows if r["level"] == lv["level"]]
            jitter = np.linspace(-0.12, 0.12, len(ys)) if len(ys) > 1 else np.zeros(len(ys))
            ax.plot(x + jitter, ys, ".", color="0.6", zorder=1)
        if lv["value"] is None:
            continue
        if lv["low"] is not None and lv["high"] is not None:
            ax.errorbar(x, lv["value"], yerr=[[lv["value"] - lv["low"]], [lv["high"] - lv["value"]]], fmt="o",
                        color="C0", capsize=5, zorder=2)
        else:
            ax.plot(x, lv["value"], "o", mfc="none", color="C0", zorder=2)
    means = [lv["value"] if lv["value"] is not None else np.nan for lv in levels]
    ax.plot(xs, means, "-", color="C0", alpha=0.5, zorder=1)
    ax.set_xticks(xs, [f"{lv['level']}\nn={lv['n']}" for lv in levels])
    ax.set_xlabel(summary["factor"])
    ax.set_ylabel(summary["score"])
    policy = summary["policy"]
    pct = round(policy["confidence"] * 100)
    ax.set_title(f"{summary['score']} vs {summary['factor']}: mean, {pct} % BCa bootstrap interval "
                 f"(none below n={policy['min_ci_n']}: hollow marker)", fontsize=9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    paths = [stem.with_suffix(".png"), stem.with_suffix(".svg")]
    for path in paths:
        fig.savefig(path, dpi=120)
    plt.close(fig)
    return paths


def write_robustness(run_dir: Path, score: str = "OMQ") -> dict:
    """Write ``robustness.json`` and ``robustness.png``/``.svg`` (:func:`plot_robustness`) into a sweep's run
    directory; returns the summary, with ``plots`` (file names) or ``plot_error`` (why there is none).

    Raises:
        UsageError: as :func:`robustness_from_run`.
    """
    summary = robustness_from_run(run_dir, score)
    manifest = read_manifest(run_dir)
    rows = sweep_rows(manifest, json.loads((run_dir / "episode_scores.json").read_text()), score)
    try:
        summary["plots"] = [p.name for p in plot_robustness(summary, run_dir / ROBUSTNESS_PLOT, rows)]
    except UsageError as exc:
        summary["plot_error"] = f"{exc.message} ({exc.hint})"
    atomic.write_json(run_dir / ROBUSTNESS_JSON, summary)
    return summary
