"""Pieces shared by the commands' option definitions.

The short flags mean one thing in every command; their table is docs/cli.md (``tests/test_cli_consistency.py``
checks every command against it). This module holds what the option lines need beyond a name and a help text:

* :func:`arch_value`: ``--arch auto`` resolved (a GPU when an NVIDIA device is present, else the CPU).
* :func:`native_words`: ``benchbot submit --native python my.py``: the words after ``--native CMD`` are part of
  the command, as in the original BenchBot.
* :func:`refused`: a flag a command does not take, named with the fix (e.g. the original's ``submit -e METHOD``,
  now ``--evaluate-with``, since ``-e`` is ``--env`` everywhere).
"""

from __future__ import annotations

import shlex
from typing import Any, Callable

import typer

ARCH_HELP = "Simulator device: auto (a GPU when an NVIDIA device is present, else the CPU), cpu or gpu."


def arch_value(value: str) -> str:
    """Option callback of ``--arch``: ``auto`` becomes ``gpu`` or ``cpu`` (see
    :func:`benchbot.cli.common.backend_options`); other values are checked where the simulator starts. Raises
    nothing."""
    from benchbot.cli.common import backend_options

    return backend_options(value, None)["arch"] if value == "auto" else value


def native_words(ctx: typer.Context, words: list[str] | None) -> list[str] | None:
    """Argument callback of ``benchbot submit``'s trailing words: with ``--native CMD`` they are appended to CMD
    (``--native python my.py`` runs ``python my.py``; ``-n 'python my.py'`` too), returned as one shell-quoted
    string that :func:`benchbot.core.submission.native_submission` splits back. Without ``--native`` they are
    returned unchanged (the command refuses them).

    Click processes every option before the positional arguments, so ``--native`` is already in ``ctx.params``.
    """
    native = ctx.params.get("native")
    if not native:
        return words
    parts = [] if native == "--" else [native]
    return [" ".join(parts + [shlex.quote(w) for w in words or ()])]


def refused(flag: str, why: str) -> Callable[[Any], Any]:
    """An option callback that rejects any value of ``flag`` with ``why`` (a usage error, exit status 2)."""

    def check(value: Any) -> Any:
        if value is not None:
            raise typer.BadParameter(why, param_hint=f"'{flag}'")
        return value

    return check
