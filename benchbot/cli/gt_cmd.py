"""``benchbot gt``: write an environment's ground truth: its ``object_map_ground_truth`` instance, or (``--layout
original``) the whole file in the original BenchBot's layout ``{environment, format, ground_truth}``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from benchbot.cli.common import err, handle_errors, registry, writing
from benchbot.core import atomic
from benchbot.core.errors import SpecError, UsageError
from benchbot.core.registry import Registry


def ground_truth_instance(reg: Registry, env: str) -> dict:
    """The ``ground_truth`` part (``{objects, class_list, synonyms}``, an ``object_map_ground_truth`` instance) of
    environment ``name:variant``'s registered ground truth.

    Objects are ``{class, ID_name, centroid, extent, isgroup}`` (metres, map frame, full side lengths of
    axis-aligned boxes), as in the BEAR ground-truth files.

    Raises:
        SpecError: ``env`` is not ``name:variant`` (one scene), the environment does not exist, or no plugin
            registers a ground truth for it.
    """
    scenes = reg.scenes(env)  # SpecError: malformed or unknown
    if len(scenes) != 1:
        raise SpecError(
            f"environment '{env}' names {len(scenes)} scenes; a ground truth belongs to one scene",
            f"give one scene, e.g. {env.split(':')[0]}:{scenes[0]['variant']}",
        )
    name = f"{scenes[0]['name']}:{scenes[0]['variant']}"
    if not reg.has("ground_truths", name):
        raise SpecError(
            f"environment {name} has no registered ground truth",
            "deriving one from the environment's plugin is not supported yet; see `benchbot list environments`",
        )
    gt = reg.ground_truth(name)["ground_truth"]
    return {"objects": gt.get("objects", []), "class_list": gt.get("class_list", []), "synonyms": gt.get("synonyms", {})}


#: The layouts ``benchbot gt`` writes.
LAYOUTS = ("instance", "original")


def ground_truth_file(reg: Registry, env: str) -> dict:
    """Environment ``name:variant``'s registered ground truth in the original BenchBot's file layout:
    ``{'environment': the environment spec it was made for, 'format': the ground-truth format spec, 'ground_truth':
    the format's instance}`` (docs/original-benchbot.md, section 10), as the original's ground-truth add-ons shipped
    it and as a content pack's ``ground_truths/`` files are laid out.

    Raises:
        SpecError: as :func:`ground_truth_instance`.
    """
    ground_truth_instance(reg, env)  # the same checks and messages
    scene = reg.scenes(env)[0]
    registered = reg.ground_truth(f"{scene['name']}:{scene['variant']}")
    return {key: registered[key] for key in ("environment", "format", "ground_truth")}


def register(app: typer.Typer) -> None:
    @app.command("gt")
    @handle_errors
    def gt_(
        env: str = typer.Argument(..., help="Environment NAME:VARIANT, e.g. miniroom:1."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write the JSON here (atomically) instead of stdout."),
        layout: str = typer.Option(
            "instance", "--layout",
            help="instance: the object_map_ground_truth instance {objects, class_list, synonyms}; original: the whole "
                 "file as the original BenchBot's ground-truth add-ons had it, {environment, format, ground_truth}."),
    ) -> None:
        """Write the ground truth of an environment in the object_map_ground_truth format
        ({objects, class_list, synonyms}; metres, map frame), from the installed plugins' ground truths; with
        --layout original, the original BenchBot's ground-truth file {environment, format, ground_truth}."""
        if layout not in LAYOUTS:
            raise UsageError(f"--layout '{layout}' is not one of {', '.join(LAYOUTS)}",
                             "use --layout instance (the default) or --layout original")
        reg = registry()
        data = ground_truth_file(reg, env) if layout == "original" else ground_truth_instance(reg, env)
        count = len((data["ground_truth"] if layout == "original" else data).get("objects", []))
        if output is None:
            typer.echo(json.dumps(data, indent=2))
        else:
            with writing(output, "--output"):
                atomic.write_json(output, data)
            err.print(f"ground truth of {env} ({count} objects, {layout} layout) written to {output}", highlight=False)
