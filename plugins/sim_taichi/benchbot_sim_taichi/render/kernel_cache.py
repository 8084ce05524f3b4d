"""What the warm-up of a scene's kernels does, so that its stage says so: compiling them (the first run on a
machine, or after the kernels' sources, Taichi or the arch changed), loading them from Taichi's offline cache (a
later run) or only warming up ones this process compiled already (a later scene in the same process).

Taichi keys its offline cache (``offline_cache_file_path``, ``~/.cache/taichi/ticache`` by default, a flat folder of
``*.tic`` files and a ``ticache.tcb`` index) by a hash of each kernel, which is not cheap to predict. So after a run
that compiled, a marker ``benchbot-<key>.compiled`` is written beside those files, ``<key>`` hashing Taichi's
version, the arch, the render mode, the Python version, the sources of ``render/`` (where every kernel is) and the
settings that are part of Taichi's own keys (Taichi's ``cpu_max_num_threads``, which ``BENCHBOT_TAICHI_THREADS``
sets, and ``BENCHBOT_TAICHI_QUICK_COMPILE``: the compile options of
:mod:`~benchbot_sim_taichi.render.compile_options`). A later run finds its kernels cached when that marker exists and
the index was written after it (Taichi writes the index when a process that compiled ends; a process that died first
left no kernels, and then it compiles again).
"""

from __future__ import annotations

import functools
import hashlib
import sys
from pathlib import Path

_SOURCES = Path(__file__).resolve().parent
_INDEX = "ticache.tcb"
_WARM: set[str] = set()  # keys whose kernels this process compiled or loaded

STAGES = {  # state -> (stage name, detail)
    "cold": ("compiling kernels", "once per machine, then cached"),
    "disk": ("loading cached kernels", "compiled on an earlier run"),
    "memory": ("warming up kernels", "compiled already in this process"),
    "off": ("compiling kernels", "Taichi's offline cache is off"),
}


@functools.lru_cache(maxsize=8)
def kernels_key(arch: str, mode: str) -> str:
    """16 hex digits naming this process's kernels: Taichi's version, ``arch``, ``mode``, Python, render/'s sources,
    the thread count and quick-compile settings (read once per process: every episode's reset asks)."""
    import taichi as ti

    from benchbot_sim_taichi.render.compile_options import quick_compiles_wanted

    try:  # the thread count initialised Taichi's config holds (its default: every core)
        threads = ti.lang.impl.current_cfg().cpu_max_num_threads
    except AttributeError:
        threads = None
    taken = f"{threads}|{quick_compiles_wanted()}"
    digest = hashlib.sha256(f"{ti.__version__}|{arch}|{mode}|{sys.version_info[:2]}|{taken}".encode())
    for path in sorted(_SOURCES.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def offline_cache_dir() -> Path | None:
    """The folder of Taichi's offline cache (initialised Taichi's config), None when the cache is off or this Taichi
    does not say where it is (its config is not public API: a stage's label must never fail)."""
    import taichi as ti

    try:
        cfg = ti.lang.impl.current_cfg()
    except AttributeError:
        return None
    return Path(cfg.offline_cache_file_path) if cfg.offline_cache else None


def kernels_state(key: str, cache: Path | None) -> str:
    """``memory`` (this process has them), ``disk`` (a finished earlier run compiled them into ``cache``),
    ``cold`` (they will be compiled) or ``off`` (``cache`` is None: no offline cache)."""
    if key in _WARM:
        return "memory"
    if cache is None:
        return "off"
    marker, index = cache / f"benchbot-{key}.compiled", cache / _INDEX
    try:
        if marker.stat().st_mtime <= index.stat().st_mtime and any(cache.glob("*.tic")):
            return "disk"
    except OSError:  # no marker or no index
        pass
    return "cold"


def mark_ready(key: str, state: str, cache: Path | None) -> None:
    """After the warm-up: this process has the kernels; after a compile, the marker for later runs (best effort:
    an unwritable cache folder only costs the next run the right words)."""
    _WARM.add(key)
    if state == "cold" and cache is not None:
        try:
            cache.mkdir(parents=True, exist_ok=True)
            (cache / f"benchbot-{key}.compiled").touch()
        except OSError:
            pass
