"""Shared CLI helpers: consoles (data on stdout, messages on stderr), error reporting, the registry."""

from __future__ import annotations

import functools
import os
import sys
import traceback
from typing import Any, Callable

import typer
from rich.console import Console

from benchbot.core.errors import BenchbotError, ExitCode
from benchbot.core.registry import Registry, get_registry

out = Console(soft_wrap=True)
err = Console(stderr=True, soft_wrap=True)


def registry() -> Registry:
    """The registry; warns on stderr (once) about plugins or specs that were skipped."""
    reg = get_registry()
    if not getattr(reg, "_warned", False):
        reg._warned = True  # type: ignore[attr-defined]
        for plugin in reg.plugins:
            if plugin.status == "failed":
                err.print(f"[yellow]warning:[/] plugin {plugin.name} ({plugin.distribution}) failed to load: {plugin.error}")
        for problem in reg.problems.values():
            err.print(f"[yellow]warning:[/] skipped: {problem}", highlight=False)
    return reg


def report(exc: BenchbotError) -> None:
    """Print an error as one line (and its hint) on stderr."""
    err.print(f"[bold red]error:[/] {exc.message}", highlight=False)
    if exc.hint:
        err.print(f"[dim]hint:[/] {exc.hint}", highlight=False)


def handle_errors(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Decorator for commands: a BenchbotError becomes one line on stderr and its exit code; Ctrl-C exits 130.
    ``BENCHBOT_DEBUG=1`` shows tracebacks."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except BenchbotError as exc:
            if os.environ.get("BENCHBOT_DEBUG") == "1":
                traceback.print_exc()
            report(exc)
            raise typer.Exit(int(exc.exit_code)) from None
        except KeyboardInterrupt:
            err.print("interrupted")
            raise typer.Exit(int(ExitCode.INTERRUPTED)) from None

    return wrapper


def is_tty() -> bool:
    """stderr is a terminal (progress bars are drawn live)."""
    return sys.stderr.isatty()
