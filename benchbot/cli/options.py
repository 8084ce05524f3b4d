"""Pieces shared by the commands' option definitions.

The short flags mean one thing in every command; their table is docs/cli.md (``tests/test_cli_consistency.py``
checks every command against it). This module holds what the option lines need beyond a name and a help text:

* :func:`arch_value`: ``--arch auto`` resolved (a GPU when an NVIDIA device is present, else the CPU).
* :func:`native_words`: ``benchbot submit --native python my.py``: the words after ``--native CMD`` are part of
  the command, as in the original BenchBot.
* :func:`refused`: a flag a command does not take, named with the fix (e.g. the original's ``submit -e METHOD``,
  now ``--evaluate-with``, since ``-e`` is ``--env`` everywhere).
* :func:`check_count` and :func:`at_most`: every flag that counts something (``--repeat``, ``--workers``,
  ``--retries``, ``--seed``, ``sim render --spp``, ...) has a maximum in :mod:`benchbot.core.limits`, said in its
  help and checked first thing in its command, before anything proportional to it is made.
"""

from __future__ import annotations

import shlex
from typing import Any, Callable

import typer

from benchbot.core.errors import UsageError
from benchbot.core.limits import Limit

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
    string that :func:`benchbot.solutions.submission.native_submission` splits back. Without ``--native`` they are
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


def at_most(limit: Limit, minimum: int = 0) -> str:
    """The range of a count flag for its help text: ``1 to 1000 (BENCHBOT_MAX_REPEAT)``, ``0 to 4294967295``."""
    top = f"{int(limit.default)}" + (f" ({limit.env})" if limit.env else "")
    return f"{minimum} to {top}"


def check_count(flag: str, value: int, limit: Limit, minimum: int = 0) -> int:
    """``value`` of the count flag ``flag`` when it lies in ``minimum`` to ``limit`` (its value now); call it first
    thing in a command, before anything proportional to the count is made.

    Raises:
        UsageError: one line naming the flag, the value and the bound (and the variable that raises a maximum),
            e.g. ``--repeat 99999999999999999999 is more than the maximum of 1000 repetitions (set
            BENCHBOT_MAX_REPEAT to raise it)``; or the limit's variable is not a valid value.
    """
    top = int(limit.value())
    digits = str(value)
    shown = digits if len(digits) <= 24 else f"{digits[:12]}… ({len(digits.lstrip('-'))} digits)"
    if value < minimum:
        raise UsageError(f"{flag} {shown} is less than {minimum}", f"give {flag} from {minimum} to {top}")
    if value > top:
        raise UsageError(f"{flag} {shown} is more than the maximum of {limit.describe()} ({limit.raise_hint()})",
                         limit.hint() if limit.env else f"give {flag} from {minimum} to {top}")
    return value
