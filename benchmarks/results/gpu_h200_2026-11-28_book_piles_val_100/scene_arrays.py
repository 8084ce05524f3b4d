"""scene_arrays.py ENV: the sizes (MiB) of the scene arrays the renderer's kernels read (``Renderer._packed``, what
``set_scene`` uploads on CUDA; benchmarks/render.py's ``scene_mb`` sums the same) for environment ENV (any registered
``name:variant``, generated homes too) as an episode with seed 0 loads it, built on the CPU: one JSON line, the total
first, then the eight largest arrays. Asked for by the 100-home runs' GPU memory (17.1 GB on 26 Nov, 26.6 GB on 28
Nov): run with another commit's code first on PYTHONPATH to compare, as
benchmarks/results/cpu2_2026-11-28_render_rate_by_commit.sh does (a worktree of REV, its packages on PYTHONPATH,
``BENCHBOT_CACHE_DIR`` a fresh folder). Needs ``uv sync``."""
import json
import sys

from benchbot.core.registry import get_registry
from benchbot.core.seeding import environment_world_seed
from benchbot_sim_taichi import scene_cache
from benchbot_sim_taichi.render.renderer import Renderer
from benchbot_worlds.scene.build import build_scene


def main(name: str) -> None:
    """Print the packed scene arrays' sizes (MiB) of environment ``name``."""
    (spec,) = get_registry().scenes(name)
    env = dict(spec)
    scene, key = scene_cache.scene_for(env, environment_world_seed(0, env), build=build_scene)
    r = Renderer("cpu")
    r.set_scene(scene)
    sizes = {k: v.nbytes / 2**20 for k, v in r._packed.items() if hasattr(v, "nbytes")}
    top = sorted(sizes.items(), key=lambda kv: -kv[1])[:8]
    print(json.dumps({"env": name, "total_mib": round(sum(sizes.values()), 1), **{k: round(v, 2) for k, v in top}}))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: scene_arrays.py NAME:VARIANT (e.g. procedural_val_0:1)")
    main(sys.argv[1])
