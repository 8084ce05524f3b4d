"""docs/architecture.md is the map of the code, and docs/original-benchbot.md points into it: both stay true.

architecture.md must name every hookspec, every command of the ``benchbot`` CLI (core and first-party plugins')
with its module, every first-party plugin (its folder, entry-point name and module) and every module of the core
packages; neither page may name a project file, folder or module that does not exist, nor link a missing page.
Nothing here imports Taichi (or any module a doc names: modules are found with ``importlib.util.find_spec`` and
their attributes read with ``ast``), so the checks take about a second.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import re
import subprocess
import sys
import tomllib
from functools import lru_cache
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
ARCHITECTURE = DOCS / "architecture.md"
ORIGINAL = DOCS / "original-benchbot.md"

#: Top-level folders and files of the repository: a backticked path starting with one of them is a project path
#: and must exist (``results/NNN_<env>.json`` or ``/tmp/benchbot_result`` are not project paths).
PROJECT_DIRS = ("benchbot", "benchbot_api", "plugins", "docs", "schemas", "tests", "benchmarks")
PROJECT_FILES = ("README.md", "pyproject.toml", "conftest.py", "uv.lock")
#: Core packages whose every module architecture.md must name.
MAPPED_PACKAGES = ("benchbot/core", "benchbot/server", "benchbot/solutions", "benchbot/packs", "benchbot/protocol", "benchbot/service", "benchbot/batch", "benchbot/api", "benchbot/tui",
                   "benchbot/plugins")

SPAN = re.compile(r"`([^`\n]+)`")
LINK = re.compile(r"\]\(([^)#\s]+\.md)(?:#[^)]*)?\)")
DOTTED = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)+")


def spans(text: str) -> set[str]:
    """Every backticked string of a Markdown text."""
    return {s.strip() for s in SPAN.findall(text)}


@lru_cache(maxsize=None)
def own_packages() -> frozenset[str]:
    """Import names of this repository's packages: the core's and each first-party plugin's."""
    plugin_packages = {p.name for p in (ROOT / "plugins").glob("*/benchbot_*") if (p / "__init__.py").is_file()}
    return frozenset({"benchbot", "benchbot_api", *plugin_packages})


@lru_cache(maxsize=None)
def project_file_names() -> frozenset[str]:
    """Names of every file under the project folders (for bare names such as ``hookspecs.py``)."""
    names = set(PROJECT_FILES)
    for top in PROJECT_DIRS:
        for _, dirs, files in os.walk(ROOT / top):
            dirs[:] = [d for d in dirs if d not in ("__pycache__", ".venv") and not d.startswith(".")]
            names.update(files)
    return frozenset(names)


def _top_level_names(source: str) -> tuple[set[str], dict[str, set[str]]]:
    """Names a module defines at top level, and the names defined in each top-level class body."""
    tree = ast.parse(source)
    names: set[str] = set()
    members: dict[str, set[str]] = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
            if isinstance(node, ast.ClassDef):
                members[node.name] = {n.name for n in node.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}
                members[node.name] |= {t.id for n in node.body if isinstance(n, (ast.Assign, ast.AnnAssign))
                                       for t in (n.targets if isinstance(n, ast.Assign) else [n.target])
                                       if isinstance(t, ast.Name)}
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
    return names, members


def dotted_problem(name: str) -> str:
    """Why the dotted ``name`` (``benchbot.core.motion.PoseController``) does not resolve, or "".

    Packages and modules are found with ``importlib.util.find_spec`` (which imports parent packages only, never
    the module itself); what follows the module is looked up in its source with ``ast`` (a top-level name, then a
    class member), so a doc naming a heavy module imports nothing of it.
    """
    parts = name.split(".")
    spec = importlib.util.find_spec(parts[0])
    if spec is None:
        return f"`{name}`: no module {parts[0]}"
    i = 1
    while i < len(parts) and spec.submodule_search_locations is not None:
        sub = importlib.util.find_spec(".".join(parts[: i + 1]))
        if sub is None:  # maybe an attribute of the package's __init__
            break
        spec, i = sub, i + 1
    rest = parts[i:]
    if not rest:
        return ""
    if spec.origin is None or not spec.origin.endswith(".py"):
        return f"`{name}`: cannot read {'.'.join(parts[:i])} to find {rest[0]}"
    source = Path(spec.origin).read_text()
    names, members = _top_level_names(source)
    lazy = "__getattr__" in names and f'"{rest[0]}"' in source  # a module-level __getattr__ that names it
    if rest[0] not in names and not lazy:
        return f"`{name}`: {'.'.join(parts[:i])} defines no {rest[0]}"
    if len(rest) > 1 and rest[0] in members and rest[1] not in members[rest[0]]:
        return f"`{name}`: class {rest[0]} defines no {rest[1]}"
    return ""


def path_problem(span: str) -> str:
    """Why a backticked project path does not exist, or "" (also "" for what is not a project path)."""
    if any(c in span for c in " <>$~:\\") or span.startswith(("/", ".")):  # ':' - image tags, name:variant
        return ""
    if "/" in span:
        first = span.split("/", 1)[0]
        if first not in PROJECT_DIRS:
            return ""
        relative = span.rstrip("/")
        exists = any(ROOT.glob(relative)) if "*" in relative else (ROOT / relative).exists()
        return "" if exists else f"`{span}`: no such file or folder in the repository"
    if span in PROJECT_FILES or span.endswith((".py", ".md")) and "*" not in span:
        return "" if span in project_file_names() else f"`{span}`: no file of that name in the repository"
    return ""


def reference_problems(doc: Path) -> list[str]:
    """Project paths, own modules and Markdown links of ``doc`` that do not exist."""
    text = doc.read_text()
    problems = []
    for span in sorted(spans(text)):
        if DOTTED.fullmatch(span) and span.split(".")[0] in own_packages():
            problems.append(dotted_problem(span))
        else:
            problems.append(path_problem(span))
    for target in sorted(set(LINK.findall(text))):
        if "://" not in target and not (doc.parent / target).is_file():
            problems.append(f"link ({target}): no such page")
    shown = doc.relative_to(ROOT) if doc.is_relative_to(ROOT) else doc
    return [f"{shown}: {p}" for p in problems if p]


# ------------------------------------------------------------------------------------------------ what must be named
def hookspec_names() -> list[str]:
    """Every ``benchbot_*`` hookspec of ``benchbot.core.hookspecs``."""
    from benchbot.core import hookspecs

    marker = f"{hookspecs.PROJECT_NAME}_spec"
    return sorted(name for cls in hookspecs.HOOK_CLASSES for name in vars(cls)
                  if name.startswith("benchbot_") and hasattr(getattr(cls, name), marker))


def cli_commands() -> dict[str, str]:
    """``{command path: module of its function}`` of every command of the ``benchbot`` CLI: the core's Typer app
    and the commands the first-party plugins add (``benchbot_commands``), walked as click sees them."""
    import typer
    import typer.main

    from benchbot.cli.main import add_plugin_commands, app
    from benchbot.core.plugin_manager import build_plugin_manager

    plugin_app = typer.Typer()

    @plugin_app.callback()
    def _group() -> None:
        """Keeps the plugins' commands a group even when there is only one."""

    warnings = add_plugin_commands(build_plugin_manager()[0], plugin_app)
    assert warnings == [], warnings
    found: dict[str, str] = {}

    def walk(command, prefix: str) -> None:
        for name, sub in sorted(getattr(command, "commands", {}).items()):
            path = f"{prefix} {name}".strip()
            if getattr(sub, "commands", None) is not None:
                walk(sub, path)
            else:
                found[path] = sub.callback.__module__

    walk(typer.main.get_command(app), "")
    walk(typer.main.get_command(plugin_app), "")
    return found


def first_party_plugins() -> list[tuple[str, str, str]]:
    """``(folder or "", entry-point name, module)`` of every entry point of group ``benchbot`` declared in the
    repository: the core's (folder "") and each ``plugins/*/pyproject.toml``'s."""
    out = []
    for pyproject in [ROOT / "pyproject.toml", *sorted((ROOT / "plugins").glob("*/pyproject.toml"))]:
        data = tomllib.loads(pyproject.read_text())
        entry_points = data.get("project", {}).get("entry-points", {}).get("benchbot", {})
        folder = "" if pyproject.parent == ROOT else f"plugins/{pyproject.parent.name}"
        assert entry_points or not folder, f"{pyproject.relative_to(ROOT)} declares no entry point of group benchbot"
        out += [(folder, name, module) for name, module in sorted(entry_points.items())]
    return out


def mapped_modules() -> list[str]:
    """Repository paths of the modules of :data:`MAPPED_PACKAGES` (not ``__init__.py``)."""
    return sorted(str(p.relative_to(ROOT)) for package in MAPPED_PACKAGES for p in (ROOT / package).glob("*.py")
                  if p.name != "__init__.py")


def _module_path(module: str) -> str:
    spec = importlib.util.find_spec(module)
    return str(Path(spec.origin).resolve().relative_to(ROOT)) if spec and spec.origin else ""


def _names_module(named: set[str], module: str) -> bool:
    """Whether ``named`` (a doc's backticked strings) names ``module`` by its dotted name or its file."""
    path = _module_path(module)
    return module in named or (path != "" and path in named)


# ------------------------------------------------------------------------------------------------------------ tests
def test_architecture_names_every_hookspec():
    named = spans(ARCHITECTURE.read_text())
    hooks = hookspec_names()
    assert "benchbot_tasks" in hooks and "benchbot_episode_finished" in hooks  # the walk itself works
    missing = [h for h in hooks if h not in named]
    assert missing == [], f"docs/architecture.md does not name the hookspecs {missing} (add them to its Hooks table)"


def test_architecture_names_every_cli_command_and_its_module():
    named = spans(ARCHITECTURE.read_text())
    commands = cli_commands()
    assert {"run", "eval", "plugin new", "sim render", "ros2 serve-sim"} <= set(commands)  # the walk itself works
    missing = [f"benchbot {c}" for c in commands
               if not any(s == f"benchbot {c}" or s.startswith(f"benchbot {c} ") for s in named)]
    assert missing == [], f"docs/architecture.md does not name the commands {missing} (add them to its Commands table)"
    unnamed = sorted({m for m in commands.values() if not _names_module(named, m)})
    assert unnamed == [], f"docs/architecture.md does not name the command modules {unnamed}"


def test_architecture_names_every_plugin_its_folder_and_entry_point():
    named = spans(ARCHITECTURE.read_text())
    plugins = first_party_plugins()
    assert {"sim_taichi", "eval_omq", "core_examples"} <= {name for _, name, _ in plugins}  # the walk itself works
    missing = []
    for folder, name, module in plugins:
        if folder and not any(s == folder or s.startswith(folder + "/") for s in named):
            missing.append(f"`{folder}/`")
        missing += [f"`{text}`" for text in (name, module) if text not in named]
    assert missing == [], f"docs/architecture.md does not name {', '.join(missing)} (add them to its Plugins table)"


def test_architecture_names_every_core_module():
    named = spans(ARCHITECTURE.read_text())
    modules = mapped_modules()
    assert "benchbot/core/episode.py" in modules  # the walk itself works
    missing = [m for m in modules if m not in named and m.removesuffix(".py").replace("/", ".") not in named]
    assert missing == [], f"docs/architecture.md does not name the modules {missing} (add them to its Layout)"


def test_every_path_module_and_link_architecture_names_exists():
    assert reference_problems(ARCHITECTURE) == []


def test_every_path_module_and_link_original_benchbot_names_exists():
    assert reference_problems(ORIGINAL) == []


def test_the_checks_catch_what_they_should(tmp_path):
    # each kind of mistake a doc can make is reported (so the tests above cannot pass for want of looking)
    doc = tmp_path / "doc.md"
    doc.write_text("`benchbot/core/gone.py` `benchbot/batch/local.py` `gone_module.py` `benchbot.core.nothing` "
                   "`benchbot.core.motion.NoSuchThing` `benchbot.core.motion.PoseController.no_method` "
                   "[x](missing.md) — and fine: `benchbot/core/motion.py` `benchbot.core.motion.PoseController` "
                   "`plugins/*/pyproject.toml` `hookspecs.py` `/tmp/benchbot_result` `results/NNN_<env>.json` "
                   "`benchbot_addons.manager` `benchbot.gym.BenchBotEnv`")
    problems = reference_problems(doc)
    assert len(problems) == 7, problems
    assert "no such page" in problems[-1]


def test_the_checks_import_no_simulator():
    # a fresh interpreter runs every check and must not have imported Taichi (nor any module the docs name);
    # the test module imports no pytest, so this costs about the CLI's own import time
    code = (
        "import importlib.util, sys\n"
        f"spec = importlib.util.spec_from_file_location('arch_doc', {str(Path(__file__))!r})\n"
        "m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m)\n"
        "m.hookspec_names(); m.cli_commands(); m.first_party_plugins()\n"
        "m.reference_problems(m.ARCHITECTURE); m.reference_problems(m.ORIGINAL)\n"
        "print(sorted(n for n in ('taichi', 'benchbot_sim_taichi.render.renderer', 'rclpy', 'ray') if n in sys.modules))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60,
                          env={**os.environ, "BENCHBOT_ONLY_PLUGINS": os.environ["BENCHBOT_ONLY_PLUGINS"]})
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1] == "[]"
