"""``benchbot ARGS`` run in the test's own process, as the ``benchbot`` script runs it (``benchbot.cli.main.main``):
the same argument checks, registry, plugin commands and one-line error reports, without a new interpreter's start-up
(0.6–0.8 s of imports, byte-compiling and registry building on a 2-core machine, per command).

For tests of what a command says and returns (usage errors, bad files, refused input). A test whose subject is the
process itself — its start-up, its signals, a terminal, an import that must not happen, code a pack brings in —
runs ``python -m benchbot.cli`` in a subprocess instead."""

from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
import traceback


def benchbot(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """Run ``benchbot ARGS`` here and return what a subprocess would: its exit status, stdout and stderr (text).

    The registry is built anew from the environment of the call (``env`` added to ``os.environ`` for the call
    only), and the Typer app too (plugins add their commands to it), so nothing of one call or of an earlier test
    carries over. An exception that escapes the command is printed with its traceback on stderr and gives status 1,
    as Python does for a script. The process's ``SIGTERM`` handler (the CLI sets its own), ``sys.argv`` and the
    environment are restored after the call, and the CLI's consoles print no colour codes (as into a pipe).
    """
    import benchbot.cli.main as cli_main
    from benchbot.cli.common import err, out
    from benchbot.core.registry import get_registry

    saved_env, saved_argv, saved_term = dict(os.environ), sys.argv, signal.getsignal(signal.SIGTERM)
    saved_colours = [(console, console._color_system) for console in (out, err)]
    stdout, stderr = io.StringIO(), io.StringIO()

    def fresh() -> None:
        get_registry.cache_clear()
        vars(cli_main).pop("app", None)

    fresh()
    os.environ.update(env or {})
    sys.argv = ["benchbot", *args]
    for console, _ in saved_colours:
        console._color_system = None  # rich picks colours when the console is made: none, as into a pipe
    code: int = 0
    try:
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            try:
                cli_main.main()
            except SystemExit as exc:
                if exc.code is None or isinstance(exc.code, int):
                    code = exc.code or 0
                else:  # sys.exit("message"): Python prints it and exits 1
                    print(exc.code, file=sys.stderr)
                    code = 1
            except Exception:  # noqa: BLE001 — what the interpreter prints for an uncaught exception
                traceback.print_exc()
                code = 1
    finally:
        os.environ.clear()
        os.environ.update(saved_env)
        sys.argv = saved_argv
        signal.signal(signal.SIGTERM, saved_term)
        for console, colours in saved_colours:
            console._color_system = colours
        fresh()
    return subprocess.CompletedProcess(["benchbot", *args], code, stdout.getvalue(), stderr.getvalue())
