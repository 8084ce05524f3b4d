"""Taichi ray tracing of a :class:`~benchbot_worlds.scene.model.Scene` (boxes, ellipsoids, cylinders and triangles in a
BVH, inside a room shell): RGB-D + segmentation images, planar laser scans, batched rendering of many cameras in one
kernel launch, and two modes: ``fast`` (direct lighting, shadow rays) and ``quality`` (path traced: physically based
materials, next-event estimation with multiple importance sampling, several bounces with Russian roulette —
:mod:`benchbot_sim_taichi.render.pathtrace` — then Intel Open Image Denoise with albedo and normal guides).

Importing this module imports Taichi but does not initialise it; :func:`ensure_taichi` (called by
:class:`Renderer`) runs ``ti.init`` once per process. Taichi must be used from one thread per process.

One kernel launch computes every sensor of a frame (or of a batch of B frames):
:func:`~benchbot_sim_taichi.render.sensors.sensors_kernel` traces the laser beams, finds every camera ray's closest hit by
rasterising the scene's primitives into a visibility buffer (:mod:`benchbot_sim_taichi.render.raster`: the same hits as
the BVH traversal, found object by object), then shades the pixels (RGB, depth, class and instance ids). Kernels take
``ti.types.ndarray``
arguments, so a scene with any number of primitives, or any image size, reuses the compiled kernels (compiled once
per process, not per scene). By default (``device_buffers``) the scene is uploaded once as
``ti.ndarray`` (GPU memory on CUDA) and the outputs stay in reused buffers; each launch goes through a compiled
``ti.graph`` with the camera and lidar pose passed by value, so the per-frame cost is one launch (the arguments set in
C++, not by Python for each kernel) plus, when wanted, one copy to the host.
The BVH (:mod:`benchbot_sim_taichi.render.bvh`) is built once per scene in NumPy and stored with both children's boxes in
each interior node's record (:func:`~benchbot_sim_taichi.render.bvh.wide_nodes`); closest-hit rays (the laser, the
shadow maps, quality mode's paths) traverse it nearer child first with a per-ray stack, any-hit rays left child
first; the rasteriser culls its clusters (:func:`~benchbot_sim_taichi.render.bvh.clusters`) against each camera's view.

Conventions: ``map`` frame, metres. Cameras use the OPTICAL frame (z forward, x right, y down); the ray of pixel
(u, v) (column, row; integer pixel centres) is ``R · K⁻¹ [u, v, 1]ᵀ`` so its parameter t is the z-depth.
Lighting: linear radiance = albedo · (ambient·(0.8 + 0.2·n_z) + Σ_lights visibility · colour · max(0, n·l) ·
attenuation), then through the camera model (:mod:`benchbot_sim_taichi.render.camera_model`: vignetting, exposure, tone
curve, gamma 2.2; by default clamped and gamma-encoded, as always) to uint8 through a table. Visibility
is the fraction of ``shadow_samples`` shadow rays (stratified over the light's disc — the sun's angular radius, a
lamp's radius — with a per-pixel rotation from a seeded integer hash, so renders are deterministic) that reach the
light; one sample is a hard shadow towards the light's centre. With one sample in a furnished scene (``Renderer``'s
``shadow_maps``), visibility comes instead from shadow maps traced once per scene: a lamp's from its cube map (the
distance from the lamp to the first occluder for each of 6 × 256² directions, compared with the point's distance),
the sun's from one orthographic map over the scene's primitives (2048² texels, about 1 cm in a furnished house: the
height, along the direction towards the sun, of the first primitive the sun's rays meet, compared with the
point's). Either way the point is first moved off its surface along its normal by 1.5 texels, and 2 × 2 texels are
compared, bilinearly weighted. The images agree with shadow rays but for a rim of a texel or two along shadow edges
(and rare specks where a texel's ray slips through a seam of the structure), and a frame costs far less (many lamps:
house:1 has 29, and the sun's ray is long). The kernels live in :mod:`benchbot_sim_taichi.render.kernels`.

Triangles (meshes, :mod:`benchbot_worlds.scene.meshes`) are shaded with their interpolated vertex normals (n above;
shadow rays leave from the hit point offset along the geometric normal, moved onto the vertices' tangent planes so
low-poly curved surfaces do not shadow themselves in facets) and, with a textured material, albedo = material albedo ×
texture: sRGB texels turned linear through a 256-entry table, bilinearly filtered, repeating, at a mip level chosen
from the ray's footprint (``t / fx`` metres per pixel, divided by the cosine of incidence) against the
triangle's texel density, and blended between the two nearest levels (trilinear), so distant surfaces do not alias.
Depth, segmentation and laser ranges use the triangles themselves.

Window panes (triangles of a glass material, ``Scene.mat_glass``; kind ``kernels.GLASS`` in ``pi``) are thin,
clear, colourless glass of index 1.5: each face is one air–glass interface with Schlick's reflectance
``F = 0.04 + 0.96 (1 − |cos θ|)⁵`` and transmittance ``1 − F``, without refraction (a sheet a few millimetres thick
shifts a ray by less than that). ``quality`` mode is exact to that model: a path reflects or goes straight on at each
face with probability F / 1 − F, and shadow rays are weighted by the ``1 − F`` of every face they cross. ``fast``
mode keeps a frame's cost: camera rays do not stop at panes but note the nearest one in front of their surface
(``kernels.PANES_TRACKED``), whose two faces pass ``(1 − F)²`` of that surface's colour and reflect
``F + (1 − F)² F`` of the ambient sky (``ambient · (0.8 + 0.3 r_z)`` in the mirror direction r, what quality mode's
escaping paths see); shadow rays and the lamps' shadow maps do not see panes (the sun through a window is about 8 %
brighter than in quality mode). Depth, segmentation and the laser see through panes (the surface beyond), as
time-of-flight and structured-light depth cameras and most laser scanners do through clear glass.

``quality`` mode with device buffers (CUDA) finishes a frame where it was rendered: Open Image Denoise reads the path
tracer's radiance and guides in GPU memory and writes the denoised image there
(:func:`~benchbot_sim_taichi.render.denoiser.denoise_shared`), and ``pathtrace.encode_kernel`` applies the camera model
there, in float64 like :meth:`~benchbot_sim_taichi.render.camera_model.CameraModel.encode`; only the results travel to the
host, through page-locked memory (on the CPU, OIDN's CPU device reads the Taichi arrays in place). Without device
buffers (``device_buffers=False``) the same steps run on NumPy arrays, with
the same images (on CUDA, not denoised, a few 8-bit values of a frame can be one level apart: the GPU's float64
``pow`` rounds a value on a level's edge differently).
"""

import contextlib
import io
import functools
import math
import os
import sys
import threading
import warnings

import numpy as np

from benchbot.core import settings, stages
from benchbot.core.errors import UsageError
from benchbot_sim_taichi.render.camera_model import CameraModel, tone_table
from benchbot_sim_taichi.render.pixel_integration import grid_side, integrate, subpixel_intrinsics
from benchbot_sim_taichi.settings import TAICHI_ARCH, TAICHI_THREADS

# Taichi prints a banner on import and "Starting on arch=…" on ti.init, on stdout, which carries our programs' data
# (tables, --json); neither is of use on every command, so both are kept in TAICHI_BANNER instead (`benchbot
# doctor` shows the version). TI_ENABLE_PYBUF=0: Taichi would otherwise see the redirected sys.stdout, announce a
# "graphical python shell" and buffer kernel prints.
os.environ.setdefault("TI_ENABLE_PYBUF", "0")
_banner = io.StringIO()
with contextlib.redirect_stdout(_banner):
    import taichi as ti

from benchbot_sim_taichi.render.denoiser import denoise_radiance, denoise_shared  # noqa: E402
from benchbot_sim_taichi.render.packed_scene import pack as pack_for_sensors  # noqa: E402
from benchbot_sim_taichi.render.pathtrace import (  # noqa: E402
    encode_kernel,
    meter_sample_kernel,
    prepare_denoiser_inputs,
    quality_kernel,
)
from benchbot_sim_taichi.render.kernels import (  # noqa: E402 - after Taichi's banner is redirected
    GLASS, LAMP_MAP_NORMAL_OFFSET, LAMP_MAP_RES, LAMP_RADIUS, LIGHT_CELL_M, LIGHT_COLS, LIGHT_GRID_BLOCK,
    LIGHT_GRID_STEP, SHADE_COLS, SHADOW_OFFSET, STACK, SUN_MAP_RES, SUN_RADIUS, lamp_map_kernel, light_grid_kernel,
    sun_map_kernel,
)
from benchbot_sim_taichi.render.lightmap import bake_kernel, layout as lightmap_layout  # noqa: E402
from benchbot_sim_taichi.render.raster import (  # noqa: E402
    CLUSTER_PRIMS, COUNTERS, EMPTY, OCCLUDER_AREA_M2, QUEUE_COLS, split, tile_entries,
)
from benchbot_sim_taichi.render import layouts as L  # noqa: E402
from benchbot_sim_taichi.render.source_positions import use_brief_positions  # noqa: E402
from benchbot_sim_taichi.render.compile_options import use_quick_compiles  # noqa: E402
from benchbot_sim_taichi.render.layouts import POSE_LEN  # noqa: E402
from benchbot_sim_taichi.render.scene_arrays import SceneArrays, arguments, launch  # noqa: E402
from benchbot_sim_taichi.render.sensors import (  # noqa: E402
    launch_parameters, reset_graph, sensors_graph, sensors_kernel,
)

#: What Taichi printed on import and on ``ti.init`` (its version line, the arch it started on).
TAICHI_BANNER: list[str] = [line for line in _banner.getvalue().splitlines() if line.strip()]

#: Render modes.
MODES = ("fast", "quality")
#: Default longest path of ``quality`` mode, in bounces (the reference renders of ``docs/realism.md`` use 8).
QUALITY_BOUNCES = 8
#: Default samples per pixel of ``quality`` mode. Denoised, 1, 4, 16 and 64 spp are nearly equally close to a
#: converged Cycles reference (25.3, 25.7, 25.9, 26.0 dB PSNR; SSIM 0.80, 0.816, 0.825, 0.83:
#: ``benchmarks/quality_vs_reference.py``, ``docs/realism.md``) at 4× the cost each; 4 gets most of the gain for a
#: quarter of 16's time.
QUALITY_SPP = 4
#: The camera model of a Renderer that is given none: the image as it always was.
DEFAULT_CAMERA = CameraModel()

_INIT_ARCH: str | None = None
_INIT_THREAD: threading.Thread | None = None  # the thread that ran ti.init


class TaichiSettingError(UsageError, ValueError):
    """An invalid Taichi setting (the arch, ``BENCHBOT_TAICHI_ARCH`` or ``BENCHBOT_TAICHI_THREADS``): a one-line
    usage error for the command line, and a ``ValueError`` for callers that catch that."""


def ensure_taichi(arch: str | None = None) -> str:
    """Initialise Taichi once per process and return the arch in use (``'cpu'`` or ``'cuda'``).

    Args:
        arch: ``'cpu'`` (default), ``'gpu'`` or ``'cuda'`` (CUDA if available, else CPU with a warning); ``None`` reads
            the environment variable ``BENCHBOT_TAICHI_ARCH``. On the CPU, ``BENCHBOT_TAICHI_THREADS`` caps the
            threads (default: one per core). A later call asking for another arch keeps the first
            one and warns (Taichi cannot switch without resetting every kernel and field).

    Raises:
        TaichiSettingError: (a ``ValueError``) an unknown arch name, or a ``BENCHBOT_TAICHI_THREADS`` that is not a
            positive integer.
    """
    global _INIT_ARCH, _INIT_THREAD
    try:
        want = TAICHI_ARCH.reader(arch) if arch else settings.value(TAICHI_ARCH)
    except (ValueError, UsageError):
        given = arch or settings.get(TAICHI_ARCH)
        raise TaichiSettingError(f"unknown Taichi arch {given.strip().lower()!r}",
                                 "use cpu, gpu or cuda (--arch, or BENCHBOT_TAICHI_ARCH)") from None
    if _INIT_ARCH is not None:
        if (want == "cpu") != (_INIT_ARCH == "cpu") and not (want != "cpu" and _INIT_ARCH == "cpu-fallback"):
            warnings.warn(f"Taichi is already initialised on {_INIT_ARCH}; ignoring the request for {want}",
                          RuntimeWarning, stacklevel=2)
        return "cpu" if _INIT_ARCH.startswith("cpu") else _INIT_ARCH
    with contextlib.redirect_stdout(sys.stderr):  # "[Taichi] Starting on arch=..." is printed on stdout
        _INIT_ARCH = _init(want)
    _INIT_THREAD = threading.current_thread()
    if _INIT_ARCH == "cuda" and threading.current_thread() is not threading.main_thread():
        # The CUDA context is current only on this thread: release Taichi here when this thread ends, or the
        # interpreter's exit (on the main thread) would synchronise a context it does not hold and abort.
        _THIS_THREAD.release = _ReleaseTaichiAtThreadExit()
    return "cpu" if _INIT_ARCH.startswith("cpu") else _INIT_ARCH


_THIS_THREAD = threading.local()


class _ReleaseTaichiAtThreadExit:
    """Held in the Taichi thread's thread-local storage; Python drops it on that thread as the thread ends."""

    def __del__(self) -> None:
        release_taichi()


def release_taichi() -> None:
    """Reset Taichi (``ti.reset``: every field, ndarray and compiled kernel is freed; after it, dropping an ndarray
    frees nothing, on any thread) and forget the arch, so that the next :func:`ensure_taichi` initialises it again on
    the calling thread. Every :class:`Renderer` made before is unusable. Called on a non-main Taichi thread as it
    ends (CUDA), and by the tests between the backend thread's episodes and the main thread's renders (CPU)."""
    global _INIT_ARCH, _INIT_THREAD
    try:
        ti.reset()
    finally:
        _INIT_ARCH, _INIT_THREAD = None, None
        reset_graph()
        with _RETIRE_LOCK:
            _DEVICE_ARRAYS.clear()
            _RETIRED.clear()


def initialised_on_another_thread() -> bool:
    """Whether Taichi was initialised on a thread other than the calling one (Taichi's LLVM context then refuses to
    build fields on this thread: "Assertion failure: std::this_thread::get_id() == main_thread_id_"; call
    :func:`release_taichi` first when that thread no longer uses Taichi)."""
    return _INIT_ARCH is not None and _INIT_THREAD is not threading.current_thread()


def _init(want: str) -> str:
    """``ti.init`` for ``want`` (``cpu``/``gpu``/``cuda``), its banner kept in :data:`TAICHI_BANNER`; returns
    ``cpu``, ``cuda`` or ``cpu-fallback``."""
    banner = io.StringIO()
    try:
        with contextlib.redirect_stdout(banner):
            return _init_quietly(want)
    finally:
        TAICHI_BANNER.extend(line for line in banner.getvalue().splitlines() if line.strip())


def _init_quietly(want: str) -> str:
    use_brief_positions()
    use_quick_compiles()
    if want == "cpu":
        ti.init(arch=ti.cpu, default_fp=ti.f32, offline_cache=True, log_level=ti.WARN, **_cpu_threads())
        return "cpu"
    try:
        ti.init(arch=ti.cuda, default_fp=ti.f32, offline_cache=True, log_level=ti.ERROR)
        got = ti.lang.impl.current_cfg().arch
    except Exception:  # noqa: BLE001 - any CUDA failure means CPU
        got = None
    if got == ti.cuda:
        return "cuda"
    warnings.warn("CUDA is not available to Taichi; rendering on the CPU", RuntimeWarning, stacklevel=3)
    ti.init(arch=ti.cpu, default_fp=ti.f32, offline_cache=True, log_level=ti.WARN, **_cpu_threads())
    return "cpu-fallback"


def _cpu_threads() -> dict:
    """``{'cpu_max_num_threads': n}`` from ``BENCHBOT_TAICHI_THREADS`` (set by batch workers so that N parallel
    episodes share the cores instead of each starting one thread per core), else ``{}`` (Taichi's default: all)."""
    try:
        n = settings.value(TAICHI_THREADS)
    except UsageError as exc:
        raise TaichiSettingError(exc.message, "set it to the simulator's threads per process, e.g. 2, or unset it"
                                 ) from None
    if n is None:
        return {}
    return {"cpu_max_num_threads": n}


def intrinsics(width: int, height: int, horizontal_fov_deg: float) -> np.ndarray:
    """Pinhole K (3, 3) float64 with square pixels, ``fx = (W/2) / tan(hfov/2)``, principal point at the image
    centre ``((W-1)/2, (H-1)/2)`` (pixel centres are integers)."""
    fx = (width / 2.0) / math.tan(math.radians(horizontal_fov_deg) / 2.0)
    return np.array([[fx, 0.0, (width - 1) / 2.0], [0.0, fx, (height - 1) / 2.0], [0.0, 0.0, 1.0]])


def pack_scene(scene) -> dict:
    """The scene as the flat float32/int32 arrays the kernels read (primitives in BVH order).

    Returns:
        ``nodes`` (max(I, 1), 16) float32, the BVH as the kernels read it (:func:`~benchbot_sim_taichi.render.bvh.wide_nodes`),
        and ``nodes_f`` (M, 6) float32 / ``nodes_i`` (M, 3) int32, its depth-first nodes (see
        :mod:`benchbot_sim_taichi.render.bvh`); leaves of plain triangles only are flagged; ``cluster_box`` (C, 6) float32
        and ``cluster_prims`` (C, 2) int32 [first, count], the BVH's clusters of at most ``raster.CLUSTER_PRIMS``
        primitives (:func:`~benchbot_sim_taichi.render.bvh.clusters`; one empty cluster without primitives);
        ``is_occluder`` (max(P, 1),) int32 1 for the triangles of at least ``raster.OCCLUDER_AREA_M2``, which the
        rasteriser draws first, ``occluders`` their indices (one −1 for none) and ``n_occluders`` how many;
        ``pf`` (max(P,1), 11) float32 [min xyz, max xyz, linear albedo rgb, roughness, metallic (glTF factors; a
        primitive or a triangle without material: 1, 0)]; ``pi`` (max(P,1), 4) int32 [kind (the scene's, or
        ``kernels.GLASS`` for a window pane), a cylinder's axis or a triangle's row of ``tris`` (k), class, instance];
        ``tris`` (max(P,1), 9) float32 vertices: row k is primitive k's, when it is a triangle (``pi[k, 1]`` is
        then k; the other rows are zeros; (1, 9) without triangles); ``shade`` (rows as ``tris``) float32
        (SHADE_COLS columns) per triangle [vertex normals (9), UVs (6), texture index
        (−1: none), texture LOD offset]; ``texels``
        (max(N,1),) int32 packed sRGB ``r | g << 8 | b << 16``; ``tex_info`` (max(X,1), 4) int32 (as
        ``Scene.tex_info``); ``tex_lut`` (256,) float32 sRGB byte → linear; ``lights`` (max(L,1), LIGHT_COLS)
        float32 [kind, vec xyz, colour rgb, range, lamp-map slot (−1 here; :meth:`Renderer.set_scene` assigns
        slots)]; ``world`` (19,) float32 [room min xyz, room max xyz, floor/wall/ceiling albedo
        (9), ambient rgb, background class]; ``n_prims``, ``n_lights`` ints; ``order`` (P,) the scene's primitive
        index of each packed primitive.

    Raises:
        ValueError: the BVH is deeper than the kernels' stack.
    """
    from benchbot_sim_taichi.render.bvh import build_bvh, bvh_depth, clusters, wide_nodes
    from benchbot_worlds.scene.meshes import face_normals

    n, nl = int(scene.prim_type.shape[0]), int(scene.light_kind.shape[0])
    nodes_f, nodes_i, order = build_bvh(scene.prim_min, scene.prim_max)
    if bvh_depth(nodes_i) >= STACK:
        raise ValueError(f"BVH too deep ({bvh_depth(nodes_i)} levels, the kernels' stack holds {STACK})")
    nt = int(scene.tri_v.shape[0])
    tri_mat = np.asarray(scene.tri_material, np.int64).reshape(-1)
    if tri_mat.shape[0] != nt:
        tri_mat = np.full(nt, -1, np.int64)
    mat_albedo = np.asarray(scene.mat_albedo, np.float32).reshape(-1, 3)
    pf = np.zeros((max(n, 1), 11), dtype=np.float32)
    pf[:, 9] = 1.0
    pi = np.zeros((max(n, 1), 4), dtype=np.int32)
    if n:
        obj = scene.prim_object[order]
        albedo = scene.prim_albedo[order].astype(np.float32)
        kind, axis = scene.prim_type[order], scene.prim_axis[order]
        if nt and mat_albedo.shape[0]:  # a triangle with a material takes the material's colour
            tri = kind == 3
            m = np.full(n, -1, np.int64)
            m[tri] = tri_mat[axis[tri]]
            albedo[m >= 0] = mat_albedo[m[m >= 0]]
            has = m >= 0
            for col, factors, default in ((9, scene.mat_roughness, 1.0), (10, scene.mat_metallic, 0.0)):
                factors = np.asarray(factors, np.float32).reshape(-1)
                if factors.shape[0] == mat_albedo.shape[0]:  # NaN (a malformed asset) reads as the default
                    pf[:n, col][has] = np.clip(np.nan_to_num(factors[m[has]], nan=default), 0.0, 1.0)
        pf[:n, 0:3], pf[:n, 3:6], pf[:n, 6:9] = scene.prim_min[order], scene.prim_max[order], albedo
        pi[:n, 0], pi[:n, 1] = np.where(scene.prim_glass()[order], GLASS, kind), axis
        is_obj = obj >= 0
        safe = np.where(is_obj, obj, 0)
        pi[:n, 2] = np.where(is_obj, scene.box_class[safe] if scene.n_boxes else 0, scene.background_class)
        pi[:n, 3] = np.where(is_obj, scene.box_instance[safe] if scene.n_boxes else 0, 0)
    count = nodes_i[:, 0].astype(np.int64)
    tri_only = np.zeros(count.shape, bool)  # leaves of plain triangles only: the traversal reads no kinds there
    if n:
        plain = np.concatenate([[0], np.cumsum(pi[:n, 0] == 3)])
        first = np.where(count > 0, nodes_i[:, 1], 0).astype(np.int64)
        tri_only = (count > 0) & (plain[first + count] - plain[first] == count)
    nodes = wide_nodes(nodes_f, nodes_i, tri_only)
    cluster_box, cluster_prims = clusters(nodes_f, nodes_i, CLUSTER_PRIMS)
    if cluster_prims.shape[0] == 0:  # no primitive: one empty cluster (the kernels' arrays have a row at least)
        cluster_box, cluster_prims = np.zeros((1, 6), np.float32), np.zeros((1, 2), np.int32)
    tris = np.zeros((max(nt, 1), 9), dtype=np.float32)
    shade = np.zeros((max(nt, 1), SHADE_COLS), dtype=np.float32)
    shade[:, 15] = -1.0
    tex_info = np.asarray(scene.tex_info, np.int32).reshape(-1, 4)
    if nt:
        tv = scene.tri_v.reshape(nt, 3, 3).astype(np.float64)
        tris[:nt] = tv.reshape(nt, 9)
        tn = np.asarray(scene.tri_n, np.float32)
        if tn.shape != (nt, 3, 3):
            tn = np.repeat(face_normals(tv)[:, None, :], 3, axis=1)
        shade[:nt, 0:9] = tn.reshape(nt, 9)
        uv = np.asarray(scene.tri_uv, np.float32)
        if uv.shape == (nt, 3, 2):
            shade[:nt, 9:15] = uv.reshape(nt, 6)
        mat_tex = np.asarray(scene.mat_texture, np.int64).reshape(-1)
        if mat_tex.shape[0] and tex_info.shape[0]:
            has = tri_mat >= 0
            tex = np.full(nt, -1, np.int64)
            tex[has] = mat_tex[tri_mat[has]]
            shade[:nt, 15] = tex
            t = np.flatnonzero(tex >= 0)
            if t.size:  # LOD offset: 0.5·log2(texels per unit of world area) of each textured triangle
                area = 0.5 * np.linalg.norm(np.cross(tv[t, 1] - tv[t, 0], tv[t, 2] - tv[t, 0]), axis=1)
                uvt = uv[t].astype(np.float64)
                e1, e2 = uvt[:, 1] - uvt[:, 0], uvt[:, 2] - uvt[:, 0]
                uv_area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
                wh = tex_info[tex[t], 1].astype(np.float64) * tex_info[tex[t], 2]
                shade[t, 16] = 0.5 * np.log2(np.maximum(wh * uv_area, 1e-30) / np.maximum(area, 1e-30))
    if n and nt:  # a triangle's rows at its primitive's index, in BVH order: no indirection in the traversal
        tri_k = np.flatnonzero(pi[:n, 0] >= 3)  # triangles and panes
        if tri_k.size:
            j = pi[tri_k, 1].astype(np.int64)
            by_prim = np.zeros((n, 9), np.float32), np.zeros((n, SHADE_COLS), np.float32)
            by_prim[1][:, 15] = -1.0
            by_prim[0][tri_k], by_prim[1][tri_k] = tris[j], shade[j]
            tris, shade = by_prim
            pi[tri_k, 1] = tri_k
    texels8 = np.asarray(scene.tex_texels, np.uint8).reshape(-1, 3).astype(np.int32)
    texels = np.zeros(max(texels8.shape[0], 1), dtype=np.int32)
    texels[:texels8.shape[0]] = texels8[:, 0] | (texels8[:, 1] << 8) | (texels8[:, 2] << 16)
    info = np.zeros((max(tex_info.shape[0], 1), 4), dtype=np.int32)
    info[:tex_info.shape[0]] = tex_info
    lights = np.zeros((max(nl, 1), LIGHT_COLS), dtype=np.float32)
    lights[:, 8] = -1.0
    if nl:
        lights[:nl, 0] = scene.light_kind
        lights[:nl, 1:4], lights[:nl, 4:7], lights[:nl, 7] = scene.light_vec, scene.light_colour, scene.light_range
    world = np.zeros(L.WORLD_LEN, np.float32)
    world[L.WORLD_ROOM_MIN:L.WORLD_ROOM_MIN + 3] = scene.room_min
    world[L.WORLD_ROOM_MAX:L.WORLD_ROOM_MAX + 3] = scene.room_max
    world[L.WORLD_SHELL_ALBEDO:L.WORLD_SHELL_ALBEDO + 9] = np.asarray(scene.shell_albedo).reshape(-1)
    world[L.WORLD_AMBIENT:L.WORLD_AMBIENT + 3] = scene.ambient
    world[L.WORLD_BACKGROUND_CLASS] = scene.background_class
    is_occluder = np.zeros(max(n, 1), np.int32)  # triangles large enough to hide much: rasterised first
    if n and nt:  # (tris is in primitive order now)
        tk = np.flatnonzero(pi[:n, 0] == 3)
        area = 0.5 * np.linalg.norm(np.cross(tris[tk, 3:6] - tris[tk, 0:3], tris[tk, 6:9] - tris[tk, 0:3]), axis=1)
        is_occluder[tk[area >= OCCLUDER_AREA_M2]] = 1
    occluders = np.flatnonzero(is_occluder).astype(np.int32)
    return {"nodes": nodes, "nodes_f": nodes_f, "nodes_i": nodes_i, "cluster_box": cluster_box,
            "cluster_prims": cluster_prims, "occluders": occluders if occluders.size else np.full(1, -1, np.int32),
            "n_occluders": int(occluders.size), "is_occluder": is_occluder, "pf": pf, "pi": pi,
            "tris": tris, "shade": shade, "texels": texels, "tex_info": info, "tex_lut": texture_lut(),
            "lights": lights, "world": world, "n_prims": n, "n_lights": nl, "order": order}


@functools.lru_cache(maxsize=1)
def texture_lut() -> np.ndarray:
    """(256,) float32 (cached: do not modify): linear value of each sRGB byte, ``(i / 255) ** 2.2`` (the gamma of
    :func:`benchbot_worlds.scene.model.srgb_to_linear`)."""
    return np.power(np.arange(256, dtype=np.float64) / 255.0, 2.2).astype(np.float32)


def render_params(shadow_samples: int = 1, seed: int = 0, sun_radius: float = SUN_RADIUS,
                  lamp_radius: float = LAMP_RADIUS, spp: int = 1, bounces: int = 0,
                  roulette_from: int = 3) -> np.ndarray:
    """(PARAMS_LEN,) float32 render parameters at their offsets (:mod:`~benchbot_sim_taichi.render.layouts`,
    ``P_*``): shadow samples, sun angular radius rad, lamp radius m, seed, spp, most bounces of a path, first bounce
    of Russian roulette (the last three for ``quality`` mode:
    :func:`~benchbot_sim_taichi.render.pathtrace.quality_kernel`)."""
    out = np.zeros(L.PARAMS_LEN, np.float32)
    out[L.P_SHADOW_SAMPLES] = max(1, int(shadow_samples))
    out[L.P_SUN_RADIUS], out[L.P_LAMP_RADIUS] = sun_radius, lamp_radius
    out[L.P_SEED] = int(seed) % (1 << 24)
    out[L.P_SPP], out[L.P_BOUNCES], out[L.P_ROULETTE_FROM] = max(1, int(spp)), max(0, int(bounces)), max(1, int(roulette_from))
    return out


def camera_params(K: np.ndarray, T_map_camera: np.ndarray) -> np.ndarray:
    """(CAM_LEN,) float32 camera row for the kernels (:mod:`~benchbot_sim_taichi.render.layouts`, ``CAM_*``): R
    row-major (optical frame into map), origin (m, map), fx, fy, cx, cy (pixels)."""
    K = np.asarray(K, dtype=np.float64)
    T = np.asarray(T_map_camera, dtype=np.float64)
    out = np.zeros(L.CAM_LEN, np.float64)
    out[L.CAM_R:L.CAM_R + 9], out[L.CAM_ORIGIN:L.CAM_ORIGIN + 3] = T[:3, :3].reshape(-1), T[:3, 3]
    out[L.CAM_FX], out[L.CAM_FY], out[L.CAM_CX], out[L.CAM_CY] = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    return out.astype(np.float32)




def sensor_pose(T_map_camera: np.ndarray | None, T_map_lidar: np.ndarray | None) -> np.ndarray:
    """(16,) float32 [camera R row-major (9), camera origin (3), lidar x, y, z, yaw] (map frame; the camera in its
    optical frame; the lidar assumed level, its yaw read from its x axis). A missing sensor's entries are zero."""
    out = np.zeros(L.POSE_LEN, dtype=np.float64)
    if T_map_camera is not None:
        T = np.asarray(T_map_camera, dtype=np.float64)
        out[L.CAM_R:L.CAM_R + 9], out[L.CAM_ORIGIN:L.CAM_ORIGIN + 3] = T[:3, :3].reshape(-1), T[:3, 3]
    if T_map_lidar is not None:
        T = np.asarray(T_map_lidar, dtype=np.float64)
        out[L.POSE_LIDAR_XYZ:L.POSE_LIDAR_XYZ + 3], out[L.POSE_LIDAR_YAW] = T[:3, 3], math.atan2(T[1, 0], T[0, 0])
    return out.astype(np.float32)




def frame_constants(world: np.ndarray, params: np.ndarray, K: np.ndarray | None,
                    camera: CameraModel = DEFAULT_CAMERA) -> np.ndarray:
    """(FRAME_TONE_TABLE + TABLE_STEPS,) float32 frame constants (:mod:`~benchbot_sim_taichi.render.layouts`,
    ``FRAME_*``): the world row (see :func:`pack_scene`), the render parameters (see :func:`render_params`), fx, fy,
    cx, cy, the camera model's 1/radiance_max and vignetting, its tone table
    (:func:`~benchbot_sim_taichi.render.camera_model.tone_table`) — what
    :func:`~benchbot_sim_taichi.render.sensors.sensors_kernel` reads besides the scene and the poses (zeros for K
    when None)."""
    table = tone_table(camera)
    out = np.zeros(L.FRAME_TONE_TABLE + len(table), np.float64)
    out[L.FRAME_WORLD:L.FRAME_WORLD + L.WORLD_LEN] = world
    out[L.FRAME_PARAMS:L.FRAME_PARAMS + L.PARAMS_LEN] = params
    if K is not None:
        out[L.FRAME_INTRINSICS:L.FRAME_INTRINSICS + 4] = np.asarray(K, dtype=np.float64)[[0, 1, 0, 1], [0, 1, 2, 2]]
    out[L.FRAME_RADIANCE_SCALE], out[L.FRAME_VIGNETTING] = camera.frame_constants()
    out[L.FRAME_TONE_TABLE:] = table
    return out.astype(np.float32)



# ---------------------------------------------------------------------------------------------------------- renderer
#: The packed scene's arrays that only the host reads (``Renderer.prepared_scene`` keeps them, with the scene's
#: arrays: :class:`~benchbot_sim_taichi.render.scene_arrays.SceneArrays`).
_HOST_ONLY = ("nodes_f", "nodes_i", "order")
#: The scene's arrays that ``Renderer._packed`` (the host's packed scene) holds: all but those computed in
#: ``set_scene``, and the shadow maps (zeros there, traced where the kernels read them; a prepared scene's as traced).
_IN_PACKED = SceneArrays.arrays(computed=False) + ("lamp_maps", "sun_map")


def _plan_sun_map(packed: dict) -> tuple[int | None, float]:
    """Plan the sun map of a packed scene (:func:`pack_scene`'s dict, modified in place): the first directional
    light's row gets map slot 0 and the map's projection (``kernels.LIGHT_COLS``): two unit vectors orthogonal to
    the light, scaled by 1/texel, and offsets, such that the box of every primitive (the BVH's root, padded by two
    texels) projects onto ``SUN_MAP_RES``² square texels. Returns (that row, the height ``top`` along the light of a
    plane above every primitive), or (None, 0.0) when the scene has no directional light, no primitive, or a
    directional light without a finite, non-zero direction."""
    lights, n = packed["lights"], packed["n_lights"]
    rows = np.flatnonzero(lights[:n, 0] == 0)
    if rows.size == 0 or packed["n_prims"] == 0:
        return None, 0.0
    j = int(rows[0])
    l = lights[j, 1:4].astype(np.float64)
    if not np.isfinite(l).all() or np.linalg.norm(l) < 1e-9:  # no direction to project along: shadow rays instead
        return None, 0.0
    l /= np.linalg.norm(l)
    helper = np.array([0.0, 1.0, 0.0]) if abs(l[0]) > 0.9 else np.array([1.0, 0.0, 0.0])
    t1 = np.cross(l, helper)
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(l, t1)
    lo, hi = packed["nodes_f"][0, :3].astype(np.float64), packed["nodes_f"][0, 3:6].astype(np.float64)
    corners = np.array([[(lo, hi)[(c >> a) & 1][a] for a in range(3)] for c in range(8)])
    u, v, h = corners @ t1, corners @ t2, corners @ l
    texel = max(u.max() - u.min(), v.max() - v.min(), 1e-3) / (SUN_MAP_RES - 4)
    lights[j, 1:4], lights[j, 8] = l, 0
    lights[j, 9:12], lights[j, 12:15] = t1 / texel, t2 / texel
    lights[j, 15], lights[j, 16] = u.min() / texel - 2.0, v.min() / texel - 2.0
    return j, float(h.max() + 1.0)


# Taichi ndarrays must be freed on Taichi's thread: on CUDA the context is current only there, and freeing GPU
# memory from any other thread aborts the process (CUDA_ERROR_INVALID_CONTEXT). A Renderer may be dropped on any
# thread (or collected there by the cyclic garbage collector), so the ndarrays it makes are also held here; a dropped
# Renderer's arrays are retired, and retired arrays are released by :func:`_free_retired` on Taichi's thread once
# nothing else refers to them.
_DEVICE_ARRAYS: dict[int, object] = {}
_RETIRED: list = []
_RETIRE_LOCK = threading.Lock()


def _new_device_array(dtype, shape: tuple):
    """A new Taichi ndarray of ``dtype`` (NumPy dtype: uint8, int32, int64 or float32) and ``shape`` (zeroed), in the arch's
    memory (GPU memory on CUDA), held until :func:`_retire`. Call on Taichi's thread."""
    arr = ti.ndarray(dtype={np.dtype(np.uint8): ti.u8, np.dtype(np.float32): ti.f32, np.dtype(np.int32): ti.i32,
                            np.dtype(np.int64): ti.i64}[np.dtype(dtype)], shape=tuple(shape))
    _DEVICE_ARRAYS[id(arr)] = arr
    return arr


def _retire(arrays) -> None:
    """Mark ``arrays`` (ndarrays from :func:`_new_device_array`) as no longer used; any thread may call this."""
    with _RETIRE_LOCK:
        for arr in arrays:
            held = _DEVICE_ARRAYS.pop(id(arr), None)
            if held is not None:
                _RETIRED.append(held)


def _references(obj) -> int:
    return sys.getrefcount(obj)


#: What :func:`_references` reports, in the comprehension of :func:`_free_retired`, for an object that only a list
#: refers to (measured, as it differs between Python versions).
_ONLY_LISTED = [_references(obj) for obj in [object()]][0]


def _free_retired() -> int:
    """Release the retired ndarrays that only the retired list still refers to (call on Taichi's thread); returns
    how many remain retired because something else still refers to them."""
    if not _RETIRED:
        return 0
    with _RETIRE_LOCK:
        keep = [arr for arr in _RETIRED if _references(arr) > _ONLY_LISTED]
        freed, _RETIRED[:] = list(_RETIRED), keep
    del freed  # the last references of the others go here, on this thread
    return len(keep)


def _empty_outputs(B: int, H: int, W: int) -> dict:
    return {"rgb": np.zeros((B, H, W, 3), np.uint8), "depth": np.zeros((B, H, W), np.float32),
            "class": np.zeros((B, H, W), np.int32), "instance": np.zeros((B, H, W), np.int32)}


class Renderer:
    """Renders one scene at a time with Taichi. Use from a single thread.

    Args:
        arch: see :func:`ensure_taichi` (``None``: ``BENCHBOT_TAICHI_ARCH`` or ``'cpu'``).
        shadow_samples: shadow rays per light and pixel in ``fast`` mode (1: hard shadows; more: soft shadows over
            the light's disc).
        seed: seeds the sampling patterns (same seed → bit-identical images).
        device_buffers: keep the scene and the output images in Taichi ndarrays (in GPU memory on CUDA), so a
            launch copies nothing between host and device and runs the all-sensors kernels as one compiled graph
            (``None``, the default: on). ``False`` passes NumPy arrays to the kernels one by one (on the CPU only;
            Python then sets every kernel's arguments on every launch: ``benchmarks/cpu_paths.py`` compares the
            two).
        shadow_maps: with one shadow sample in ``fast`` mode, take the lamps' (point lights') shadows from cube
            shadow maps (``kernels.LAMP_MAP_RES``² texels a face) and the sun's (the first directional light's) from
            an orthographic map (``kernels.SUN_MAP_RES``² texels), all traced once per scene in :meth:`set_scene`,
            instead of one shadow ray per light and pixel. ``None`` (default): for furnished scenes (``scene.style
            == 'furnished'``: many lamps and triangles, where those rays cost most of a frame), not for primitive
            scenes (whose shadows stay exact, ray for ray). Soft shadows (``shadow_samples`` > 1) always use rays,
            and so does ``quality`` mode.
        baked_light: in ``fast`` mode, take the triangles' direct light from a lattice of points baked once per
            scene (:mod:`benchbot_sim_taichi.render.lightmap`) instead of summing the lights at each pixel. ``None``
            (default): when the lights' shadows come from shadow maps (then the light does not change from frame
            to frame); the room shell, boxes, ellipsoids and cylinders always sum their lights per pixel.
        camera: exposure, tone curve and vignetting (:class:`~benchbot_sim_taichi.render.camera_model.CameraModel`);
            the default is the image as it always was.
        denoise_device: where ``quality`` mode's denoiser runs (:func:`~benchbot_sim_taichi.render.denoiser.denoise_radiance`):
            ``'cpu'`` or ``'cuda'``; ``None`` (default): ``'cuda'`` when rendering on CUDA (falling back to the CPU,
            with a warning, if Open Image Denoise cannot start there), else ``'cpu'``.
    """

    def __init__(self, arch: str | None = None, *, shadow_samples: int = 1, seed: int = 0,
                 device_buffers: bool | None = None, shadow_maps: bool | None = None,
                 baked_light: bool | None = None, camera: CameraModel = DEFAULT_CAMERA,
                 denoise_device: str | None = None) -> None:
        self.arch = ensure_taichi(arch)
        self.denoise_device = denoise_device or ("cuda" if self.arch == "cuda" else "cpu")
        self._denoise_device_chosen = denoise_device is None
        self.camera = camera
        self._packed: dict | None = None
        self._every_light_mapped = False  # (of the current scene: see shadow_rays)
        self._scene: SceneArrays | None = None  # the current scene where the kernels read it
        self.shadow_samples = int(shadow_samples)
        self.seed = int(seed)
        self.device_buffers = True if device_buffers is None else bool(device_buffers)
        self._buffers: dict = {}
        self._work_arrays: dict = {}
        self._uploaded: dict = {}
        self._consts_key: tuple | None = None
        self._consts = None
        self._scene_buffers: list = []  # the device arrays of the current scene (retired with it)
        self.shadow_maps = shadow_maps
        self.baked_light = baked_light
        self.baked_points = 0  # lattice points of the current scene's baked light
        #: ``None``, or a callable taking a kernel's name and returning a context manager: the all-sensors kernels then
        #: run one by one inside it (not through the compiled graph), for ``benchmarks/sensors_kernels.py`` to time
        #: each (:func:`~benchbot_sim_taichi.render.sensors.sensors_kernel`'s ``timer``).
        self.kernel_timer = None
        self._pinned_copier = None  # render_sensors(to_host="pinned"): page-locked host arrays, made on first use
        self._render_copier = None  # render(): its own page-locked arrays (render_sensors' stay the caller's)

    def __del__(self) -> None:
        # may run on any thread: the device arrays are only retired here, and freed later on Taichi's thread
        try:
            _retire(list(getattr(self, "_buffers", {}).values()) + getattr(self, "_scene_buffers", [])
                    + [a for a in getattr(self, "_work_arrays", {}).values() if not isinstance(a, np.ndarray)])
        except (TypeError, AttributeError):  # at interpreter exit this module's globals may already be None
            pass

    def close(self) -> None:
        """Release the GPU memory of this renderer now (call on the thread that renders); it cannot render
        afterwards until :meth:`set_scene` is called again."""
        _retire(list(self._buffers.values()) + self._scene_buffers
                + [a for a in self._work_arrays.values() if not isinstance(a, np.ndarray)])
        self._buffers, self._uploaded, self._scene_buffers, self._work_arrays = {}, {}, [], {}
        self._packed = self._scene = self._consts = self._consts_key = None
        _free_retired()
        for copier in (self._pinned_copier, self._render_copier):
            if copier is not None:
                copier.close()
        self._pinned_copier = self._render_copier = None

    def set_scene(self, scene, prepared: dict | None = None) -> None:
        """Upload ``scene`` (a :class:`~benchbot_worlds.scene.model.Scene`); builds its BVH, traces its shadow maps
        and bakes its light. Later renders and scans use it. With device buffers, this is the only host-to-device
        copy of the scene.

        Args:
            scene: the scene.
            prepared: what :meth:`prepared_scene` returned for this scene with a renderer of the same
                :meth:`preparation_options` (read from :mod:`benchbot_sim_taichi.scene_cache`): then nothing is built,
                traced or baked, the arrays are uploaded as they are (only ``scene.style`` is read from ``scene``).

        Raises:
            ValueError: the BVH is too deep (:func:`pack_scene`); KeyError: ``prepared`` lacks an array.
        """
        _free_retired()
        if prepared is not None:
            self._set_prepared_scene(prepared)
            return
        with stages.stage("building the BVH"):
            packed = pack_scene(scene)
        use_maps = (getattr(scene, "style", "") == "furnished") if self.shadow_maps is None else bool(self.shadow_maps)
        lamps = np.flatnonzero(packed["lights"][:packed["n_lights"], 0] == 1) if use_maps else np.zeros(0, np.int64)
        packed["lights"][lamps, 8] = np.arange(lamps.size)
        res = LAMP_MAP_RES if lamps.size else 1
        packed["lamp_maps"] = np.zeros((6 * max(lamps.size, 1), res, res), np.float32)
        sun, top = _plan_sun_map(packed) if use_maps else (None, 0.0)
        res = SUN_MAP_RES if sun is not None else 1
        packed["sun_map"] = np.zeros((res, res), np.float32)
        packed["light_of_slot"] = lamps.astype(np.int32) if lamps.size else np.full(1, -1, np.int32)
        self._packed = packed
        self._every_light_mapped = bool((packed["lights"][:packed["n_lights"], 8] >= 0).all())
        self._retire_scene()
        arrays = {k: self._scene_array(packed[k]) for k in _IN_PACKED}  # where the kernels read them
        if lamps.size or sun is not None:  # the lamps' and the sun's shadow maps, traced once per scene
            with stages.stage("tracing shadow maps", detail=f"{lamps.size} lamps" + (" and the sun" if sun is not None
                                                                                    else "")):
                if lamps.size:
                    launch(lamp_map_kernel, arrays)
                if sun is not None:
                    launch(sun_map_kernel, arrays, j=sun, top=top)
        always, grid, xform = self._light_grid(arrays, lamps.size)
        arrays.update(always=self._scene_array(always if always.size else np.full(1, -1, np.int32)),
                      light_grid=self._scene_array(grid), grid_xform=self._scene_array(xform))
        bake = (lamps.size > 0 or sun is not None) and self.shadow_samples <= 1 \
            if self.baked_light is None else bool(self.baked_light)
        arrays.update(self._bake(arrays, always.shape[0], bake))
        self._scene = SceneArrays(**arrays, n_lights=packed["n_lights"], n_always=always.shape[0],
                                  n_occluders=packed["n_occluders"])

    def _set_prepared_scene(self, prepared: dict) -> None:
        """:meth:`set_scene` from :meth:`prepared_scene`'s arrays: upload them, trace and bake nothing."""
        arrays = {k: np.asarray(prepared[k]) for k in SceneArrays.arrays()}
        packed = {k: arrays[k] for k in _IN_PACKED}
        packed.update({k: np.asarray(prepared[k]) for k in _HOST_ONLY})
        packed.update({k: int(prepared[k]) for k in ("n_prims", "n_lights", "n_occluders")})
        self._packed = packed
        self._every_light_mapped = bool((packed["lights"][:packed["n_lights"], 8] >= 0).all())
        self._retire_scene()
        self.baked_points = int(prepared["baked_points"])
        self._scene = SceneArrays(**{k: self._scene_array(a) for k, a in arrays.items()},
                                  **{k: int(prepared[k]) for k in SceneArrays.counts()})

    def _retire_scene(self) -> None:
        """Retire the last scene's device arrays (a new scene is being set)."""
        _retire(self._scene_buffers)
        self._scene_buffers, self._scene = [], None

    def preparation_options(self) -> dict:
        """What, besides the scene, decides :meth:`prepared_scene`'s arrays: ``{arch, shadow_samples, seed,
        shadow_maps, baked_light, taichi}`` (JSON-ready; part of the scene cache's key)."""
        return {"arch": self.arch, "shadow_samples": self.shadow_samples, "seed": self.seed,
                "shadow_maps": self.shadow_maps, "baked_light": self.baked_light,
                "taichi": ".".join(str(v) for v in ti.__version__)}

    def prepared_scene(self) -> dict[str, np.ndarray]:
        """Everything :meth:`set_scene` made of the current scene, as host NumPy arrays that :meth:`set_scene`
        takes back (``prepared=``) instead of building it again: the packed scene (:func:`pack_scene`'s arrays, the
        BVH among them, with the lamps' map slots and the sun map's projection), the traced shadow maps
        (``lamp_maps``, ``sun_map``), the light lists (``n_always``, ``always``, ``light_grid``, ``grid_xform``) and the
        baked light (``baked``, ``baked_info``, ``baked_points``); counts as 0-d int64 arrays. Copies: the caller owns
        them. For :mod:`benchbot_sim_taichi.scene_cache`.

        Raises:
            RuntimeError: no scene is set.
        """
        packed, scene = self._need_scene(), self._scene
        out = {k: np.array(packed[k]) for k in SceneArrays.arrays(computed=False) + _HOST_ONLY}
        out.update(self._fetch({k: getattr(scene, k) for k in SceneArrays.arrays(computed=True)}, once=True))
        out.update({k: np.array(getattr(scene, k), np.int64) for k in SceneArrays.counts()})
        out["n_prims"] = np.array(packed["n_prims"], np.int64)
        out["baked_points"] = np.array(self.baked_points, np.int64)
        return {k: np.asarray(v) for k, v in out.items()}

    def _pack_for_sensors(self) -> tuple:
        """The current scene's arrays packed for CUDA's all-sensors kernels (:mod:`benchbot_sim_taichi.render.packed_scene`),
        where they read them: ``(scene_f32, scene_i32)``, made by the first launch that needs them. The arrays that
        kernels computed in :meth:`set_scene` (shadow maps, baked light) and the light lists are copied from where
        the kernels read them; the others are taken from the packed scene."""
        named = {k: self._packed[k] for k in SceneArrays.arrays(packed=True, computed=False)}
        named.update(self._fetch({k: getattr(self._scene, k) for k in SceneArrays.arrays(packed=True, computed=True)},
                                 once=True))
        return tuple(self._scene_array(a) for a in pack_for_sensors(named))

    def _bake(self, arrays: dict, n_always: int, bake: bool) -> dict:
        """The current scene's baked direct light (:mod:`benchbot_sim_taichi.render.lightmap`): ``{"baked": store,
        "baked_info": info}`` where the kernels read them, baked now when ``bake`` (``arrays``: the scene's arrays so
        far, by name; ``n_always``: its count of always-summed lights); else an empty store and every triangle
        unbaked (per-pixel light)."""
        packed = self._packed
        n = packed["n_prims"]
        kinds = packed["pi"][:n, 0] if bake else np.zeros(n, np.int32)  # kinds 0: no triangle is baked
        info, starts = lightmap_layout(packed["tris"], kinds)
        store = np.zeros(max(int(starts[-1]), 1), np.int32)
        self.baked_points = int(starts[-1])
        store, info_arr = self._scene_array(store), self._scene_array(info)
        if starts[-1] > 0:
            params = self._upload("bake_params", render_params(self.shadow_samples, self.seed))
            with stages.stage("baking light", detail=f"{int(starts[-1]):,} points"):
                launch(bake_kernel, arrays, starts=self._upload("bake_starts", starts.astype(np.int64)), params=params,
                       n_always=n_always, baked_info=info_arr, baked=store)
        return {"baked": store, "baked_info": info_arr}

    def _scene_array(self, a: np.ndarray) -> object:
        """``a`` where the kernels read it for the current scene: a new device array (freed with the scene) with
        device buffers, else ``a`` itself."""
        if not self.device_buffers:
            return a
        arr = _new_device_array(a.dtype, a.shape)
        arr.from_numpy(np.ascontiguousarray(a))
        self._scene_buffers.append(arr)
        return arr

    def _light_grid(self, arrays: dict, n_maps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The current scene's light lists for :func:`~benchbot_sim_taichi.render.kernels._direct`: ``(always (A,) int32,
        grid (NY, NX, words) int32, xform (4,) float32)``. With lamp shadow maps and one shadow sample, ``always``
        holds the lights without a map (the sun) and the grid, over the xy extent of the room shell and the
        primitives and a cell more on each side, in cells of ``kernels.LIGHT_CELL_M``, a bit for each lamp in each cell where its map may let it
        light a point: the cells that :func:`~benchbot_sim_taichi.render.kernels.light_grid_kernel` marks, grown by the
        distance its docstring names. Otherwise every light is in ``always`` and the grid is empty (words = 0)."""
        packed = self._packed
        n = packed["n_lights"]
        lamp = (packed["lights"][:n, 0] == 1) & (packed["lights"][:n, 8] >= 0)
        if n_maps == 0 or self.shadow_samples > 1 or not lamp.any():
            return np.arange(n, dtype=np.int32), np.zeros((1, 1, 1), np.int32), np.zeros(4, np.float32)
        world = packed["world"]
        # a cell more on each side: the shell's walls lie on the extent's edges, and rounding puts points just out
        room_lo, room_hi = world[L.WORLD_ROOM_MIN:L.WORLD_ROOM_MIN + 2], world[L.WORLD_ROOM_MAX:L.WORLD_ROOM_MAX + 2]
        lo = np.minimum(room_lo, packed["nodes_f"][0, 0:2]).astype(np.float64) - LIGHT_CELL_M
        hi = np.maximum(room_hi, packed["nodes_f"][0, 3:5]).astype(np.float64) + LIGHT_CELL_M
        nx, ny = (np.floor((hi - lo) / LIGHT_CELL_M).astype(int) + 1).tolist()
        words = (n_maps + 31) // 32
        xform = np.array([lo[0], lo[1], 1.0 / LIGHT_CELL_M, words], np.float32)
        marked = self._buffer("light_grid_marks", (ny, nx, words), np.int32) if self.device_buffers \
            else np.zeros((ny, nx, words), np.int32)
        if self.device_buffers:
            marked.fill(0)
        launch(light_grid_kernel, arrays, grid_xform=self._upload("light_grid_xform", xform), block=LIGHT_GRID_BLOCK,
               step=LIGHT_GRID_STEP, grid=marked)
        marked = self._fetch({"marks": marked})["marks"]  # (not to_numpy: its first call compiles a copy kernel,
        # which leaves the ndarray in a reference cycle for the collector to free on any thread)
        reach = float(packed["lights"][:n, 7][lamp].max())
        R = LAMP_MAP_RES
        grow = (LIGHT_GRID_STEP / 2 + reach * LIGHT_GRID_BLOCK * math.sqrt(2.0) / R  # the block's cone
                + SHADOW_OFFSET + LAMP_MAP_NORMAL_OFFSET * reach * 2.0 / R)  # the lookup point's offset
        r = int(math.ceil(grow / LIGHT_CELL_M))
        grid = np.zeros_like(marked)
        padded = np.pad(marked, ((r, r), (r, r), (0, 0)))
        for dy in range(2 * r + 1):
            for dx in range(2 * r + 1):
                grid |= padded[dy:dy + ny, dx:dx + nx]
        always = np.flatnonzero(~lamp).astype(np.int32)
        return always, grid, xform

    @property
    def sun_map(self) -> bool:
        """Whether the current scene's sun takes its shadows from the sun map (False before :meth:`set_scene`)."""
        return self._packed is not None and bool(((self._packed["lights"][:, 0] == 0)
                                                  & (self._packed["lights"][:, 8] >= 0)).any())

    @property
    def shadow_rays(self) -> bool:
        """Whether fast mode's frames need the code of shadow rays: more than one shadow sample, or a light of the
        current scene without a shadow map. When not, the all-sensors work shades with
        :func:`~benchbot_sim_taichi.render.sensors.shade_maps_kernel` (the same images, faster)."""
        return self.shadow_samples > 1 or not self._every_light_mapped

    @property
    def lamps_with_maps(self) -> int:
        """How many of the current scene's lamps take their shadows from cube shadow maps (0 before
        :meth:`set_scene`)."""
        if self._packed is None:
            return 0
        return int(((self._packed["lights"][:, 0] == 1) & (self._packed["lights"][:, 8] >= 0)).sum())

    def _need_scene(self) -> dict:
        if self._packed is None:
            raise RuntimeError("Renderer.set_scene() has not been called")
        return self._packed

    def _kernel_scene(self) -> SceneArrays:
        """The current scene where the kernels read it."""
        self._need_scene()
        return self._scene

    def _buffer(self, name: str, shape: tuple, dtype) -> object:
        """The output/input buffer ``name`` of ``shape``: a reused Taichi ndarray with device buffers, else a new
        NumPy array."""
        if not self.device_buffers:
            return np.zeros(shape, dtype=dtype)
        key = (name, shape)
        if key not in self._buffers:
            self._buffers[key] = _new_device_array(dtype, shape)
        return self._buffers[key]

    def _work(self, name: str, shape: tuple, dtype, fill) -> object:
        """The kernels' work array ``name`` of ``shape`` holding ``fill`` when made, kept between launches (a
        Taichi ndarray with device buffers, else a NumPy array): the visibility buffers, which the sensors kernel
        leaves as it found them, and its lists and counters."""
        key = (name, shape)
        if key not in self._work_arrays:
            if len(self._work_arrays) >= 16:  # sizes changed often: drop the old ones
                _retire([a for a in self._work_arrays.values() if not isinstance(a, np.ndarray)])
                self._work_arrays = {}
            a = np.full(shape, fill, dtype)
            if self.device_buffers:  # (Ndarray.fill cannot take an int64 beyond int32)
                a, host = _new_device_array(dtype, shape), a
                a.from_numpy(host)
            self._work_arrays[key] = a
        return self._work_arrays[key]

    def _upload(self, name: str, a: np.ndarray, *, cached: bool = False) -> object:
        """``a`` where the kernels read it: copied into a reused device buffer, or ``a`` itself. ``cached``: skip
        the copy when the buffer already holds these values (beam angles, which rarely change)."""
        a = np.ascontiguousarray(a)
        if not self.device_buffers:
            return a
        buf = self._buffer(name, a.shape, a.dtype.type)
        if cached and np.array_equal(self._uploaded.get(name), a):
            return buf
        buf.from_numpy(a)
        self._uploaded[name] = a.copy() if cached else None
        return buf

    def _frame_constants(self, K) -> object:
        """:func:`frame_constants` for ``K`` and the current render settings, rebuilt (and uploaded) only when they
        change."""
        key = (None if K is None else np.asarray(K, dtype=np.float64).tobytes(), self.shadow_samples, self.seed,
               id(self._packed), self.camera)
        if self._consts_key != key:
            params = render_params(self.shadow_samples, self.seed)
            self._consts = self._upload("consts", frame_constants(self._packed["world"], params, K, self.camera))
            self._consts_key = key
        return self._consts

    def sync(self) -> None:
        """Wait for every launched kernel to finish (launches on CUDA are asynchronous; copies to the host wait
        by themselves)."""
        ti.sync()

    def wait_for_readers(self) -> None:
        """On CUDA, wait for all work queued in the GPU context on any stream — a consumer's, such as a PyTorch
        stream of its own still reading the buffers handed out without a copy (:mod:`.dlpack`) — so that the next
        launch does not write over a frame before it is read (``cuCtxSynchronize``; Taichi's own :meth:`sync` waits
        for its stream only, and work on non-blocking streams does not order against it). Nothing on the CPU.

        Raises:
            RuntimeError: the driver call failed (its CUDA error in the message).
        """
        if self.arch == "cuda":
            from benchbot_sim_taichi.render.host_copy import check, cuda_driver

            check("cuCtxSynchronize", cuda_driver().cuCtxSynchronize())

    def render_sensors(self, K: np.ndarray, T_map_cameras, width: int, height: int, T_map_lidars=None,
                       angles: np.ndarray | None = None, *, to_host: bool | str = True) -> dict:
        """Render B camera views (``fast`` mode) and, optionally, B planar laser scans, all in one launch of the
        all-sensors kernels (:func:`~benchbot_sim_taichi.render.sensors.sensors_kernel`).

        Args:
            K: (3, 3) intrinsics shared by the views. T_map_cameras: (B, 4, 4) optical-frame poses in ``map``.
            width, height: image size, pixels.
            T_map_lidars: (B, 4, 4) lidar poses (x forward, z up, assumed level), or ``None`` for no scans.
            angles: (N,) beam angles (rad, about each lidar's z from its +x); required with ``T_map_lidars``.
            to_host: ``True``: return new NumPy arrays (on CUDA copied through page-locked memory, then into new
                arrays: :meth:`_fetch`).
                ``"pinned"``: on CUDA, copy into page-locked NumPy arrays that the renderer makes once and reuses
                (:class:`~benchbot_sim_taichi.render.host_copy.HostCopier`: several times faster), valid until the next
                ``"pinned"`` call of the same sizes overwrites them — copy what you keep; on the CPU the same as
                ``True``. ``False`` leaves the outputs where the kernel wrote them — Taichi ndarrays with device
                buffers (in GPU memory on CUDA; ``.to_numpy()`` copies one), NumPy arrays otherwise — and returns
                without waiting for the GPU (see :meth:`sync`); such device outputs are overwritten by the next
                call of the same sizes.

        Returns:
            ``rgb`` (B, H, W, 3) uint8, ``depth`` (B, H, W) float32 z-depth metres, ``class``/``instance``
            (B, H, W) int32 (as :meth:`render`), and with lidars ``ranges`` (B, N) float32 metres.

        Raises:
            ValueError: lidars without angles, a lidar count different from the camera count, or an unknown
                ``to_host``.
            RuntimeError: a CUDA driver call of the ``"pinned"`` copy failed (its name and error).
        """
        if to_host not in (True, False, "pinned"):
            raise ValueError(f"render_sensors: to_host must be True, False or 'pinned', got {to_host!r}")
        Ts = np.asarray(T_map_cameras, dtype=np.float64).reshape(-1, 4, 4)
        Tl = None
        if T_map_lidars is not None:
            if angles is None:
                raise ValueError("render_sensors: T_map_lidars needs angles")
            Tl = np.asarray(T_map_lidars, dtype=np.float64).reshape(-1, 4, 4)
            if Tl.shape[0] != Ts.shape[0]:
                raise ValueError(f"render_sensors: {Tl.shape[0]} lidar poses for {Ts.shape[0]} camera poses")
        out = self._launch(K, Ts, int(width), int(height), Tl, angles, lit=True)
        if to_host == "pinned" and self.device_buffers and self.arch == "cuda":
            if self._pinned_copier is None:
                from benchbot_sim_taichi.render.host_copy import HostCopier

                self._pinned_copier = HostCopier(pinned=True)
            return self._pinned_copier.copy(out)
        if to_host and self.device_buffers:
            out = self._fetch(out)
        return out

    def render_batch(self, K: np.ndarray, T_map_cameras, width: int, height: int) -> dict[str, np.ndarray]:
        """Render B views of the scene in ONE kernel launch (``fast`` mode).

        Args:
            K: (3, 3) intrinsics shared by the views. T_map_cameras: (B, 4, 4) optical-frame poses.

        Returns:
            as :meth:`render` with a leading batch axis: ``rgb`` (B, H, W, 3) uint8, ``depth`` (B, H, W) float32,
            ``class``/``instance`` (B, H, W) int32 (NumPy arrays).
        """
        return self.render_sensors(K, T_map_cameras, width, height)

    def _launch(self, K, Ts, W: int, H: int, Tl, angles, *, lit: bool) -> dict:
        """One :func:`~benchbot_sim_taichi.render.sensors.sensors_kernel` launch (its kernels): images for the (B, 4, 4) camera poses
        ``Ts`` (none if ``K`` is None), scans for the lidar poses ``Tl`` (none if None) at beam ``angles``. Outputs
        stay in the renderer's buffers. ``lit=False`` skips the lights (no shadow rays: RGB is ambient only) for
        callers that only keep depth and segmentation, which do not depend on the lights."""
        self._need_scene()
        if _RETIRED:
            _free_retired()
        images = K is not None
        B = Ts.shape[0] if images else Tl.shape[0]
        n_beams = 0 if Tl is None else int(np.asarray(angles).size)
        if B == 0 or (Tl is not None and n_beams == 0):  # nothing to launch: empty NumPy outputs
            out = _empty_outputs(B, H, W) if images else {}
            if Tl is not None:
                out["ranges"] = np.zeros((B, 0), np.float32)
            return out
        shape = (B, H, W) if images else (1, 1, 1)
        out = {"rgb": self._buffer("rgb", shape + (3,), np.uint8), "depth": self._buffer("depth", shape, np.float32),
               "class": self._buffer("class", shape, np.int32), "instance": self._buffer("instance", shape, np.int32)}
        ranges = self._buffer("ranges", (B, max(n_beams, 1)), np.float32)
        poses = [sensor_pose(Ts[b] if images else None, None if Tl is None else Tl[b]) for b in range(B)]
        if B == 1:  # the pose travels by value: no upload (an upload costs a device round trip on CUDA)
            table, pose0, one = self._buffer("no_table", (1, POSE_LEN), np.float32), poses[0], 1
        else:
            table, pose0, one = self._upload("poses", np.stack(poses)), np.zeros(POSE_LEN, np.float32), 0
        beams = self._upload("beams", np.asarray(angles if n_beams else [0.0], dtype=np.float32).reshape(-1),
                             cached=True)
        consts = self._frame_constants(K)
        scene = self._kernel_scene()
        n_clusters = self._packed["cluster_prims"].shape[0]
        work = {"listed": self._work("listed", (B * n_clusters if images else 1,), np.int32, 0),
                "queue": self._work("queue", ((B if images else 1) * split()["queue_items"], QUEUE_COLS), np.int32, 0),
                "counters": self._work("counters", (COUNTERS,), np.int32, 0),
                "tiles": self._work("tiles", (shape[0], tile_entries(shape[2], shape[1])), np.float32, 0.0),
                "vis": self._work("vis", (2,) + shape, np.int64, EMPTY)}
        rays = self.shadow_rays
        names = launch_parameters(self.arch, rays)
        if "scene_f32" in names and scene.scene_f32 is None:  # (CUDA's kernels: the first launch of a scene)
            scene.scene_f32, scene.scene_i32 = self._pack_for_sensors()
        values = arguments(names, scene, dict(
            table=table, pose0=pose0, one=one, images=int(images), beams=beams, n_beams=n_beams, lit=int(lit),
            consts=consts, **work, rgb=out["rgb"], depth=out["depth"], cls=out["class"], inst=out["instance"],
            ranges=ranges))
        if self.device_buffers and self.kernel_timer is None:  # all Taichi ndarrays: launch the compiled graph
            values["pose0"] = ti.Vector(values["pose0"].tolist())
            sensors_graph(self.arch, rays).run(values)
        else:
            sensors_kernel(self.arch, values, self.kernel_timer, rays)
        if not images:
            out = {}
        if Tl is not None:
            out["ranges"] = ranges
        return out

    def render(self, K: np.ndarray, T_map_camera: np.ndarray, width: int, height: int,
               mode: str = "fast", spp: int = QUALITY_SPP, denoise: bool = True, T_map_lidar: np.ndarray | None = None,
               angles: np.ndarray | None = None, bounces: int = QUALITY_BOUNCES,
               samples_per_pixel: int = 1) -> dict[str, np.ndarray]:
        """Render one view and, with ``T_map_lidar``, the laser scan of the same instant in the same kernel launch.

        Args:
            K: (3, 3) pinhole intrinsics (pixels). T_map_camera: (4, 4) pose of the camera's OPTICAL frame in ``map``.
            width, height: image size in pixels.
            mode: ``'fast'`` (default) or ``'quality'`` (RGB path traced with ``spp`` samples per pixel and paths
                of up to ``bounces`` bounces (:mod:`~benchbot_sim_taichi.render.pathtrace`), then Open Image Denoise if
                ``denoise``: :func:`denoise_radiance`; depth and segmentation as in ``fast``).
            T_map_lidar, angles: as :meth:`scan`; ``None`` (default) for no scan.
            samples_per_pixel: ``fast`` mode's pixel integration
                (:mod:`~benchbot_sim_taichi.render.pixel_integration`): 1 (default) shades each pixel's centre; 4, 9
                or 16 render the RGB on an n × n grid of sub-pixels (a second launch) and average them in linear
                radiance. Depth, segmentation and the scan are the pixel centres' either way. ``quality`` mode's
                paths are already jittered over each pixel and ignore it.

        Returns:
            ``{'rgb': (H, W, 3) uint8 RGB, 'depth': (H, W) float32 z-depth metres (0 = no hit), 'class': (H, W)
            int32 class ids (background where the shell or nothing is hit), 'instance': (H, W) int32
            ``class*1000+instance`` ids (0 = background)}``, plus ``'ranges'`` (N,) float64 metres (as :meth:`scan`)
            with a lidar, and in ``quality`` mode ``'radiance'`` (H, W, 3) float32, the linear radiance that ``rgb``
            encodes (denoised if ``denoise``).

        Raises:
            ValueError: an unknown mode, a lidar pose without angles, or ``samples_per_pixel`` not 1, 4, 9 or 16.
        """
        if mode not in MODES:
            raise ValueError(f"unknown render mode {mode!r}: use one of {MODES}")
        n_sub = grid_side(samples_per_pixel) if mode == "fast" else 1
        Tl = beams = None
        if T_map_lidar is not None:
            if angles is None:
                raise ValueError("render: T_map_lidar needs angles")
            Tl = np.asarray(T_map_lidar, dtype=np.float64)[None]
            beams = np.asarray(angles, dtype=np.float64).reshape(-1)
        # quality mode replaces the RGB, so its fast pass only needs depth and segmentation: no lights
        with_scan = beams is not None and beams.size > 0  # no beams: nothing to launch for the scan
        Ts = np.asarray(T_map_camera, dtype=np.float64)[None]
        batch = self._launch(K, Ts, int(width), int(height), Tl if with_scan else None, beams,
                             lit=mode == "fast" and n_sub == 1)
        host = None
        if n_sub > 1:  # the pixel centres' depth, segmentation and scan to the host, then the sub-pixels' RGB
            batch = self._fetch(batch)
            sub = self._launch(subpixel_intrinsics(K, n_sub), Ts, n_sub * int(width), n_sub * int(height), None,
                               None, lit=True)
            batch["rgb"] = integrate(self._fetch({"rgb": sub["rgb"]})["rgb"][0], n_sub, self.camera)[None]
        if mode == "quality":
            H, W = int(height), int(width)
            lin = self._buffer("quality", (1, H, W, 3), np.float32)
            aux = self._buffer("quality_guides", (1, H, W, 6), np.float32)
            params = render_params(seed=self.seed, spp=spp, bounces=bounces)
            launch(quality_kernel, self._kernel_scene(), cam=camera_params(K, T_map_camera), params=params, out=lin,
                   aux=aux)
            finished = self._finish_quality_in_place(lin, aux, K, denoise)
            if finished is not None:  # denoised and encoded where the images are: copy the results only
                batch["radiance"], batch["rgb"] = finished
            else:
                host = self._fetch({"radiance": lin, "guides": aux})
                lin = host["radiance"][0]
                if denoise:
                    guides = host["guides"][0]
                    lin = self._denoise(lin, guides[..., :3], guides[..., 3:])
                host = {"radiance": np.ascontiguousarray(lin, dtype=np.float32)[None],
                        "rgb": self.camera.encode(lin, np.asarray(K, dtype=np.float64))[None]}
                batch = {k: v for k, v in batch.items() if k not in host}
        out = {k: v[0] for k, v in self._fetch(batch).items()}
        if host is not None:
            out.update({k: v[0] for k, v in host.items()})
        if beams is not None:
            out["ranges"] = out["ranges"][:beams.size].astype(np.float64) if with_scan else np.zeros(0)
        return out

    def host_copies(self, arrays: dict) -> dict:
        """New NumPy arrays the caller owns, of ``arrays`` (``{key: output of render_sensors(..., to_host=False)}``):
        the outputs a caller needs on the host, copied without the others (on CUDA through page-locked memory)."""
        return self._fetch(arrays)

    def _fetch(self, arrays: dict, *, once: bool = False) -> dict:
        """New NumPy arrays holding ``arrays`` (``{key: Taichi ndarray or NumPy array}``; NumPy arrays pass
        through). On CUDA they come through the page-locked copier (one synchronisation and a fast copy each), then
        a host copy, so that the caller owns them; with ``once`` (copies made once per scene, too large to keep
        page-locked buffers for) through ordinary host memory instead. On the CPU they are copied from the
        ndarrays' own memory (:func:`~benchbot_sim_taichi.render.host_copy.host_view`)."""
        if self.device_buffers and self.arch == "cuda":
            from benchbot_sim_taichi.render.host_copy import HostCopier

            if once:  # a throwaway copier: its arrays are the caller's
                return HostCopier(pinned=False).copy(arrays)
            if self._render_copier is None:
                self._render_copier = HostCopier(pinned=True)
            return {k: v.copy() for k, v in self._render_copier.copy(arrays).items()}
        from benchbot_sim_taichi.render.host_copy import host_view

        return {k: (v if isinstance(v, np.ndarray) else host_view(v).copy()) for k, v in arrays.items()}

    def _finish_quality_in_place(self, lin, aux, K, denoise: bool) -> tuple | None:
        """With device buffers, where the denoiser's device reads the renderer's memory (OIDN on CUDA for a CUDA
        renderer, on the CPU for a CPU one; or no denoising): denoise the path tracer's radiance ``lin`` with its
        guides ``aux`` where they lie (:func:`~benchbot_sim_taichi.render.denoiser.denoise_shared`) and encode it with the
        camera model there (``pathtrace.encode_kernel``); returns the (radiance, rgb) device buffers (B = 1). None
        when that does not apply (the caller copies to the host and finishes there), or when a GPU denoiser the
        renderer chose cannot start (then, as :meth:`_denoise`, it warns once and denoises on the CPU from now on).
        """
        if not self.device_buffers or (denoise and self.denoise_device != ("cuda" if self.arch == "cuda" else "cpu")):
            return None
        from benchbot_sim_taichi.render.host_copy import device_pointer

        if denoise:
            prepare_denoiser_inputs(lin, aux)
            ti.sync()  # the denoiser runs on its own stream: the path tracer's images must be complete
            denoised = self._buffer("quality_denoised", lin.shape, np.float32)
            try:
                denoise_shared(device_pointer(lin), device_pointer(aux), device_pointer(denoised), lin.shape[1],
                               lin.shape[2], device=self.denoise_device)
            except RuntimeError as e:
                self._denoise_on_the_cpu_instead(e)
                return None
            lin = denoised
        gain = 1.0
        rows, cols = self.camera.meter_shape(lin.shape[1], lin.shape[2])
        if self.camera.auto_exposure and rows and cols:  # the meter's pixels gathered where the image is
            sample = self._buffer("quality_meter", (1, rows, cols, 3), np.float32)
            meter_sample_kernel(lin, sample)
            gain = self.camera.metered_gain(self._fetch({"sample": sample})["sample"][0])
        rgb = self._buffer("quality_rgb", lin.shape, np.uint8)
        encode_kernel(lin, self.camera.kernel_params(K, gain), rgb)
        return lin, rgb

    def _denoise(self, radiance: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """:func:`denoise_radiance` on :attr:`denoise_device`. A GPU denoiser that the renderer chose by itself (CUDA
        rendering, ``denoise_device=None``) and that cannot start falls back to the CPU, once, with a warning; one
        asked for explicitly raises its ``RuntimeError``."""
        try:
            return denoise_radiance(radiance, albedo, normal, device=self.denoise_device)
        except RuntimeError as e:
            self._denoise_on_the_cpu_instead(e)
            return denoise_radiance(radiance, albedo, normal, device="cpu")

    def _denoise_on_the_cpu_instead(self, error: RuntimeError) -> None:
        """After the denoiser failed with ``error``: re-raise it if its device was asked for (or is the CPU), else
        warn once and denoise on the CPU from now on."""
        if not (self._denoise_device_chosen and self.denoise_device != "cpu"):
            raise error
        warnings.warn(f"quality mode: {error}; denoising on the CPU instead", RuntimeWarning, stacklevel=4)
        self.denoise_device = "cpu"

    def scan(self, T_map_lidar: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """Planar laser ranges.

        Args:
            T_map_lidar: (4, 4) lidar pose (x forward, z up); beams lie in the map's horizontal plane at its height,
                at ``angles`` (rad, about the lidar's z from its +x; the lidar is assumed level).
            angles: (N,) beam angles, radians.

        Returns:
            (N,) float64 distances (metres) to the first primitive or wall hit (no clipping).
        """
        angles = np.asarray(angles, dtype=np.float64).reshape(-1)
        ranges = self._launch(None, None, 1, 1, np.asarray(T_map_lidar, dtype=np.float64)[None], angles,
                              lit=False)
        return self._fetch(ranges)["ranges"][0, :angles.size].astype(np.float64)
