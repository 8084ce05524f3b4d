"""``benchbot list KIND``: what is installed."""

from __future__ import annotations

import enum
import re
from dataclasses import asdict

import typer
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from benchbot.cli.common import handle_errors, out, print_json, registry
from benchbot.core.names import close_names
from benchbot.core.world_generators import MAX_BATCH_HOMES


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


#: Other spellings of the kinds that ``benchbot list``/``show`` accept (singular forms and short names).
KIND_ALIASES = {**{k.value[:-1]: k for k in Kind if k is not Kind.batches}, "batch": Kind.batches,
                "ground-truths": Kind.ground_truths, "gt": Kind.ground_truths, "env": Kind.environments,
                "envs": Kind.environments, "evaluation_methods": Kind.evaluators, "methods": Kind.evaluators}
KINDS_HELP = ", ".join(k.value for k in Kind)


def parse_kind(value: str) -> Kind:
    """Argument callback: the :class:`Kind` named ``value`` (a plural as listed, or a singular such as ``task``).

    Raises:
        typer.BadParameter: no kind has that name (the message suggests close ones and lists every kind).
    """
    text = value.strip().lower()
    if text in Kind.__members__:
        return Kind(text)
    if text in KIND_ALIASES:
        return KIND_ALIASES[text]
    close = close_names(text, [k.value for k in Kind])
    guess = f"did you mean {', '.join(close)}? " if close else ""
    raise typer.BadParameter(f"'{value}' is not a kind of spec; {guess}(kinds: {KINDS_HELP})")


def first_sentence(text: str) -> str:
    """The first sentence of a description, on one line, without its full stop. A sentence ends at '. ' before a
    capital letter outside brackets, so abbreviations stay ("Hall et al. 2020", "e.g. a group")."""
    flat = " ".join(str(text).split())
    depth = 0
    for i, ch in enumerate(flat):
        depth += (ch in "([{") - (ch in ")]}")
        if ch == "." and depth <= 0 and re.match(r"\.\s+[A-Z]", flat[i:i + 3]):
            return flat[:i]
    return flat.rstrip(".")


def plugin_rows() -> list[dict]:
    """One dict per plugin: ``name``, ``module``, ``distribution``, ``version``, ``status`` (loaded, disabled,
    failed), ``error``, ``registers`` ({kind: names}), ``hooks`` (implemented hook names), ``problems`` (skipped
    specs, one line each); plus the installed content packs as ``packs`` of the ``content_packs`` plugin."""
    from benchbot.packs.content_packs import installed_packs

    rows = [asdict(p) for p in registry().plugins]
    for row in rows:
        if row["name"] == "content_packs":
            row["packs"] = [{k: p.get(k) for k in ("name", "path", "source", "allow_code", "files")} for p in installed_packs()]
    return rows


def print_plugins(as_json: bool) -> None:
    """Print the plugins (``benchbot plugins`` and ``benchbot list plugins``)."""
    rows = plugin_rows()
    if as_json:
        print_json(rows)
        return
    table = Table("plugin", "distribution", "version", "status", "hooks", "registers / problems")
    for p in rows:
        hooks = ", ".join(h.removeprefix("benchbot_") for h in p["hooks"])
        what = "; ".join(f"{k}: {', '.join(v)}" for k, v in p["registers"].items())
        if p.get("packs"):
            what += ("; " if what else "") + "packs: " + ", ".join(pk["name"] for pk in p["packs"])
        if p["error"]:
            what = f"[red]{escape(p['error'])}[/]"
        else:
            what = escape(what)
        for problem in p["problems"]:
            what += f"\n[yellow]skipped:[/] {escape(problem)}"
        status = p["status"] + (f" ({len(p['problems'])} problem(s))" if p["problems"] else "")
        table.add_row(*(Text(str(v)) for v in (p["name"], p["distribution"], p["version"], status, hooks)), what)
    out.print(table)
    for _, note in sorted(registry().notes.items()):  # second sources of a name that are no clash
        out.print(f"[dim]note:[/] {escape(note)}", highlight=False)


def generated_rows(reg, kind: Kind) -> list[dict]:
    """One row per split of every world generator (``procedural_val_N``: made on demand, too many to list), as
    :func:`list_` shows them after the listed entries."""
    rows = []
    for gen_name, gen in reg.generators.items():
        plugin = reg._generator_plugins[gen_name]
        for split in gen.splits:
            if kind is Kind.environments:
                rows.append({"name": f"{gen_name}_{split}_N:1..5", "plugin": plugin, "path": None, "generated": True,
                             "description": f"split {split}, home N = 0, 1, ... (short form {gen_name}:{split}:N): "
                                            + gen.describe(split)})
            else:
                rows.append({"name": f"{gen_name}_{split}_COUNT", "plugin": plugin, "path": None, "generated": True,
                             "description": f"variant 1 of homes 0..COUNT-1 of split {split} (COUNT up to "
                                            f"{MAX_BATCH_HOMES})"})
    return rows


def register(app: typer.Typer) -> None:
    @app.command("list")
    @handle_errors
    def list_(
        kind: str = typer.Argument(..., metavar="KIND", callback=parse_kind, help=f"What to list: {KINDS_HELP} (or a singular, e.g. task)."),
        as_json: bool = typer.Option(False, "--json", help="Print JSON (for machines)."),
    ) -> None:
        """List installed tasks, robots, environments, formats, evaluators, examples, batches, ground truths or
        plugins. Environments are listed as name:variant."""
        reg = registry()
        if kind is Kind.plugins:
            print_plugins(as_json)
            return
        entries = [reg.entries[kind.value][n] for n in reg.names(kind.value)]
        sets: dict[str, list[str]] = {}
        if kind is Kind.ground_truths:  # every set that has the environment's ground truth, the default's first
            for set_name, members in sorted(reg.ground_truth_sets().items()):
                for env in members:
                    sets.setdefault(env, []).append(set_name)
            for e in entries:
                default = reg.ground_truth_set(e.name)
                sets[e.name] = [default] + [s for s in sets.get(e.name, []) if s != default]
        if as_json:
            rows = []
            for e in entries:
                row = {"name": e.name, "plugin": e.plugin, "path": str(e.path) if e.path else None,
                       "description": str(e.spec.get("description",
                                                     e.spec.get("environment", {}).get("description", ""))).strip()}
                if kind is Kind.robots:
                    row["unavailable"] = reg.unavailable_reason("robots", e.name) or None
                if kind is Kind.ground_truths:
                    row["sets"] = sets.get(e.name, [])
                rows.append(row)
            if kind in (Kind.environments, Kind.batches):  # generated on demand: one row per split, a pattern
                rows.extend(generated_rows(reg, kind))
            print_json(rows)
            return
        table = Table("name", "plugin", "sets (default first)" if kind is Kind.ground_truths else "description")
        table.columns[0].no_wrap = True
        for e in entries:  # spec text is shown as written: Text, never markup ("centroid [x, y, z]" keeps its brackets)
            third = Text(first_sentence(e.spec.get("description", "")))
            if kind is Kind.ground_truths:
                third = Text(", ".join(sets.get(e.name, [])))
            unavailable = reg.unavailable_reason(kind.value, e.name)
            if unavailable:
                third = Text(f"unavailable here: {unavailable}", style="yellow")
            table.add_row(Text(e.name), Text(e.plugin), third)
        if kind in (Kind.environments, Kind.batches):
            for row in generated_rows(reg, kind):
                table.add_row(Text(row["name"]), Text(row["plugin"]), Text(row["description"], style="cyan"))
        out.print(table)
