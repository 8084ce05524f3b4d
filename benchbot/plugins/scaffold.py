"""``benchbot plugin new``: writes a complete, publishable plugin project from the string templates below.

A project for kind ``K`` and name ``N`` is the distribution ``benchbot-K-N`` with the package ``benchbot_K_N``,
registered under the entry point ``K_N`` of group ``benchbot``; it holds the hook implementations, schema-valid
example specs, a README, tests calling the core's contract checks (fixture ``benchbot_contract``) and a GitHub
Actions workflow. Kinds: ``sim`` and ``robot`` (a robot backend, a robot and an environment), ``task``, ``eval``,
``env`` (environments of the ``sim_taichi`` simulator with their ground truths).
"""

from __future__ import annotations

import json
import re
import textwrap
from pathlib import Path

from benchbot.core.atomic import write_text
from benchbot.core.errors import UsageError

KINDS = ("sim", "robot", "task", "eval", "env")
_NAME_RE = re.compile(r"^[a-z][a-z0-9_]{0,40}$")

PYPROJECT = '''\
[project]
name = "{dist}"
version = "0.1.0"
description = "BenchBot plugin: {summary}"
readme = "README.md"
requires-python = ">=3.11"
license = "MIT"
dependencies = ["benchbot>=0.1", "numpy>=1.26"]

[project.optional-dependencies]
test = ["pytest>=8"]

# BenchBot finds plugins through this entry-point group; the value is the module with the hook implementations.
[project.entry-points.benchbot]
{ep} = "{pkg}.plugin"

[build-system]
requires = ["hatchling>=1.24"]
build-backend = "hatchling.build"

[tool.hatch.build.targets.wheel]
packages = ["{pkg}"]

[tool.pytest.ini_options]
testpaths = ["tests"]
'''

README = '''\
# {dist}

A [BenchBot](https://github.com/qcr/benchbot) plugin: {summary}

```bash
benchbot install .            # or: benchbot install {dist}  (once published), or a wheel: benchbot install dist/*.whl
benchbot plugins              # shows `{ep}`, its hooks and what it registers
{usage}
```

## Layout

| file | what |
|---|---|
| `{pkg}/plugin.py` | the hook implementations (`benchbot.core.hookspecs`; reference in BenchBot's `docs/hooks.md`) |
{layout}| `tests/test_contract.py` | the core's contract checks (`benchbot_contract` fixture, from `benchbot.plugins.testing`) |
| `.github/workflows/ci.yml` | builds the wheel, installs it, runs the tests |

## Develop

```bash
uv venv && uv pip install -e ".[test]"    # needs benchbot installed (PyPI, a path or a git URL)
uv run pytest
uv build                                  # dist/{pkg}-0.1.0-py3-none-any.whl
```

Rules: every spec must validate against BenchBot's schemas (`benchbot show ...` prints it); import nothing heavy at
module level in `plugin.py` (do it inside the factories); names must not clash with installed content.
'''

CI = '''\
name: ci
on: [push, pull_request]
jobs:
  test:
    runs-on: ubuntu-latest
    strategy:
      matrix:
        python: ["3.11", "3.12", "3.13"]
    steps:
      - uses: actions/checkout@v4
      - uses: astral-sh/setup-uv@v5
      - run: uv venv --python ${{{{ matrix.python }}}}
      # BENCHBOT_CORE: where the benchbot core comes from (a PyPI requirement, a git URL or a path).
      - run: uv pip install "${{BENCHBOT_CORE:-benchbot}}" pytest
        env:
          BENCHBOT_CORE: ${{{{ vars.BENCHBOT_CORE }}}}
      - run: uv build
      - run: uv pip install dist/*.whl
      - run: uv run --no-project pytest -q
'''

TEST_HEADER = '''\
"""Contract tests of {dist}: the core's checks (fixture ``benchbot_contract`` = ``benchbot.plugins.testing``)."""

from __future__ import annotations

from {pkg} import plugin
'''

# ---------------------------------------------------------------------------------------------------------- sim/robot
BACKEND = '''\
"""The ``{type}`` robot backend: a minimal simulator of a square, empty room (replace it with yours).

The robot moves instantly; the camera sees a grey room whose depth is the distance to the walls; the laser measures
the walls. Frames and structures: BenchBot's docs/observations.md.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from benchbot.core.geometry import matrix_to_quaternion_xyzw, pose7_to_se2, se2_to_matrix
from benchbot.core.robot import MotionOutcome, RobotBackend

SPEED_M_S = 0.5


class {cls}(RobotBackend):
    """A robot in a square room of half-size ``environment['room_half_size_m']`` (default 3 m) centred at the
    map origin.

    Args:
        robot_spec: the robot spec (``sensors.camera.width/height``, ``sensors.laser.beams``).
        options: ``width``/``height`` override the camera size; ``seed`` is unused.
    """

    def __init__(self, robot_spec: dict, options: dict) -> None:
        camera = robot_spec.get("sensors", {{}}).get("camera", {{}})
        self.width = int(options.get("width", camera.get("width", 160)))
        self.height = int(options.get("height", camera.get("height", 120)))
        self.beams = int(robot_spec.get("sensors", {{}}).get("laser", {{}}).get("beams", 180))
        self.frames = [f for f in robot_spec.get("poses", []) if f != "initial_pose"]
        self.half = 3.0
        self.pose = np.zeros(3)

    def load_scene(self, environment: dict, *, seed: int = 0) -> None:
        self.half = float(environment.get("room_half_size_m", 3.0))
        self.pose = np.asarray(pose7_to_se2(environment["start_pose"]), dtype=np.float64)

    def base_pose(self) -> np.ndarray:
        return self.pose.copy()

    def move_to(self, goal: np.ndarray) -> MotionOutcome:
        goal = np.asarray(goal, dtype=np.float64)
        distance = float(np.hypot(*(goal[:2] - self.pose[:2])))
        if np.abs(goal[:2]).max() > self.half - 0.25:  # the footprint would touch a wall: stay put
            return MotionOutcome(collided=True, duration_s=0.0)
        self.pose = np.array([goal[0], goal[1], math.atan2(math.sin(goal[2]), math.cos(goal[2]))])
        return MotionOutcome(collided=False, duration_s=distance / SPEED_M_S)

    def frame_transforms(self) -> dict[str, np.ndarray]:
        base = se2_to_matrix(*self.pose)
        camera = base @ np.array([[0, 0, 1, 0.1], [-1, 0, 0, 0], [0, -1, 0, 0.5], [0, 0, 0, 1]], dtype=np.float64)
        lidar = base @ se2_to_matrix(0.0, 0.0, 0.0, 0.3)
        known = {{"robot": base, "camera": camera, "lidar": lidar}}
        return {{f: known.get(f, base) for f in self.frames}}

    def _ranges(self, angles: np.ndarray) -> np.ndarray:
        dx, dy = np.cos(angles), np.sin(angles)
        with np.errstate(divide="ignore"):
            tx = np.where(dx != 0, (np.sign(dx) * self.half - self.pose[0]) / dx, np.inf)
            ty = np.where(dy != 0, (np.sign(dy) * self.half - self.pose[1]) / dy, np.inf)
        return np.minimum(tx, ty)

    def observe(self, names: Sequence[str]) -> dict[str, Any]:
        out: dict[str, Any] = {{}}
        fx = self.width / 2.0  # 90 degree horizontal field of view
        K = np.array([[fx, 0, self.width / 2], [0, fx, self.height / 2], [0, 0, 1]], dtype=np.float64)
        for name in names:
            if name == "image_rgb":
                out[name] = np.full((self.height, self.width, 3), 128, dtype=np.uint8)
            elif name == "image_depth":
                u = np.arange(self.width) + 0.5
                angles = self.pose[2] - np.arctan((u - self.width / 2) / fx)
                z = self._ranges(angles) * np.cos(angles - self.pose[2])
                out[name] = np.broadcast_to(z.astype(np.float32), (self.height, self.width)).copy()
            elif name in ("image_rgb_info", "image_depth_info"):
                out[name] = {{"frame_id": "camera", "height": self.height, "width": self.width,
                             "matrix_intrinsics": K, "matrix_projection": np.hstack([K, np.zeros((3, 1))])}}
            elif name == "laser":
                rel = -math.pi + 2 * math.pi * np.arange(self.beams) / self.beams
                ranges = self._ranges(self.pose[2] + rel)
                out[name] = {{"scans": np.stack([ranges, rel], axis=1).astype(np.float64),
                             "range_min": 0.1, "range_max": 20.0}}
            else:
                raise KeyError(f"{{name}}: this robot has no such sensor")
        return out
'''

SIM_PLUGIN = '''\
"""BenchBot hook implementations of {dist}: the robot type ``{type}`` (backend in ``backend.py``), the robot
``{robot}`` and the environment ``{env}:1``. Imports nothing heavy: the backend is imported by the factory."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl

HERE = Path(__file__).resolve().parent


def factory(robot_spec: dict, options: dict):
    """``factory(robot_spec, options) -> {cls}`` (see ``backend.py``)."""
    from {pkg}.backend import {cls}

    return {cls}(robot_spec, options)


@hookimpl
def benchbot_robot_backends() -> dict:
    """``{{'{type}': factory}}``."""
    return {{"{type}": factory}}


@hookimpl
def benchbot_robots() -> list[Path]:
    """The robot spec ``robots/{robot}.yaml``."""
    return sorted((HERE / "robots").glob("*.yaml"))


@hookimpl
def benchbot_environments() -> list[Path]:
    """The environment specs in ``environments/``."""
    return sorted((HERE / "environments").glob("*.yaml"))
'''

ROBOT_YAML = '''\
# The {robot} robot of {dist}. Frames: map (global), robot (x forward, y left, z up), camera (optical frame),
# lidar. Every action and observation a task needs must be a connection here.
name: {robot}
type: {type}
description: A differential-drive robot in a square room (template of {dist}).
global_frame: map
robot_frame: robot
poses: [camera, lidar, robot, initial_pose]
actions: [move_next, move_distance, move_angle]
observations: [image_rgb, image_depth, image_rgb_info, image_depth_info, laser, poses]
connections:
  move_next: {{connection: api_to_ros}}
  move_distance: {{connection: api_to_ros}}
  move_angle: {{connection: api_to_ros}}
  image_rgb: {{connection: ros_to_api}}
  image_depth: {{connection: ros_to_api}}
  image_rgb_info: {{connection: ros_to_api}}
  image_depth_info: {{connection: ros_to_api}}
  laser: {{connection: ros_to_api}}
  poses: {{connection: ros_to_api}}
sensors:
  camera: {{width: 160, height: 120}}
  laser: {{beams: 180}}
'''

ENV_YAML = '''\
# An environment of type {type}: start_pose and trajectory poses are [qw, qx, qy, qz, x, y, z] in the map frame.
name: {env}
variant: 1
type: {type}
map_path: room
room_half_size_m: 3.0
start_pose: [1, 0, 0, 0, 0.0, 0.0, 0.0]
trajectory_poses:
  - [1, 0, 0, 0, 1.0, 0.0, 0.0]
  - [0.7071068, 0, 0, 0.7071068, 1.0, 1.0, 0.0]
object_labels: []
description: An empty square room, 6 m wide (template of {dist}).
'''

SIM_TESTS = '''
ROBOT = plugin.HERE / "robots" / "{robot}.yaml"
ENV = plugin.HERE / "environments" / "{env}_1.yaml"


def test_content(benchbot_contract):
    registers = benchbot_contract.check_content_plugin(plugin)
    assert registers == {{"robot_backends": ["{type}"], "robots": ["{robot}"], "environments": ["{env}:1"]}}


def test_robot_backend(benchbot_contract):
    import yaml

    robot = yaml.safe_load(ROBOT.read_text())
    environment = yaml.safe_load(ENV.read_text())
    obs = benchbot_contract.check_robot_backend(plugin.factory, robot, environment)
    assert obs["image_rgb"].shape == (48, 64, 3)
'''

# --------------------------------------------------------------------------------------------------------------- task
TASK_PLUGIN = '''\
"""BenchBot hook implementations of {dist}: the task ``{task}`` (``tasks/``)."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl

HERE = Path(__file__).resolve().parent


@hookimpl
def benchbot_tasks() -> list[Path]:
    """The task specs in ``tasks/``."""
    return sorted((HERE / "tasks").glob("*.yaml"))
'''

TASK_YAML = '''\
# A task: what a solution may do (actions) and see (observations), and what it must produce (results_format,
# e.g. object_map from benchbot-task-semslam).
name: {task}
type: {name}
description: Drive along the environment's trajectory and map its objects (template of {dist}).
actions: [move_next]
observations: [image_rgb, image_depth, image_rgb_info, image_depth_info, poses]
localisation: ground_truth
results_format: object_map
scene_count: 1
'''

TASK_TESTS = '''

def test_content(benchbot_contract):
    assert benchbot_contract.check_content_plugin(plugin) == {{"tasks": ["{task}"]}}


def test_task(benchbot_contract):
    for path in plugin.benchbot_tasks():
        benchbot_contract.check_task(path)
'''

# --------------------------------------------------------------------------------------------------------------- eval
EVAL_PLUGIN = '''\
"""BenchBot hook implementations of {dist}: the evaluation method ``{name}`` (``evaluation_methods/``)."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl

HERE = Path(__file__).resolve().parent


@hookimpl
def benchbot_evaluators() -> list[Path]:
    """The evaluation-method specs in ``evaluation_methods/``."""
    return sorted((HERE / "evaluation_methods").glob("*.yaml"))
'''

EVAL_YAML = '''\
name: {name}
description: Compares the number of proposed objects with the number of ground-truth objects (template of {dist}).
valid_result_formats: [object_map, object_map_with_states]
valid_ground_truth_formats: [object_map_ground_truth]
functions:
  evaluate: "{pkg}.metric:evaluate"
  combine: "{pkg}.metric:combine"
'''

EVAL_METRIC = '''\
"""The ``{name}`` metric: 1 when a results file proposes as many objects as its ground truths hold, falling
towards 0 as the counts differ."""

from __future__ import annotations


def evaluate(results: dict, ground_truths: list[dict]) -> dict:
    """Score one results file.

    Args:
        results: a whole results file (``task_details``, ``environment_details``, ``results.objects``).
        ground_truths: one ground truth per scene (``ground_truth.objects``).

    Returns:
        ``{{task_details, environment_details, scores: {{count_score, proposed, expected}}}}``.
    """
    proposed = len(results["results"].get("objects", []))
    expected = sum(len(gt["ground_truth"]["objects"]) for gt in ground_truths)
    score = 1.0 - abs(proposed - expected) / max(proposed, expected, 1)
    return {{"task_details": results["task_details"], "environment_details": results["environment_details"],
            "scores": {{"count_score": score, "proposed": proposed, "expected": expected}}}}


def combine(scores_list: list[dict]) -> dict:
    """Average ``count_score`` over several results (a missing result, ``{{}}``, counts as 0)."""
    values = [s.get("scores", {{}}).get("count_score", 0.0) for s in scores_list]
    return {{"scores": {{"count_score": sum(values) / len(values) if values else 0.0}}}}
'''

EVAL_TESTS = '''

GT = {{"environment": {{"name": "room", "variant": 1}}, "format": {{"name": "object_map_ground_truth"}},
      "ground_truth": {{"class_list": ["chair"], "objects": [
          {{"class": "chair", "centroid": [0, 0, 0.5], "extent": [0.5, 0.5, 1.0]}}]}}}}
RESULTS = {{"task_details": {{"name": "semantic_slam:passive:ground_truth", "results_format": "object_map"}},
           "environment_details": [{{"name": "room", "variant": 1}}],
           "results": {{"class_list": ["chair"], "objects": [
               {{"label_probs": [1.0], "centroid": [0, 0, 0.5], "extent": [0.5, 0.5, 1.0]}}]}}}}


def test_content(benchbot_contract):
    assert benchbot_contract.check_content_plugin(plugin) == {{"evaluators": ["{name}"]}}


def test_evaluator(benchbot_contract):
    (spec,) = plugin.benchbot_evaluators()
    benchbot_contract.check_evaluator(spec, RESULTS, [GT], expect={{"scores.count_score": 1.0}})
'''

# ---------------------------------------------------------------------------------------------------------------- env
ENV_PLUGIN = '''\
"""BenchBot hook implementations of {dist}: the environment ``{env}:1`` for the ``sim_taichi`` simulator
(``pip install benchbot-sim-taichi``) and its ground truth. The map is a BEAR-style JSON in ``data/``: the
simulator builds the scene from its ground-truth objects (axis-aligned boxes, metres, map frame)."""

from __future__ import annotations

import json
from pathlib import Path

from benchbot.core.hookspecs import hookimpl

HERE = Path(__file__).resolve().parent
MAP = HERE / "data" / "{env}_1.json"


@hookimpl
def benchbot_environments() -> list[dict]:
    """The environment spec (``map_path`` = the bundled JSON, absolute)."""
    data = json.loads(MAP.read_text())
    env = data["environment"]
    return [{{"name": env["name"], "variant": env["variant"], "type": "sim_taichi", "map_path": str(MAP),
             "start_pose": env["start_pose"], "trajectory_poses": env["trajectory_poses"],
             "object_labels": sorted({{o["class"] for o in data["ground_truth"]["objects"]}}),
             "description": env["description"], "robots": ["carter"]}}]


@hookimpl
def benchbot_ground_truths() -> list[dict]:
    """The ground truth of ``{env}:1`` (format ``object_map_ground_truth``)."""
    data = json.loads(MAP.read_text())
    return [{{"environment": data["environment"], "format": data["format"], "ground_truth": data["ground_truth"]}}]
'''

ENV_TESTS = '''

def test_content(benchbot_contract):
    registers = benchbot_contract.check_content_plugin(plugin)
    assert registers == {{"environments": ["{env}:1"], "ground_truths": ["{env}:1"]}}
'''


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
         "cls": "".join(p.title() for p in name.split("_")) + "Backend"}
    files: dict[str, str] = {f"{pkg}/__init__.py": f'"""{dist}: a BenchBot plugin."""\n'}
    tests = TEST_HEADER
    if kind in ("sim", "robot"):
        what = "a simulator" if kind == "sim" else "a robot"
        v["summary"] = f"{what} (robot type `{v['type']}`), the robot `{v['robot']}` and the environment `{v['env']}:1`."
        v["usage"] = f"benchbot run --robot {v['robot']} --env {v['env']}:1 --port 0     # any task its robot can do"
        v["layout"] = (f"| `{pkg}/backend.py` | the robot backend (`benchbot.core.robot.RobotBackend`) |\n"
                       f"| `{pkg}/robots/`, `{pkg}/environments/` | the robot and environment specs |\n")
        files[f"{pkg}/plugin.py"] = SIM_PLUGIN.format(**v)
        files[f"{pkg}/backend.py"] = BACKEND.format(**v)
        files[f"{pkg}/robots/{v['robot']}.yaml"] = ROBOT_YAML.format(**v)
        files[f"{pkg}/environments/{v['env']}_1.yaml"] = ENV_YAML.format(**v)
        tests += SIM_TESTS
    elif kind == "task":
        v["summary"] = f"the task `{v['task']}`."
        v["usage"] = f"benchbot show tasks {v['task']}"
        v["layout"] = f"| `{pkg}/tasks/` | the task specs |\n"
        files[f"{pkg}/plugin.py"] = TASK_PLUGIN.format(**v)
        files[f"{pkg}/tasks/{name}.yaml"] = TASK_YAML.format(**v)
        tests += TASK_TESTS
    elif kind == "eval":
        v["summary"] = f"the evaluation method `{name}`."
        v["usage"] = f"benchbot eval results.json --method {name}"
        v["layout"] = (f"| `{pkg}/evaluation_methods/` | the evaluation-method spec |\n"
                       f"| `{pkg}/metric.py` | `evaluate` and `combine` |\n")
        files[f"{pkg}/plugin.py"] = EVAL_PLUGIN.format(**v)
        files[f"{pkg}/evaluation_methods/{name}.yaml"] = EVAL_YAML.format(**v)
        files[f"{pkg}/metric.py"] = EVAL_METRIC.format(**v)
        tests += EVAL_TESTS
    else:
        v["summary"] = f"the environment `{v['env']}:1` for the sim_taichi simulator, with its ground truth."
        v["usage"] = f"benchbot run --env {v['env']}:1 --port 0"
        v["layout"] = f"| `{pkg}/data/` | the map and ground truth (BEAR JSON) |\n"
        files[f"{pkg}/plugin.py"] = ENV_PLUGIN.format(**v)
        files[f"{pkg}/data/{v['env']}_1.json"] = _env_map(v["env"], dist)
        tests += ENV_TESTS
    files["tests/test_contract.py"] = tests.format(**v)
    files["pyproject.toml"] = PYPROJECT.format(**v)
    files["README.md"] = README.format(**v)
    files[".github/workflows/ci.yml"] = CI.format(**v)
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
        write_text(root / rel, textwrap.dedent(text) if rel.endswith(".yml") else text)
    return root
