"""Trial (29 Nov 2026): a camera whose colour processing raises saturation, as a camera's colour pipeline does.
Fast frames are decoded to the camera's linear radiance (``CameraModel.decode``), each pixel's chroma scaled by S
about its Rec. 709 luminance Y (``Y + S (L - Y)``, clipped at 0) and encoded again by the same camera; quality
frames are left as they are. S is chosen from the photos alone (``--calibrate``), before any detector runs: the S
at which the mean HSV saturation of fast frames of the ten BEAR homes (every 16th pose) equals the real photos'.

    uv run --extra realism python benchmarks/results/cpu2_2026-11-29_realism_records/camera_saturation.py --calibrate
    uv run --extra realism python benchmarks/results/cpu2_2026-11-29_realism_records/camera_saturation.py S \
        --all-homes --every 4 --quality-frames 0 --reference-frames 0 --real-reference --detector centernet --out DIR

(the second: benchmarks/realism.py's arguments after S).
"""
import glob
import sys

import numpy as np

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402
from benchbot_sim_taichi.render.renderer import Renderer  # noqa: E402
from benchbot_worlds.scene.model import LUMA_709  # noqa: E402

CAMERA = R.camera_model()
K_ANY = np.array([[320.0, 0, 320], [0, 320, 240], [0, 0, 1]])  # encode's intrinsics: the camera has no vignetting


def saturated(rgb: np.ndarray, s: float) -> np.ndarray:
    """(H, W, 3) uint8 ``rgb`` as the camera with its chroma scaled by ``s`` would encode it."""
    lin = CAMERA.decode(rgb)
    y = lin @ np.asarray(LUMA_709)
    return CAMERA.encode(np.maximum(y[..., None] + s * (lin - y[..., None]), 0.0), K_ANY, gain=1.0)


def mean_saturation(rgb: np.ndarray) -> float:
    """Mean HSV saturation of a uint8 image, pixels with value above 0.05."""
    x = rgb.astype(np.float64) / 255.0
    mx, mn = x.max(-1), x.min(-1)
    return float(np.mean(np.where(mx > 0.05, (mx - mn) / np.maximum(mx, 1e-6), 0.0)))


def calibrate() -> None:
    """Print the photos' mean HSV saturation and the fast frames' (ten BEAR homes, every 16th pose) at several S."""
    from PIL import Image
    from benchbot.core.geometry import se2_to_matrix
    from benchbot.core.seeding import environment_world_seed
    from benchbot_sim_taichi import scene_cache
    from benchbot_worlds.scene.build import build_scene
    photos = [mean_saturation(np.asarray(Image.open(p).convert("RGB")))
              for p in sorted(glob.glob("benchmarks/realism/photos/*.jpg"))]
    frames = []
    for name in R.all_homes():
        env = R._env_spec(name, None)
        world = environment_world_seed(0, env)
        scene, key = scene_cache.scene_for(env, world, build=build_scene)
        K, Tc = R.camera_setup(640, 480)
        r = Renderer("cpu", seed=world, camera=CAMERA)
        scene_cache.set_scene(r, scene, key)
        for i in range(0, len(scene.trajectory_se2), 16):
            frames.append(r.render(K, se2_to_matrix(*scene.trajectory_se2[i]) @ Tc, 640, 480, mode="fast")["rgb"])
    print(f"photos: {len(photos)}, mean HSV saturation {np.mean(photos):.3f}; fast frames: {len(frames)}")
    for s in (1.0, 1.25, 1.5, 1.75, 2.0, 2.5):
        mean = np.mean([mean_saturation(saturated(f, s)) for f in frames])
        print(f"S = {s}: fast frames' mean saturation {mean:.3f}")


def main(argv: list[str]) -> int:
    try:
        s = float(argv[0])
    except (IndexError, ValueError):
        sys.exit("usage: camera_saturation.py --calibrate | camera_saturation.py S REALISM_ARGS... (S a number)")
    render = Renderer.render

    def render_saturated(self, *a, **k):
        out = render(self, *a, **k)
        if k.get("mode", "fast") == "fast" and out["rgb"].shape[0] > 8:
            out = dict(out, rgb=saturated(out["rgb"], s))
        return out

    Renderer.render = render_saturated
    return R.main(argv[1:])


if __name__ == "__main__":
    if sys.argv[1:] == ["--calibrate"]:
        calibrate()
    else:
        sys.exit(main(sys.argv[1:]))
