"""Quality mode against a converged Blender Cycles reference, error against time, on the same machine.

    uv run --extra realism python benchmarks/quality_vs_reference.py [--env miniroom:1] [--pose 0]
        [--width 320 --height 240] [--reference-spp 1024] [--ladder 1,4,16,64,256] [--ours-spp 1,4,16,64]
        [--arch cpu] [--out runs/quality_vs_reference]

One frame (the environment's trajectory pose ``--pose``, the robot's default camera) is rendered:

- by **Cycles** (the reference renderer of ``docs/realism.md``, same exported scene, camera and lights, through
  ``benchmarks/realism.py``'s job) at ``--reference-spp`` samples per pixel — the "converged" reference — and at the
  timed ``--ladder`` of lower sample counts;
- by **our quality mode** (path tracer + Open Image Denoise) at each ``--ours-spp``, each timed as a caller gets the
  frame (``Renderer.render(mode='quality')``, kernels already compiled; the median of ``--repeats``), and without the
  denoiser.

Every image is encoded as ours (``realism.encode_like_ours``) and compared with the reference: PSNR (all channels)
and SSIM (luma). For each of our sample counts, ``cycles_s_to_same_psnr`` is the time Cycles needs to reach the
same PSNR, interpolated on its ladder (``<``/``>``: outside it). The reference's own noise is estimated from the
ladder's largest rung as in ``realism.py``. Writes ``<out>/quality_vs_reference.json`` and
``<out>/side_by_side.png`` (ours fast | ours quality at each spp | Cycles reference) and prints a table.

Needs what the reference half of ``realism.py`` needs: uv and Python 3.11 for ``bpy`` (fetched by uv on the first
run). Both renderers run on this machine's CPU (``--arch cpu``); with ``--arch cuda`` ours runs on the GPU (with
``--reference-from`` an earlier run's Cycles renders, e.g. made on a CPU machine, are reused), and the two
renderers' times are then of different machines (say so when quoting them).

``--smoke`` (tiny: miniroom:4, 32×24, ours at 1 and 2 spp, written under the system's temporary folder) runs without
Blender: it exports the scene and writes Cycles' job as a real run does, then leaves Cycles out and compares ours with
a stand-in reference, our own quality mode at ``--reference-spp`` without the denoiser (so its PSNR and SSIM compare
ours with ours, and there is no ladder).
"""

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import realism  # noqa: E402 - benchmarks/realism.py, beside this file
import smoke  # noqa: E402 - benchmarks/smoke.py, beside this file


def _int_list(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"expected integers ≥ 1, got {text!r}")
    return values


def earlier_reference(ref_dir: Path, cam: dict, spp: int,
                      ladder: list[int]) -> tuple[dict, np.ndarray, dict | None]:
    """The Cycles renders of an earlier run's ``<out>/reference`` folder, checked against this run's settings.

    Args:
        ref_dir: the folder (``job.json``, ``timings.json``, ``frame0_spp<N>.npy``: (H, W, 3) linear radiance, any
            float dtype).
        cam: this run's Blender camera (``realism.blender_camera``); spp, ladder: this run's sample counts.

    Returns:
        (its ``timings.json``: ``{'frames': {'frame0': {str(spp): seconds}}, …}``, the reference's (H, W, 3) float32
        linear radiance, the ladder's figures read from the earlier run's ``quality_vs_reference.json`` beside the
        folder when the ladder's renders are not in it, else None: compute them from the renders).

    Raises:
        realism.RealismError: a missing or malformed file, or renders made with other settings (one line each).
    """
    def refuse(why: str) -> realism.RealismError:
        return realism.RealismError(f"--reference-from {ref_dir}: {why}",
                                    "point it at the reference folder of a run with the same settings")

    try:
        timings = json.loads((ref_dir / "timings.json").read_text())
        rendered = all((ref_dir / f"frame0_spp{s}.npy").exists() for s in ladder)
        for s in [spp] + (ladder if rendered else []):
            float(timings["frames"]["frame0"][str(s)])
        frame = json.loads((ref_dir / "job.json").read_text())
        settings = (frame.get("spp"), frame.get("ladder"), frame["frames"][0].get("matrix_world"),
                    frame["frames"][0].get("width"), frame["frames"][0].get("height"))
    except (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError) as e:
        raise refuse(f"cannot read its timings.json/job.json ({type(e).__name__}: {e})") from None
    if settings != (spp, ladder, cam["matrix_world"], cam["width"], cam["height"]):
        raise refuse("it was rendered with other settings (spp, ladder, pose or size)")
    try:
        ref_linear = np.load(ref_dir / f"frame0_spp{spp}.npy").astype(np.float32)
    except (OSError, ValueError) as e:
        raise refuse(f"cannot read frame0_spp{spp}.npy ({e})") from None
    if ref_linear.shape != (cam["height"], cam["width"], 3):
        raise refuse(f"frame0_spp{spp}.npy has shape {ref_linear.shape}, not ({cam['height']}, {cam['width']}, 3)")
    if rendered:
        return timings, ref_linear, None
    try:  # a trimmed copy: the earlier run's figures of the ladder
        return timings, ref_linear, json.loads((ref_dir.parent / "quality_vs_reference.json").read_text())["cycles"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise refuse(f"the ladder's renders are missing and so is an earlier quality_vs_reference.json beside it "
                     f"({type(e).__name__}: {e})") from None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="miniroom:1")
    ap.add_argument("--pose", type=int, default=0, help="trajectory pose index")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--reference-spp", type=int, default=1024)
    ap.add_argument("--ladder", type=_int_list, default=[1, 4, 16, 64, 256])
    ap.add_argument("--ours-spp", type=_int_list, default=[1, 4, 16, 64])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--arch", default="cpu")
    ap.add_argument("--bpy", default=realism.BPY_REQUIREMENT)
    ap.add_argument("--reference-timeout", type=float, default=realism.REFERENCE_TIMEOUT_S)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("runs") / "quality_vs_reference")
    ap.add_argument("--reference-from", type=Path, default=None,
                    help="reuse the Cycles renders of an earlier run's <out>/reference folder (same env, pose, size, "
                         "spp and ladder) instead of rendering them again, e.g. to time ours on another machine; "
                         "without the ladder's .npy files there, the ladder's figures are read from the earlier "
                         "run's quality_vs_reference.json beside it")
    args = smoke.parse_args(ap, argv, env="miniroom:4", width=32, height=24, reference_spp=8, ladder=[1, 4],
                            ours_spp=[1, 2], repeats=1,
                            out=Path(tempfile.gettempdir()) / "benchbot-smoke" / "quality_vs_reference")

    from PIL import Image

    from benchbot.core.geometry import se2_to_matrix
    from benchbot_sim_taichi.render.renderer import Renderer
    from benchbot_worlds.scene.build import build_scene

    try:
        scene = build_scene(realism._env_spec(args.env, None))
    except realism.RealismError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    W, H = args.width, args.height
    K, Tc = realism.camera_setup(W, H)
    poses = scene.trajectory_se2 if len(scene.trajectory_se2) else scene.start_se2[None]
    if not 0 <= args.pose < len(poses):
        print(f"error: --pose {args.pose} is outside the trajectory's 0..{len(poses) - 1}", file=sys.stderr)
        return 2
    T = se2_to_matrix(*poses[args.pose]) @ Tc
    try:
        r = Renderer(args.arch, seed=args.seed)
    except ValueError as e:
        print(f"error: --arch {args.arch}: {e}", file=sys.stderr)
        return 2
    r.set_scene(scene)
    out_dir = args.out
    ref_dir = out_dir / "reference"
    ref_dir.mkdir(parents=True, exist_ok=True)

    # the reference and its ladder
    glb = realism.export_reference_glb(scene, ref_dir / "scene.glb")
    cam = realism.blender_camera(K, T, W, H)
    cam["name"] = "frame0"
    ladder = [s for s in args.ladder if s < args.reference_spp]
    job = {"glb": str(ref_dir / "scene.glb"), "shell": "camera-only", "lights": realism.reference_lights(scene),
           "frames": [cam], "spp": args.reference_spp, "ladder": ladder, "seed": args.seed, "out_dir": str(ref_dir)}
    reference_name = f"Cycles {args.reference_spp} spp"
    try:
        if args.reference_from is not None:
            ref_dir = args.reference_from
            timings, ref_linear, cycles = earlier_reference(ref_dir, cam, args.reference_spp, ladder)
        elif args.smoke:
            (ref_dir / "job.json").write_text(json.dumps(job))  # as realism.run_cycles writes it
            smoke.left_out("the Cycles reference", f"it needs bpy, which `uv sync` does not install; {ref_dir} has "
                           "the scene and the job Cycles would render, and ours is compared with our own quality "
                           f"mode at {args.reference_spp} spp, not denoised")
            t = time.perf_counter()
            ref_linear = r.render(K, T, W, H, mode="quality", spp=args.reference_spp, denoise=False)["radiance"]
            timings = {"frames": {"frame0": {str(args.reference_spp): time.perf_counter() - t}}}
            ref_linear, cycles = np.asarray(ref_linear, np.float32), {}
            reference_name = f"stand-in: ours {args.reference_spp} spp"
        else:
            print(f"Cycles: {args.reference_spp} spp reference and ladder {ladder} at {W}x{H} …", flush=True)
            timings = realism.run_cycles(job, ref_dir / "job.json", args.bpy, args.reference_timeout)
            ref_linear = np.load(ref_dir / f"frame0_spp{args.reference_spp}.npy").astype(np.float32)
            cycles = None
    except realism.RealismError as e:
        print(f"error: {e.message}" + (f"; {e.hint}" if e.hint else ""), file=sys.stderr)
        return 2 if args.reference_from is not None else 1
    per = timings["frames"]["frame0"]
    ref = realism.encode_like_ours(ref_linear)
    if cycles is None:
        cycles = {}
        for s in ladder:
            img = realism.encode_like_ours(np.load(ref_dir / f"frame0_spp{s}.npy"))
            cycles[str(s)] = {"seconds": per[str(s)], "psnr_db": realism.psnr(img, ref),
                              "ssim": realism.ssim(img, ref)}

    # ours
    fast = r.render(K, T, W, H)["rgb"]
    r.render(K, T, W, H, mode="quality", spp=1)  # compiles the kernels and starts the denoiser
    ours, pictures = {}, [fast]
    for spp in args.ours_spp:
        entry = {}
        for denoise in (True, False):
            seconds = []
            for _ in range(max(1, args.repeats)):
                t = time.perf_counter()
                img = r.render(K, T, W, H, mode="quality", spp=spp, denoise=denoise)["rgb"]
                seconds.append(time.perf_counter() - t)
            key = "denoised" if denoise else "raw"
            entry[key] = {"seconds": float(np.median(seconds)), "psnr_db": realism.psnr(img, ref),
                          "ssim": realism.ssim(img, ref)}
            if denoise:
                entry[key]["exposure_gain"] = realism.exposure_gain(img, ref_linear)
                entry[key]["cycles_s_to_same_psnr"] = realism.seconds_to_reach(cycles, entry[key]["psnr_db"])
                pictures.append(img)
        ours[str(spp)] = entry
    pictures.append(ref)
    labels = ["ours fast"] + [f"ours quality {s} spp" for s in args.ours_spp] + [reference_name]
    realism.side_by_side(pictures, labels).save(out_dir / "side_by_side.png")
    Image.fromarray(ref).save(out_dir / "reference.png")

    top = max((int(s) for s in cycles), default=None)  # the ladder's largest rung
    result = {"env": args.env, "pose": args.pose, "width": W, "height": H, "arch": r.arch,
              "reference": reference_name, "reference_spp": args.reference_spp,
              "reference_s": per[str(args.reference_spp)],
              "reference_psnr_est_db": (cycles[str(top)]["psnr_db"] + 10 * math.log10(args.reference_spp / top + 1.0)
                                        if top else None),
              "cycles": cycles, "ours": ours, "export": glb, "blender": timings.get("blender"),
              "fast": {"psnr_db": realism.psnr(fast, ref), "ssim": realism.ssim(fast, ref)}}
    (out_dir / "quality_vs_reference.json").write_text(json.dumps(result, indent=1) + "\n")

    print(f"\n{args.env} pose {args.pose}, {W}x{H}, against {reference_name} "
          f"({result['reference_s']:.0f} s; its own noise ≈ {result['reference_psnr_est_db'] or float('nan'):.1f} dB)")
    print(f"{'renderer':<26}{'seconds':>10}{'PSNR dB':>10}{'SSIM':>8}   Cycles to the same PSNR")
    for s, v in cycles.items():
        print(f"{'Cycles ' + s + ' spp':<26}{v['seconds']:>10.2f}{v['psnr_db']:>10.2f}{v['ssim']:>8.3f}")
    f = result["fast"]
    print(f"{'ours fast':<26}{'':>10}{f['psnr_db']:>10.2f}{f['ssim']:>8.3f}")
    for s, e in ours.items():
        d, raw = e["denoised"], e["raw"]
        reach = d["cycles_s_to_same_psnr"]
        same = f"{reach.get('bound', '')}{reach.get('seconds', float('nan')):.1f} s" if reach else "–"
        print(f"{'ours quality ' + s + ' spp':<26}{d['seconds']:>10.2f}{d['psnr_db']:>10.2f}{d['ssim']:>8.3f}   {same}")
        print(f"{'  (not denoised)':<26}{raw['seconds']:>10.2f}{raw['psnr_db']:>10.2f}{raw['ssim']:>8.3f}")
    print(f"\nwrote {out_dir / 'quality_vs_reference.json'} and {out_dir / 'side_by_side.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
