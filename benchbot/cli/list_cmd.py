"""``benchbot list KIND``: what is installed."""

from __future__ import annotations

import enum
import json
from dataclasses import asdict

import typer
from rich.table import Table

from benchbot.cli.common import handle_errors, out, registry


class Kind(str, enum.Enum):
    tasks = "tasks"
    robots = "robots"
    environments = "environments"
    formats = "formats"
    evaluators = "evaluators"
    examples = "examples"
    batches = "batches"
    ground_truths = "ground_truths"
    plugins = "plugins"


def register(app: typer.Typer) -> None:
    @app.command("list")
    @handle_errors
    def list_(
        kind: Kind = typer.Argument(..., help="What to list."),
        as_json: bool = typer.Option(False, "--json", help="Print JSON (for machines)."),
    ) -> None:
        """List installed tasks, robots, environments, formats, evaluators, examples, batches, ground truths or
        plugins. Environments are listed as name:variant."""
        reg = registry()
        if kind is Kind.plugins:
            rows = [asdict(p) for p in reg.plugins]
            if as_json:
                out.print_json(json.dumps(rows))
                return
            table = Table("plugin", "distribution", "version", "status", "registers")
            for p in rows:
                what = "; ".join(f"{k}: {', '.join(v)}" for k, v in p["registers"].items()) or p["error"]
                table.add_row(p["name"], p["distribution"], p["version"], p["status"], what)
            out.print(table)
            return
        entries = [reg.entries[kind.value][n] for n in reg.names(kind.value)]
        if as_json:
            out.print_json(json.dumps([
                {"name": e.name, "plugin": e.plugin, "path": str(e.path) if e.path else None,
                 "description": str(e.spec.get("description", e.spec.get("environment", {}).get("description", ""))).strip()}
                for e in entries
            ]))
            return
        table = Table("name", "plugin", "description")
        table.columns[0].no_wrap = True
        for e in entries:
            desc = " ".join(str(e.spec.get("description", "")).split())
            table.add_row(e.name, e.plugin, desc.split(". ")[0].rstrip("."))
        out.print(table)
