"""Check that a change to the simulator's renderer leaves its output unchanged: render a fixed set of views to a
``.npz`` file, do so again after the change, and compare the two array for array.

    uv run python tools/render_fingerprint.py save before.npz      # on the old code
    uv run python tools/render_fingerprint.py save after.npz       # on the new code
    uv run python tools/render_fingerprint.py compare before.npz after.npz

``save`` renders, on the CPU (``--arch cuda``: on the GPU), the first three trajectory poses of ``--envs`` (default
``miniroom:1,house:1``) at 96 × 72 pixels: RGB, depth, class and instance images with the laser scan of the same
instant (fast mode), and one quality-mode view (4 samples per pixel, not denoised); ``--samples-per-pixel N`` renders
the fast views with the camera's pixel integration (``sensors.camera.samples_per_pixel``), ``--shadow-samples N`` with
N shadow rays per light and pixel (soft shadows: the shading kernel with shadow rays, ``sensors.shade_kernel``).
Saved on the CPU and on a GPU and compared, two files show how far the two devices' images are apart. ``compare``
prints one line per differing array (largest absolute difference) and the count of equal ones; it exits 1 when any
differs or the two files hold different arrays. Bit-identical output is what a refactor of the kernels should give; a
change meant to alter the images shows here how much they moved.

Ground truth: BEAR (QUT Centre for Robotic Vision, https://github.com/qcr/benchbot_envs; see the BEAR data manifest
shipped with sim_taichi).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

#: Image size (pixels), horizontal field of view (degrees) and poses per environment of ``save``.
WIDTH, HEIGHT, FOV_DEG, POSES = 96, 72, 90.0, 3
#: Height of the laser scanner above the floor (metres) in the fixed views.
LIDAR_Z = 0.3


def save(path: str, envs: list[str], arch: str = "cpu", samples_per_pixel: int = 1,
         shadow_samples: int = 1) -> int:
    """Render the fixed views of ``envs`` (``name:variant``) on ``arch`` (``cpu`` or ``cuda``), the fast views with
    ``samples_per_pixel`` sub-pixels a pixel and ``shadow_samples`` shadow rays per light and pixel, and write them
    to ``path`` (``.npz``, one array per ``env/pose/output``). Returns the exit status."""
    from benchbot.core.geometry import se2_to_matrix
    from benchbot.core.registry import get_registry
    from benchbot_sim_taichi.backend import camera_mount
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    registry = get_registry()
    renderer = Renderer(arch, shadow_samples=shadow_samples)
    K = intrinsics(WIDTH, HEIGHT, FOV_DEG)
    angles = np.linspace(-3.0, 3.0, 90)
    out: dict[str, np.ndarray] = {}
    for key in envs:
        scene = build_scene(registry.scenes(key)[0])
        renderer.set_scene(scene)
        for i, (x, y, yaw) in enumerate(scene.trajectory_se2[:POSES]):
            T_cam = se2_to_matrix(x, y, yaw) @ camera_mount()
            T_lidar = se2_to_matrix(x, y, yaw, z=LIDAR_Z)
            for name_, image in renderer.render(K, T_cam, WIDTH, HEIGHT, T_map_lidar=T_lidar, angles=angles,
                                                samples_per_pixel=samples_per_pixel).items():
                out[f"{key}/{i}/{name_}"] = np.asarray(image)
        for name_, image in renderer.render(K, T_cam, WIDTH, HEIGHT, mode="quality", spp=4, denoise=False).items():
            out[f"{key}/quality/{name_}"] = np.asarray(image)
    np.savez(path, **out)
    print(f"{path}: {len(out)} arrays from {', '.join(envs)}")
    return 0


def compare(a_path: str, b_path: str) -> int:
    """Compare two files written by :func:`save`; print the differing arrays. Returns 0 when all are equal."""
    a, b = np.load(a_path), np.load(b_path)
    if sorted(a.files) != sorted(b.files):
        print(f"the files hold different arrays: only in {a_path}: {sorted(set(a.files) - set(b.files))}; "
              f"only in {b_path}: {sorted(set(b.files) - set(a.files))}")
        return 1
    differing = 0
    for key in sorted(a.files):
        x, y = a[key], b[key]
        if x.shape != y.shape or not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
            differing += 1
            gap = "shapes differ" if x.shape != y.shape else (
                f"largest difference {np.nanmax(np.abs(x.astype(np.float64) - y.astype(np.float64))):.6g}, "
                f"{int(np.count_nonzero(x != y))} of {x.size} values differ")
            print(f"{key}: {gap}")
    print(f"{len(a.files) - differing} of {len(a.files)} arrays equal")
    return 1 if differing else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    s = sub.add_parser("save", help="render the fixed views to an .npz file")
    s.add_argument("path")
    s.add_argument("--envs", default="miniroom:1,house:1", help="environments, name:variant, comma-separated")
    s.add_argument("--arch", default="cpu", choices=("cpu", "cuda"), help="where to render (default: cpu)")
    s.add_argument("--samples-per-pixel", type=int, default=1, choices=(1, 4, 9, 16),
                   help="the fast views' pixel integration (sensors.camera.samples_per_pixel; default 1)")
    s.add_argument("--shadow-samples", type=int, default=1, choices=(1, 2, 4),
                   help="shadow rays per light and pixel (the option shadow_samples; default 1: hard shadows from the "
                        "shadow maps)")
    c = sub.add_parser("compare", help="compare two .npz files written by save")
    c.add_argument("before")
    c.add_argument("after")
    args = parser.parse_args(argv)
    if args.command == "save":
        return save(args.path, [e.strip() for e in args.envs.split(",") if e.strip()], args.arch,
                    args.samples_per_pixel, args.shadow_samples)
    return compare(args.before, args.after)


if __name__ == "__main__":
    sys.exit(main())
