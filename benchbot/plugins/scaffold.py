"""``benchbot plugin new``: writes a complete, publishable plugin project from the template files in
``scaffold_templates/`` (package data; ``string.Template`` syntax).

A project for kind ``K`` and name ``N`` is the distribution ``benchbot-K-N`` with the package ``benchbot_K_N``,
registered under the entry point ``K_N`` of group ``benchbot``; it holds the hook implementations, schema-valid
example specs, a README, tests calling the core's contract checks (fixture ``benchbot_contract``) and a GitHub
Actions workflow. Kinds: ``sim`` and ``robot`` (a robot backend, a robot and an environment), ``task``, ``eval``,
``env`` (environments of the ``sim_taichi`` simulator with their ground truths).
"""

from __future__ import annotations

import json
import re
import string
from pathlib import Path

from benchbot.core.atomic import write_text
from benchbot.core.errors import UsageError

KINDS = ("sim", "robot", "task", "eval", "env")
_NAME_RE = re.compile(r"^[a-z][a-z0-9_]{0,40}$")

#: Folder of the project templates (package data): ``string.Template`` files, ``${name}`` placeholders, ``$$`` for ``$``.
TEMPLATES = Path(__file__).resolve().parent / "scaffold_templates"


def _fill(template: str, values: dict) -> str:
    """The template file ``TEMPLATES/<template>.tmpl`` with its ``${key}`` placeholders replaced by ``values``.

    Raises:
        KeyError: the template names a key that ``values`` lacks.
    """
    return string.Template((TEMPLATES / f"{template}.tmpl").read_text(encoding="utf-8")).substitute(values)


def _env_map(env: str, dist: str) -> str:
    walls = [("wall", [0, 2.55, 1.0], [5.0, 0.1, 2.0]), ("wall", [0, -2.55, 1.0], [5.0, 0.1, 2.0]),
             ("wall", [2.55, 0, 1.0], [0.1, 5.0, 2.0]), ("wall", [-2.55, 0, 1.0], [0.1, 5.0, 2.0])]
    objects = [("table", [1.5, 1.5, 0.375], [1.2, 0.8, 0.75]), ("chair", [1.5, 0.6, 0.45], [0.5, 0.5, 0.9])]
    data = {
        "environment": {"name": env, "variant": 1, "map_path": f"/Game/{env}_base/Maps/{env}",
                        "start_pose": [1, 0, 0, 0, -1.5, -1.5, 0],
                        "trajectory_poses": [[1, 0, 0, 0, -0.5, -1.5, 0], [0.7071068, 0, 0, 0.7071068, -0.5, -0.5, 0]],
                        "description": f"A 5 m square room with a table and a chair (template of {dist})."},
        "format": {"name": "object_map_ground_truth"},
        "ground_truth": {"class_list": ["chair", "table", "wall", "background"], "objects": [
            {"class": c, "ID_name": f"{c}_{i}", "centroid": ce, "extent": ex, "isgroup": False}
            for i, (c, ce, ex) in enumerate(walls + objects)]},
    }
    return json.dumps(data, indent=2) + "\n"


def installed_from(distribution: str) -> dict | None:
    """Where the installed ``distribution`` came from, as a uv source (``[tool.uv.sources]``): ``{"path": folder,
    "editable": True}`` for an editable install, ``{"path": folder or wheel}`` for a local one, ``{"git": url,
    "rev": commit}`` for a git install; None when it came from a package index (or is not installed), where its
    name alone finds it. Read from the installed distribution's ``direct_url.json`` (PEP 610)."""
    import importlib.metadata
    import urllib.parse
    import urllib.request

    try:
        text = importlib.metadata.distribution(distribution).read_text("direct_url.json")
        data = json.loads(text) if text else None
    except (importlib.metadata.PackageNotFoundError, ValueError):
        return None
    if not isinstance(data, dict) or not isinstance(data.get("url"), str):
        return None
    url = data["url"]
    vcs = data.get("vcs_info")
    if isinstance(vcs, dict) and vcs.get("vcs") == "git":
        return {"git": url, "rev": str(vcs.get("commit_id", ""))}
    if url.startswith("file:"):
        source: dict = {"path": urllib.request.url2pathname(urllib.parse.urlsplit(url).path)}
        if (data.get("dir_info") or {}).get("editable"):
            source["editable"] = True
        return source
    return None


def _sources(distributions: list[str]) -> tuple[str, str]:
    """The ``[tool.uv.sources]`` block for the BenchBot distributions a generated project depends on (where this
    machine's came from; nothing for those from an index) and the README's sentence saying so."""
    lines, where = [], []
    for dist in distributions:
        source = installed_from(dist)
        if source is None:
            continue
        fields = ", ".join(f"{k} = {json.dumps(v)}" for k, v in source.items())
        lines.append(f"{dist} = {{ {fields} }}")
        where.append(f"`{dist}` from `{source.get('path') or source.get('git')}`")
    if not lines:
        return "", ("`benchbot` comes from the package index, like every other dependency.")
    block = ("\n# Where BenchBot comes from until it is on PyPI: this machine's install when the project was made. Change\n"
             "# it to a git URL ({ git = \"https://...\" }) or a wheel ({ path = \"benchbot-X-py3-none-any.whl\" })\n"
             "# when the project moves; `uv` reads it (`pip` needs BenchBot installed first).\n[tool.uv.sources]\n"
             + "\n".join(lines) + "\n")
    return block, ("BenchBot is not on PyPI yet: `uv` takes " + ", ".join(where)
                   + " (`[tool.uv.sources]` in `pyproject.toml`, written when the project was made; point it at a "
                     "git URL or a wheel when the project moves). With `pip`, install BenchBot first from the same "
                     "place.")


def project_files(kind: str, name: str) -> dict[str, str]:
    """``{relative path: text}`` of the project for plugin ``kind`` and ``name``.

    Raises:
        UsageError: unknown kind, or a name that is not ``[a-z][a-z0-9_]*``.
    """
    if kind not in KINDS:
        raise UsageError(f"unknown plugin kind '{kind}'", f"use one of {', '.join(KINDS)}")
    name = name.strip().lower().replace("-", "_")
    if not _NAME_RE.match(name):
        raise UsageError(f"'{name}' is not a valid plugin name", "use lower-case letters, digits and _ (starting with a letter)")
    dist, pkg, ep = f"benchbot-{kind}-{name.replace('_', '-')}", f"benchbot_{kind}_{name}", f"{kind}_{name}"
    v = {"dist": dist, "pkg": pkg, "ep": ep, "name": name, "kind": kind, "type": f"{kind}_{name}",
         "robot": f"{name}_bot", "env": f"{name}_room", "task": f"{name}:passive:ground_truth",
         "cls": "".join(p.title() for p in name.split("_")) + "Backend",
         "speed_setting": f"BENCHBOT_{kind.upper()}_{name.upper()}_SPEED_M_S"}
    files: dict[str, str] = {f"{pkg}/__init__.py": f'"""{dist}: a BenchBot plugin."""\n'}
    tests = ["test_header.py"]  # followed by the kind's tests
    if kind in ("sim", "robot"):
        what = "a simulator" if kind == "sim" else "a robot"
        v["summary"] = f"{what} (robot type `{v['type']}`), the robot `{v['robot']}` and the environment `{v['env']}:1`."
        v["usage"] = f"benchbot run --robot {v['robot']} --env {v['env']}:1 --port 0     # any task its robot can do"
        v["layout"] = (f"| `{pkg}/backend.py` | the robot backend (`benchbot.core.robot.RobotBackend`) |\n"
                       f"| `{pkg}/settings.py` | the environment variables it reads (`benchbot doctor` shows them) |\n"
                       f"| `{pkg}/robots/`, `{pkg}/environments/` | the robot and environment specs |\n")
        files[f"{pkg}/plugin.py"] = _fill("sim_plugin.py", v)
        files[f"{pkg}/backend.py"] = _fill("backend.py", v)
        files[f"{pkg}/settings.py"] = _fill("settings.py", v)
        files[f"{pkg}/robots/{v['robot']}.yaml"] = _fill("robot.yaml", v)
        files[f"{pkg}/environments/{v['env']}_1.yaml"] = _fill("environment.yaml", v)
        tests.append("sim_tests.py")
    elif kind == "task":
        v["summary"] = f"the task `{v['task']}`."
        v["usage"] = f"benchbot show tasks {v['task']}"
        v["layout"] = f"| `{pkg}/tasks/` | the task specs |\n"
        files[f"{pkg}/plugin.py"] = _fill("task_plugin.py", v)
        files[f"{pkg}/tasks/{name}.yaml"] = _fill("task.yaml", v)
        tests.append("task_tests.py")
    elif kind == "eval":
        v["summary"] = f"the evaluation method `{name}`."
        v["usage"] = f"benchbot eval results.json --method {name}"
        v["layout"] = (f"| `{pkg}/evaluation_methods/` | the evaluation-method spec |\n"
                       f"| `{pkg}/metric.py` | `evaluate` and `combine` |\n")
        files[f"{pkg}/plugin.py"] = _fill("eval_plugin.py", v)
        files[f"{pkg}/evaluation_methods/{name}.yaml"] = _fill("evaluation_method.yaml", v)
        files[f"{pkg}/metric.py"] = _fill("metric.py", v)
        tests.append("eval_tests.py")
    else:
        v["summary"] = f"the environment `{v['env']}:1` for the sim_taichi simulator, with its ground truth."
        v["usage"] = f"benchbot run --env {v['env']}:1 --port 0"
        v["layout"] = f"| `{pkg}/data/` | the map and ground truth (BEAR JSON) |\n"
        files[f"{pkg}/plugin.py"] = _fill("env_plugin.py", v)
        files[f"{pkg}/data/{v['env']}_1.json"] = _env_map(v["env"], dist)
        tests.append("env_tests.py")
    needs = ["benchbot"] + (["benchbot-sim-taichi"] if kind == "env" else [])
    v["sources"], v["core_source"] = _sources(needs)
    v["core_deps"] = ", ".join(f'"{d}>=0.1"' for d in needs)
    files["tests/test_contract.py"] = "".join(_fill(t, v) for t in tests)
    files["pyproject.toml"] = _fill("pyproject.toml", v)
    files["README.md"] = _fill("README.md", v)
    files[".github/workflows/ci.yml"] = _fill("ci.yml", v)
    files[".gitignore"] = "dist/\n__pycache__/\n.venv/\n"
    return files


def new_plugin(kind: str, name: str, out_dir: Path | str = ".", *, force: bool = False) -> Path:
    """Write the project for ``kind``/``name`` into ``out_dir/benchbot-<kind>-<name>/``.

    Returns:
        The project folder.

    Raises:
        UsageError: bad kind or name, or the folder exists and is not empty (without ``force``).
    """
    files = project_files(kind, name)
    dist = files["pyproject.toml"].split('name = "', 1)[1].split('"', 1)[0]  # benchbot-<kind>-<name>
    root = Path(out_dir).expanduser() / dist
    if root.exists() and not root.is_dir():
        raise UsageError(f"{root} exists and is not a folder", "choose another -o folder")
    if root.exists() and any(root.iterdir()) and not force:
        raise UsageError(f"{root} exists and is not empty", "choose another -o folder or pass --force")
    for rel, text in files.items():
        write_text(root / rel, text)
    return root
