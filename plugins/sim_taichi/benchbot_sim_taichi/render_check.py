"""A check that the simulator renders the same image twice where it runs: with ``BENCHBOT_SIM_CHECK_RENDERS=1``
(:data:`~benchbot_sim_taichi.settings.CHECK_RENDERS`) the backend renders every pose a second time, right after the
first, and compares the two. Where they differ it logs one warning (logger ``benchbot_sim_taichi.render_check``: a
command's stderr, the simulator service's log for episodes it serves) naming the environment, the frame, the outputs
and the image region that differ, and keeps both renders in ``<cache dir>/sim_taichi-render-checks/`` (an ``.npz``
file a difference, at most :data:`MAX_KEPT` a process; the cache directory is hidden from sandboxed solutions). The
episode goes on with the first render, as without the check, so its observations and results are those of an
unchecked run; each frame costs a second render.

Why: on hosts with several GPUs and the simulator service, an episode now and then received one frame whose RGB
image differed from the same frame of the other episodes of its environment in one small region. This check showed
that a render repeated at once could give another image there, which led to the cause: the rasteriser lost a nearer
hit now and then on CUDA (``render.raster._keep``, fixed; docs/service.md, *What is left*). It stays to check a
device, a driver or a change of the kernels.
"""

from __future__ import annotations

import logging
import os
import tempfile
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

#: Renders kept (as ``.npz`` files) per process; later differences are logged only.
MAX_KEPT = 20
#: Folder under BenchBot's cache directory where the differing renders are kept.
FOLDER = "sim_taichi-render-checks"


def differences(first: dict, second: dict) -> list[str]:
    """Where two renders of one pose differ, one text per output that differs.

    Args:
        first, second: a render's outputs (``{'rgb': (H, W, 3) uint8, 'depth': (H, W) float32 m, 'class',
            'instance': (H, W) int32, 'ranges': (N,) float64 m, ...}``, as the renderer returns them; any NumPy
            arrays of matching keys).

    Returns:
        e.g. ``["rgb: 37 pixels in rows 95..120, columns 170..230; first (97, 171): [12, 40, 33] then [12, 41,
        33]"]``: for an image (2 or more axes), the pixels (over its first two axes) that differ, their bounding
        box and the first of them; for another array, the elements that differ; an output only one of the two
        has, or of another shape or dtype, as such. ``[]`` when every output is equal, bit for bit (NaN equal to a
        NaN of the same bits).
    """
    out = []
    for key in sorted(set(first) | set(second)):
        if key not in first or key not in second:
            out.append(f"{key}: only in the {'first' if key in first else 'second'} render")
            continue
        a, b = np.ascontiguousarray(first[key]), np.ascontiguousarray(second[key])
        if a.shape != b.shape or a.dtype != b.dtype:
            out.append(f"{key}: {a.dtype}{list(a.shape)} then {b.dtype}{list(b.shape)}")
            continue
        if a.tobytes() == b.tobytes():
            continue
        unequal = a.view(np.uint8).reshape(a.shape + (-1,)) != b.view(np.uint8).reshape(b.shape + (-1,))
        if a.ndim >= 2:
            where = np.argwhere(unequal.reshape(a.shape[:2] + (-1,)).any(axis=-1))
            (r0, c0), (r1, c1) = where.min(axis=0), where.max(axis=0)
            r, c = where[0]
            out.append(f"{key}: {len(where)} pixels in rows {r0}..{r1}, columns {c0}..{c1}; first ({r}, {c}): "
                       f"{a[r, c].tolist()} then {b[r, c].tolist()}")
        else:
            out.append(f"{key}: {int(unequal.reshape(a.size, -1).any(axis=-1).sum())} of {a.size} elements")
    return out


class RenderCheck:
    """Compares a backend's two renders of each pose; logs and keeps those that differ.

    Args:
        folder: where differing renders are kept (made on the first); None keeps none.
    """

    kept = 0  # renders kept by this process (every RenderCheck of it), up to MAX_KEPT

    def __init__(self, folder: Path | None) -> None:
        self.folder = folder

    def compare(self, first: dict, second: dict, where: str) -> list[str]:
        """Compare two renders of the pose ``where`` names (e.g. ``"miniroom:3 frame 50"``); where they differ, log
        one warning and keep both (:data:`MAX_KEPT` a process). Returns :func:`differences`. Never raises: a file
        that cannot be written is said in the warning."""
        found = differences(first, second)
        if not found:
            return found
        kept = ""
        if self.folder is not None and RenderCheck.kept < MAX_KEPT:
            kept = "; " + self._keep(first, second, where)
        log.warning("render check: %s rendered twice gave two images: %s%s", where, "; ".join(found), kept)
        return found

    def _keep(self, first: dict, second: dict, where: str) -> str:
        """Write both renders to one ``.npz`` file (atomically); returns what to say of it."""
        name = "".join(ch if ch.isalnum() else "_" for ch in where) + f"_{os.getpid()}_{RenderCheck.kept}.npz"
        arrays = {f"first_{k}": np.asarray(v) for k, v in first.items()}
        arrays.update({f"second_{k}": np.asarray(v) for k, v in second.items()})
        tmp = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True, mode=0o700)
            fd, tmp = tempfile.mkstemp(dir=self.folder, suffix=".tmp")
            with os.fdopen(fd, "wb") as f:
                np.savez_compressed(f, **arrays)
            os.replace(tmp, self.folder / name)
        except OSError as exc:
            if tmp is not None:  # a full disk: no half-written file left behind
                Path(tmp).unlink(missing_ok=True)
            return f"not kept ({exc.strerror or exc})"
        RenderCheck.kept += 1
        return f"both kept in {self.folder / name}"


def render_check() -> RenderCheck | None:
    """The check the settings ask for: a :class:`RenderCheck` keeping renders under the cache directory when
    ``BENCHBOT_SIM_CHECK_RENDERS`` is ``1``, else None (the default: each pose rendered once).

    Raises:
        UsageError: the variable is set to something else than ``0`` or ``1`` (one line naming it).
    """
    from benchbot.core import settings
    from benchbot.packs.pack_layout import cache_dir

    from benchbot_sim_taichi.settings import CHECK_RENDERS

    if settings.value(CHECK_RENDERS) != "1":
        return None
    return RenderCheck(cache_dir() / FOLDER)
