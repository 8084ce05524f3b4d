"""``benchbot show KIND NAME``: one spec."""

from __future__ import annotations


import typer
import yaml

from benchbot.cli.common import handle_errors, out, print_json, registry
from benchbot.cli.list_cmd import KINDS_HELP, Kind, parse_kind
from benchbot.core.errors import UsageError
from benchbot.core.specs import singular


def register(app: typer.Typer) -> None:
    @app.command("show")
    @handle_errors
    def show(
        kind: str = typer.Argument(..., metavar="KIND", callback=parse_kind, help=f"The kind of spec: {KINDS_HELP} (or a singular, e.g. robot)."),
        name: str = typer.Argument(..., help="Its name (environments: name:variant, e.g. miniroom:1)."),
        as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    ) -> None:
        """Show a spec: where it comes from and its content."""
        if kind is Kind.plugins:
            raise UsageError("`benchbot show` shows specs, not plugins", "use `benchbot plugins` (or --json)")
        entry = registry().entry(kind.value, name)
        spec = {k: v for k, v in entry.spec.items() if k != "_file_path"}
        if as_json:
            print_json(spec)
            return
        # spec text is printed as written (markup=False): "[x, y, z]" in a description is not Rich markup
        out.print(f"# {singular(kind.value)} '{entry.name}' from plugin {entry.plugin}" + (f" ({entry.path})" if entry.path else ""), markup=False, highlight=False)
        text = yaml.safe_dump(spec, sort_keys=False, width=110)
        lines = text.splitlines()
        out.print("\n".join(lines[:60]) + (f"\n... ({len(lines) - 60} more lines; --json for all)" if len(lines) > 60 else ""), markup=False, highlight=False)
