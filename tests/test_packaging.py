"""Packaging: the six distributions carry what a PyPI page and an install need, share one version, declare every
library their code imports, and the core's wheel and source distribution hold what they should (docs/releasing.md).
The wheels installed in a clean environment import their plugins (slow); the wheels installed with pip outside
the workspace, and the lowest versions the declared ranges allow, are run by `.ci/packaging` in CI."""

from __future__ import annotations

import ast
import email
import functools
import json
import os
import shutil
import subprocess
import sys
import tarfile
import tomllib
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]
PROJECTS = [ROOT] + sorted(p.parent for p in (ROOT / "plugins").glob("*/pyproject.toml"))


def project(folder: Path) -> dict:
    return tomllib.loads((folder / "pyproject.toml").read_text())["project"]


def packages(folder: Path) -> list[str]:
    """The import packages the distribution in ``folder`` ships (its wheel's ``packages``)."""
    data = tomllib.loads((folder / "pyproject.toml").read_text())
    return data["tool"]["hatch"]["build"]["targets"]["wheel"]["packages"]


def canonical(name: str) -> str:
    """A distribution's name as PEP 503 compares them (``PyYAML`` and ``pyyaml`` are one)."""
    from packaging.utils import canonicalize_name

    return str(canonicalize_name(name))


#: Import names whose distribution is not installed in the workspace (the rest are read from the installed
#: distributions' metadata, ``importlib.metadata.packages_distributions``).
NOT_INSTALLED = {"rclpy": "ros-jazzy-rclpy"}
#: Imports that may be declared in an extra only (optional: the module imports them where they are used, and says
#: which extra to install), per distribution: {import name: extra}.
OPTIONAL = {
    "benchbot": {"gymnasium": "gym", "matplotlib": "vis", "mcap": "record", "mcap_ros2": "record", "ray": "ray",
                 "cv2": "examples", "benchbot_worlds": "worlds"},
    "benchbot-sim-taichi": {"matplotlib": "vis"},
    "benchbot-worlds": {"matplotlib": "vis"},
    "benchbot-task-semslam": {"onnxruntime": "detector"},
}
#: Imports no pyproject can declare, and why.
UNDECLARED = {
    "benchbot": {"pytest": "benchbot.plugins.testing is a pytest plugin (entry point pytest11): only pytest loads it"},
    "benchbot-robot-ros2": {"rclpy": "ROS 2's client library comes with a ROS 2 installation (no PyPI wheels for "
                                     "every Python); without it the plugin speaks DDS through cyclonedds"},
}


@functools.cache
def imported_modules(folder: Path) -> dict[str, list[str]]:
    """{top-level module: [files importing it]} of every absolute import in the distribution's packages (module
    level and inside functions alike; ``if TYPE_CHECKING:`` blocks left out), without the standard library and
    modules of the distribution's own files (an example's sibling modules)."""
    roots = [folder / name for name in packages(folder)]
    own = {p.stem for root in roots for p in root.rglob("*.py")} | {p.name for root in roots
                                                                     for p in root.rglob("*") if p.is_dir()}
    found: dict[str, list[str]] = {}
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            tree = ast.parse(path.read_text(), str(path))
            typing_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                           and "TYPE_CHECKING" in ast.unparse(node.test) for b in node.body for n in ast.walk(b)}
            for node in ast.walk(tree):
                if id(node) in typing_only:
                    continue
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    top = name.split(".")[0]
                    if top not in sys.stdlib_module_names and top not in own:
                        found.setdefault(top, []).append(str(path.relative_to(ROOT)))
    return found


def distributions_of(module: str) -> set[str]:
    """The (canonical) names of the distributions that provide the top-level ``module``: the workspace's own, an
    installed one's, or :data:`NOT_INSTALLED`'s."""
    for folder in PROJECTS:
        if module in packages(folder):
            return {canonical(project(folder)["name"])}
    if module in NOT_INSTALLED:
        return {NOT_INSTALLED[module]}
    return {canonical(d) for d in installed_modules().get(module, [])}


@functools.cache
def installed_modules() -> dict[str, list[str]]:
    """{top-level module: [distribution names]} of the distributions installed here."""
    from importlib.metadata import packages_distributions

    return packages_distributions()


def declared(folder: Path) -> tuple[set[str], dict[str, set[str]]]:
    """(the distribution's dependencies, {extra: its dependencies}), as canonical names."""
    meta = project(folder)
    return ({canonical(Requirement(r).name) for r in meta.get("dependencies", [])},
            {extra: {canonical(Requirement(r).name) for r in reqs}
             for extra, reqs in meta.get("optional-dependencies", {}).items()})


def required_modules(folder: Path) -> list[str]:
    """The third-party top-level modules the distribution's code imports and must find installed (neither
    optional nor undeclarable)."""
    name = canonical(project(folder)["name"])
    return sorted(m for m in imported_modules(folder) if m not in OPTIONAL.get(name, {})
                  and m not in UNDECLARED.get(name, {}) and distributions_of(m) != {name})


@pytest.mark.parametrize("folder", PROJECTS, ids=lambda p: p.name)
def test_every_distribution_declares_what_its_code_imports(folder):
    """Each third-party module a distribution's code imports (statically: ast) is one of its dependencies, or, for
    the optional ones of :data:`OPTIONAL`, of the extra named there. An undeclared import works in the workspace,
    where another package brought it, and not from the wheels: sim_taichi imported Pillow without declaring it, and
    its wheels rendered the furniture untextured and scored differently from the workspace."""
    name = canonical(project(folder)["name"])
    dependencies, extras = declared(folder)
    problems = []
    for module, files in sorted(imported_modules(folder).items()):
        dists = distributions_of(module)
        if dists == {name} or module in UNDECLARED.get(name, {}):
            continue
        if not dists:
            problems.append(f"{module} ({files[0]}): no installed distribution provides it; add it to NOT_INSTALLED")
        elif module in OPTIONAL.get(name, {}):
            extra = OPTIONAL[name][module]
            if not dists & extras.get(extra, set()):
                problems.append(f"{module} ({files[0]}): optional, but {name} has no extra {extra!r} that declares "
                                f"{' or '.join(sorted(dists))}")
        elif not dists & dependencies:
            problems.append(f"{module} ({files[0]}, {len(files)} file(s)): add {' or '.join(sorted(dists))} to "
                            f"{folder.relative_to(ROOT) / 'pyproject.toml'} [project] dependencies")
    assert not problems, "\n".join(problems)


def test_the_import_scan_sees_lazy_imports_and_maps_import_names():
    """The scan reads imports inside functions (meshes.py imports Pillow only where it decodes a texture) and finds
    a module's distribution under another name (PIL: pillow, yaml: pyyaml, cv2: opencv-python-headless)."""
    sim, worlds = ROOT / "plugins" / "sim_taichi", ROOT / "plugins" / "worlds"
    assert "plugins/worlds/benchbot_worlds/scene/meshes.py" in imported_modules(worlds)["PIL"]
    assert {m: distributions_of(m) for m in ("PIL", "yaml", "cv2")} == {
        "PIL": {"pillow"}, "yaml": {"pyyaml"}, "cv2": {"opencv-python-headless"}}
    assert {"PIL", "taichi", "cv2", "benchbot", "benchbot_worlds"} <= set(required_modules(sim))
    assert {"PIL", "trimesh", "benchbot"} <= set(required_modules(worlds))


@pytest.mark.parametrize("folder", PROJECTS, ids=lambda p: p.name)
def test_every_distribution_has_what_a_pypi_page_needs(folder):
    meta = project(folder)
    assert (folder / meta["readme"]).is_file() and (folder / "LICENSE").is_file()
    assert meta["license"] and meta["description"] and meta["authors"] and meta["urls"]
    assert "Programming Language :: Python :: 3.11" in meta["classifiers"]
    assert "version" in meta and "dynamic" not in meta  # one source: the version written here


def test_one_version_and_plugins_accept_the_core_they_ship_with():
    import benchbot

    core = project(ROOT)["version"]
    assert {project(p)["version"] for p in PROJECTS} == {core}
    assert benchbot.__version__ == core  # read from the installed metadata, not written twice
    for folder in PROJECTS[1:]:
        (requirement,) = [Requirement(r) for r in project(folder)["dependencies"] if Requirement(r).name == "benchbot"]
        assert requirement.specifier.contains(core), f"{folder.name} does not accept benchbot {core}"


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("uv") is None, reason="needs uv")
def test_the_cores_wheel_and_sdist_hold_the_core(tmp_path):
    subprocess.run(["uv", "build", "--quiet", "--out-dir", str(tmp_path), str(ROOT)], check=True, timeout=600)
    (wheel,) = tmp_path.glob("benchbot-*.whl")
    (sdist,) = tmp_path.glob("benchbot-*.tar.gz")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        metadata = email.message_from_bytes(archive.read(next(n for n in names if n.endswith(".dist-info/METADATA"))))
    assert "benchbot/schemas/task.schema.json" in names and "benchbot_api/__init__.py" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    assert metadata["License-Expression"] == "MIT" and metadata["Description-Content-Type"] == "text/markdown"
    assert "uv run benchbot batch" in metadata.get_payload()  # the README is the page
    with tarfile.open(sdist) as archive:
        top = {Path(n).parts[1] for n in archive.getnames() if len(Path(n).parts) > 1}
    assert top - {".gitignore"} == {"benchbot", "benchbot_api", "schemas", "README.md", "LICENSE", "pyproject.toml", "PKG-INFO"}
    assert sdist.stat().st_size < 2 << 20  # the core alone: no plugins, benchmarks or pictures


#: In the clean environment: import every plugin module the distributions register (entry point group benchbot)
#: and every console script's module, then every third-party module the code requires, then load a textured model
#: of the shipped pack and require its textures.
CLEAN_CHECK = """
import importlib, json, sys
from importlib import metadata
ours, required = json.loads(sys.argv[1]), json.loads(sys.argv[2])
imported = []
for dist in metadata.distributions():
    if dist.metadata["Name"] not in ours:
        continue
    for ep in dist.entry_points:
        if ep.group in ("benchbot", "console_scripts"):
            importlib.import_module(ep.value.split(":")[0])
            imported.append(f"{dist.metadata['Name']}: {ep.group} {ep.name} = {ep.value}")
for module in required:
    importlib.import_module(module)
from benchbot_assets_sh3d.plugin import PACK_DIR
from benchbot_worlds.scene.meshes import load_mesh
textures = [m.texture for m in load_mesh(PACK_DIR / "chair__sc_children_chair.glb").materials]
assert any(t is not None for t in textures), "the wheels load the pack's models without their textures"
print(json.dumps(imported))
"""


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("uv") is None, reason="needs uv")
def test_the_wheels_in_a_clean_environment_import_their_plugins(tmp_path):
    """Every distribution's wheel (uv build --all-packages), installed with uv into a clean virtual environment
    (no workspace, no dev group), imports each module its entry points name and every third-party module its code
    requires (:func:`required_modules`), and decodes the pack's textures."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VIRTUAL_ENV", "UV_", "PYTHON"))}
    run = {"check": True, "timeout": 600, "env": env, "capture_output": True, "text": True}
    subprocess.run(["uv", "build", "--all-packages", "--quiet", "--out-dir", str(tmp_path / "dist")], cwd=ROOT, **run)
    wheels = sorted(str(p) for p in (tmp_path / "dist").glob("*.whl"))
    assert len(wheels) == len(PROJECTS)
    subprocess.run(["uv", "venv", "--quiet", "--python", sys.executable, str(tmp_path / "venv")], cwd=tmp_path, **run)
    python = tmp_path / "venv" / "bin" / "python"
    subprocess.run(["uv", "pip", "install", "--quiet", "--python", str(python), *wheels], cwd=tmp_path, **run)
    ours = [project(folder)["name"] for folder in PROJECTS]
    required = sorted({m for folder in PROJECTS for m in required_modules(folder)})
    res = subprocess.run([str(python), "-c", CLEAN_CHECK, json.dumps(ours), json.dumps(required)],
                         cwd=tmp_path, env={**env, "BENCHBOT_CACHE_DIR": str(tmp_path / "cache")},
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    imported = json.loads(res.stdout.splitlines()[-1])
    assert {line.split(":")[0] for line in imported} == set(ours)  # every distribution registers something
    assert any("benchbot_sim_taichi.plugin" in line for line in imported)
