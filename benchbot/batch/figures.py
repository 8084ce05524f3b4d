r"""The figures of ``benchbot report`` (matplotlib, Agg): each one states its n, draws every episode as a dot next to
the mean, draws an interval only where one was computed, and scales its axis to the data (docs/report.md).

**Print size.** Every figure is made at the width it is printed at in a two-column paper — one column,
:data:`COLUMN_IN`, or both, :data:`PAGE_IN` (IEEEtran's ``\columnwidth`` and ``\textwidth``, within IEEE's 3.5 in
and 7.16 in) — with no text smaller than :data:`MIN_FONT_PT`, and saved at exactly that size (no cropping), so
``\includegraphics`` without a width prints it 1:1 (``tests/test_paper_latex.py`` compiles them and measures).

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

TEX_PT_PER_IN = 72.27
"""TeX points per inch (a PDF's points, "big points", are 72 per inch)."""

COLUMN_IN = 252 / TEX_PT_PER_IN
r"""A one-column figure's width: IEEEtran's ``\columnwidth``, 252 pt = 3.487 in (IEEE's guide says 3.5 in; a figure
made at 3.5 in would stick out of IEEEtran's column by 0.9 pt, and scaling it down would shrink its text)."""

PAGE_IN = 516 / TEX_PT_PER_IN
r"""A two-column (``figure*``) figure's width: IEEEtran's ``\textwidth``, 516 pt = 7.14 in (IEEE's guide: 7.16 in)."""

MIN_FONT_PT = 7.0
"""No text of a figure is smaller than this, at the size it is printed (IEEE asks for 8–10 pt, at least 7)."""

STYLE = {"font.size": 8, "axes.titlesize": 8, "axes.labelsize": 8, "xtick.labelsize": 7, "ytick.labelsize": 7,
         "legend.fontsize": 7, "figure.titlesize": 8, "axes.spines.top": False, "axes.spines.right": False,
         "svg.fonttype": "none", "pdf.fonttype": 42, "svg.hashsalt": "benchbot",
         "figure.constrained_layout.h_pad": 0.02, "figure.constrained_layout.w_pad": 0.02,
         "legend.handlelength": 1.5, "legend.columnspacing": 1.0}
"""matplotlib settings of every figure (text stays text in SVG and PDF, so it can be edited and searched; nothing
below :data:`MIN_FONT_PT`)."""

STATUS_COLOURS = {"TP": "#222222", "FN": "#D55E00", "FP": "#E69F00", "group": "#999999"}
"""Top-down maps, by the ``status`` of an evaluation's per-object ``matches`` (docs/evaluation.md): ground truth found
(TP, dark outline), missed ground truth (FN), false positive (FP), inside a group box (neither); matched predictions
are filled by their quality (viridis) instead."""


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
    """``{"png": ..., "svg": ..., "pdf": ...}``: ``fig`` in every format of :data:`FORMATS`, then closed; saved at
    its size (no cropping: the PDF is as wide as the figure was made, :data:`COLUMN_IN` or :data:`PAGE_IN`)."""
    plt = pyplot()
    out = {}
    for fmt in FORMATS:
        buffer = io.BytesIO()
        metadata = {"Date": None} if fmt in ("svg", "pdf") else {}
        if fmt == "pdf":
            metadata["CreationDate"] = None
            metadata.pop("Date")
        fig.savefig(buffer, format=fmt, dpi=PNG_DPI if fmt == "png" else None, metadata=metadata)
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


SHORT_LABEL_CHARS = 14
"""Run labels longer than this are drawn as letters (A, B, ...) on axes, the legend saying which is which."""


def short_labels(names: list[str]) -> list[str]:
    """What a figure's axes call the runs: their names when every one is at most :data:`SHORT_LABEL_CHARS`
    characters, else A, B, C, ... (the legend, :func:`_key`, pairs each letter with its name)."""
    if all(len(n) <= SHORT_LABEL_CHARS for n in names):
        return list(names)
    return [_letters(k) for k in range(len(names))]


def _letters(k: int) -> str:
    out = ""
    k += 1
    while k:
        k, r = divmod(k - 1, 26)
        out = chr(65 + r) + out
    return out


def _wrap(text: str, width: int = 28) -> str:
    """``text`` broken at spaces into lines of at most ``width`` characters (a longer word stays whole)."""
    lines: list[str] = []
    for word in str(text).split():
        if lines and len(lines[-1]) + 1 + len(word) <= width:
            lines[-1] += " " + word
        else:
            lines.append(word)
    return "\n".join(lines)


def chars_per_line(width_in: float, size_pt: float = 8.0) -> int:
    """How many characters of ``size_pt`` text fit in ``width_in`` inches: DejaVu Sans's characters are up to about
    0.63 em wide on average over the report's labels, so at 8 pt about 49 fit in :data:`COLUMN_IN`."""
    return max(12, int(width_in * 72 / (0.63 * size_pt)))


def width_for(columns_needed: float) -> float:
    """:data:`COLUMN_IN` when a figure's content needs at most one column (``columns_needed`` ≤ 1, in units of
    :data:`COLUMN_IN`), else :data:`PAGE_IN`."""
    return COLUMN_IN if columns_needed <= 1.0 else PAGE_IN


def _key(fig, min_n: int, runs: list[tuple[str, str, str]], *, markers: bool = True, level: str = "") -> None:
    """A legend under the figure's axes, as wide as the figure: one colour per run (its short label and, when
    shortened, its name), then what the markers mean."""
    from matplotlib.lines import Line2D

    width = fig.get_figwidth()
    ncol = 2 if width <= COLUMN_IN + 1e-6 else 4
    wrap = chars_per_line(width / ncol - 0.3, 7)
    handles = [Line2D([], [], marker="s", color=c, ls="none", ms=6,
                      label=_wrap(label if label == name else f"{label}: {name}", wrap)) for label, c, name in runs]
    if markers:
        handles += [Line2D([], [], marker="o", color="#444444", ls="-", lw=1, ms=4, label="mean, 95 % CI"),
                    Line2D([], [], marker="D", color="#444444", ls="none", ms=4,
                           label=_wrap(f"mean, no interval (n < {min_n})", wrap)),
                    Line2D([], [], marker="o", mfc="none", mec="#444444", ls="none", ms=4,
                           label=f"one {level or 'episode'}")]
    fig.legend(handles=handles, loc="outside lower center", frameon=False, ncol=ncol)


def _series_key(series: list[dict]) -> list[tuple[str, str, str]]:
    return [(run.get("short", run["label"]), PALETTE[k % len(PALETTE)], run["label"]) for k, run in enumerate(series)]


GROUPS_PER_ROW = 10
"""A per-group figure with more groups than this draws them in several rows of panels (each group gets at least
about 0.6 in of a two-column figure's width)."""

GROUPS_PER_COLUMN = 4
"""A per-group figure with at most this many groups (of at most two runs) fits one column."""


def per_group(title: str, score: str, groups: list[str], series: list[dict], min_n: int, xlabel: str = "",
              level: str = "episode"):
    """Dots of every value and the mean (with its interval where there is one) of ``score`` per group
    (environment, robot, lighting...), one colour per run; more than :data:`GROUPS_PER_ROW` groups go in several
    rows, on one shared scale. One column wide (:data:`COLUMN_IN`) for up to :data:`GROUPS_PER_COLUMN` groups of at
    most two runs, else two (:data:`PAGE_IN`).

    Args:
        title: the figure's title; the n of every group and run is added under each group's name.
        groups: the groups in order.
        series: one per run, ``{"label", "short" (optional: its axis label), "values": {group: [score per
            episode]}, "estimates": {group: Estimate dict}}``.
        min_n: the smallest n that gets an interval (for the legend's note).
        level: what a dot is (``episode``).
    """
    plt = pyplot()
    rows = max(1, -(-len(groups) // GROUPS_PER_ROW))
    per_row = -(-len(groups) // rows) if groups else 1
    width_in = width_for(per_row / GROUPS_PER_COLUMN * max(1.0, len(series) / 2))
    fig, axes = plt.subplots(rows, 1, figsize=(width_in, 1.1 + 2.0 * rows + 0.16 * (len(series) + 3)),
                             squeeze=False, layout="constrained")
    width = 0.7 / max(1, len(series))
    everything = []
    for k, run in enumerate(series):
        for group in groups:
            everything += run["values"].get(group, [])
            est = run["estimates"].get(group) or {}
            everything += [v for v in (est.get("low"), est.get("high")) if v is not None]
    slot = width_in / max(per_row, 1)
    tilt = any(len(g) * 0.58 * 7 / 72 > slot * 0.9 for g in groups)
    for r, ax in enumerate(axes[:, 0]):
        chunk = groups[r * per_row:(r + 1) * per_row]
        for k, run in enumerate(series):
            colour = PALETTE[k % len(PALETTE)]
            for g, group in enumerate(chunk):
                x = g + (k - (len(series) - 1) / 2) * width
                values = run["values"].get(group, [])
                ax.scatter(x + _jitter(len(values), width * 0.6), values, s=9, facecolors="none", edgecolors=colour,
                           linewidths=0.7, alpha=0.8, zorder=2)
                est = run["estimates"].get(group)
                if est:
                    _errorbar(ax, x, est, colour)
        ns = [", ".join(str(len(run["values"].get(g, []))) for run in series) for g in chunk]
        ax.set_xticks(range(len(chunk)), [f"{g}\nn = {n}" for g, n in zip(chunk, ns)],
                      rotation=35 if tilt else 0, ha="right" if tilt else "center", rotation_mode="anchor")
        ax.set_xlim(-0.6, per_row - 0.4)
        ax.set_ylim(*_limits(everything))
        ax.set_ylabel(score)
        ax.grid(axis="y", color="#dddddd", lw=0.5)
    if xlabel:
        axes[-1, 0].set_xlabel(xlabel)
    axes[0, 0].set_title(_wrap(title, chars_per_line(width_in - 0.9)))
    _key(fig, min_n, _series_key(series), level=level)
    return fig


def summary(scores: list[str], series: list[dict], min_n: int, level: str = "environment"):
    """One panel per score: each run's values as dots (one per environment), their mean and its interval. One
    column wide for one or two scores, else two columns (three panels a row).

    Args:
        scores: the score names, one panel each.
        series: one per run, ``{"label", "short" (optional), "values": {score: [one per environment]},
            "estimates": {score: Estimate dict}}``.
        level: what a dot is (``environment``), for the titles and the legend.
    """
    plt = pyplot()
    width_in = width_for(len(scores) / 2 * max(1.0, len(series) / 4))
    cols = min(len(scores), 2 if width_in == COLUMN_IN else 3)
    rows = -(-len(scores) // cols)
    names = [run.get("short", run["label"]) for run in series]
    slot = width_in / cols / max(1, len(series))
    tilt = max(len(n) * 0.58 * 7 / 72 for n in names) > slot * 0.9
    label_in = max(len(n) for n in names) * 0.58 * 7 / 72 * 0.6 if tilt else 0.15
    fig, axes = plt.subplots(rows, cols, figsize=(width_in, 0.9 + (1.7 + label_in) * rows + 0.16 * (len(series) + 3)),
                             squeeze=False, layout="constrained")
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
        ax.set_xticks(range(len(series)), names, rotation=35 if tilt else 0, ha="right" if tilt else "center",
                      rotation_mode="anchor")
        ax.set_xlim(-0.6, len(series) - 0.4)
        ax.set_ylim(*_limits(everything))
        ns = ", ".join(str(len(r["values"].get(score, []))) for r in series)
        plural = "s" if any(len(r["values"].get(score, [])) != 1 for r in series) else ""
        ax.set_title(_wrap(f"{score}, n = {ns} {level}{plural}", chars_per_line(width_in / cols - 0.45)))
        ax.grid(axis="y", color="#dddddd", lw=0.5)
    _key(fig, min_n, _series_key(series), level=level)
    return fig


def paired_differences(comparison: dict, score: str, min_pairs: int):
    """A comparison with the environment as the unit: per environment, its episode pairs' differences (B − A,
    small dots) and their mean (a large dot, what the test is over); the mean over environments with its interval,
    and the zero line. One column wide up to 8 environments, else two.

    Args:
        comparison: ``{"a", "b", "keys", "envs", "differences" (per episode pair), "environments",
            "environment_differences", "difference": Estimate dict, "n", "ttest_p_holm", "reason", "pairing",
            "episodes": {...}}`` (:func:`benchbot.batch.run_stats.compare`).
    """
    plt = pyplot()
    envs = comparison.get("environments") or list(dict.fromkeys(comparison.get("envs", [])))
    means = comparison.get("environment_differences") or []
    width_in = width_for(len(envs) / 8)
    fig, ax = plt.subplots(figsize=(width_in, 3.1), layout="constrained")
    ax.axhline(0, color="#555555", lw=0.8)
    position = {e: i for i, e in enumerate(envs)}
    d = comparison["differences"]
    xs = [position.get(e, 0) for e in comparison.get("envs", [])]
    for e in envs:  # spread each environment's pairs
        idx = [i for i, x in enumerate(comparison.get("envs", [])) if x == e]
        for j, off in zip(idx, _jitter(len(idx), 0.4)):
            xs[j] = position.get(e, 0) + off
    ax.scatter(xs, d, s=8, color="#999999", zorder=2, label="one episode pair")
    ax.scatter(range(len(envs)), means, s=30, color=PALETTE[1], zorder=3, label="environment mean")
    est = comparison["difference"]
    if est.get("value") is not None:
        ax.axhline(est["value"], color=PALETTE[0], lw=1.2, label="mean over environments")
        if est.get("low") is not None:
            ax.axhspan(est["low"], est["high"], color=PALETTE[0], alpha=0.15, lw=0, label="95 % CI (environments)")
    slot = width_in / max(1, len(envs))
    tilt = any(len(e) * 0.58 * 7 / 72 > slot * 0.9 for e in envs)
    ax.set_xticks(range(len(envs)), envs, rotation=35 if tilt else 0, ha="right" if tilt else "center",
                  rotation_mode="anchor")
    ax.set_xlim(-0.6, len(envs) - 0.4)
    ax.set_ylim(*_limits(list(d) + list(means) + [0.0] + [v for v in (est.get("low"), est.get("high")) if v is not None]))
    ax.set_ylabel(f"{score}: B − A")
    verdict = comparison["reason"] or f"paired t-test over environments p = {fmt(comparison['ttest_p_holm'])} (Holm)"
    chars = chars_per_line(width_in - 0.9)  # the title is centred on the axes, which the y label moves right
    ax.set_title(_wrap(f"B = {comparison['b']}, A = {comparison['a']}: n = {len(envs)} environments, "
                       f"{len(d)} episode pairs", chars) + "\n" + _wrap(verdict, chars))
    fig.legend(loc="outside lower center", frameon=False, ncol=2 if width_in == COLUMN_IN else 4)
    ax.grid(axis="y", color="#dddddd", lw=0.5)
    return fig


def per_class(label: str, rows: list[dict], episodes: int, counts: list[tuple[str, str]],
              scores: list[str]):
    """A run's per-class counts (horizontal bars: those where higher is better to the right of 0, the others to
    the left) and up to four of its per-class scores (markers, on their axis); two columns wide.

    Args:
        rows: ``{"class", <count>: int, <score>: float or None}`` per class.
        episodes: how many episodes the counts are pooled over (stated in the title).
        counts: ``[(count name, "higher" or "lower")]`` in the method's order.
        scores: the per-class scores to draw (their values in [0, 1] or any range).
    """
    plt = pyplot()
    rows = sorted(rows, key=lambda r: sum(r.get(c, 0) for c, _ in counts))
    names = [r["class"] for r in rows]
    y = np.arange(len(rows))
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(PAGE_IN, 1.5 + 0.15 * len(rows)), sharey=True,
                                 gridspec_kw={"width_ratios": [3, 2]}, layout="constrained")
    right = np.zeros(len(rows))
    left = np.zeros(len(rows))
    colours = {"higher": ["#009E73", "#56B4E9", "#000000"], "lower": ["#D55E00", "#E69F00", "#CC79A7"]}
    used = {"higher": 0, "lower": 0}
    for name, direction in counts:
        v = np.array([r.get(name, 0) for r in rows], float)
        colour = colours[direction][used[direction] % 3]
        used[direction] += 1
        if direction == "higher":
            ax.barh(y, v, left=right, color=colour, label=name)
            right += v
        else:
            ax.barh(y, -v, left=-left, color=colour, label=f"{name} (left of 0)")
            left += v
    ax.axvline(0, color="#555555", lw=0.6)
    ax.set_yticks(y, names)
    ax.set_ylim(-0.7, len(rows) - 0.3)
    ax.set_xlabel("count (lower is better: left of 0)")
    markers = "osD^"
    values = []
    for k, key in enumerate(scores[:4]):
        vals = [r.get(key) if r.get(key) is not None else np.nan for r in rows]
        values += [v for v in vals if np.isfinite(v)]
        bx.plot(vals, y, marker=markers[k], ls="none", color=PALETTE[k % len(PALETTE)], ms=4, label=key)
    lo, hi = _limits(values)
    bx.set_xlim(min(lo, 0.0), max(hi, 1.0) if values and min(values) >= 0 and max(values) <= 1 else hi)
    bx.set_xlabel("per-class score")
    bx.grid(axis="x", color="#dddddd", lw=0.5)
    handles, labels = [], []
    for a in (ax, bx):
        h, lab = a.get_legend_handles_labels()
        handles += h
        labels += lab
    fig.legend(handles, labels, loc="outside lower center", frameon=False, ncol=min(len(labels), 4))
    fig.suptitle(_wrap(f"{label}: per class, pooled over n = {episodes} episodes", chars_per_line(PAGE_IN)))
    return fig


MAP_LABEL_PT = 7.0
"""The size of the class names on a top-down map (:data:`MIN_FONT_PT`): names that would overlap another are left
out (:func:`_drop_overlapping`), so a small map shows fewer of them rather than smaller ones."""


def topdown(env: str, panels: list[dict]):
    """Top-down maps of one environment, one panel per run: ground-truth boxes (dark: found, red: missed),
    predicted boxes (filled by the pair's quality when matched, orange when false positives, grey inside a group
    box), a line from each match to its ground truth, the path the robot drove (solid; start: triangle) and the
    planned one (faint, dashed). Class names that would overlap another are left out. One column wide for one
    panel; two columns (two panels a row) for more.

    Args:
        panels: ``{"title", "matches": evaluation ``matches`` dict, "path": (k, 2) metres (x, y; map frame) the
            robot drove or None, "plan": (k, 2) the planned path or None, "path_source": where ``path`` came from}``
            per run.
    """
    plt = pyplot()
    import matplotlib
    from matplotlib import cm, colors
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle

    cmap, norm = matplotlib.colormaps["viridis"], colors.Normalize(0, 1)
    n = len(panels)
    extent = []
    for panel in panels:
        for item in panel["matches"]["ground_truth"] + panel["matches"]["proposals"]:
            (cx, cy), (ex, ey) = item["centroid"][:2], item["extent"][:2]
            extent += [(cx - ex / 2, cy - ey / 2), (cx + ex / 2, cy + ey / 2)]
        for key in ("path", "plan"):
            if panel.get(key) is not None and len(panel[key]):
                extent += [tuple(p) for p in np.asarray(panel[key], float)]
    span = np.ptp(np.asarray(extent, float), axis=0) if extent else np.ones(2)
    aspect = float(np.clip(span[1] / max(span[0], 1e-6), 0.5, 1.4))
    width_in = COLUMN_IN if n == 1 else PAGE_IN
    cols = 1 if n == 1 else 2
    rows = -(-n // cols)
    panel_in = width_in / cols - (0.75 if n == 1 else 0.6)
    fig, axes = plt.subplots(rows, cols, figsize=(width_in, rows * (panel_in * aspect + 0.8) + 0.75),
                             squeeze=False, layout="constrained")
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    labels = []
    for ax, panel in zip(axes.flat, panels):
        m = panel["matches"]
        points = []
        for g in m["ground_truth"]:
            (cx, cy), (ex, ey) = g["centroid"][:2], g["extent"][:2]
            colour = STATUS_COLOURS[g["status"]]
            ax.add_patch(Rectangle((cx - ex / 2, cy - ey / 2), ex, ey, fill=False, ec=colour, lw=1.0,
                                   ls="--" if g.get("isgroup") else "-", zorder=2))
            labels.append(ax.text(cx, cy + ey / 2, g["class"], fontsize=MAP_LABEL_PT, color="#333333", ha="center",
                                  va="bottom", zorder=5))
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
        plan = panel.get("plan")
        if plan is not None and len(plan):
            plan = np.asarray(plan, float)
            ax.plot(plan[:, 0], plan[:, 1], color="#000000", lw=0.8, ls="--", alpha=0.25, zorder=3)
            points += [tuple(p) for p in plan]
        path = panel.get("path")
        if path is not None and len(path):
            path = np.asarray(path, float)
            ax.plot(path[:, 0], path[:, 1], color="#000000", lw=1.0, alpha=0.85, zorder=4)
            ax.plot(path[:1, 0], path[:1, 1], marker="^", color="#000000", ms=5, zorder=4)
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
        ax.set_title("\n".join(_wrap(line, chars_per_line(panel_in + 0.4, 7)) for line in panel["title"].split("\n")),
                     fontsize=7)
    handles = [Line2D([], [], color=STATUS_COLOURS["TP"], lw=1.3, label="ground truth, found (TP)"),
               Line2D([], [], color=STATUS_COLOURS["FN"], lw=1.3, label="ground truth, missed (FN)"),
               Patch(color=cmap(0.75), alpha=0.55, label="prediction, matched"),
               Patch(color=STATUS_COLOURS["FP"], alpha=0.35, label="prediction, false positive"),
               Patch(color=STATUS_COLOURS["group"], alpha=0.35, label="prediction in a group box"),
               Line2D([], [], color="#000000", lw=1.0, marker="^", label="driven path (start ▲)"),
               Line2D([], [], color="#000000", lw=0.8, ls="--", alpha=0.3, label="planned path")]
    fig.legend(handles=handles, loc="outside lower center", ncol=2 if n == 1 else 4, frameon=False)
    sm = cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=axes.flat[:n] if n > 1 else axes[0, 0], shrink=0.7, label="matched pair's quality")
    fig.suptitle(_wrap(f"{env}: what was mapped (top-down, x-y footprints)", chars_per_line(width_in)))
    _drop_overlapping(fig, labels)
    return fig


def _drop_overlapping(fig, texts: list) -> None:
    """Hide each of ``texts`` whose box overlaps one already kept (in order), so labels never print over each
    other."""
    renderer = fig.canvas.get_renderer()
    fig.draw_without_rendering()
    kept = []
    for t in texts:
        box = t.get_window_extent(renderer)
        if any(box.overlaps(k) for k in kept):
            t.set_visible(False)
        else:
            kept.append(box)


def visible_texts(fig) -> list:
    """The texts a reader sees in ``fig`` once drawn: per visible axes its titles, axis labels, the tick labels
    within its view, its free texts and legend; the figure's suptitle, texts and legends (empty texts left out)."""
    fig.draw_without_rendering()
    out = []

    def legend_texts(legend):
        return list(legend.get_texts()) + ([legend.get_title()] if legend is not None else []) if legend else []

    for ax in fig.axes:
        if not ax.get_visible():
            continue
        out += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label] + list(ax.texts)
        for axis, (lo, hi) in ((ax.xaxis, sorted(ax.get_xlim())), (ax.yaxis, sorted(ax.get_ylim()))):
            for tick in axis.get_major_ticks():
                if lo - 1e-9 <= tick.get_loc() <= hi + 1e-9:
                    out += [tick.label1, tick.label2]
        out += legend_texts(ax.get_legend())
    out += list(fig.texts) + ([fig._suptitle] if fig._suptitle is not None else [])
    for legend in fig.legends:
        out += legend_texts(legend)
    seen: set[int] = set()
    return [t for t in out if t is not None and t.get_visible() and t.get_text().strip()
            and not (id(t) in seen or seen.add(id(t)))]


def text_overlaps(fig, ignore: tuple[str, ...] = ()) -> list[tuple[str, str]]:
    """Pairs of the texts a reader sees in ``fig`` (:func:`visible_texts`) whose boxes overlap as drawn (each box
    shrunk by a few per cent, so that touching is not overlapping): labels printed over each other. ``ignore``:
    texts not to check. ``[]`` for a figure that reads cleanly."""
    renderer = fig.canvas.get_renderer()
    boxes = [(t.get_text(), t.get_window_extent(renderer).shrunk(0.96, 0.85)) for t in visible_texts(fig)
             if t.get_text() not in ignore]
    return [(a, b) for i, (a, ba) in enumerate(boxes) for b, bb in boxes[i + 1:] if ba.overlaps(bb)]


def print_problems(fig) -> list[str]:
    """What keeps ``fig`` from printing 1:1 in a two-column paper, in words: a width other than :data:`COLUMN_IN`
    or :data:`PAGE_IN`, a text a reader sees (:func:`visible_texts`) smaller than :data:`MIN_FONT_PT`, a text
    sticking out of the figure. ``[]`` for a figure that prints as made."""
    out = []
    width = fig.get_figwidth()
    if min(abs(width - COLUMN_IN), abs(width - PAGE_IN)) > 1e-6:
        out.append(f"width {width:.3f} in is neither {COLUMN_IN:.3f} (one column) nor {PAGE_IN:.3f} (two)")
    renderer = fig.canvas.get_renderer()
    bounds = fig.bbox
    for t in visible_texts(fig):
        if t.get_fontsize() < MIN_FONT_PT - 1e-9:
            out.append(f"{t.get_text()!r} is {t.get_fontsize():g} pt (< {MIN_FONT_PT:g})")
        box = t.get_window_extent(renderer)
        if box.x0 < bounds.x0 - 1 or box.x1 > bounds.x1 + 1 or box.y0 < bounds.y0 - 1 or box.y1 > bounds.y1 + 1:
            out.append(f"{t.get_text()!r} sticks out of the figure")
    return out


def scatter_predictivity(units: list[str], sim: Sequence[float], real: Sequence[float], result: dict,
                         sim_name: str, real_name: str, score: str):
    """Sim (x) against real (y) performance per paired unit, with the line y = x and the statistics in the title;
    one column wide.

    Args:
        result: :func:`benchbot.batch.stats.predictivity`'s output.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(COLUMN_IN, 3.4), layout="constrained")
    ax.scatter(sim, real, s=18, color=PALETTE[0], zorder=3)
    for name, x, y in zip(units, sim, real):
        ax.annotate(name, (x, y), xytext=(3, 3), textcoords="offset points", fontsize=MIN_FONT_PT)
    lo, hi = _limits(list(sim) + list(real))
    ax.plot([lo, hi], [lo, hi], color="#999999", lw=0.8, ls="--", label="y = x")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{score} in {sim_name}")
    ax.set_ylabel(f"{score} in {real_name}")
    s, p, m = result["spearman"], result["pearson"], result["mmrv"]
    ax.set_title(_wrap(f"n = {result['n']} paired units: Spearman ρ = {fmt(s['value'])}, Pearson r = "
                       f"{fmt(p['value'])}, MMRV = {fmt(m['value'])}", chars_per_line(COLUMN_IN)))
    ax.grid(color="#eeeeee", lw=0.5)
    ax.legend(loc="lower right", frameon=False)
    return fig


def score_distribution(score: str, series: list[dict]):
    """Score distributions (Agarwal et al. 2021's performance profiles of run scores): per run, the fraction of
    episodes scoring above τ (averaged over environments) against τ, with its 95 % band (stratified bootstrap)
    where there is one; one column wide.

    Args:
        series: one per run, ``{"label", "short" (optional), "distribution":``
            :func:`benchbot.batch.stats.score_distribution` ``'s dict, "n": environments}``.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(COLUMN_IN, 2.9 + 0.16 * len(series)), layout="constrained")
    for k, run in enumerate(series):
        d, colour = run["distribution"], PALETTE[k % len(PALETTE)]
        short = run.get("short", run["label"])
        ax.plot(d["taus"], d["fraction"], color=colour, lw=1.2, drawstyle="steps-post",
                label=_wrap(short if short == run["label"] else f"{short}: {run['label']}", 30))
        if d.get("low") is not None:
            ax.fill_between(d["taus"], d["low"], d["high"], color=colour, alpha=0.18, lw=0, step="post")
    ax.set_xlabel(f"τ ({score})")
    ax.set_ylabel(f"fraction of episodes with {score} > τ")
    ax.set_ylim(-0.02, 1.02)
    ns = ", ".join(str(run.get("n", "?")) for run in series)
    ax.set_title(_wrap(f"Score distribution, mean over n = {ns} environments; bands: 95 % stratified bootstrap",
                       chars_per_line(COLUMN_IN - 0.9)))
    ax.grid(color="#eeeeee", lw=0.5)
    fig.legend(loc="outside lower center", frameon=False, ncol=2)
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


def _test_text(c: dict) -> str:
    d = c["difference"]
    text = f"mean difference {fmt(d['value'])}"
    if c["reason"]:
        return f"{text}; {c['reason']}"
    return (f"{text} {interval_text(d)}, Cohen's d_z = {fmt(c['cohens_dz'])}; paired t-test p = {fmt(c['ttest_p'])} "
            f"(Holm {fmt(c.get('ttest_p_holm'))}), Wilcoxon p = {fmt(c['wilcoxon_p'])} "
            f"(Holm {fmt(c.get('wilcoxon_p_holm'))}), rank-biserial r = {fmt(c['rank_biserial'])}")


def comparison_text(comparison: dict) -> str:
    """A paired comparison in words (what ``benchbot report`` and a sweep print after naming the two sides), at the
    environment level and then, when it has one (``episodes``), at the episode level: ``over N environments: mean
    difference X [low, high], Cohen's d_z, the paired t-test and Wilcoxon p with their Holm adjustments,
    rank-biserial r`` — or the mean difference and why there is no test. ``comparison`` has the keys of
    ``stats.paired_test`` (with ``level``) plus ``ttest_p_holm`` and ``wilcoxon_p_holm``, and optionally
    ``episodes`` with the same keys."""
    c = comparison
    level = c.get("level_of_n", c.get("level", "pairs"))
    unit = {"environment pairs": "environment", "pairs": "episode pair"}.get(level, level)
    text = f"over {c['n']} {unit}{'' if c['n'] == 1 else 's'}: {_test_text(c)}"
    ep = c.get("episodes")
    if ep:
        text += (f" | over {ep['n']} episode pair{'' if ep['n'] == 1 else 's'} (these environments only): "
                 f"{_test_text(ep)}")
    return text
