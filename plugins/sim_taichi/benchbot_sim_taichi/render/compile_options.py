"""Quick compiles: the simulator's kernels that Taichi compiles without its CFG optimisation, because their output is
the same without it and they compile several times faster.

Where a cold start's time goes (``benchmarks/cold_start.py``): Taichi 1.7 compiles a kernel in three parts, its front
end (Python, every process), its own IR passes (``compile_to_offloads`` on the calling thread, then each offloaded
task's on worker threads) and LLVM's. On the 2-core development CPU most of it is one pass of Taichi's own:
``full_simplify`` runs ``cfg_optimization`` (store-to-load forwarding and dead-store elimination over a control-flow
graph of the whole kernel, built with a reaching-definition analysis whose cost grows faster than the kernel's length)
in each of its calls. Loading miniroom:1 cold with every kernel compiled with it, the calling thread spent 54.8 s in
``compile_kernel``, 33.5 s of them in ``cfg_optimization`` (13.1 s more on the workers) and 1.8 s in LLVM's
``optimize_module`` (``benchmarks/cold_start.py --taichi-profile``, Taichi's scoped profiler; load average 3). LLVM then
does that work again (``mem2reg``, ``GVN``, dead-store elimination at ``-O3``), so a kernel compiled without it is the
same program; floating-point results can still move by an ulp where LLVM fuses a multiply and an add that Taichi's pass
would have left apart (fast math). Hence a list, each kernel on it checked: the values it produces with and without the
pass are equal bit for bit (``tools/render_fingerprint.py``, 40 of 40 arrays: fast-mode images lit through the shadow
maps and the baked light, laser scans and quality views of miniroom:1 and house:1; ``--shadow-samples 2`` for
:func:`~benchbot_sim_taichi.render.sensors.shade_kernel`). Kernels left off: ``occluders_kernel`` (its laser ranges
moved by up to 2e-6 m), ``clusters_kernel`` (Taichi 1.7 fails an assertion in its ``scalarize`` pass without the CFG
pass), ``quality_kernel`` (radiance moved by up to 4e-4) and those not checked on an arch.

Taichi has no per-kernel compile option, so :func:`use_quick_compiles` wraps ``Kernel.materialize`` (Taichi 1.7:
where a kernel's Python code becomes its IR, in every process): right after a listed kernel of this package is
materialised it is compiled with ``cfg_optimization`` off, then the option is put back. Taichi keeps the kernel's
cache key (which holds its compile options) with the kernel and its compiled code in memory, so its launches, and
the compute graph of :func:`~benchbot_sim_taichi.render.sensors.sensors_graph`, use that code; its offline cache
keeps it under that key, so a later process that compiles the same way loads it. ``BENCHBOT_TAICHI_QUICK_COMPILE=0``
compiles every kernel with the pass (the kernels are then cached under other keys: the first run compiles them).
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from benchbot.core import settings
from benchbot_sim_taichi.settings import TAICHI_QUICK_COMPILE

#: Kernel name -> the Taichi archs on which it compiles without ``cfg_optimization`` (checked there as the module
#: docstring says). CPU seconds of each compile on the 2-core CPU, with the pass and without (miniroom:1, an empty
#: kernel cache, medians of 2 runs of ``benchmarks/cold_start.py --compare --runs 2``): primitives 11.4 -> 1.9, bake
#: 5.8 -> 0.8, shade_maps 3.9 -> 0.9, lamp_map 1.8 -> 0.3, sun_map 1.7 -> 0.3; all kernels of its first frame 35.8 ->
#: 15.6 (occluders 9.3-9.5 either way). Frame times unchanged (``benchmarks/render_fps.py``, 640 x 480: 44.1-44.4 ms
#: against 44.1-44.8 ms for miniroom:1, 46.8-47.5 against 46.0-47.7 for house:1). None for CUDA: there lamp_map,
#: sun_map, light_grid, bake and shade_maps_packed render the same without the pass (40 of 40 arrays) but compile no
#: faster (miniroom:1 cold on an H200, steps 1 to 3 then one kernel: 106.4 s against 100.7 s).
QUICK_COMPILES: dict[str, frozenset[str]] = {
    "lamp_map_kernel": frozenset({"cpu"}),
    "sun_map_kernel": frozenset({"cpu"}),
    "light_grid_kernel": frozenset({"cpu"}),
    "bake_kernel": frozenset({"cpu"}),
    "primitives_kernel": frozenset({"cpu"}),
    "shade_maps_kernel": frozenset({"cpu"}),
    "shade_kernel": frozenset({"cpu"}),
}

#: This package's folder: only kernels defined under it are compiled quickly.
PACKAGE_DIR = str(Path(__file__).resolve().parents[1])
_installed = False


def quick_compiles_wanted() -> bool:
    """Whether listed kernels compile without the CFG pass: ``BENCHBOT_TAICHI_QUICK_COMPILE`` (default 1)."""
    return settings.value(TAICHI_QUICK_COMPILE) == "1"


def quick(kernel, arch: str) -> bool:
    """Whether the Taichi kernel object ``kernel`` (``taichi.lang.kernel_impl.Kernel``) compiles quickly on ``arch``
    (``'cpu'`` or ``'cuda'``): its function is defined in this package and is listed in :data:`QUICK_COMPILES` for
    ``arch``."""
    func = getattr(kernel, "func", None)
    code = getattr(func, "__code__", None)
    if code is None or not str(code.co_filename).startswith(PACKAGE_DIR):
        return False
    return arch in QUICK_COMPILES.get(getattr(func, "__name__", ""), ())


@contextlib.contextmanager
def _cfg_optimization_off(config):
    saved = config.cfg_optimization
    config.cfg_optimization = False
    try:
        yield
    finally:
        config.cfg_optimization = saved


def use_quick_compiles() -> bool:
    """Compile the kernels of :data:`QUICK_COMPILES` without Taichi's CFG optimisation from now on in this process
    (once per process; idempotent). Returns whether quick compiles are in use: False when
    ``BENCHBOT_TAICHI_QUICK_COMPILE`` is ``0`` or this Taichi lacks what it wraps (``Kernel.materialize`` and
    ``compiled_kernels`` of Taichi 1.7); then nothing is changed.

    Raises:
        UsageError: ``BENCHBOT_TAICHI_QUICK_COMPILE`` is neither 0 nor 1.
    """
    global _installed
    if _installed:
        return True
    if not quick_compiles_wanted():
        return False
    try:
        from taichi.lang import impl
        from taichi.lang.kernel_impl import Kernel
    except ImportError:
        return False
    materialize = getattr(Kernel, "materialize", None)
    if materialize is None:
        return False

    def quick_materialize(self, key=None, args=None, arg_features=None):
        wanted = (self.func, 0, self.autodiff_mode) if key is None else key
        new = wanted not in getattr(self, "compiled_kernels", {wanted: None})
        materialize(self, key, args, arg_features)
        if new and wanted in self.compiled_kernels:
            _compile_quickly(self, self.compiled_kernels[wanted], impl)

    quick_materialize.__doc__ = materialize.__doc__
    quick_materialize.__wrapped__ = materialize
    Kernel.materialize = quick_materialize
    _installed = True
    return True


def _compile_quickly(kernel, compiled, impl) -> None:
    """Compile the C++ kernel ``compiled`` of ``kernel`` now, without the CFG pass, when :func:`quick` says so (its
    code and key are then Taichi's for every later launch of it)."""
    prog = impl.get_runtime().prog
    config = prog.config()
    arch = "cuda" if str(config.arch).endswith("cuda") else ("cpu" if str(config.arch).endswith(("x64", "arm64"))
                                                             else str(config.arch))
    if not quick(kernel, arch):
        return
    with _cfg_optimization_off(config):
        prog.compile_kernel(config, prog.get_device_caps(), compiled)
