"""The benchmarks' smoke mode: ``--smoke`` on every script here runs it tiny (the smallest scene, images and counts;
seconds on a 2-core CPU), printing its figures as a real run does, so that a script that no longer runs is found
(``tests/test_benchmarks_smoke.py`` runs each one so). Its figures are not measurements.

A script parses its command line with :func:`parse_args` instead of ``ap.parse_args``, naming its tiny settings::

    args = smoke.parse_args(ap, argv, frames=2, width=32, height=24, env="miniroom:4")

With ``--smoke`` those become the defaults (a flag given on the command line still wins), environments are built in
the fast ``primitives`` style unless ``$BENCHBOT_SIM_STYLE`` says otherwise (or the script asks for another), and a
line on stderr says that this is a smoke run. What a smoke run leaves out (a GPU's part, a program that ``uv sync``
does not install) it names with :func:`left_out`, on stderr.
"""

from __future__ import annotations

import argparse
import os
import sys

HELP = ("a tiny run (the smallest scene, images and counts: seconds on a 2-core CPU) that checks that this script "
        "works; its figures are not measurements, and flags given as well still apply")


def parse_args(ap: argparse.ArgumentParser, argv: list[str] | None = None, *, style: str | None = "primitives",
               force_style: bool = False, **tiny) -> argparse.Namespace:
    """``ap.parse_args(argv)`` with ``--smoke`` added: when it is given, ``tiny`` (argument dest → value) are the
    defaults, and ``$BENCHBOT_SIM_STYLE`` is ``style`` unless already set (``force_style``: even then; ``None``:
    left alone)."""
    ap.add_argument("--smoke", action="store_true", help=HELP)
    unknown = set(tiny) - {action.dest for action in ap._actions}
    if unknown:  # a typo here would make the smoke run silently big
        raise ValueError(f"smoke settings for arguments this script does not have: {sorted(unknown)}")
    known, _ = ap.parse_known_args(argv)
    if known.smoke:
        ap.set_defaults(**tiny)
        if style and (force_style or "BENCHBOT_SIM_STYLE" not in os.environ):
            os.environ["BENCHBOT_SIM_STYLE"] = style
        print(f"smoke: a tiny run of {ap.prog} (its figures are not measurements)", file=sys.stderr, flush=True)
    return ap.parse_args(argv)


def left_out(what: str, why: str) -> None:
    """Say on stderr what a smoke run leaves out, and why."""
    print(f"smoke: left out {what}: {why}", file=sys.stderr, flush=True)
