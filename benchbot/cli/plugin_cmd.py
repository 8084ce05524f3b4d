"""``benchbot plugins`` (what is installed, with hooks and load errors) and ``benchbot plugin new|docs``."""

from __future__ import annotations

from pathlib import Path

import typer

from benchbot.cli.common import err, handle_errors, out


def register(app: typer.Typer) -> None:
    @app.command("plugins")
    @handle_errors
    def plugins(as_json: bool = typer.Option(False, "--json", help="Print JSON (for machines).")) -> None:
        """List plugins: distribution, version, status, hooks implemented, what each registers, load errors and
        skipped specs (same as `benchbot list plugins`)."""
        from benchbot.cli.list_cmd import print_plugins

        print_plugins(as_json)

    plugin_app = typer.Typer(help="Write plugins: a project template, the hook reference.", no_args_is_help=True)
    app.add_typer(plugin_app, name="plugin")

    @plugin_app.command("new")
    @handle_errors
    def new(
        name: str = typer.Argument(..., help="Plugin name, e.g. 'lidar_noise': the project is the folder and distribution benchbot-<kind>-<name> (with - for _, e.g. benchbot-sim-lidar-noise), its package benchbot_<kind>_<name>."),
        kind: str = typer.Option(..., "--kind", "-k", help="sim, robot, task, eval or env."),
        out_dir: Path = typer.Option(Path("."), "--output", "--out", "-o", help="Folder to create the project folder in."),
        force: bool = typer.Option(False, "--force", help="Write into an existing, non-empty project folder."),
    ) -> None:
        """Write a complete plugin project: pyproject (entry point), hook implementations, an example spec,
        README, contract tests and a CI workflow. It installs (`benchbot install ./benchbot-<kind>-<name>`) and its
        tests pass as written, anywhere: until BenchBot is on PyPI its pyproject takes BenchBot from where this
        machine's came from (a checkout, a wheel or a git URL, in its \\[tool.uv.sources] table)."""
        from benchbot.plugins.scaffold import new_plugin

        root = new_plugin(kind, name, out_dir, force=force)
        err.print(f"[green]created[/] {root}", highlight=False)
        out.print(str(root), highlight=False)

    @plugin_app.command("docs")
    @handle_errors
    def docs() -> None:
        """Print the hook reference (Markdown, from the hookspecs' docstrings; docs/hooks.md is this output)."""
        from benchbot.core.hookdoc import render

        typer.echo(render(), nl=False)
