"""Tools for solutions: :class:`ObservationVisualiser`, like the original's ``benchbot_api.tools``
(docs/original-benchbot.md, section 5).

matplotlib is imported on first use (``pip install benchbot[vis]``), so ``import benchbot.api`` stays light.
With a display the figure is shown in a window; without one (no ``DISPLAY``/``WAYLAND_DISPLAY`` on Linux, or a
non-interactive backend) nothing is shown and :meth:`ObservationVisualiser.save` writes PNG files.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import Any, Sequence

from benchbot.core.observations import AXIS_LENGTH_M, BUILT_IN  # noqa: F401 - AXIS_LENGTH_M: its home is there


def views(kinds: dict | None = None) -> dict[str, tuple[str, Any]]:
    """``{entry: (observation name, View)}`` of every view the observation ``kinds`` declare (default: the
    built-in ones, :data:`benchbot.core.observations.BUILT_IN`)."""
    return {view.name: (name, view) for name, kind in (BUILT_IN if kinds is None else kinds).items()
            for view in kind.views}


#: The entries the visualiser draws by default: the built-in kinds' views.
SUPPORTED = tuple(views())


def _has_display() -> bool:
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def _pyplot() -> Any:
    try:
        import matplotlib
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("the visualiser needs matplotlib: `pip install benchbot[vis]`") from None
    if not _has_display():
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


class ObservationVisualiser:
    """Draws observations on a grid of 2 rows × ceil(n/2) columns, filled column by column.

    Args:
        vis_list: the entries to draw, from ``image_rgb``, ``image_depth`` (colour map 'hot'), ``laser`` (a scatter
            plot in the robot frame, metres), ``poses`` (3-D axes of each frame, 0.25 m long, map frame),
            ``image_class`` and ``image_instance`` (both from ``image_segment``): the views of the observation
            kinds (:mod:`benchbot.core.observations`).
        show: show a window (default: when there is a display).
        kinds: the observation kinds whose views may be drawn (default the built-in ones; a plugin's sensor is
            drawn with ``kinds=get_registry().observations`` when its kind declares a view).

    Raises:
        ValueError: an unsupported entry.
    """

    def __init__(self, vis_list: Sequence[str] = ("image_rgb", "image_depth", "laser", "poses"),
                 show: bool | None = None, kinds: dict | None = None) -> None:
        self.views = views(kinds)
        unknown = [v for v in vis_list if v not in self.views]
        if unknown:
            raise ValueError(f"cannot visualise {unknown}; supported: {', '.join(self.views)}")
        self.vis_list = list(vis_list)
        self.show = _has_display() if show is None else show
        self.fig: Any = None
        self.axs: list[Any] = []

    def _layout(self) -> None:
        plt = _pyplot()
        n = len(self.vis_list)
        cols = max(1, math.ceil(n / 2))
        self.fig = plt.figure(figsize=(4 * cols, 7))
        self.axs = []
        for i, name in enumerate(self.vis_list):
            row, col = i % 2, i // 2  # column by column
            index = row * cols + col + 1
            projection = self.views[name][1].projection
            self.axs.append(self.fig.add_subplot(2, cols, index, projection=projection))
        if self.show:
            plt.ion()
            plt.show(block=False)

    def visualise(self, observations: dict, step_count: int | None = None) -> None:
        """Draw ``observations`` (the API's structures); the window title is "Agent Observations (step # N)".

        Raises:
            KeyError: an entry of ``vis_list`` is missing from ``observations``.
        """
        if self.fig is None:
            self._layout()
        title = "Agent Observations" + ("" if step_count is None else f" (step # {step_count})")
        self.fig.suptitle(title)
        manager = getattr(self.fig.canvas, "manager", None)
        if manager is not None:
            manager.set_window_title(title)
        for ax, name in zip(self.axs, self.vis_list):
            ax.clear()
            observation, view = self.views[name]
            view.draw(ax, observations[observation])
        self.fig.canvas.draw_idle()
        if self.show:
            self.update()

    def update(self) -> None:
        """Pump GUI events for 0.05 s (a window stays responsive)."""
        if self.fig is not None and self.show:
            _pyplot().pause(0.05)

    def save(self, path: str | Path) -> Path:
        """Write the current figure as PNG to ``path``; returns it.

        Raises:
            RuntimeError: nothing was visualised yet.
        """
        if self.fig is None:
            raise RuntimeError("call visualise(observations) before save()")
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.fig.savefig(path, format="png", dpi=80)
        return path

    def close(self) -> None:
        """Close the figure."""
        if self.fig is not None:
            _pyplot().close(self.fig)
            self.fig = None
