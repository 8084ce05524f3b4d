"""What the simulator's first run on a machine builds, built ahead (``benchbot sim prepare``): the kernels compiled
into Taichi's offline cache and the environments' scenes into the scene cache, so that the first episode starts
as a later one does (``docs/simulator.md``, Cold start).

The steps, each done as an episode does it, so that what they leave is what an episode looks for:

1. per environment, its scene, BVH, shadow maps and baked light (:mod:`benchbot_sim_taichi.scene_cache`) and the
   kernels of fast mode's first frame, through :meth:`TaichiSimBackend.load_scene
   <benchbot_sim_taichi.backend.TaichiSimBackend.load_scene>` with the world seed of an episode of run seed ``seed``;
2. the shading kernel with shadow rays (soft shadows, ``shadow_samples`` above 1, and scenes whose lights are not
   all mapped), rendering one small view of the first environment;
3. with ``quality``, the path tracer's kernels (quality mode's first frame), through a backend in quality mode.

At the end Taichi is reset, which writes its offline cache (Taichi writes it when its program ends).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from benchbot.core import stages
from benchbot.core.seeding import environment_world_seed

#: The environments prepared when none are named: README command 1's.
DEFAULT_ENVIRONMENTS = ("miniroom:1",)
#: The size of the views the steps render (pixels): the kernels do not depend on it.
VIEW = (8, 6)


@dataclass(frozen=True)
class Step:
    """One step of :func:`steps`: ``label`` says what it builds (a progress bar's line), ``run()`` builds it."""

    label: str
    run: Callable[[], None]


def steps(environments: list[tuple[str, dict]], robot: dict, options: dict, seed: int = 0,
          quality: bool = False) -> list[Step]:
    """The steps that prepare ``environments`` (``(name:variant, environment spec)`` pairs, at least one) for robot
    spec ``robot`` and backend ``options`` (``{'arch': 'cpu'|'gpu'|'cuda'}`` as ``benchbot batch`` gives them); see
    the module docstring.

    Raises:
        ValueError: no environment.
    """
    if not environments:
        raise ValueError("no environment to prepare")
    out = [Step(f"{name}: scene, shadow maps, baked light and fast mode's kernels",
                _loader(environment, robot, options, seed)) for name, environment in environments]
    name, environment = environments[0]
    out.append(Step(f"the shading kernel with shadow rays (on {name})", _soft_shadows(environment, options, seed)))
    if quality:
        out.append(Step(f"quality mode's kernels (on {name})",
                        _loader(environment, robot, {**options, "mode": "quality"}, seed)))
    return out


def _loader(environment: dict, robot: dict, options: dict, seed: int) -> Callable[[], None]:
    def run() -> None:
        from benchbot_sim_taichi.backend import TaichiSimBackend

        backend = TaichiSimBackend(robot, options)
        try:
            backend.load_scene(environment, seed=environment_world_seed(seed, environment))
        finally:
            backend.close()

    return run


def _soft_shadows(environment: dict, options: dict, seed: int) -> Callable[[], None]:
    def run() -> None:
        from benchbot_sim_taichi import scene_cache
        from benchbot_sim_taichi.backend import trajectory_cameras
        from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
        from benchbot_worlds.scene.build import build_scene

        world = environment_world_seed(seed, environment)
        scene, _key = scene_cache.scene_for(environment, world, build=build_scene)
        with stages.stage("starting Taichi"):
            renderer = Renderer(options.get("arch"), shadow_samples=2, seed=world)
        try:
            renderer.set_scene(scene)
            with stages.stage("compiling kernels", detail="the shading kernel with shadow rays"):
                width, height = VIEW
                renderer.render(intrinsics(width, height, 90.0), trajectory_cameras(scene)[0], width, height)
        finally:
            renderer.close()

    return run


def finish() -> dict:
    """After the steps: reset Taichi, which writes its offline cache, and say what the caches hold:
    ``{'kernel_cache': folder or None, 'kernel_cache_bytes': int, 'scene_cache': folder, 'scene_cache_bytes': int}``
    (bytes of the regular files in each folder)."""
    from benchbot_sim_taichi import scene_cache
    from benchbot_sim_taichi.render import kernel_cache
    from benchbot_sim_taichi.render.renderer import release_taichi

    kernels = kernel_cache.offline_cache_dir()
    release_taichi()
    scenes = scene_cache.cache_folder()
    return {"kernel_cache": None if kernels is None else str(kernels), "kernel_cache_bytes": folder_bytes(kernels),
            "scene_cache": str(scenes), "scene_cache_bytes": folder_bytes(scenes)}


def folder_bytes(folder: Path | None) -> int:
    """Bytes of the regular files under ``folder`` (0 when it is None or does not exist)."""
    if folder is None:
        return 0
    total = 0
    for root, _dirs, names in os.walk(folder):
        for name in names:
            path = os.path.join(root, name)
            if os.path.isfile(path):
                total += os.path.getsize(path)
    return total
