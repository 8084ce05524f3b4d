"""``benchbot container-base``: make ``benchbot/submission:base``, the image containerised solutions start FROM,
on this machine, without an image registry (docs/containers.md)."""

from __future__ import annotations

import sys
from typing import Optional

import typer

from benchbot.cli.common import err, handle_errors, out, print_json


def register(app: typer.Typer) -> None:
    @app.command("container-base")
    @handle_errors
    def container_base(
        source: str = typer.Option("debian", "--from", help="debian: a Debian root file system made with mmdebstrap "
                                   "from this machine's apt mirror (no registry); or an image with Python 3 of "
                                   "this Python's version to start from, e.g. python:3.11-slim (the engine pulls it: "
                                   "needs the internet)."),
        mirror: Optional[str] = typer.Option(None, "--mirror", help="The Debian mirror (default: the one apt uses "
                                             "here, else http://deb.debian.org/debian)."),
        tag: str = typer.Option("benchbot/submission:base", "--tag", help="The image's tag."),
        fresh_rootfs: bool = typer.Option(False, "--fresh-rootfs", help="Make the Debian root file system again "
                                          "even if benchbot/submission-rootfs:<release> exists."),
        as_json: bool = typer.Option(False, "--json", help="Print {tag, source, python, distributions, rootfs_s, "
                                     "layer_s} on stdout."),
    ) -> None:
        """Make the base image of containerised solutions: Python 3 and pip (Debian's, by default) plus BenchBot's
        client and its dependencies, copied from the Python BenchBot runs in (the same versions). Original
        Dockerfiles (`FROM benchbot/submission:base`) then build with no registry. Uses Docker where its daemon
        answers, else Podman. The steps' output goes to stderr."""
        from benchbot.solutions.container_base import build_base
        from benchbot.solutions.container_engine import container_engine, engine_facts

        tool = container_engine()
        err.print(f"making {tag} with {engine_facts(tool).describe()} from {source} …", highlight=False)
        made = build_base(tool, source=source, mirror=mirror, tag=tag, log=sys.stderr, reuse_rootfs=not fresh_rootfs)
        if as_json:
            print_json(made.__dict__)
        else:
            reused = "reused" if made.rootfs_s < 1 else f"{made.rootfs_s:g} s"
            out.print(f"{made.tag}: {made.source} (Python {made.python}; root file system {reused}) + "
                      f"{made.distributions} distributions ({made.layer_s:g} s)", highlight=False, markup=False)
