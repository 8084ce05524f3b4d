"""``benchbot list KIND``: what is installed."""

from __future__ import annotations

import enum
import json
from dataclasses import asdict

import typer
from rich.table import Table

from benchbot.cli.common import handle_errors, out, registry


class Kind(str, enum.Enum):
    """What ``benchbot list`` can list: a registry kind, or the plugins."""

    tasks = "tasks"
    robots = "robots"
    environments = "environments"
    formats = "formats"
    evaluators = "evaluators"
    examples = "examples"
    batches = "batches"
    ground_truths = "ground_truths"
    plugins = "plugins"


def plugin_rows() -> list[dict]:
    """One dict per plugin: ``name``, ``module``, ``distribution``, ``version``, ``status`` (loaded, disabled,
    failed), ``error``, ``registers`` ({kind: names}), ``hooks`` (implemented hook names), ``problems`` (skipped
    specs, one line each); plus the installed content packs as ``packs`` of the ``content_packs`` plugin."""
    from benchbot.core.content_packs import installed_packs

    rows = [asdict(p) for p in registry().plugins]
    for row in rows:
        if row["name"] == "content_packs":
            row["packs"] = [{k: p.get(k) for k in ("name", "path", "source", "allow_code", "files")} for p in installed_packs()]
    return rows


def print_plugins(as_json: bool) -> None:
    """Print the plugins (``benchbot plugins`` and ``benchbot list plugins``)."""
    rows = plugin_rows()
    if as_json:
        out.print_json(json.dumps(rows))
        return
    table = Table("plugin", "distribution", "version", "status", "hooks", "registers / problems")
    for p in rows:
        hooks = ", ".join(h.removeprefix("benchbot_") for h in p["hooks"])
        what = "; ".join(f"{k}: {', '.join(v)}" for k, v in p["registers"].items())
        if p.get("packs"):
            what += ("; " if what else "") + "packs: " + ", ".join(pk["name"] for pk in p["packs"])
        if p["error"]:
            what = f"[red]{p['error']}[/]"
        for problem in p["problems"]:
            what += f"\n[yellow]skipped:[/] {problem}"
        status = p["status"] + (f" ({len(p['problems'])} problem(s))" if p["problems"] else "")
        table.add_row(p["name"], p["distribution"], p["version"], status, hooks, what)
    out.print(table)


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
            print_plugins(as_json)
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
