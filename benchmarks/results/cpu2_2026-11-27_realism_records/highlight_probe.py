"""highlight_probe.py (after `git apply fast_lamp_highlights.patch`): a black glossy floor (albedo 0) under the sun and
under a lamp, roughness 0.3 and 0.45, no bounce: quality mode's radiance (256 spp, clipped to 1) and fast mode's decoded
image, their brightest pixels and their sums over the image. Run from the repository root:
uv run python benchmarks/results/cpu2_2026-11-27_realism_records/highlight_probe.py"""
import sys, numpy as np
sys.path.insert(0, "plugins/sim_taichi/tests")
import test_pathtrace as T
from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
W, H = 40, 30
K, P = intrinsics(W, H, 60.0), T._looking_down()
for kind in ("sun", "lamp"):
  for rough in (0.3, 0.45):
    r = Renderer("cpu", seed=2); r.set_scene(T._lit_floor_scene(kind, roughness=rough, albedo=0.0))
    q = r.render(K, P, W, H, mode="quality", spp=256, denoise=False, bounces=0)["radiance"].mean(axis=2)
    f = T._decode(r.render(K, P, W, H)["rgb"]).mean(axis=2)
    qc = np.clip(q, 0, 1)
    print(kind, rough, "max", q.max().round(3), f.max().round(3), "argmax", np.unravel_index(q.argmax(), q.shape), np.unravel_index(f.argmax(), f.shape), "sum clipped", qc.sum().round(2), f.sum().round(2))
