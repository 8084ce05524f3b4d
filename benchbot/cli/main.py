"""The ``benchbot`` command: one Typer app, one module per command; plugins add commands through the hook
``benchbot_commands``."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from benchbot import __version__

if TYPE_CHECKING:
    import typer

    from benchbot.core.errors import UsageError

# The Typer app and its commands are built on first use (``app``, below): ``benchbot --version`` imports none of
# them and builds no registry; ``--help`` loads the plugins (their commands) but not their specs.

HELP = ("""BenchBot: benchmark robotics research on simulated and real robots.

Typical use:

  benchbot batch --example semslam_geometric --envs miniroom:1
      run an example solution on an environment, score it, print a table

  benchbot run --env miniroom:1
      a backend to develop against; in another terminal:
      benchbot submit --native python my_solution.py

  benchbot eval results.json
      score a results file with OMQ

"""  # each paragraph below is one line: Rich wraps it to the terminal (a break in it showed as a ragged line)
        "See `benchbot list tasks|robots|environments|...` for what is installed. A short flag means the same in "
        "every command: -e environment(s), -t task, -r robot, -n native, -c containerised, -E example, -a args, "
        "-o output (docs/cli.md).\n")


def _no_type_on_flags() -> None:
    """Typer's rich help (from 0.16 or so) shows ``<bool>`` after every flag (``--json <bool>``, even ``--help
    <bool>``), as if it took a value; a flag takes none, so its type column is left empty (options that take a value
    keep theirs). Typer has no public setting for it, so this wraps its ``TyperOption.display_type_rich`` where that
    exists; a Typer without it (older ones, which show no type on flags) is left as it is."""
    from typer.core import TyperOption

    shown = getattr(TyperOption, "display_type_rich", None)
    if shown is None or getattr(shown, "_benchbot_flags_untyped", False):
        return

    def display_type_rich(self: TyperOption, ctx: Any) -> "str | None":
        return None if self.is_flag or self.count else shown(self, ctx)

    display_type_rich._benchbot_flags_untyped = True  # type: ignore[attr-defined]
    TyperOption.display_type_rich = display_type_rich  # type: ignore[method-assign]


#: -h is --help in every command (as in the original BenchBot); sub-commands and plugins' commands inherit it.
CONTEXT = {"help_option_names": ["-h", "--help"]}

#: The words of a command line that only ask for the version: answered before anything else is imported.
VERSION_WORDS = (["--version"], ["-v"])


def _version(value: bool) -> None:
    import typer

    if value:
        typer.echo(f"benchbot {__version__}")
        raise typer.Exit()


def _build_app() -> typer.Typer:
    """The root Typer app with the core's commands (plugins' commands are added by :func:`main`)."""
    import typer

    from benchbot.cli import (
        batch_cmd, doctor_cmd, eval_cmd, gt_cmd, install_cmd, leaderboard_cmd, list_cmd, plugin_cmd, replay_cmd,
        report_cmd, run_cmd, service_cmd, show_cmd, submit_cmd, tui_cmd,
    )
    from benchbot.cli import challenge_cmd, container_base_cmd, verify_cmd

    _no_type_on_flags()
    root = typer.Typer(help=HELP, no_args_is_help=True, add_completion=False, rich_markup_mode="rich",
                       context_settings=CONTEXT)
    for module in (list_cmd, show_cmd, run_cmd, submit_cmd, eval_cmd, batch_cmd, report_cmd, leaderboard_cmd,
                   install_cmd, plugin_cmd, doctor_cmd, gt_cmd, tui_cmd, replay_cmd, challenge_cmd, verify_cmd,
                   service_cmd, container_base_cmd):
        module.register(root)

    @root.callback()
    def _root(
        version: bool = typer.Option(False, "--version", "-v", help="Print the version and exit.", callback=_version,
                                     is_eager=True),
    ) -> None:
        """BenchBot."""

    return root


def get_app() -> typer.Typer:
    """The root Typer app, built once (on first use)."""
    if "app" not in globals():
        globals()["app"] = _build_app()
    return globals()["app"]


def __getattr__(name: str) -> Any:
    """``app``, the root Typer app, built on first use (PEP 562)."""
    if name == "app":
        return get_app()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _stop_as_on_ctrl_c(signum: int, frame: object) -> None:
    """SIGTERM (``kill``, a process manager, a container stop) ends a command as Ctrl-C does: its clean-up runs
    (the server stops, the backend closes, a recording is finished, shared-memory segments are removed)."""
    raise KeyboardInterrupt


#: Where a command line's words become a solution's own (``submit --native python my.py --classes chair, table``).
SOLUTION_WORDS_FROM = frozenset(("--", "--native", "-n", "--args", "-a"))


def spaced_comma_list(argv: list[str]) -> UsageError | None:
    """The usage error of a comma list broken by a space (``--envs miniroom:1, house:1``: the shell passes
    ``house:1`` as a word of its own, which Typer would report as an unexpected extra argument, with no hint), or
    None. ``argv``: the command line's words after the program name; the words from ``--``, ``--native``/``-n`` or
    ``--args``/``-a`` on are a solution's own and are not read."""
    for k, word in enumerate(argv):
        if word in SOLUTION_WORDS_FROM:
            argv = argv[:k]
            break
    from benchbot.core.errors import UsageError

    for option, value, after in zip(argv, argv[1:], argv[2:]):
        if option.startswith("--") and "=" not in option and value.endswith(",") and not after.startswith("-"):
            return UsageError(f"{option} {value!r} is followed by {after!r}: a comma list is one word, with no spaces",
                              f"write {option} {value}{after} (or quote the whole list)")
    return None


def asks_only_for_help(argv: list[str]) -> bool:
    """Whether a command line (its words after the program name) only prints help: no words (the root's help), or
    ``-h``/``--help`` before the words that are a solution's own. Such a line needs the plugins' commands but not
    their specs, so :func:`main` loads the plugins without building the registry."""
    for k, word in enumerate(argv):
        if word in SOLUTION_WORDS_FROM:
            argv = argv[:k]
            break
    return not argv or any(word in CONTEXT["help_option_names"] for word in argv)


def _plugins_for_help() -> Any:
    """The plugin manager of the installed, enabled plugins, without the registry's specs (for help only); warns on
    stderr, as the registry does, about plugins that failed to load."""
    from benchbot.cli.common import err
    from benchbot.core.plugin_manager import build_plugin_manager

    plugin_manager, plugins = build_plugin_manager()
    for plugin in plugins:
        if plugin.status == "failed":
            err.print(f"[yellow]warning:[/] plugin {plugin.name} ({plugin.distribution}) failed to load: {plugin.error}")
    return plugin_manager


#: OpenBLAS's thread-count variable, read once, as the library loads with NumPy.
OPENBLAS_THREADS_VARIABLE = "OPENBLAS_NUM_THREADS"


def import_numpy_with_one_blas_thread() -> None:
    """Import NumPy so that the command's own process runs one OpenBLAS thread, and leave the environment as it was.

    NumPy's wheels from PyPI ship OpenBLAS, which starts one thread per core as it loads and keeps them spinning
    after every matrix product. The command's own products are small (poses, OMQ's boxes), but on a host with 32
    cores its 31 extra threads took 4.3–4.8 s of CPU in a `benchbot eval` of 0.6–1.0 s wall, CPU that a sweep's
    solutions on the same cores need (``benchmarks/cpu_by_process.py -- benchbot eval FILE``, 2 × H100 host,
    2026-11-26; ``benchmarks/service_warm.py`` counted 4.83 s of the command's CPU in README command 1 on one such
    host before, 0.63 s on another after). OpenBLAS reads ``OPENBLAS_NUM_THREADS`` only as it loads, so the variable
    is set for NumPy's import and then removed again: the processes the command starts (the service, its workers,
    the solutions, to which a batch gives their share of the cores) see the environment the user gave. A value the
    user set is kept, and so is a NumPy already imported (the command run in-process)."""
    import os
    import sys

    if "numpy" in sys.modules or OPENBLAS_THREADS_VARIABLE in os.environ:
        return
    os.environ[OPENBLAS_THREADS_VARIABLE] = "1"
    try:
        import numpy  # noqa: F401
    finally:
        del os.environ[OPENBLAS_THREADS_VARIABLE]


def main() -> None:
    """Entry point of the ``benchbot`` script. ``benchbot --version`` is answered at once (no command, no plugin
    imported); help loads the plugins (for their commands) but builds no registry."""
    import atexit
    import gc
    import signal
    import sys

    argv = sys.argv[1:]
    if argv in VERSION_WORDS:
        print(f"benchbot {__version__}")
        return
    # At exit the interpreter's last garbage collections walk every object the command made (0.1 s of the 2-core
    # CPU's 3.4 s of `benchbot batch` warm); frozen, they are skipped. Registered first, this runs after the other
    # exit handlers (last in, first out). Objects are still freed as the modules are torn down; only reference
    # cycles left at exit stay uncollected, which Python never promised to collect at exit.
    atexit.register(gc.freeze)
    import_numpy_with_one_blas_thread()

    from benchbot.cli.common import registry, report
    from benchbot.core.errors import ExitCode

    spaced = spaced_comma_list(argv)
    if spaced is not None:
        report(spaced)
        raise SystemExit(int(ExitCode.USAGE))

    signal.signal(signal.SIGTERM, _stop_as_on_ctrl_c)
    root = get_app()
    plugin_manager = _plugins_for_help() if asks_only_for_help(argv) else registry().plugin_manager
    add_plugin_commands(plugin_manager, root)
    root()


def add_plugin_commands(plugin_manager: Any, cli_app: typer.Typer) -> list[str]:
    """Call every plugin's ``benchbot_commands(app)``. A plugin whose hook raises does not break the CLI: its
    commands are left out, with a one-line warning on stderr naming the plugin. Returns those warnings."""
    from benchbot.cli.common import err

    from benchbot.core.plugin_manager import call_each_plugin

    warnings = []
    for plugin_name, _, exc in call_each_plugin(plugin_manager, "benchbot_commands", app=cli_app):
        if exc is not None:
            warnings.append(f"plugin {plugin_name} could not add its commands: {exc!r}")
            err.print(f"[yellow]warning:[/] {warnings[-1]}", highlight=False)
    return warnings
