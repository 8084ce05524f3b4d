"""The figures of ``benchbot report`` (matplotlib, Agg): each one states its n, draws every episode as a dot next to
the mean, draws an interval only where one was computed, and scales its axis to the data (docs/report.md).

Every function takes plain data and returns a ``matplotlib.figure.Figure``; :func:`render` turns one into PNG, SVG
and PDF bytes (no timestamps in the files, so the same report gives the same bytes). Colours are the Okabe–Ito
palette, which readers with colour-vision deficiencies can tell apart.
"""

from __future__ import annotations

import io
from typing import Sequence

import numpy as np

from benchbot.core.errors import UsageError

PALETTE = ["#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000"]
"""Okabe & Ito (2008) colour-blind-safe colours, one per run in order."""

FORMATS = ("png", "svg", "pdf")
"""What every figure is saved as: PNG for the page, SVG and PDF for papers."""

PNG_DPI = 200
"""Resolution of the PNG files (the page shows them at CSS width)."""

STYLE = {"font.size": 8, "axes.titlesize": 9, "axes.labelsize": 8, "xtick.labelsize": 7, "ytick.labelsize": 7,
         "legend.fontsize": 7, "axes.spines.top": False, "axes.spines.right": False, "svg.fonttype": "none",
         "pdf.fonttype": 42, "svg.hashsalt": "benchbot"}
"""matplotlib settings of every figure (text stays text in SVG and PDF, so it can be edited and searched)."""

STATUS_COLOURS = {"TP": "#222222", "FN": "#D55E00", "FP": "#E69F00", "group": "#999999"}
"""Top-down maps: ground truth found (TP, dark outline), missed ground truth (FN), false positive (FP), inside a
group box (neither); matched predictions are filled by their quality (viridis) instead."""

COUNT_COLOURS = {"TP": "#009E73", "FN": "#D55E00", "FP": "#E69F00"}
"""Per-class bars: found, missed, false positives."""


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend.

    Raises:
        UsageError: matplotlib is not installed.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UsageError("reports need matplotlib", "install it: uv pip install matplotlib (or benchbot[vis])") from None
    plt.rcParams.update(STYLE)
    return plt


def render(fig) -> dict[str, bytes]:
    """``{"png": ..., "svg": ..., "pdf": ...}``: ``fig`` in every format of :data:`FORMATS`, then closed."""
    plt = pyplot()
    out = {}
    for fmt in FORMATS:
        buffer = io.BytesIO()
        metadata = {"Date": None} if fmt in ("svg", "pdf") else {}
        if fmt == "pdf":
            metadata["CreationDate"] = None
            metadata.pop("Date")
        fig.savefig(buffer, format=fmt, dpi=PNG_DPI if fmt == "png" else None, bbox_inches="tight", metadata=metadata)
        out[fmt] = buffer.getvalue()
    plt.close(fig)
    return out


def _limits(values: Sequence[float]) -> tuple[float, float]:
    """Axis limits around ``values`` with 8 % padding (0.02 when they are all equal); never below 0 when no
    value is."""
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)], dtype=float)
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = float(v.min()), float(v.max())
    pad = 0.08 * (hi - lo) if hi > lo else 0.02
    low = lo - pad
    if lo >= 0 and low < 0:
        low = 0.0
    return low, hi + pad


def _jitter(n: int, width: float) -> np.ndarray:
    """Fixed offsets spreading ``n`` dots over ``width`` (deterministic: the same figure every time)."""
    return np.zeros(n) if n <= 1 else np.linspace(-width / 2, width / 2, n)


def _errorbar(ax, x: float, est: dict, colour: str) -> None:
    """The mean as a filled marker, with its interval when it has one."""
    if est.get("value") is None:
        return
    if est.get("low") is not None and est.get("high") is not None:
        ax.errorbar([x], [est["value"]], yerr=[[est["value"] - est["low"]], [est["high"] - est["value"]]],
                    fmt="o", color=colour, ms=5, capsize=3, lw=1.2, zorder=3)
    else:
        ax.plot([x], [est["value"]], marker="D", color=colour, ms=5, ls="none", zorder=3)


def _key(ax, min_n: int, runs: list[tuple[str, str]]) -> None:
    """A legend outside the axes on the right: one colour per run, then what the markers mean."""
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], marker="s", color=c, ls="none", ms=6, label=label) for label, c in runs]
    handles += [Line2D([], [], marker="o", color="#444444", ls="-", lw=1, ms=4, label="mean, 95 % CI"),
                Line2D([], [], marker="D", color="#444444", ls="none", ms=4, label=f"mean, no interval (n < {min_n})"),
                Line2D([], [], marker="o", mfc="none", mec="#444444", ls="none", ms=4, label="one episode")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False, borderaxespad=0)


def per_group(title: str, score: str, groups: list[str], series: list[dict], min_n: int, xlabel: str = ""):
    """Dots of every episode and the mean (with its interval where there is one) of ``score`` per group
    (environment, robot, lighting...), one colour per run.

    Args:
        title: the figure's title; the n of every group and run is added under each group's name.
        groups: the groups in order.
        series: one per run, ``{"label", "values": {group: [score per episode]}, "estimates": {group: Estimate
            dict}}``.
        min_n: the smallest n that gets an interval (for the legend's note).
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(max(3.4, 0.9 * len(groups) * max(1, len(series)) ** 0.5 + 1.2), 2.8))
    width = 0.7 / max(1, len(series))
    everything = []
    for k, run in enumerate(series):
        colour = PALETTE[k % len(PALETTE)]
        for g, group in enumerate(groups):
            x = g + (k - (len(series) - 1) / 2) * width
            values = run["values"].get(group, [])
            everything += values
            ax.scatter(x + _jitter(len(values), width * 0.6), values, s=9, facecolors="none", edgecolors=colour,
                       linewidths=0.7, alpha=0.8, zorder=2)
            est = run["estimates"].get(group)
            if est:
                _errorbar(ax, x, est, colour)
                everything += [v for v in (est.get("low"), est.get("high")) if v is not None]
    ns = [", ".join(str(len(run["values"].get(g, []))) for run in series) for g in groups]
    tilt = len(groups) > 6
    ax.set_xticks(range(len(groups)), [f"{g}\nn = {n}" for g, n in zip(groups, ns)],
                  rotation=30 if tilt else 0, ha="right" if tilt else "center")
    ax.set_ylim(*_limits(everything))
    ax.set_ylabel(score)
    if xlabel:
        ax.set_xlabel(xlabel)
    ax.set_title(title)
    ax.grid(axis="y", color="#dddddd", lw=0.5)
    _key(ax, min_n, [(run["label"], PALETTE[k % len(PALETTE)]) for k, run in enumerate(series)])
    return fig


def summary(scores: list[str], series: list[dict], min_n: int):
    """One panel per score: each run's episodes as dots, their mean and its interval.

    Args:
        scores: the score names, one panel each.
        series: one per run, ``{"label", "values": {score: [per episode]}, "estimates": {score: Estimate dict}}``.
    """
    plt = pyplot()
    cols = min(3, len(scores))
    rows = -(-len(scores) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(1.4 + 1.7 * cols, 2.5 * rows), squeeze=False)
    flat = list(axes.flat)
    for ax in flat[len(scores):]:
        ax.set_visible(False)
    for ax, score in zip(flat, scores):
        everything = []
        for k, run in enumerate(series):
            colour = PALETTE[k % len(PALETTE)]
            values = run["values"].get(score, [])
            everything += values
            ax.scatter(k + _jitter(len(values), 0.35), values, s=9, facecolors="none", edgecolors=colour,
                       linewidths=0.7, alpha=0.8)
            est = run["estimates"].get(score)
            if est:
                _errorbar(ax, k, est, colour)
                everything += [v for v in (est.get("low"), est.get("high")) if v is not None]
        ax.set_xticks(range(len(series)), [r["label"] for r in series], rotation=30 if len(series) > 1 else 0,
                      ha="right" if len(series) > 1 else "center")
        ax.set_xlim(-0.6, len(series) - 0.4)
        ax.set_ylim(*_limits(everything))
        ns = ", ".join(str(len(r["values"].get(score, []))) for r in series)
        ax.set_title(f"{score}\nn = {ns}")
        ax.grid(axis="y", color="#dddddd", lw=0.5)
    _key(flat[cols - 1], min_n, [(run["label"], PALETTE[k % len(PALETTE)]) for k, run in enumerate(series)])
    fig.tight_layout()
    return fig


def paired_differences(comparison: dict, score: str, min_pairs: int):
    """A comparison's paired differences (B − A) as dots, their mean with its interval, and the zero line.

    Args:
        comparison: ``{"a", "b", "keys": [pair names], "differences": [...], "difference": Estimate dict,
            "ttest_p_holm", "wilcoxon_p_holm", "reason", "pairing"}``.
    """
    plt = pyplot()
    d = comparison["differences"]
    fig, ax = plt.subplots(figsize=(max(3.2, 0.28 * len(d) + 2.0), 2.6))
    x = np.arange(len(d))
    ax.axhline(0, color="#555555", lw=0.8)
    ax.scatter(x, d, s=12, color=PALETTE[1], zorder=2, label="one pair")
    est = comparison["difference"]
    if est.get("value") is not None:
        ax.axhline(est["value"], color=PALETTE[0], lw=1.2, label="mean difference")
        if est.get("low") is not None:
            ax.axhspan(est["low"], est["high"], color=PALETTE[0], alpha=0.15, lw=0, label="95 % CI")
    ax.set_xticks(x, comparison["keys"], rotation=60, ha="right", fontsize=5 if len(d) > 12 else 6)
    ax.set_ylim(*_limits(list(d) + [0.0] + [v for v in (est.get("low"), est.get("high")) if v is not None]))
    ax.set_ylabel(f"{score}: {comparison['b']} − {comparison['a']}")
    if comparison.get("reason"):
        verdict = comparison["reason"]
    else:
        verdict = f"paired t-test p = {fmt(comparison['ttest_p_holm'])} (Holm)"
    ax.set_title(f"{comparison['b']} vs {comparison['a']}: n = {len(d)} pairs ({comparison['pairing']})\n{verdict}",
                 fontsize=8)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False, borderaxespad=0)
    ax.grid(axis="y", color="#dddddd", lw=0.5)
    return fig


def per_class(label: str, rows: list[dict], episodes: int):
    """A run's per-class counts (TP, FN of the ground-truth objects; FP of the proposals) and the mean label and
    spatial quality of its true positives.

    Args:
        rows: ``{"class", "TP", "FP", "FN", "avg_label", "avg_spatial"}`` per class (qualities None without TPs).
        episodes: how many episodes the counts are pooled over (stated in the title).
    """
    plt = pyplot()
    rows = sorted(rows, key=lambda r: (r["TP"] + r["FN"], r["FP"]))
    names = [r["class"] for r in rows]
    y = np.arange(len(rows))
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(6.4, 0.9 + 0.17 * len(rows)), sharey=True,
                                 gridspec_kw={"width_ratios": [3, 2]})
    tp, fn, fp = (np.array([r[k] for r in rows], float) for k in ("TP", "FN", "FP"))
    ax.barh(y, tp, color=COUNT_COLOURS["TP"], label="TP (found)")
    ax.barh(y, fn, left=tp, color=COUNT_COLOURS["FN"], label="FN (missed)")
    ax.barh(y, -fp, color=COUNT_COLOURS["FP"], label="FP (left of 0)")
    ax.axvline(0, color="#555555", lw=0.6)
    ax.set_yticks(y, names, fontsize=6)
    ax.set_xlabel("objects (FP to the left)")
    ax.legend(loc="lower right", frameon=False, fontsize=6)
    for key, marker, colour in (("avg_label", "o", PALETTE[0]), ("avg_spatial", "s", PALETTE[3])):
        vals = [r[key] if r[key] is not None else np.nan for r in rows]
        bx.plot(vals, y, marker=marker, ls="none", color=colour, ms=4, label=key.replace("avg_", "mean ") + " quality")
    bx.set_xlim(0, 1)
    bx.set_xlabel("quality of the TPs")
    bx.legend(loc="lower right", frameon=False, fontsize=6)
    bx.grid(axis="x", color="#dddddd", lw=0.5)
    fig.suptitle(f"{label}: per class, pooled over n = {episodes} episodes", fontsize=9)
    fig.tight_layout()
    return fig


def topdown(env: str, panels: list[dict]):
    """Top-down maps of one environment, one panel per run: ground-truth boxes (dark: found, red: missed),
    predicted boxes (filled by the pair's quality when matched, orange when false positives, grey inside a group
    box), a line from each match to its ground truth, and the robot's trajectory (start: triangle).

    Args:
        panels: ``{"title", "matches": evaluation ``matches`` dict, "path": (k, 2) metres (x, y; map frame) or
            None}`` per run.
    """
    plt = pyplot()
    import matplotlib
    from matplotlib import cm, colors
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle

    cmap, norm = matplotlib.colormaps["viridis"], colors.Normalize(0, 1)
    n = len(panels)
    fig, axes = plt.subplots(1, n, figsize=(4.6 * n, 4.4), squeeze=False)
    for ax, panel in zip(axes[0], panels):
        m = panel["matches"]
        points = []
        for g in m["ground_truth"]:
            (cx, cy), (ex, ey) = g["centroid"][:2], g["extent"][:2]
            colour = STATUS_COLOURS[g["status"]]
            ax.add_patch(Rectangle((cx - ex / 2, cy - ey / 2), ex, ey, fill=False, ec=colour, lw=1.3,
                                   ls="--" if g.get("isgroup") else "-", zorder=2))
            ax.text(cx, cy + ey / 2, g["class"], fontsize=4.5, color="#333333", ha="center", va="bottom", zorder=5)
            points += [(cx - ex / 2, cy - ey / 2), (cx + ex / 2, cy + ey / 2)]
        for p in m["proposals"]:
            (cx, cy), (ex, ey) = p["centroid"][:2], p["extent"][:2]
            if p["status"] == "TP":
                face, alpha = cmap(norm(p["quality"])), 0.55
            else:
                face, alpha = STATUS_COLOURS[p["status"]], 0.35
            ax.add_patch(Rectangle((cx - ex / 2, cy - ey / 2), ex, ey, fc=face, ec="none", alpha=alpha, zorder=1))
            if p["status"] == "TP":
                gc = m["ground_truth"][p["ground_truth"]]["centroid"]
                ax.plot([cx, gc[0]], [cy, gc[1]], color="#333333", lw=0.5, zorder=3)
            points += [(cx - ex / 2, cy - ey / 2), (cx + ex / 2, cy + ey / 2)]
        path = panel.get("path")
        if path is not None and len(path):
            path = np.asarray(path, float)
            ax.plot(path[:, 0], path[:, 1], color="#000000", lw=0.9, alpha=0.7, zorder=4)
            ax.plot(path[:1, 0], path[:1, 1], marker="^", color="#000000", ms=6, zorder=4)
            points += [tuple(p) for p in path]
        if points:
            pts = np.array(points)
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            pad = 0.04 * float((hi - lo).max() or 1.0)
            ax.set_xlim(lo[0] - pad, hi[0] + pad)
            ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m, map frame)")
        ax.set_ylabel("y (m)")
        ax.set_title(panel["title"], fontsize=8)
    handles = [Line2D([], [], color=STATUS_COLOURS["TP"], lw=1.3, label="ground truth, found (TP)"),
               Line2D([], [], color=STATUS_COLOURS["FN"], lw=1.3, label="ground truth, missed (FN)"),
               Patch(color=cmap(0.75), alpha=0.55, label="prediction, matched (colour: quality)"),
               Patch(color=STATUS_COLOURS["FP"], alpha=0.35, label="prediction, false positive"),
               Patch(color=STATUS_COLOURS["group"], alpha=0.35, label="prediction in a group box"),
               Line2D([], [], color="#000000", lw=0.9, marker="^", label="trajectory (start ▲)")]
    fig.legend(handles=handles, loc="upper center", ncol=3, frameon=False, fontsize=6, bbox_to_anchor=(0.5, 0.06))
    sm = cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=axes[0].tolist(), shrink=0.6, label="pair quality (OMQ's pairwise)")
    fig.suptitle(f"{env}: what was mapped (top-down, x-y footprints)", fontsize=9)
    return fig


def scatter_predictivity(units: list[str], sim: Sequence[float], real: Sequence[float], result: dict,
                         sim_name: str, real_name: str, score: str):
    """Sim (x) against real (y) performance per paired unit, with the line y = x and the statistics in the title.

    Args:
        result: :func:`benchbot.batch.stats.predictivity`'s output.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(3.8, 3.6))
    ax.scatter(sim, real, s=18, color=PALETTE[0], zorder=3)
    for name, x, y in zip(units, sim, real):
        ax.annotate(name, (x, y), xytext=(3, 3), textcoords="offset points", fontsize=6)
    lo, hi = _limits(list(sim) + list(real))
    ax.plot([lo, hi], [lo, hi], color="#999999", lw=0.8, ls="--", label="y = x")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{score} in {sim_name}")
    ax.set_ylabel(f"{score} in {real_name}")
    s, p, m = result["spearman"], result["pearson"], result["mmrv"]
    ax.set_title(f"n = {result['n']} paired units\nSpearman ρ = {fmt(s['value'])}, Pearson r = {fmt(p['value'])}, "
                 f"MMRV = {fmt(m['value'])}", fontsize=8)
    ax.grid(color="#eeeeee", lw=0.5)
    ax.legend(loc="lower right", frameon=False)
    return fig


def fmt(x, digits: int = 4) -> str:
    """A number to ``digits`` significant digits (``"–"`` for None): how every number is printed."""
    if x is None:
        return "–"
    if isinstance(x, (int, np.integer)) and not isinstance(x, bool):
        return str(int(x))
    x = float(x)
    if not np.isfinite(x):
        return "–"
    if x == 0:
        return "0"
    text = f"{x:.{digits}g}"
    if "e" in text:
        mantissa, exp = text.split("e")
        return f"{mantissa}×10{str(int(exp)).translate(SUPERSCRIPT)}"
    return text


SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
"""Exponents as superscripts: 1.489×10⁻¹⁰."""


def interval_text(estimate: dict) -> str:
    """``[low, high]`` of an estimate (``stats.Estimate.to_json()``), in :func:`fmt`'s digits, or the reason it has
    none."""
    if estimate.get("low") is not None and estimate.get("high") is not None:
        return f"[{fmt(estimate['low'])}, {fmt(estimate['high'])}]"
    return estimate.get("reason") or "–"


def comparison_text(comparison: dict) -> str:
    """A paired comparison in words (what ``benchbot report`` and a sweep print after naming the two sides):
    ``mean difference X [low, high], Cohen's d_z, the paired t-test and Wilcoxon p with their Holm adjustments,
    rank-biserial r`` — or the mean difference and why there is no test. ``comparison`` has the keys of
    ``stats.paired_test`` plus ``ttest_p_holm`` and ``wilcoxon_p_holm``."""
    c, d = comparison, comparison["difference"]
    text = f"mean difference {fmt(d['value'])}"
    if c["reason"]:
        return f"{text}; {c['reason']}"
    return (f"{text} {interval_text(d)}, Cohen's d_z = {fmt(c['cohens_dz'])}; paired t-test p = {fmt(c['ttest_p'])} "
            f"(Holm {fmt(c['ttest_p_holm'])}), Wilcoxon p = {fmt(c['wilcoxon_p'])} (Holm {fmt(c['wilcoxon_p_holm'])}), "
            f"rank-biserial r = {fmt(c['rank_biserial'])}")
