"""Top-down figure of a :class:`~benchbot_worlds.homes.floorplan.FloorPlan`: rooms labelled by kind, walls, doorways,
windows, ground-truth boxes and the robot paths (matplotlib, imported lazily: the ``vis`` extra)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchbot.core.errors import UsageError

#: Floor tint per room kind in the figure.
ROOM_COLOURS = {"kitchen": "#f6e7c8", "bathroom": "#d5ecf2", "bedroom": "#e8dcf0", "living_room": "#e3efd5",
                "dining_room": "#f3ddd0", "office": "#f0e0d6", "hall": "#eeeeee"}


def save_plan_figure(plan, objects: list[dict], paths: list, out_path, *, title: str | None = None,
                     dpi: int = 110) -> Path:
    """Draw ``plan`` with the ground-truth ``objects`` (dicts with class, centroid, extent) and ``paths`` ((M, 2) xy;
    a dot marks each start) to ``out_path`` (.png, .svg or .pdf: matplotlib picks the format from the suffix);
    returns the path.

    Raises:
        UsageError: matplotlib is not installed (install the ``vis`` extra).
    """
    try:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise UsageError("drawing a floor plan needs matplotlib, which is not installed",
                         "install the vis extra: pip install 'benchbot[vis]'") from e
    size = plan.outer_hi - plan.outer_lo + 2 * plan.wall_thickness
    scale = 9.0 / max(size)
    fig, ax = plt.subplots(figsize=(max(4.0, size[0] * scale + 1.5), max(4.0, size[1] * scale + 0.8)))
    draw_plan(ax, plan, objects, paths, title=title)
    out = Path(out_path)
    fig.savefig(out, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return out


def draw_plan(ax, plan, objects: list[dict], paths: list, *, title: str | None = None, small: bool = False) -> None:
    """Draw ``plan`` with ``objects`` and ``paths`` (as :func:`save_plan_figure`) on the matplotlib axes ``ax``;
    ``small``: for a grid of many plans (smaller labels, no object names, no legend)."""
    from matplotlib.patches import Rectangle

    boxes = [(np.asarray(o["centroid"], float)[:2] - np.asarray(o["extent"], float)[:2] / 2,
              np.asarray(o["centroid"], float)[:2] + np.asarray(o["extent"], float)[:2] / 2) for o in objects]
    pts = np.concatenate([np.asarray(p, float).reshape(-1, 2) for p in paths]) if paths else np.zeros((0, 2))
    for r in plan.rooms:
        ax.add_patch(Rectangle(r.lo, *(r.hi - r.lo), facecolor=ROOM_COLOURS.get(r.kind, "#eeeeee"),
                               edgecolor="none", zorder=0))
        c = _label_spot(r, boxes, pts)
        ax.text(c[0], c[1], f"{r.index}: {r.kind.replace('_', ' ')}", ha="center", va="center", fontsize=5 if small else 9,
                color="#444444", zorder=7, fontweight="bold",
                bbox={"facecolor": "white", "alpha": 0.6, "edgecolor": "none", "pad": 1.0})
    for w in plan.walls:
        if w.lo[2] > 0.0:  # lintels and window heads: drawn as the opening
            continue
        low = w.hi[2] < plan.wall_height - 1e-6  # the parapet under a window
        ax.add_patch(Rectangle(w.lo[:2], *(w.hi[:2] - w.lo[:2]), facecolor="#7fb2d9" if low else "#333333",
                               edgecolor="none", zorder=3))
    for op in plan.openings:
        if op.kind == "door":  # doorways with a door: red; open passages: pale orange
            ax.add_patch(Rectangle(op.lo[:2], *(op.hi[:2] - op.lo[:2]), facecolor="#c0392b" if op.leaf else "#f0b27a",
                                   edgecolor="none", alpha=0.8, zorder=3))
    for o in objects:
        c = np.asarray(o["centroid"], dtype=float)
        e = np.asarray(o["extent"], dtype=float)
        ax.add_patch(Rectangle(c[:2] - e[:2] / 2, e[0], e[1], facecolor="none", edgecolor="#2c7a3f", lw=0.7,
                               zorder=4))
        if not small:
            ax.text(c[0], c[1], str(o["class"]), fontsize=4.5, ha="center", va="center", color="#1b4d27", zorder=6)
    for k, p in enumerate(paths):
        p = np.asarray(p, dtype=float)
        label = "robot path" if len(paths) == 1 else f"path {k + 1}"
        ax.plot(p[:, 0], p[:, 1], lw=0.7, alpha=0.7, zorder=4, label=label)
        ax.plot(p[0, 0], p[0, 1], "o", ms=3, color=ax.lines[-1].get_color(), zorder=4)
    for q in plan.lights:
        ax.plot(q[0], q[1], "*", ms=6, color="#e6b800", zorder=5)
    ax.set_aspect("equal")
    ax.set_xlim(plan.outer_lo[0] - 0.5, plan.outer_hi[0] + 0.5)
    ax.set_ylim(plan.outer_lo[1] - 0.5, plan.outer_hi[1] + 0.5)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.tick_params(labelsize=7)
    if paths and not small:
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    n_doors = sum(o.kind == "door" and o.leaf for o in plan.openings)
    n_open = sum(o.kind == "door" and not o.leaf for o in plan.openings)
    n_windows = sum(o.kind == "window" for o in plan.openings)
    summary = (f"{len(plan.rooms)} rooms, {n_doors} doors (red), {n_open} open passages (orange), {n_windows} windows "
               f"(blue), {len(plan.lights)} lamps (stars)")
    ax.set_title(f"{title}\n{summary}" if title else summary, fontsize=5 if small else 9)


def _label_spot(room, boxes, pts) -> np.ndarray:
    """The point of a 9×9 grid over ``room`` farthest from the ground-truth boxes and path points (for its label)."""
    g = np.linspace(0.2, 0.8, 9)
    cand = room.lo + np.stack(np.meshgrid(g, g), -1).reshape(-1, 2) * (room.hi - room.lo)
    d = np.full(len(cand), 3.0)
    for lo, hi in boxes:
        e = np.maximum(np.maximum(lo - cand, cand - hi), 0.0)
        d = np.minimum(d, np.hypot(e[:, 0], e[:, 1]))
    if len(pts):
        d = np.minimum(d, np.min(np.linalg.norm(cand[:, None, :] - pts[None, :, :], axis=2), axis=1))
    centre = (room.lo + room.hi) / 2
    return cand[int(np.argmax(d - 0.05 * np.linalg.norm(cand - centre, axis=1)))]
