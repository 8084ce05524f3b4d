"""No import circles: within each first-party package, the modules' imports (module-level and inside functions alike)
form no cycle, so each module can be read, tested and moved after the ones it uses (the simulator had two: its scene
and its hook module, its scene and its meshes; the core one, registry, content packs, spec meaning and the original
add-ons, held together by 13 imports inside functions)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"benchbot": ROOT / "benchbot", "benchbot_sim_taichi": ROOT / "plugins" / "sim_taichi" / "benchbot_sim_taichi",
            "benchbot_worlds": ROOT / "plugins" / "worlds" / "benchbot_worlds"}


def import_graph(folder: Path, package: str) -> dict[str, set[str]]:
    """``{module: modules of the same package it imports}``, from the source (every import statement, anywhere but
    under ``if TYPE_CHECKING:``, which never runs)."""
    modules = {}
    for path in folder.rglob("*.py"):
        parts = path.relative_to(folder.parent).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    edges: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        type_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                     and getattr(block.test, "id", getattr(block.test, "attr", "")) == "TYPE_CHECKING"
                     for stmt in block.body for n in ast.walk(stmt)}
        for node in ast.walk(tree):
            if id(node) in type_only:
                continue
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith(package):
                targets = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
            elif isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                continue
            edges[name] |= {t for t in targets if t in modules and t != name}
    return edges


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in edges:
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_the_cycle_finder_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


@pytest.mark.parametrize("package", sorted(PACKAGES))
def test_no_import_circles(package):
    edges = import_graph(PACKAGES[package], package)
    assert len(edges) > 10  # the walk found the modules
    assert cycles(edges) == []


def test_every_plugin_declares_the_first_party_packages_it_imports():
    """A plugin's shipped code imports another BenchBot distribution only if its pyproject.toml depends on it
    (robot_ros2 imported the simulator's backend and kinematics without: now the registry gives it a simulator's
    backend, and the motion model is the core's)."""
    import tomllib

    from packaging.requirements import Requirement

    undeclared = []
    for pyproject in sorted((ROOT / "plugins").glob("*/pyproject.toml")):
        meta = tomllib.loads(pyproject.read_text())["project"]
        declared = {Requirement(r).name.replace("-", "_") for r in meta.get("dependencies", [])}
        own = {p.name for p in pyproject.parent.iterdir() if (p / "__init__.py").is_file()}
        for path in pyproject.parent.rglob("*.py"):
            if {"tests", "tools"} & set(path.relative_to(pyproject.parent).parts):
                continue
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                names = ([node.module] if isinstance(node, ast.ImportFrom) and node.module else
                         [a.name for a in node.names] if isinstance(node, ast.Import) else [])
                for name in names:
                    top = name.split(".")[0]
                    if top.startswith("benchbot") and top not in own | declared | {"benchbot", "benchbot_api"}:
                        undeclared.append(f"{path.relative_to(ROOT)}: {top}")
    assert undeclared == [], undeclared


def test_the_core_imports_no_client():
    """The core (backend, supervisor, registry) never imports the client, :mod:`benchbot.api` (what both need, as
    the one-off request of :mod:`benchbot.solutions.solution_lease`, lives there); nor do the server, the
    solutions' runner and the content packs."""
    edges = import_graph(PACKAGES["benchbot"], "benchbot")
    core = {name for name in edges if name.startswith(("benchbot.core", "benchbot.server", "benchbot.solutions",
                                                        "benchbot.packs", "benchbot.protocol"))}
    assert len(core) > 10
    assert {name: sorted(t for t in edges[name] if t.startswith("benchbot.api")) for name in core
            if any(t.startswith("benchbot.api") for t in edges[name])} == {}
