"""``benchbot gt``: write an environment's ground truth (``object_map_ground_truth``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from benchbot.cli.common import err, handle_errors, registry, writing
from benchbot.core import atomic
from benchbot.core.errors import SpecError
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
    if name not in reg.entries["ground_truths"]:
        raise SpecError(
            f"environment {name} has no registered ground truth",
            "deriving one from the environment's plugin is not supported yet; see `benchbot list environments`",
        )
    gt = reg.ground_truth(name)["ground_truth"]
    return {"objects": gt.get("objects", []), "class_list": gt.get("class_list", []), "synonyms": gt.get("synonyms", {})}


def register(app: typer.Typer) -> None:
    @app.command("gt")
    @handle_errors
    def gt_(
        env: str = typer.Argument(..., help="Environment NAME:VARIANT, e.g. miniroom:1."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write the JSON here (atomically) instead of stdout."),
    ) -> None:
        """Write the ground truth of an environment in the object_map_ground_truth format
        ({objects, class_list, synonyms}; metres, map frame), from the installed plugins' ground truths."""
        instance = ground_truth_instance(registry(), env)
        if output is None:
            typer.echo(json.dumps(instance, indent=2))
        else:
            with writing(output, "--output"):
                atomic.write_json(output, instance)
            err.print(f"ground truth of {env} ({len(instance['objects'])} objects) written to {output}", highlight=False)
