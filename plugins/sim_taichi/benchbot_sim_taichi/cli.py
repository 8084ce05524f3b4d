"""``benchbot sim …``: the Taichi simulator's commands (a Typer sub-app registered by the plugin's
``benchbot_commands`` hook). ENV is ``name:variant`` of a registered environment or the path of an environment YAML.

* ``benchbot sim render ENV [--pose x,y,z,yaw_deg] [--mode fast|quality] [--width W --height H] -o FILE.png``
* ``benchbot sim export ENV -o FILE.glb`` (the whole scene with its materials and textures; other formats trimesh
  writes: one mesh with face colours)
* ``benchbot sim plan ENV -o FILE.png`` (top-down floor plan of a furnished home: rooms, walls, doors, windows,
  the ground-truth boxes and the robot's path)
* ``benchbot sim ground-truth ENV -o FILE.json`` (the ground truth derived from the scene: per object the
  axis-aligned bounds of its geometry; for environments with mesh ``objects``)
* ``benchbot sim prepare [ENV ...] [--arch auto|cpu|gpu] [--quality] [--workers N] [--json]`` (a machine's first-run
  work done ahead: the kernels compiled into Taichi's offline cache, the scenes built into the scene cache;
  :mod:`benchbot_sim_taichi.prepare`)
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import typer

from benchbot.cli.common import showing_stages
from benchbot.cli.options import at_most, check_count
from benchbot.core import stages
from benchbot.core.limits import MAX_CAMERA_SIDE, MAX_RENDER_SAMPLES, MAX_SEED, MAX_WORKERS
from benchbot.core.seeding import environment_world_seed

app = typer.Typer(help="The Taichi simulator (sim_taichi): render views, export scenes, derive ground truths.",
                  no_args_is_help=True)


def _environment(env: str) -> dict:
    from benchbot.core.errors import SpecError

    p = Path(env)
    if p.suffix in (".yaml", ".yml") or p.is_file():
        import yaml

        try:
            spec = yaml.safe_load(p.read_text(encoding="utf-8"))
        except (OSError, yaml.YAMLError) as e:
            raise SpecError(f"cannot read the environment file {p}: {e}", "give name:variant or an environment YAML")
        if not isinstance(spec, dict):
            raise SpecError(f"the environment file {p} is not a mapping", "an environment spec is a YAML mapping")
        spec["_file_path"] = str(p.resolve())
        return spec
    from benchbot.cli.common import registry

    return registry().scenes(env)[0]


def _world(seed: int, environment: dict, env: str) -> int:
    """The world seed an episode with ``--seed`` ``seed`` gets for ``environment``
    (:func:`benchbot.core.seeding.environment_world_seed`).

    Raises:
        SpecError: the environment (an environment YAML ``env``) has no ``name`` or no ``variant``.
    """
    from benchbot.core.errors import SpecError

    missing = [field for field in ("name", "variant") if field not in environment]
    if missing:
        raise SpecError(f"the environment {env} has no {' and no '.join(missing)}",
                        "give it name: and variant: (with --seed they fix the look of its scene)")
    return environment_world_seed(seed, environment)


def _T_camera(scene, pose: str | None) -> "object":
    from benchbot.core.errors import UsageError
    from benchbot_sim_taichi.backend import DEFAULT_SENSORS, camera_at

    if pose:
        try:
            x, y, z, yaw = (float(v) for v in pose.split(","))
        except ValueError:
            raise UsageError(f"--pose {pose!r} is not x,y,z,yaw_deg", "e.g. --pose 1.0,2.0,0.8,90") from None
        return camera_at(x, y, math.radians(yaw), z)
    x, y, yaw = scene.start_se2
    return camera_at(x, y, yaw, DEFAULT_SENSORS["camera"]["mount_xyz"][2])


def _styled(environment: dict, style: str | None) -> dict:
    """The environment with ``style`` set (``--style``); a style it does not know is refused by build_scene."""
    return environment if style is None else {**environment, "style": style}


def _run(fn):
    from benchbot.cli.common import handle_errors

    return handle_errors(fn)()


@app.command("render")
def render(env: str = typer.Argument(..., help="name:variant or an environment YAML"),
           output: Path = typer.Option(..., "-o", "--output", help="PNG file to write"),
           pose: str = typer.Option(None, "--pose", help="camera x,y,z (m),yaw (deg); default: the start pose"),
           mode: str = typer.Option("fast", "--mode", help="fast or quality"),
           width: int = typer.Option(640, "--width", help=f"image width, pixels ({at_most(MAX_CAMERA_SIDE, 1)})"),
           height: int = typer.Option(480, "--height", help=f"image height, pixels ({at_most(MAX_CAMERA_SIDE, 1)})"),
           spp: int = typer.Option(32, "--spp", help=f"samples per pixel in quality mode ({at_most(MAX_RENDER_SAMPLES, 1)})"),
           shadow_samples: int = typer.Option(8, "--shadow-samples", help=f"soft-shadow rays per light, fast mode ({at_most(MAX_RENDER_SAMPLES, 1)})"),
           fov: float = typer.Option(90.0, "--fov", help="horizontal field of view, degrees"),
           seed: int = typer.Option(0, "--seed", help=f"the run's seed: with ENV's name and variant it fixes the scene's look and the sampling, as in an episode with that --seed ({at_most(MAX_SEED)})"),
           style: str = typer.Option(None, "--style",
                                     help="furnished (a house: rooms, walls, textured models) or primitives; "
                                          "default: the environment's own, else furnished"),
           ) -> None:
    """Render one RGB view of ENV to a PNG, through the default robot's camera model (exposure, tone curve)."""

    def go():
        for flag, value, limit in (("--width", width, MAX_CAMERA_SIDE), ("--height", height, MAX_CAMERA_SIDE),
                                   ("--spp", spp, MAX_RENDER_SAMPLES),
                                   ("--shadow-samples", shadow_samples, MAX_RENDER_SAMPLES)):
            check_count(flag, value, limit, 1)  # first: before the simulator is even imported
        check_count("--seed", seed, MAX_SEED)

        import cv2

        from benchbot.core.errors import UsageError
        from benchbot_sim_taichi.backend import camera_model
        from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
        from benchbot_sim_taichi import scene_cache
        from benchbot_worlds.scene.build import build_scene

        if mode not in ("fast", "quality"):
            raise UsageError(f"unknown --mode {mode!r}", "use fast or quality")
        if not 0.0 < fov < 180.0:
            raise UsageError(f"--fov {fov} is not between 0 and 180 degrees", "e.g. --fov 90")
        with showing_stages(env):
            environment = _environment(env)
            world = _world(seed, environment, env)  # the world an episode with this --seed sees
            scene, key = scene_cache.scene_for(_styled(environment, style), world, build=build_scene)
            with stages.stage("starting Taichi"):
                r = Renderer(None, shadow_samples=shadow_samples, seed=world, camera=camera_model())
            scene_cache.set_scene(r, scene, key)  # BVH, shadow maps and baked light: from the cache when it has them
            with stages.stage("rendering", detail=f"{mode} mode, {width}x{height}"
                              + (f", {spp} samples a pixel" if mode == "quality" else "")
                              + "; the first run also compiles kernels"):
                out = r.render(intrinsics(width, height, fov), _T_camera(scene, pose), width, height, mode=mode,
                               spp=spp)
        output.parent.mkdir(parents=True, exist_ok=True)
        try:
            written = cv2.imwrite(str(output), out["rgb"][:, :, ::-1])
        except cv2.error:
            written = False
        if not written:
            raise UsageError(f"cannot write the image {output}", "use a writable path ending in .png (or .jpg)")
        typer.echo(str(output))

    _run(go)


@app.command("export")
def export(env: str = typer.Argument(..., help="name:variant or an environment YAML"),
           output: Path = typer.Option(..., "-o", "--output", help="mesh file (.glb, .obj, .ply, …)"),
           style: str = typer.Option(None, "--style",
                                     help="furnished (a house: rooms, walls, textured models) or primitives; "
                                          "default: the environment's own, else furnished"),
           ) -> None:
    """Export the whole scene of ENV (objects and room shell) as triangles: a .glb keeps the materials, textures and
    normals (for a reference renderer); other formats get one mesh with face colours."""

    def go():
        from benchbot_sim_taichi import scene_cache
        from benchbot_worlds.scene.export import export_scene, scene_mesh
        from benchbot_worlds.scene.build import build_scene

        from benchbot.core.errors import UsageError

        environment = _environment(env)
        scene, _ = scene_cache.scene_for(_styled(environment, style), _world(0, environment, env),
                                         build=build_scene)  # as --seed 0
        if output.suffix.lower() == ".glb":
            try:
                written = export_scene(scene, output)
            except OSError as e:
                raise UsageError(f"cannot write the mesh {output}: {e.strerror or e}", "use a writable path") from e
            typer.echo(f"{output} ({sum(len(g.faces) for g in written.geometry.values())} triangles)")
            return
        mesh = scene_mesh(scene)
        mesh.metadata.pop("face_instance", None)
        output.parent.mkdir(parents=True, exist_ok=True)
        try:
            mesh.export(str(output))
        except (ValueError, KeyError, OSError) as e:  # trimesh: unknown format (ValueError/KeyError)
            why = e.strerror if isinstance(e, OSError) else f"no exporter for {output.suffix or 'files without a suffix'}"
            raise UsageError(f"cannot write the mesh {output}: {why}",
                             "use a writable path ending in .glb, .gltf, .obj, .ply or .stl") from e
        typer.echo(f"{output} ({len(mesh.faces)} triangles)")

    _run(go)


@app.command("plan")
def plan(env: str = typer.Argument(..., help="name:variant or an environment YAML"),
         output: Path = typer.Option(..., "-o", "--output", help="image file to write (.png, .svg or .pdf)")) -> None:
    """Draw the floor plan of ENV's furnished home from above: rooms by kind, walls, doors and open passages,
    windows, ENV's ground-truth boxes and its robot path (start dot, then the trajectory). Prints the plan's counts
    and the first 12 hex digits of its digest on stderr (the same for every variant of a home), the file on stdout."""

    def go():
        import numpy as np

        from benchbot.core.errors import UsageError
        from benchbot_worlds.homes.floorplan_plot import save_plan_figure
        from benchbot_sim_taichi import scene_cache
        from benchbot_worlds.scene.build import build_scene

        environment = _environment(env)
        scene, _ = scene_cache.scene_for(_styled(environment, "furnished"), _world(0, environment, env),
                                         build=build_scene)
        if scene.plan is None:
            raise UsageError(f"{env} has no ground-truth objects, so no floor plan is derived for it",
                             "give an environment with a map_path (BEAR ground truth)")
        objects = [{"class": scene.class_list[int(c)], "centroid": ((lo + hi) / 2).tolist(),
                    "extent": (hi - lo).tolist()} for c, lo, hi in zip(scene.box_class, scene.box_min, scene.box_max)]
        path = np.concatenate([scene.start_se2[None, :2], scene.trajectory_se2[:, :2]])
        output.parent.mkdir(parents=True, exist_ok=True)
        try:
            save_plan_figure(scene.plan, objects, [path], output,
                             title=f"{env}: {len(scene.plan.rooms)} rooms, {len(objects)} ground-truth objects")
        except (OSError, ValueError) as e:
            raise UsageError(f"cannot write the plan {output}: {e}", "use a writable path ending in .png, .svg or .pdf")
        typer.echo(f"{env}: {scene.plan.summary()}; plan {scene.plan.digest()[:12]}", err=True)
        typer.echo(str(output))

    _run(go)


@app.command("ground-truth")
def ground_truth(env: str = typer.Argument(..., help="name:variant or an environment YAML"),
                 output: Path = typer.Option(..., "-o", "--output", help="JSON file to write")) -> None:
    """Write the ground truth derived from ENV's scene (axis-aligned bounds of every object's geometry)."""

    def go():
        from benchbot_worlds.scene.build import derive_ground_truth

        gt = derive_ground_truth(_environment(env))
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_text(json.dumps(gt, indent=1))
        typer.echo(f"{output} ({len(gt['ground_truth']['objects'])} objects)")

    _run(go)


@app.command("prepare")
def prepare(envs: list[str] = typer.Argument(None, help="environments, name:variant or YAML files (default: "
                                             "miniroom:1, README command 1's)"),
            arch: str = typer.Option("auto", "--arch", help="as benchbot batch's: auto (a GPU when an NVIDIA device "
                                     "is present, else the CPU), cpu or gpu"),
            seed: int = typer.Option(0, "--seed", help=f"the run seed of the episodes to prepare for, as benchbot "
                                     f"batch's --seed ({at_most(MAX_SEED)})"),
            quality: bool = typer.Option(False, "--quality", help="also quality mode's kernels (the path tracer: "
                                         "about half a minute more on 2 cores)"),
            workers: int = typer.Option(1, "--workers", help="prepare for benchbot batch --workers N on the CPU: "
                                        "Taichi keys its kernels by the thread count, and each of N workers gets "
                                        f"cores/N threads ({at_most(MAX_WORKERS, 1)})"),
            as_json: bool = typer.Option(False, "--json", help="print {kernel_cache, kernel_cache_bytes, "
                                         "scene_cache, scene_cache_bytes, seconds} as JSON"),
            ) -> None:
    """Build ahead what a machine's first run builds: compile the simulator's kernels into Taichi's offline cache and
    build ENVS' scenes (BVH, shadow maps, baked light) into the scene cache, with a progress bar on stderr. The
    first episode then starts as later ones do (docs/simulator.md, Cold start)."""

    def go():
        import time

        from benchbot.cli.common import backend_options, registry
        from benchbot_sim_taichi import prepare as ahead

        check_count("--seed", seed, MAX_SEED)
        check_count("--workers", workers, MAX_WORKERS, 1)
        if arch not in ("auto", "cpu", "gpu", "cuda"):
            from benchbot.core.errors import UsageError

            raise UsageError(f"unknown --arch {arch!r}", "use auto, cpu or gpu")
        if workers > 1:  # as a batch's worker gets it (benchbot.batch.executors); a value set already wins
            import os

            os.environ.setdefault("BENCHBOT_TAICHI_THREADS", str(max(1, (os.cpu_count() or 1) // workers)))
        names = list(envs or ahead.DEFAULT_ENVIRONMENTS)
        todo = ahead.steps([(name, _environment(name)) for name in names], registry().get("robots", "carter"),
                           backend_options(arch, None), seed=seed, quality=quality)
        started = time.monotonic()
        _run_steps(todo)
        summary = {**ahead.finish(), "seconds": round(time.monotonic() - started, 1)}
        if as_json:
            typer.echo(json.dumps(summary))
            return
        kernels = summary["kernel_cache"] or "off (Taichi's offline cache is off)"
        typer.echo(f"kernels: {kernels} ({summary['kernel_cache_bytes'] / 1e6:.1f} MB)")
        typer.echo(f"scenes: {summary['scene_cache']} ({summary['scene_cache_bytes'] / 1e6:.1f} MB)")
        typer.echo(f"prepared {', '.join(names)} in {summary['seconds']:.0f} s")

    _run(go)


def _run_steps(todo: list) -> None:
    """Run the steps of :func:`benchbot_sim_taichi.prepare.steps` under a progress bar on stderr (a terminal: the
    bar, the step and its current stage; a log: a line as each step and stage starts, and one with each step's
    time)."""
    import time

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from benchbot.cli.common import err, is_tty

    live = is_tty()
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=err, disable=not live) as progress:
        task = progress.add_task("preparing", total=len(todo))
        for step in todo:
            def show(event, step=step) -> None:
                if event.kind == "end":
                    return
                if live:
                    progress.update(task, description=f"{step.label} [dim]{event.text()} …[/]")
                elif event.kind == "start":
                    err.print(f"  {event.text()} …", highlight=False)

            progress.update(task, description=step.label)
            if not live:
                err.print(f"{step.label} …", highlight=False)
            t = time.monotonic()
            with stages.listening(show):
                step.run()
            err.print(f"{step.label}: {time.monotonic() - t:.1f} s", highlight=False)
            progress.advance(task)
