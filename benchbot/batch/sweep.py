"""Sweeps (``benchbot batch --sweep FACTOR=LEVEL,LEVEL,...``) and their robustness curves: a score against the
levels of one factor, with confidence intervals (docs/noise.md, *Sweeps*).

Factors: ``noise`` (the presets of :mod:`benchbot.core.noise`), ``robot`` (robot names), ``variant`` (environment
variants of every ``--envs`` name) and ``lighting`` (the variants of every ``--envs`` name whose ``lighting`` is the
level). Every level runs the whole batch (robots × environments × repetitions) and reuses the same seeds (common
random numbers: level k's j-th episode has seed ``--seed + j`` whatever k), so two levels differ only by the factor
and their episodes pair up.

Statistics (:func:`robustness`): per level, the mean score over its scored episodes and the Student t interval of
the mean (``scipy.stats.t.interval``), refused below :data:`MIN_N` episodes; for ``noise`` and ``robot``, each
level's paired differences from the first level (matched by robot or noise, environment and repetition) with
their t interval and the p-value of the one-sample t test of mean difference 0 (``scipy.stats.ttest_1samp``).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchbot.batch.plan import EpisodeSpec, plan_episodes, read_manifest
from benchbot.core import atomic
from benchbot.core.errors import UsageError
from benchbot.core.noise import get_preset

#: What ``--sweep`` can vary.
FACTORS = ("noise", "robot", "variant", "lighting")

#: Fewest values a confidence interval is computed from. With 2 values the 95 % t interval is ±12.7 standard
#: errors (t₀.₉₇₅ with 1 degree of freedom) around a mean whose spread is itself estimated from 2 numbers: wider
#: than a score's whole range, so it would say nothing; with 3 it is ±4.3 standard errors.
MIN_N = 3

#: Relative spread below which values count as all equal (rounding, not variation).
SPREAD_EPS = 1e-12

#: Confidence level of every interval.
CONFIDENCE = 0.95

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
def mean_interval(values, confidence: float = CONFIDENCE, min_n: int = MIN_N) -> dict:
    """``{n, mean, sd, low, high, note}`` of ``values``: the mean, the sample standard deviation (ddof 1) and the
    Student t interval of the mean, ``mean ± t_{(1+confidence)/2, n-1} · sd/√n``.

    ``low``/``high`` are None (and ``note`` says why) with fewer than ``min_n`` values; with every value equal (up
    to :data:`SPREAD_EPS` relative) ``sd`` is 0, the interval is the mean itself and ``note`` says the values do not
    vary. NaN values are dropped.
    """
    from scipy import stats

    x = np.asarray([v for v in values if v is not None and not math.isnan(v)], dtype=np.float64)
    n = int(x.size)
    out = {"n": n, "mean": float(x.mean()) if n else None, "sd": float(x.std(ddof=1)) if n > 1 else None,
           "low": None, "high": None, "note": ""}
    if n < min_n:
        out["note"] = (f"n = {n} < {min_n}: no interval (a t interval from fewer than {min_n} values is too wide to "
                       "say anything, and their spread is no estimate); run more repetitions (--repeat)")
        return out
    if out["sd"] <= SPREAD_EPS * max(1.0, abs(out["mean"])):  # equal up to rounding (differences of equal sums)
        out["sd"] = 0.0
        out["low"] = out["high"] = out["mean"]
        out["note"] = f"all {n} values equal: the repetitions vary nothing this score sees"
        return out
    low, high = stats.t.interval(confidence, n - 1, loc=out["mean"], scale=out["sd"] / math.sqrt(n))
    out["low"], out["high"] = float(low), float(high)
    return out


def robustness(rows: list[dict], factor: str, levels: list[str], *, score: str = "OMQ",
               confidence: float = CONFIDENCE, min_n: int = MIN_N) -> dict:
    """A robustness curve: ``score`` against the ``levels`` of ``factor``.

    Args:
        rows: one per scored episode: ``level`` (str), ``score`` (float), and ``robot``, ``env``, ``repeat``,
            ``noise`` (what pairs episodes across levels).
        factor: one of :data:`FACTORS`. levels: in plot order; the first is the baseline of the differences.

    Returns:
        ``{factor, score, confidence, min_n, interval, levels: [{level, n, mean, sd, low, high, note}],
        differences: [{level, baseline, pairs, mean, sd, low, high, p_value, note}]}``. ``differences`` is empty
        for ``variant`` and ``lighting`` (their levels are different environments, so no episodes pair up);
        otherwise each level's episodes are paired with the baseline's of the same robot (or noise), environment
        and repetition, and ``mean`` is level − baseline.
    """
    from scipy import stats

    out = {"factor": factor, "score": score, "confidence": confidence, "min_n": min_n,
           "interval": "Student t interval of the mean (scipy.stats.t.interval)", "levels": [], "differences": []}
    by_level: dict[str, list[dict]] = {lv: [] for lv in levels}
    for row in rows:
        if row.get("level") in by_level and row.get("score") is not None:
            by_level[row["level"]].append(row)
    for lv in levels:
        out["levels"].append({"level": lv, **mean_interval([r["score"] for r in by_level[lv]], confidence, min_n)})
    if factor not in ("noise", "robot") or not levels:
        return out
    keys = ("env", "repeat", "noise" if factor == "robot" else "robot")
    base = {tuple(r.get(k) for k in keys): r["score"] for r in by_level[levels[0]]}
    for lv in levels[1:]:
        d = [r["score"] - base[key] for r in by_level[lv] if (key := tuple(r.get(k) for k in keys)) in base]
        diff = mean_interval(d, confidence, min_n)
        diff["pairs"] = diff.pop("n")
        diff["p_value"] = None
        if diff["pairs"] >= min_n and diff["sd"]:
            diff["p_value"] = float(stats.ttest_1samp(d, 0.0).pvalue)
        out["differences"].append({"level": lv, "baseline": levels[0], **diff})
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
    interval as an error bar (a hollow marker where there is no interval), ``rows``' episodes as dots, n under each
    level.

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
        if lv["mean"] is None:
            continue
        if lv["low"] is not None:
            ax.errorbar(x, lv["mean"], yerr=[[lv["mean"] - lv["low"]], [lv["high"] - lv["mean"]]], fmt="o",
                        color="C0", capsize=5, zorder=2)
        else:
            ax.plot(x, lv["mean"], "o", mfc="none", color="C0", zorder=2)
    means = [lv["mean"] if lv["mean"] is not None else np.nan for lv in levels]
    ax.plot(xs, means, "-", color="C0", alpha=0.5, zorder=1)
    ax.set_xticks(xs, [f"{lv['level']}\nn={lv['n']}" for lv in levels])
    ax.set_xlabel(summary["factor"])
    ax.set_ylabel(summary["score"])
    pct = round(summary["confidence"] * 100)
    ax.set_title(f"{summary['score']} vs {summary['factor']}: mean, {pct} % t interval (none below n={summary['min_n']})",
                 fontsize=9)
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
