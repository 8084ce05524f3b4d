"""The environment variables the simulator reads, declared once (hook ``benchbot_settings`` in
:mod:`benchbot_sim_taichi.plugin`): ``benchbot doctor`` shows them, and the simulator reads them through these
declarations (``settings.get(TAICHI_ARCH)``), whether or not the plugin is loaded. Imports nothing heavy."""

from __future__ import annotations

from benchbot.core.settings import Setting, one_of, whole_number

#: The Taichi arch (``--arch`` wins); the reader gives ``cpu``, ``gpu`` or ``cuda``.
TAICHI_ARCH = Setting("BENCHBOT_TAICHI_ARCH", "cpu", "Taichi arch of the simulator: cpu, gpu or cuda (--arch wins)",
                      reader=one_of("cpu", "gpu", "cuda"))
#: CPU threads per simulator process; a batch sets it for its workers (``benchbot.batch.executors``) and a sandboxed
#: solution is given it (the sandbox's environment allow-list), so both share the cores alike.
TAICHI_THREADS = Setting("BENCHBOT_TAICHI_THREADS", None, "CPU threads per simulator process (default: one per "
                         "core; batch workers set it)", reader=whole_number(1))
#: ``1``: Taichi keeps its full source excerpts in the kernels' debug information
#: (:mod:`benchbot_sim_taichi.render.source_positions`).
TAICHI_FULL_POSITIONS = Setting("BENCHBOT_TAICHI_FULL_POSITIONS", None, "1: the simulator's kernels keep Taichi's "
                                "full source excerpts in their debug information (slower start; for changing the "
                                "kernels)")
#: ``1`` (default): the kernels listed in :mod:`benchbot_sim_taichi.render.compile_options` compile without Taichi's
#: CFG optimisation (several times faster, the same output); ``0``: every kernel with it.
TAICHI_QUICK_COMPILE = Setting("BENCHBOT_TAICHI_QUICK_COMPILE", "1", "1: the simulator's kernels checked to render the "
                               "same without Taichi's CFG optimisation compile without it (a faster first run); 0: "
                               "every kernel with it", reader=one_of("0", "1"))
#: ``1``: the backend renders every pose twice and says where the two differ
#: (:mod:`benchbot_sim_taichi.render_check`); ``0`` (default): once.
CHECK_RENDERS = Setting("BENCHBOT_SIM_CHECK_RENDERS", "0", "1: render every pose twice and log where the two images "
                        "differ, keeping both under the cache directory (a check of the simulator's determinism; "
                        "twice the render time)", reader=one_of("0", "1"))

#: Every setting of the simulator, in the order ``benchbot doctor`` shows them.
SETTINGS = (TAICHI_ARCH, TAICHI_THREADS, TAICHI_FULL_POSITIONS, TAICHI_QUICK_COMPILE, CHECK_RENDERS)
