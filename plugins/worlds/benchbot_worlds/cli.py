"""``benchbot worlds …``: procedural homes (a Typer sub-app registered by the plugin's ``benchbot_commands``).

* ``benchbot worlds generate --split val --count 100 -o PACK`` writes homes as a content pack
  (:mod:`benchbot_worlds.procedural.pack`) for ``benchbot install``;
* ``benchbot worlds key`` makes this host's key of the held-out test split (:mod:`benchbot_worlds.procedural.splits`).

Homes need no pack to be used: ``benchbot run --env procedural:val:42`` makes the home on first use.
"""

from __future__ import annotations

from pathlib import Path

import typer

from benchbot.cli.options import at_most, check_count
from benchbot.core.limits import MAX_GENERATED_HOMES, MAX_HOME_INDEX

app = typer.Typer(help="Procedural homes: write them as a content pack, make the test split's key.",
                  no_args_is_help=True)


@app.command("generate", help=(
    "Write procedural homes as a content pack: five variants each (lighting and scene changes), their environments, "
    "ground truths and a batch of variant 1 of every home.\n\nInstall it with `benchbot install PACK`. Example: "
    "benchbot worlds generate --split val --count 100 -o procedural_val_100"))
def generate(
    split: str = typer.Option("val", "--split", help="train, val or test (test needs this host's key: "
                                                     "`benchbot worlds key`)."),
    count: int = typer.Option(10, "--count", help=f"How many homes: {at_most(MAX_GENERATED_HOMES, 1)}."),
    start: int = typer.Option(0, "--start", help=f"The first home's index (homes start .. start+count-1): "
                                                 f"{at_most(MAX_HOME_INDEX)}."),
    out: Path = typer.Option(..., "--output", "-o", help="The pack's folder (must not exist, unless --force)."),
    force: bool = typer.Option(False, "--force", help="Replace an existing folder."),
) -> None:
    """Write procedural homes as a content pack (:func:`benchbot_worlds.procedural.pack.write_pack`)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from benchbot.cli.common import handle_errors
    from benchbot_worlds.procedural.pack import check_request, write_pack

    @handle_errors
    def run() -> None:
        check_count("--count", count, MAX_GENERATED_HOMES, 1)
        check_count("--start", start, MAX_HOME_INDEX)
        check_request(split, start, count, out, force=force)
        with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                      transient=False) as progress:
            task = progress.add_task(f"generating {split} homes", total=count)
            write_pack(split, start, count, out, force=force,
                       advance=lambda home: progress.update(task, advance=1, description=f"generated {home}"))
        typer.echo(f"wrote {count} homes to {out}; install them with: benchbot install {out}")

    run()


@app.command("key", help=(
    "Make this host's key of the held-out test split (a random 32-byte key, readable by you only).\n\nOnly a host "
    "holding the key can build test homes and their ground truth; keep it secret and backed up."))
def key(force: bool = typer.Option(False, "--force", help="Replace the existing key (every test home changes).")) -> None:
    """Make this host's key of the held-out test split (:func:`benchbot_worlds.procedural.splits.make_key`)."""
    from benchbot.cli.common import handle_errors
    from benchbot_worlds.procedural.splits import make_key

    @handle_errors
    def run() -> None:
        path = make_key(force=force)
        typer.echo(f"wrote this host's test-split key to {path} (keep it secret; back it up)")

    run()
