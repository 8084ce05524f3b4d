"""Performance profiles of batch runs: tables, 95 % bootstrap confidence intervals, plots, and paired comparisons.

Inputs are run directories written by ``benchbot batch`` (``manifest.json``, ``config.json``,
``episode_scores.json``). The HTML report embeds its plots as PNG (matplotlib, Agg backend) so it is one file.

Statistics: the confidence interval of a mean is the percentile bootstrap (Efron & Tibshirani 1993, ch. 13) with
10,000 resamples from ``numpy.random.default_rng(0)`` (so reports are reproducible); two runs are compared on the
environments both contain, pairing each environment's mean OMQ, with the paired t-test and the Wilcoxon
signed-rank test (``scipy.stats.ttest_rel``, ``scipy.stats.wilcoxon``).
"""

from __future__ import annotations

import base64
import html
import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchbot.batch.plan import read_manifest
from benchbot.core.errors import UsageError

SCORES = ["OMQ", "avg_pairwise", "avg_label", "avg_spatial", "avg_fp_quality", "avg_state_quality"]
BOOTSTRAP_RESAMPLES = 10_000


@dataclass
class RunData:
    """One run directory's episodes with their scores.

    Attributes:
        run_dir: the folder. manifest: its manifest. rows: one dict per scored episode: ``index``, ``env``,
            ``robot``, ``repeat``, ``seed``, ``lighting`` (or ``""``), and every score of ``SCORES`` it has.
    """

    run_dir: Path
    manifest: dict
    rows: list[dict]

    @property
    def name(self) -> str:
        """The run directory's folder name."""
        return self.run_dir.name


def load_run(run_dir: Path) -> RunData:
    """Read a run directory.

    Raises:
        UsageError: not a run directory, or it has no scores (not evaluated yet).
    """
    manifest = read_manifest(run_dir)
    path = run_dir / "episode_scores.json"
    if not path.is_file():
        raise UsageError(f"{run_dir} has no episode_scores.json (the batch was not evaluated)", "run it with --evaluate-with omq")
    try:
        config = json.loads((run_dir / "config.json").read_text()) if (run_dir / "config.json").is_file() else {}
        lighting = {env: "+".join(str(s.get("lighting", "")) for s in scenes) for env, scenes in config.get("environments", {}).items()}
        rows = []
        for entry in json.loads(path.read_text()):
            row = {k: entry[k] for k in ("index", "env", "robot", "repeat", "seed")}
            row["lighting"] = lighting.get(entry["env"], "")
            row.update({k: float(v) for k, v in entry.get("scores", {}).items() if k in SCORES})
            rows.append(row)
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:  # unreadable, not JSON, wrong shape
        raise UsageError(f"{run_dir}: episode_scores.json or config.json is unreadable or malformed ({exc!r})",
                         "they are written by `benchbot batch`; were they edited?") from None
    if not rows:
        raise UsageError(f"{run_dir} has no scored episodes", "every episode failed, or the batch ran with --no-evaluate")
    return RunData(run_dir, manifest, rows)


def bootstrap_ci(values: "list[float] | np.ndarray", level: float = 0.95) -> tuple[float, float, float]:
    """``(mean, low, high)``: the mean of ``values`` and its percentile-bootstrap confidence interval.

    One value gives ``(v, v, v)``; no values give NaNs.
    """
    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        return (float("nan"),) * 3
    if x.size == 1:
        return (float(x[0]),) * 3
    rng = np.random.default_rng(0)
    means = x[rng.integers(0, x.size, size=(BOOTSTRAP_RESAMPLES, x.size))].mean(axis=1)
    alpha = (1.0 - level) / 2.0
    return float(x.mean()), float(np.quantile(means, alpha)), float(np.quantile(means, 1.0 - alpha))


def group(rows: list[dict], key: str, score: str = "OMQ") -> dict[str, list[float]]:
    """``{value of key: [score of each row]}`` in first-seen order."""
    out: dict[str, list[float]] = {}
    for row in rows:
        if score in row:
            out.setdefault(str(row[key]), []).append(row[score])
    return out


def summary(run: RunData) -> dict[str, tuple[float, float, float]]:
    """Mean and 95 % CI of every score present, over all episodes."""
    present = [s for s in SCORES if any(s in r for r in run.rows)]
    return {s: bootstrap_ci([r[s] for r in run.rows if s in r]) for s in present}


def compare(a: RunData, b: RunData) -> dict:
    """Paired comparison of two runs on the environments both contain (each environment's mean OMQ).

    Returns:
        ``{'environments': [...], 'mean_a', 'mean_b', 'mean_difference' (b − a), 'ttest_p', 'wilcoxon_p'}``; the
        p-values are None with fewer than 2 shared environments (or when every difference is 0, for Wilcoxon).
    """
    from scipy import stats

    ga, gb = group(a.rows, "env"), group(b.rows, "env")
    shared = [e for e in ga if e in gb]
    xa = np.array([np.mean(ga[e]) for e in shared])
    xb = np.array([np.mean(gb[e]) for e in shared])
    out = {"environments": shared, "mean_a": float(xa.mean()) if shared else None,
           "mean_b": float(xb.mean()) if shared else None,
           "mean_difference": float((xb - xa).mean()) if shared else None, "ttest_p": None, "wilcoxon_p": None}
    if len(shared) >= 2:
        diff = xb - xa
        if np.any(diff != 0):
            out["ttest_p"] = float(stats.ttest_rel(xb, xa).pvalue)
            out["wilcoxon_p"] = float(stats.wilcoxon(xb, xa).pvalue)
        else:
            out["ttest_p"] = 1.0
    return out


def _figure_png(fig) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return base64.b64encode(buffer.getvalue()).decode()


def plots(runs: list[RunData]) -> list[tuple[str, str]]:
    """``[(title, base64 PNG)]``: scores per environment, OMQ per lighting variant, per robot, and the
    distribution over repetitions.

    Raises:
        UsageError: matplotlib is not installed.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UsageError("reports need matplotlib", "install it: uv pip install matplotlib (or benchbot[vis])") from None
    out = []
    envs = list(dict.fromkeys(r["env"] for run in runs for r in run.rows))
    scores = [s for s in SCORES if any(s in r for run in runs for r in run.rows)]
    fig, axes = plt.subplots(1, len(scores), figsize=(3.2 * len(scores), 3.4), squeeze=False)
    width = 0.8 / len(runs)
    for k, score in enumerate(scores):
        ax = axes[0][k]
        for j, run in enumerate(runs):
            g = group(run.rows, "env", score)
            means = [np.mean(g[e]) if e in g else np.nan for e in envs]
            ax.bar(np.arange(len(envs)) + j * width, means, width, label=run.name)
        ax.set_title(score)
        ax.set_xticks(np.arange(len(envs)) + width * (len(runs) - 1) / 2, envs, rotation=60, ha="right", fontsize=7)
        ax.set_ylim(0, 1)
    if len(runs) > 1:
        axes[0][0].legend(fontsize=7)
    out.append(("Scores per environment (mean over repetitions)", _figure_png(fig)))
    for key, title in (("lighting", "OMQ per lighting variant"), ("robot", "OMQ per robot")):
        fig, ax = plt.subplots(figsize=(5, 3.2))
        for j, run in enumerate(runs):
            g = group(run.rows, key)
            cis = [bootstrap_ci(v) for v in g.values()]
            x = np.arange(len(g)) + j * width
            ax.bar(x, [c[0] for c in cis], width, label=run.name,
                   yerr=np.array([[c[0] - c[1] for c in cis], [c[2] - c[0] for c in cis]]), capsize=3)
            ax.set_xticks(x, list(g), fontsize=8)
        ax.set_ylim(0, 1)
        ax.set_title(f"{title} (95% CI)")
        if len(runs) > 1:
            ax.legend(fontsize=7)
        out.append((title, _figure_png(fig)))
    fig, ax = plt.subplots(figsize=(max(4, 0.6 * len(envs)), 3.2))
    data = [[r["OMQ"] for run in runs for r in run.rows if r["env"] == e and "OMQ" in r] for e in envs]
    ax.boxplot(data, tick_labels=envs)
    ax.tick_params(axis="x", rotation=60, labelsize=7)
    ax.set_ylim(0, 1)
    ax.set_title("OMQ distribution over repetitions")
    out.append(("OMQ distribution over repetitions", _figure_png(fig)))
    return out


def _table(headers: list[str], rows: list[list[object]]) -> str:
    def cell(v: object) -> str:
        return f"{v:.4f}" if isinstance(v, float) else html.escape(str(v))

    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def render_html(runs: list[RunData]) -> str:
    """The whole report as one HTML page (plots embedded)."""
    parts = ["<!doctype html><meta charset='utf-8'><title>BenchBot report</title><style>",
             "body{font-family:sans-serif;margin:2em}table{border-collapse:collapse;margin:1em 0}",
             "td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}th{background:#eee}</style>",
             "<h1>BenchBot performance profile</h1>"]
    for run in runs:
        m = run.manifest
        parts.append(f"<h2>{html.escape(run.name)}</h2><p>task <b>{html.escape(str(m.get('task')))}</b>, robots "
                     f"{html.escape(', '.join(m.get('robots', [])))}, {len(run.rows)} scored episodes, wall "
                     f"{m.get('wall_s', '?')} s</p>")
        summ = summary(run)
        parts.append(_table(["score", "mean", "95% CI low", "95% CI high"], [[k, *v] for k, v in summ.items()]))
        per_env = group(run.rows, "env")
        parts.append(_table(["environment", "episodes", "mean OMQ", "95% CI low", "95% CI high"],
                            [[e, len(v), *bootstrap_ci(v)] for e, v in per_env.items()]))
        keys = ["index", "env", "robot", "repeat", "seed", "lighting"] + [s for s in SCORES if s in summ]
        parts.append("<details><summary>episodes</summary>" + _table(keys, [[r.get(k, "") for k in keys] for r in run.rows]) + "</details>")
    if len(runs) == 2:
        c = compare(*runs)
        parts.append("<h2>Comparison</h2>" + _table(
            ["shared environments", "mean OMQ A", "mean OMQ B", "B − A", "paired t-test p", "Wilcoxon p"],
            [[len(c["environments"]), c["mean_a"], c["mean_b"], c["mean_difference"], c["ttest_p"], c["wilcoxon_p"]]]))
    for title, png in plots(runs):
        parts.append(f"<h3>{html.escape(title)}</h3><img src='data:image/png;base64,{png}'>")
    return "\n".join(parts)
