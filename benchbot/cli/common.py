"""Shared CLI helpers: consoles (data on stdout, messages on stderr), error reporting, the registry."""

from __future__ import annotations

import contextlib
import functools
import os
import re
import sys
import threading
import traceback
from typing import Any, Callable, Iterator

import typer
from rich.console import Console
from rich.markup import escape

from benchbot.core import limits, settings
from benchbot.core.errors import BenchbotError, ExitCode, UsageError
from benchbot.core.registry import Registry, get_registry

# Tables go to stdout; when it is not a terminal (a pipe, a file, CI) they get room instead of 80 columns.
out = Console(soft_wrap=True, width=None if sys.stdout.isatty() else 160)
err = Console(stderr=True, soft_wrap=True)


def print_json(data: Any, *, default: Callable[[Any], Any] | None = None) -> None:
    """Print ``data`` as JSON (indented by 2, non-ASCII kept) on stdout: highlighted by Rich in a terminal, written
    as is into a pipe or a file, where Rich's highlighting only costs time (a large batch's outcome) and the bytes
    are the same. ``default``: as :func:`json.dumps`'s (objects JSON cannot hold).

    Raises:
        TypeError, ValueError: ``data`` cannot be written as JSON."""
    import json

    text = json.dumps(data, indent=2, ensure_ascii=False, default=default)
    if out.is_terminal:
        out.print_json(text)
    else:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()


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
    """Print an error as one line (and its hint) on stderr; brackets in them (a file named ``[/x].yaml``, a URL)
    are printed as they are, never read as Rich markup."""
    err.print(f"[bold red]error:[/] {escape(exc.message)}", highlight=False)
    if exc.hint:
        err.print(f"[dim]hint:[/] {escape(exc.hint)}", highlight=False)


def handle_errors(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Decorator for commands: a BenchbotError becomes one line on stderr and its exit code; Ctrl-C exits 130.
    ``BENCHBOT_DEBUG=1`` shows tracebacks."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except BenchbotError as exc:
            if settings.get("BENCHBOT_DEBUG") == "1":
                traceback.print_exc()
            report(exc)
            raise typer.Exit(int(exc.exit_code)) from None
        except KeyboardInterrupt:
            err.print("interrupted")
            raise typer.Exit(int(ExitCode.INTERRUPTED)) from None

    return wrapper


def backend_options(arch: str, camera_size: str | None) -> dict:
    """Robot-backend options from the CLI: ``{'arch': 'cpu'|'gpu', 'width': W, 'height': H}`` (``arch='auto'``
    means a GPU when an NVIDIA device is present, else the CPU).

    Raises:
        UsageError: ``camera_size`` is not ``WxH`` with positive integers of at most
            :data:`~benchbot.core.limits.MAX_CAMERA_SIDE` (8192) pixels each.
    """
    if arch == "auto":  # a GPU when the machine has an NVIDIA device, else the CPU
        arch = "gpu" if os.path.exists("/dev/nvidiactl") else "cpu"
    options: dict = {"arch": arch}
    if camera_size:
        shown = camera_size if len(camera_size) <= 40 else camera_size[:37] + "..."
        match = re.fullmatch(r"0*(\d+)[xX]0*(\d+)", camera_size.strip())
        if not match or match[1] == "0" or match[2] == "0":
            raise UsageError(f"--camera-size '{shown}' is not WIDTHxHEIGHT", "e.g. --camera-size 320x240")
        side = int(limits.MAX_CAMERA_SIDE.value())
        if max(len(match[1]), len(match[2])) > len(str(side)) or max(int(match[1]), int(match[2])) > side:
            raise UsageError(f"--camera-size '{shown}': each side must be at most {side} pixels",
                             f"e.g. --camera-size 640x480 (at most {side}x{side})")
        options.update(width=int(match[1]), height=int(match[2]))
    return options


@contextlib.contextmanager
def writing(path: Any, flag: str) -> Iterator[None]:
    """Context for writing an output file: an OSError (no such folder, permission denied) becomes one line.

    Raises:
        UsageError: ``flag``'s file ``path`` cannot be written.
    """
    try:
        yield
    except OSError as exc:
        raise UsageError(f"{flag}: cannot write {path} ({exc.strerror or exc})", "choose a writable path") from None


#: How often (seconds) :func:`wait_until_interrupted` lets the main thread run a signal handler that is pending.
INTERRUPT_POLL_S = 0.5


def wait_until_interrupted() -> None:
    """Block the main thread until Ctrl-C (or SIGTERM, which ``benchbot`` turns into Ctrl-C) raises
    KeyboardInterrupt, which propagates to the caller.

    Waits in timed slices of :data:`INTERRUPT_POLL_S`, never in one untimed wait: the kernel may deliver a signal
    to any thread of the process (a server's, a refresher's), and CPython runs Python signal handlers only on the
    main thread, between bytecodes; an untimed lock wait on the main thread is then never woken, and the signal is
    left pending for good (a ``kill`` that did not stop the process). A pending signal is handled within one slice.
    """
    never_set = threading.Event()
    while not never_set.wait(INTERRUPT_POLL_S):
        pass


def is_tty() -> bool:
    """stderr is a terminal (progress bars are drawn live)."""
    return sys.stderr.isatty()


#: Stages shorter than this (seconds) leave no line behind in a terminal (the status line showed them meanwhile).
STAGE_LINE_MIN_S = 0.5
#: In a log, a stage's start is a line; its end is one too when it took this long or more (seconds).
STAGE_END_LINE_MIN_S = 5.0


@contextlib.contextmanager
def showing_stages(label: str = "") -> Iterator[None]:
    """Show the stages of the work done inside the block (:mod:`benchbot.core.stages`: building the scene,
    compiling kernels, ...) on stderr, ``label`` (e.g. an environment's name) before each. In a terminal: a status
    line with a spinner naming the current stage and its progress, and a line with its time for each stage that
    took :data:`STAGE_LINE_MIN_S` or more. In a log: a line as each stage starts, and one with its time when it took
    :data:`STAGE_END_LINE_MIN_S` or more. Nothing is shown for work that has no stages."""
    from benchbot.core import stages

    prefix = f"{label}: " if label else ""
    status = err.status("starting …", spinner="dots") if is_tty() else None

    def show(event: stages.StageEvent) -> None:
        if event.kind == "end":
            if event.elapsed_s >= (STAGE_LINE_MIN_S if status is not None else STAGE_END_LINE_MIN_S):
                err.print(f"[dim]{prefix}{event.text()}: {event.elapsed_s:.1f} s[/]", highlight=False)
        elif status is not None:
            status.update(f"{prefix}{event.text()} …")
        elif event.kind == "start":
            err.print(f"{prefix}{event.text()} …", highlight=False)

    if status is not None:
        status.start()
    try:
        with stages.listening(show):
            yield
    finally:
        if status is not None:
            status.stop()
