"""Where a one-camera sensor frame's time goes on CUDA: the host's launch work against the GPU's work.

    python benchmarks/one_camera.py --arch cuda --env house:1 [--frames 1500] [--json]
    python benchmarks/one_camera.py --arch cpu --launch-only [--json]
    python benchmarks/one_camera.py --smoke     (the launch probes on the CPU, one burst each)

With one camera a fast-mode frame (640×480 RGB + depth + class/instance segmentation + a 360-beam laser scan, as
``render.py`` renders it) is short on a GPU, and the host's work to launch it can take longer than the GPU's work.
This script measures both, for the renderer's one-camera frames along the environment's trajectory (and, below,
what a Taichi launch costs per argument):

* ``fps``: frames one after another with nothing in between (the GPU waits only at the end), as ``render.py``;
* ``host_us_per_frame``: the host's time to launch a frame (``render_sensors(..., to_host=False)``) while the GPU is
  kept busy by a spin kernel launched first, so that launching never waits for the GPU;
* ``gpu_us_per_frame``: the GPU's time per frame for those frames, run back to back behind the spin kernel, between
  two CUDA events (``cuEventRecord``/``cuEventElapsedTime`` through the driver library that Taichi loaded). A group
  whose launches outlasted the spin kernel (the GPU could have waited for the host) is measured again with a longer
  spin;
* ``python_us_per_frame``: the part of the host's time spent in the renderer's Python, with the compiled graph's
  ``run`` replaced by a no-op for the measurement.

The frame rate is about 10⁶ / max(host, GPU) µs: when the host's figure is the larger, the launches limit it, and a
faster host CPU (or fewer launch arguments) raises it; the GPU's figure does not depend on the host.

What a launch costs (``launch``, on either arch): a compiled ``ti.graph`` of one small kernel (one loop over 32
items) run with 2 ndarray arguments, with 30, as two dispatches of the 2-argument kernel, and with 8 loops instead
of one (8 offloaded tasks, 8 GPU kernel launches), each timed over bursts (median µs per run). From those:
``per_ndarray_us`` = (30 − 2 arguments) / 28, ``per_dispatch_us`` = two dispatches − one, ``per_task_us`` = (8 loops
− 1) / 7. ``frame_launch`` counts the ndarray arguments and dispatches of the renderer's own graph on this arch
(``sensors.sensors_kernels``, ``scene_arrays.annotations``) and adds up their cost (``estimate_us``, see
:func:`frame_launch`), the per-task cost left out: the frame's task count is not read here.

JSON keys: ``env``, ``arch``, ``width``, ``height``, ``frames``, ``fps``, ``host_us_per_frame``,
``gpu_us_per_frame`` (median over groups of ``--group`` frames) with ``gpu_us_range``, ``spin_ms``,
``python_us_per_frame``, ``shadow_rays``, ``gpu``, ``launch`` ({``two_ndarrays_us``, ``thirty_ndarrays_us``,
``two_dispatches_us``, ``eight_tasks_us``, ``per_ndarray_us``, ``per_dispatch_us``, ``per_task_us``}),
``frame_launch`` ({``ndarray_args``, ``dispatches``, ``estimate_us``}), ``launch_after_frames`` (the probes again
after the frame measurements, CUDA: the host's speed can drift within a process), ``cpu_model``, ``cpu_count``. On the CPU (or
with ``--launch-only``) only ``launch`` and ``frame_launch`` are measured, and no scene is built: CPU kernels run
while they are launched, so there is no separate GPU time.
"""

import argparse
import contextlib
import functools
import json
import os
import statistics
import sys
import time

import smoke  # this folder is on sys.path when a script here runs

_LOOP = 32  # items of the probe kernels' loop: little work, so that a run costs its launch


@functools.cache
def _probe_kernels(ti):
    """The launch-cost probes: Taichi kernels with 2 and 30 ndarray parameters, and one with 8 loops (made once)."""
    nd = ti.types.ndarray(dtype=ti.f32, ndim=1)  # (_LOOP,) f32 each

    @ti.kernel
    def two(a0: nd, a1: nd):
        for i in range(_LOOP):
            a0[i] += a1[i]

    @ti.kernel
    def thirty(a0: nd, a1: nd, a2: nd, a3: nd, a4: nd, a5: nd, a6: nd, a7: nd, a8: nd, a9: nd, a10: nd, a11: nd,
               a12: nd, a13: nd, a14: nd, a15: nd, a16: nd, a17: nd, a18: nd, a19: nd, a20: nd, a21: nd, a22: nd,
               a23: nd, a24: nd, a25: nd, a26: nd, a27: nd, a28: nd, a29: nd):
        for i in range(_LOOP):
            a0[i] += (a1[i] + a2[i] + a3[i] + a4[i] + a5[i] + a6[i] + a7[i] + a8[i] + a9[i] + a10[i] + a11[i] + a12[i]
                      + a13[i] + a14[i] + a15[i] + a16[i] + a17[i] + a18[i] + a19[i] + a20[i] + a21[i] + a22[i]
                      + a23[i] + a24[i] + a25[i] + a26[i] + a27[i] + a28[i] + a29[i])

    @ti.kernel
    def eight_loops(a0: nd, a1: nd):
        for k in ti.static(range(8)):
            for i in range(_LOOP):
                a0[i] += a1[i] * (k + 1)

    return two, thirty, eight_loops


def _median_us(ti, run, bursts: int, per_burst: int = 50) -> float:
    """Median over ``bursts`` bursts of µs per call of ``run`` (the device synchronised before and after each)."""
    for _ in range(10):
        run()
    ti.sync()
    times = []
    for _ in range(bursts):
        ti.sync()
        t0 = time.perf_counter()
        for _ in range(per_burst):
            run()
        ti.sync()
        times.append((time.perf_counter() - t0) / per_burst * 1e6)
    return statistics.median(times)


def launch_costs(ti, bursts: int) -> dict:
    """µs per run of the probe graphs and the costs derived from them (see the module's docstring)."""
    two, thirty, eight_loops = _probe_kernels(ti)
    arrays = {f"a{i}": ti.ndarray(ti.f32, shape=(_LOOP,)) for i in range(30)}
    syms = {name: ti.graph.Arg(ti.graph.ArgKind.NDARRAY, name, ti.f32, ndim=1) for name in arrays}

    def graph(*dispatches):
        builder = ti.graph.GraphBuilder()
        for kernel, names in dispatches:
            builder.dispatch(kernel, *(syms[n] for n in names))
        return builder.compile()

    pair, every = ("a0", "a1"), tuple(arrays)
    two_args = {n: arrays[n] for n in pair}
    graphs = {"two_ndarrays_us": (graph((two, pair)), two_args),
              "thirty_ndarrays_us": (graph((thirty, every)), arrays),
              "two_dispatches_us": (graph((two, pair), (two, pair)), two_args),
              "eight_tasks_us": (graph((eight_loops, pair)), two_args)}
    out = {key: _median_us(ti, lambda g=g, v=v: g.run(v), bursts) for key, (g, v) in graphs.items()}
    out["per_ndarray_us"] = (out["thirty_ndarrays_us"] - out["two_ndarrays_us"]) / 28
    out["per_dispatch_us"] = out["two_dispatches_us"] - out["two_ndarrays_us"]
    out["per_task_us"] = (out["eight_tasks_us"] - out["two_ndarrays_us"]) / 7
    return out


def frame_launch(arch: str, costs: dict) -> dict:
    """The ndarray arguments and dispatches of the renderer's graph on ``arch``, and their cost at ``costs``: one
    2-ndarray dispatch, one ``per_dispatch_us`` (a 2-ndarray dispatch) for each further kernel, and
    ``per_ndarray_us`` for each ndarray argument beyond those."""
    from taichi.types.ndarray_type import NdarrayType

    from benchbot_sim_taichi.render.scene_arrays import annotations
    from benchbot_sim_taichi.render.sensors import sensors_kernels

    kernels = sensors_kernels(arch)  # (both shading kernels take the same arguments)
    n_nd = sum(isinstance(a, NdarrayType) for k in kernels for a in annotations(k).values())
    return {"ndarray_args": n_nd, "dispatches": len(kernels),
            "estimate_us": costs["two_ndarrays_us"] + (len(kernels) - 1) * costs["per_dispatch_us"]
            + (n_nd - 2 * len(kernels)) * costs["per_ndarray_us"]}


def _cpu_model() -> str:
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return "unknown"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1", help="environment NAME:VARIANT (default house:1)")
    ap.add_argument("--arch", default="cuda", choices=("cpu", "cuda"),
                    help="Taichi arch (default cuda; cpu measures the launch probes only)")
    ap.add_argument("--width", type=int, default=640, help="image width, pixels (default 640)")
    ap.add_argument("--height", type=int, default=480, help="image height, pixels (default 480)")
    ap.add_argument("--frames", type=int, default=1500, help="frames of the frame-rate run (CUDA)")
    ap.add_argument("--group", type=int, default=25, help="frames queued behind each spin kernel (CUDA)")
    ap.add_argument("--groups", type=int, default=12, help="groups measured (CUDA)")
    ap.add_argument("--bursts", type=int, default=15, help="bursts of 50 runs per launch probe")
    ap.add_argument("--launch-only", action="store_true", help="measure only the launch probes")
    ap.add_argument("--json", action="store_true", help="print one JSON object (keys in the module docstring)")
    args = smoke.parse_args(ap, argv, arch="cpu", launch_only=True, bursts=1)
    if min(args.width, args.height, args.frames, args.group, args.groups, args.bursts) < 1:
        ap.error("--width, --height, --frames, --group, --groups and --bursts must be at least 1")

    from benchbot_worlds import bear
    from benchbot_sim_taichi.render import renderer as renderer_module
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics  # (imports Taichi, its banner sent to stderr)
    from benchbot_worlds.scene.build import build_scene
    from trajectory_views import trajectory_views  # this folder is on sys.path when a script here runs

    import taichi as ti  # (after the renderer's import, which sends Taichi's banner to stderr)

    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    if args.env not in envs:
        ap.error(f"unknown environment {args.env}; one of {sorted(envs)}")
    r = Renderer(args.arch)  # (initialises Taichi on the arch)
    if args.arch == "cuda" and r.arch != "cuda":
        ap.error("--arch cuda: Taichi found no CUDA device here (use --arch cpu --launch-only)")
    out = {"env": args.env, "arch": r.arch, "width": args.width, "height": args.height, "cpu_model": _cpu_model(),
           "cpu_count": os.cpu_count()}
    out["launch"] = launch_costs(ti, args.bursts)
    out["frame_launch"] = frame_launch(r.arch, out["launch"])
    if args.smoke and (r.arch != "cuda" or args.launch_only):
        smoke.left_out("the frames' host/GPU split", "it needs CUDA and a run without --smoke or --launch-only")
    if r.arch == "cuda" and not args.launch_only:
        scene = build_scene(envs[args.env])
        r.set_scene(scene)
        out["shadow_rays"] = r.shadow_rays
        out.update(_frames(args, r, renderer_module, intrinsics, trajectory_views(scene), ti))
        out["launch_after_frames"] = launch_costs(ti, args.bursts)  # the host may have changed speed meanwhile
        import gpu_host  # (this folder is on sys.path when a script here runs)

        out["gpu"] = gpu_host.device_info()["gpu"]
    if args.json:
        print(json.dumps(out))
    else:
        launch, fl = out["launch"], out["frame_launch"]
        print(f"launch ({r.arch}): {launch['two_ndarrays_us']:.1f} µs with 2 ndarrays, {launch['per_ndarray_us']:.2f} "
              f"µs per more ndarray, {launch['per_dispatch_us']:.1f} per dispatch, {launch['per_task_us']:.1f} per "
              f"task; the frame's graph: {fl['ndarray_args']} ndarray arguments, {fl['dispatches']} dispatches ≈ "
              f"{fl['estimate_us']:.0f} µs")
        if "fps" in out:
            print(f"{args.env} one camera: {out['fps']:.0f} fps; host {out['host_us_per_frame']:.0f} µs a frame "
                  f"(Python {out['python_us_per_frame']:.0f}), GPU {out['gpu_us_per_frame']:.0f} µs a frame")
    return 0


def _frames(args, r, renderer_module, intrinsics, views, ti) -> dict:
    """The CUDA frame measurements (see the module's docstring)."""
    import gpu_host

    W, H = args.width, args.height
    K = intrinsics(W, H, 90.0)
    cams, lidars, angles = views

    def frame(i):
        k = i % len(cams)
        r.render_sensors(K, cams[k][None], W, H, lidars[k][None], angles, to_host=False)

    for i in range(10):
        frame(i)
    r.sync()
    t0 = time.perf_counter()
    for i in range(args.frames):
        frame(i)
    r.sync()
    fps = args.frames / (time.perf_counter() - t0)

    ev = gpu_host.CudaEvents()
    spin_out = ti.ndarray(ti.f32, shape=(1,))

    @ti.kernel
    def spin(n: ti.i32, out: ti.types.ndarray()):  # out: (1,) f32
        for _ in range(1):  # one GPU thread, n dependent steps
            x = 0.0
            for i in range(n):
                x = x * 0.999 + ti.sin(ti.cast(i, ti.f32))
            out[0] = x

    start, spin_end, end = ev.new(), ev.new(), ev.new()
    spin(1000, spin_out)
    r.sync()
    ev.record(start)
    spin(200_000, spin_out)
    ev.record(spin_end)
    steps_per_ms = 200_000 / max(ev.ms(start, spin_end), 1e-3)
    host, gpu, spin_ms = [], [], 0.5 * args.group  # half a millisecond of spin a frame, doubled while too short
    g = 0
    while len(gpu) < args.groups:
        if spin_ms * steps_per_ms >= 2**31:
            raise SystemExit(f"one_camera.py: {args.group} frames took the host longer than a {spin_ms:.0f} ms spin "
                             "kernel; try a smaller --group")
        r.sync()
        spin(int(spin_ms * steps_per_ms), spin_out)
        ev.record(spin_end)
        t0 = time.perf_counter()
        for i in range(g * args.group, (g + 1) * args.group):
            frame(i)
        t1 = time.perf_counter()
        ev.record(end)
        g += 1
        if ev.done(spin_end):  # the GPU may have waited for the launches: spin longer, measure again
            ev.ms(spin_end, end)
            spin_ms *= 2
            continue
        host.append((t1 - t0) / args.group * 1e6)
        gpu.append(ev.ms(spin_end, end) / args.group * 1e3)

    class _NoLaunch:  # the compiled graph's run replaced by nothing: the renderer's Python alone
        def run(self, values):
            pass

    real = renderer_module.sensors_graph
    renderer_module.sensors_graph = lambda *a, **k: _NoLaunch()
    try:
        t0 = time.perf_counter()
        for i in range(args.frames):
            frame(i)
        python_us = (time.perf_counter() - t0) / args.frames * 1e6
    finally:
        renderer_module.sensors_graph = real
    return {"frames": args.frames, "fps": fps, "host_us_per_frame": statistics.median(host),
            "gpu_us_per_frame": statistics.median(gpu), "gpu_us_range": [min(gpu), max(gpu)],
            "spin_ms": spin_ms, "python_us_per_frame": python_us}


if __name__ == "__main__":
    sys.exit(main())
