"""Contract checks for BenchBot plugins, and a pytest plugin exposing them.

Every check raises :class:`AssertionError` with a message naming what is wrong, so a plugin's test is one call::

    def test_contract(benchbot_contract):
        import benchbot_sim_mine.plugin as plugin
        benchbot_contract.check_content_plugin(plugin)
        benchbot_contract.check_robot_backend(plugin.factory, robot_spec, environment)

The fixture ``benchbot_contract`` is this module (registered under the ``pytest11`` entry point ``benchbot``;
without it, ``from benchbot.plugins import testing`` works the same). Checks import nothing heavy themselves.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any, Callable, Iterable

import numpy as np

HEAVY_MODULES = ("taichi", "rclpy", "ray", "torch", "cyclonedds")
CONTENT_KINDS = ("tasks", "robots", "environments", "formats", "evaluators", "examples", "batches", "ground_truths")


def _fail(what: str, problems: list[str]) -> None:
    if problems:
        raise AssertionError(f"{what}: {len(problems)} problem(s):\n  " + "\n  ".join(problems))


def _load(raw: Any) -> dict:
    from benchbot.core.specs import load_spec_file

    if isinstance(raw, (str, Path)):
        return load_spec_file(Path(raw))
    if isinstance(raw, dict):
        return dict(raw)
    raise AssertionError(f"a spec must be a dict or a file path, got {type(raw).__name__}")


def spec_items(specs: Iterable[Any]) -> list:
    """What a content hook returned, with every folder replaced by the spec files in it (as the registry reads
    them: :func:`benchbot.core.specs.expand_spec_folders`), so each item can go to a ``check_*`` function.

    Args:
        specs: the hook's list: dicts, and paths of spec files or of folders of them.
    """
    from benchbot.core.specs import expand_spec_folders

    return expand_spec_folders(list(specs))


def _importable(module_name: str) -> bool:
    import importlib.util

    try:
        return importlib.util.find_spec(module_name) is not None
    except (ImportError, ValueError):
        return False


def check_content_plugin(module: ModuleType | object, *, light_import: bool = True) -> dict[str, list[str]]:
    """Check a plugin module: its hook implementations name real hooks, every content hook returns a list of specs
    that load and validate against their schema, names are unique, robot-backend factories are callable, its
    settings (``benchbot_settings``) follow the rules of :mod:`benchbot.core.settings` (the ``BENCHBOT_`` prefix
    unless external, no name the core or the plugin declares already), and importing the module imports nothing
    heavy (taichi, rclpy, ray, torch, cyclonedds).

    Args:
        module: the plugin (the object registered under the entry point).
        light_import: also import the module in a fresh interpreter and check no heavy module was imported
            (only for real modules).

    Returns:
        ``{kind: [names]}`` of what the plugin registers (``robot_backends`` and ``settings`` included).

    Raises:
        AssertionError: every problem found, one per line.
    """
    import pluggy

    from benchbot.core import hookspecs
    from benchbot.core.errors import SpecError
    from benchbot.core.specs import KIND_SCHEMAS, entry_name, expand_spec_folders, singular, validate

    pm = pluggy.PluginManager(hookspecs.PROJECT_NAME)
    for hook_class in hookspecs.HOOK_CLASSES:
        pm.add_hookspecs(hook_class)
    problems: list[str] = []
    try:
        pm.register(module, name="under_test")
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        raise AssertionError(f"plugin does not match the hookspecs: {exc}") from None
    implemented = {c.name for c in pm.get_hookcallers(module) or []}
    if not implemented:
        problems.append("the plugin implements no benchbot hook (mark functions with benchbot.core.hookspecs.hookimpl)")
    registers: dict[str, list[str]] = {}
    for kind, schema in KIND_SCHEMAS.items():
        if f"benchbot_{kind}" not in implemented:
            continue
        try:
            specs = getattr(pm.hook, f"benchbot_{kind}")()
        except Exception as exc:  # noqa: BLE001 — report any failure of the plugin
            problems.append(f"benchbot_{kind}() raised {exc!r}")
            continue
        for result in specs:
            if not isinstance(result, (list, tuple)):
                problems.append(f"benchbot_{kind}() must return a list, got {type(result).__name__}")
                continue
            for raw in expand_spec_folders(list(result)):
                try:
                    spec = _load(raw)
                    validate({k: v for k, v in spec.items() if k != "_file_path"}, schema, str(raw) if not isinstance(raw, dict) else f"benchbot_{kind}()")
                    name = entry_name(kind, spec)
                except (SpecError, AssertionError) as exc:
                    problems.append(str(exc))
                    continue
                if name in registers.get(kind, []):
                    problems.append(f"{singular(kind)} '{name}' is returned twice")
                registers.setdefault(kind, []).append(name)
                if kind in ("formats", "evaluators"):
                    from benchbot.core.plugin_manager import import_object

                    for fn_name, path in spec["functions"].items():
                        try:
                            if not callable(import_object(path)):
                                problems.append(f"{kind[:-1]} '{name}': functions.{fn_name} '{path}' is not callable")
                        except (ImportError, AttributeError) as exc:
                            problems.append(f"{kind[:-1]} '{name}': functions.{fn_name} '{path}' cannot be imported: {exc}")
                if kind == "examples" and not isinstance(raw, (str, Path)):
                    problems.append(f"example '{name}' must be given as a file path (its command runs from its folder)")
    if "benchbot_robot_backends" in implemented:
        for result in pm.hook.benchbot_robot_backends():
            if not isinstance(result, dict):
                problems.append(f"benchbot_robot_backends() must return a dict, got {type(result).__name__}")
                continue
            for type_name, factory in result.items():
                if not callable(factory):
                    problems.append(f"robot backend '{type_name}': factory is not callable")
                registers.setdefault("robot_backends", []).append(type_name)
    if "benchbot_settings" in implemented:
        from benchbot.core.settings import from_plugins

        declared = from_plugins(pm)
        problems.extend(declared.problems)
        if declared.settings:
            registers["settings"] = [s.name for s in declared.settings]
    module_name = getattr(module, "__name__", None)
    if light_import and isinstance(module, ModuleType) and module_name and _importable(module_name):
        code = (f"import sys, json; import {module_name}; "
                f"print(json.dumps([m for m in {list(HEAVY_MODULES)!r} if m in sys.modules]))")
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        if proc.returncode != 0:
            problems.append(f"importing {module_name} failed: {proc.stderr.strip().splitlines()[-1:]}")
        else:
            heavy = json.loads(proc.stdout.strip().splitlines()[-1])
            if heavy:
                problems.append(f"importing {module_name} imports {', '.join(heavy)}: import them inside the factories")
    _fail(f"plugin {module_name or module!r}", problems)
    return registers


def _kinds(registry: Any) -> dict:
    """The observation kinds of ``registry`` (default: the process's registry, plugins' kinds included)."""
    if registry is None:
        from benchbot.core.registry import get_registry

        registry = get_registry()
    return registry.observations


def check_observations(obs: dict, names: Iterable[str], *, registry: Any = None) -> None:
    """Check observation structures (docs/observations.md) for ``names``: each must be there, and every observation
    of a kind in ``obs`` must pass its kind's structure check (:func:`benchbot.core.observations.problems`).

    Args:
        obs: the observations.
        names: the names that must be there.
        registry: the :class:`~benchbot.core.registry.Registry` whose observation kinds check (default: the
            process's; give the one holding a plugin defined in a test).

    Raises:
        AssertionError: a missing key, a wrong dtype/shape, or an inconsistent size (one line each).
    """
    from benchbot.core.observations import problems

    _fail("observations", problems(obs, list(names), _kinds(registry)))


def _check_transform(name: str, t: Any, problems: list[str]) -> None:
    t = np.asarray(t)
    if t.shape != (4, 4) or not np.issubdtype(t.dtype, np.floating):
        problems.append(f"frame_transforms[{name!r}]: expected (4, 4) float, got {t.shape} {t.dtype}")
        return
    r = t[:3, :3]
    if not np.allclose(t[3], [0, 0, 0, 1]) or not np.allclose(r @ r.T, np.eye(3), atol=1e-5) or np.linalg.det(r) < 0:
        problems.append(f"frame_transforms[{name!r}]: not a rigid transform (last row [0,0,0,1], rotation orthonormal)")



def _first_difference(a: Any, b: Any, where: str = "") -> str | None:
    """Where nested observations ``a`` and ``b`` first differ (key path), or None when their values are equal."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        same = isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.dtype == b.dtype \
            and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        return None if same else where or "the top level"
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return f"{where or 'the top level'} (keys {sorted(set(a) ^ set(b))})"
        return next((d for k in a if (d := _first_difference(a[k], b[k], f"{where}['{k}']"))), None)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):  # may hold arrays: compared item by item
        if len(a) != len(b):
            return f"{where or 'the top level'} (lengths {len(a)} and {len(b)})"
        return next((d for i, (x, y) in enumerate(zip(a, b)) if (d := _first_difference(x, y, f"{where}[{i}]"))), None)
    return None if a == b else where or "the top level"


def _yaw_of(start_pose: list[float]) -> float:
    from benchbot.core.geometry import start_pose_to_se2  # loaded when a check runs, not with pytest

    return float(start_pose_to_se2(start_pose)[2])


def _angle_diff(a: float, b: float) -> float:
    from benchbot.core.geometry import wrap_angle

    return wrap_angle(a - b)


def check_robot_backend(factory: Callable, robot_spec: dict, environment: dict, *, options: dict | None = None,
                        turn_rad: float = 0.3, registry: Any = None) -> dict:
    """Drive a robot backend through the :class:`~benchbot.core.robot.RobotBackend` contract: build it, load the
    scene, read the pose (must be the environment's ``start_pose``), frame transforms for every frame of the
    robot's ``poses``, every sensor observation the robot offers (structures of docs/observations.md; the same values
    from ``observe_borrowed`` where the backend overrides it), turn on the
    spot by ``turn_rad`` with ``move_to`` (the pose must follow unless it collided), ask for an unknown
    observation (``KeyError``), reload the scene (back at the start), close.

    Args:
        factory: ``factory(robot_spec, options) -> RobotBackend``.
        robot_spec: the robot spec (schema ``robot``).
        environment: an environment spec (schema ``environment``) of the robot's type.
        options: backend options (default ``{'seed': 0, 'width': 64, 'height': 48, 'arch': 'cpu'}``).
        turn_rad: the test turn (rad, counter-clockwise).
        registry: the registry whose observation kinds say which of the robot's observations are sensors and check
            them (default: the process's).

    Returns:
        The observations of the first scene (dict).

    Raises:
        AssertionError: every contract violation found.
    """
    from benchbot.core.specs import validate
    from benchbot.core.robot import MotionOutcome, RobotBackend

    validate({k: v for k, v in robot_spec.items() if k != "_file_path"}, "robot", "robot_spec")
    validate({k: v for k, v in environment.items() if k != "_file_path"}, "environment", "environment")
    problems: list[str] = []
    backend = factory(robot_spec, {"seed": 0, "width": 64, "height": 48, "arch": "cpu", **(options or {})})
    if not isinstance(backend, RobotBackend):
        raise AssertionError(f"factory returned {type(backend).__name__}, not a benchbot.core.robot.RobotBackend")
    try:
        backend.load_scene(environment, seed=0)
        pose = np.asarray(backend.base_pose())
        if pose.shape != (3,) or not np.isfinite(pose).all():
            raise AssertionError(f"base_pose(): expected (3,) finite [x, y, yaw], got {pose!r}")
        start = environment["start_pose"]
        if np.hypot(pose[0] - start[4], pose[1] - start[5]) > 0.05 or abs(_angle_diff(pose[2], _yaw_of(start))) > 0.05:
            problems.append(f"after load_scene the robot is at {pose.round(3).tolist()}, not at the start pose "
                            f"[{start[4]}, {start[5]}, {_yaw_of(start):.3f}]")
        frames = [f for f in robot_spec.get("poses", []) if f != "initial_pose"]
        transforms = backend.frame_transforms()
        for frame in frames:
            if frame not in transforms:
                problems.append(f"frame_transforms(): missing frame '{frame}' (listed in the robot's poses)")
            else:
                _check_transform(frame, transforms[frame], problems)
        offered = set(robot_spec.get("observations", [])) | set(robot_spec.get("connections", {}))
        kinds = _kinds(registry)
        names = [n for n, kind in kinds.items() if kind.sensor and n in offered]
        obs = backend.observe(names)
        try:
            check_observations(obs, names, registry=registry)
        except AssertionError as exc:
            problems.append(str(exc))
        # a backend that overrides observe_borrowed must give observe's values (the default is observe itself,
        # whose values may change between two calls on a live robot)
        overrides = getattr(type(backend), "observe_borrowed", None) is not RobotBackend.observe_borrowed
        difference = _first_difference(obs, backend.observe_borrowed(names)) if overrides else None
        if difference:
            problems.append(f"observe_borrowed() differs from observe() at {difference}: it must give the same "
                            "values (only without copies)")
        try:
            backend.observe(["no_such_sensor"])
            problems.append("observe(['no_such_sensor']) must raise KeyError")
        except KeyError:
            pass
        goal = np.array([pose[0], pose[1], pose[2] + turn_rad])
        outcome = backend.move_to(goal)
        if not isinstance(outcome, MotionOutcome):
            problems.append(f"move_to(): expected a MotionOutcome, got {type(outcome).__name__}")
        else:
            after = np.asarray(backend.base_pose())
            if not outcome.collided and (abs(_angle_diff(after[2], goal[2])) > 0.05 or np.hypot(*(after[:2] - goal[:2])) > 0.05):
                problems.append(f"move_to({goal.round(3).tolist()}) ended at {after.round(3).tolist()} without a collision")
            if outcome.duration_s < 0:
                problems.append("move_to(): duration_s must be >= 0")
        backend.load_scene(environment, seed=0)
        again = np.asarray(backend.base_pose())
        if np.abs(again[:2] - pose[:2]).max() > 1e-6 or abs(_angle_diff(again[2], pose[2])) > 1e-6:
            problems.append("load_scene() again does not return the robot to the start pose")
    finally:
        backend.close()
    _fail(f"robot backend for '{robot_spec.get('name')}'", problems)
    return obs


def check_format(spec: dict | str | Path) -> dict:
    """Check a results-format spec: it validates, its functions import, ``create()`` returns a dict that its own
    ``validate`` accepts, ``create_object()`` (if any) returns a dict.

    Returns:
        What ``create()`` returned.

    Raises:
        AssertionError: a problem.
    """
    from benchbot.core.plugin_manager import import_object
    from benchbot.core.specs import validate

    spec = _load(spec)
    validate({k: v for k, v in spec.items() if k != "_file_path"}, "format", f"format '{spec.get('name')}'")
    fns = {k: import_object(v) for k, v in spec["functions"].items()}
    empty = fns["create"]()
    if not isinstance(empty, dict):
        raise AssertionError(f"format '{spec['name']}': create() returned {type(empty).__name__}, not a dict")
    if "create_object" in fns and not isinstance(fns["create_object"](), dict):
        raise AssertionError(f"format '{spec['name']}': create_object() must return a dict")
    if "validate" in fns:
        fns["validate"](empty)
    return empty


def check_evaluator(spec: dict | str | Path, results: dict, ground_truths: list[dict], *, expect: dict | None = None) -> dict:
    """Check an evaluation method: the spec validates, ``evaluate(results, ground_truths)`` returns
    ``{name: finite number}`` with the spec's declared primary score (``scores``) under ``scores`` and every declared
    score it returns inside its declared range, and ``combine([scores, scores])`` (if any) returns the same kind of dict.

    Args:
        spec: the evaluator spec (dict or file).
        results: a whole results file (``task_details``, ``environment_details``, ``results``).
        ground_truths: one ground truth (schema ``ground_truth``) per scene of ``results``.
        expect: scores that must come out, by dotted key (``{"scores.OMQ": 1.0}``; 1e-6 tolerance).

    Returns:
        The scores of ``evaluate``.

    Raises:
        AssertionError: a problem.
    """
    from benchbot.core.plugin_manager import import_object
    from benchbot.core.specs import validate

    spec = _load(spec)
    name = spec.get("name")
    validate({k: v for k, v in spec.items() if k != "_file_path"}, "evaluator", f"evaluator '{name}'")
    for gt in ground_truths:
        validate(gt, "ground_truth", "ground truth")
        if gt["format"]["name"] not in spec["valid_ground_truth_formats"]:
            raise AssertionError(f"evaluator '{name}' does not accept ground truths of format {gt['format']['name']}")
    fns = {k: import_object(v) for k, v in spec["functions"].items()}
    scores = fns["evaluate"](results, ground_truths)

    def check_scores(what: str, s: Any) -> None:
        if not isinstance(s, dict) or not s:
            raise AssertionError(f"evaluator '{name}': {what} must return a non-empty dict, got {s!r}")
        bad = [k for k, v in s.items() if isinstance(v, (int, float)) and not math.isfinite(v)]
        if bad:
            raise AssertionError(f"evaluator '{name}': {what} returned non-finite {', '.join(bad)}")

    check_scores("evaluate", scores)
    returned = scores.get("scores") if isinstance(scores.get("scores"), dict) else {}
    for d in spec.get("scores") or []:  # a declared score may be absent from some results (a mode's), not the primary
        value = returned.get(d["name"])
        if value is None and not d.get("primary"):
            continue
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise AssertionError(f"evaluator '{name}': declares score '{d['name']}' but evaluate returned "
                                 f"scores.{d['name']} = {value!r}")
        low, high = (list(d.get("range") or [None, None]) + [None, None])[:2]
        if (low is not None and value < low) or (high is not None and value > high):
            raise AssertionError(f"evaluator '{name}': scores.{d['name']} = {value} is outside its declared range "
                                 f"[{low}, {high}]")
    for key, value in (expect or {}).items():
        got: Any = scores
        for part in key.split("."):
            got = got.get(part) if isinstance(got, dict) else None
        if not isinstance(got, (int, float)) or abs(float(got) - value) > 1e-6:
            raise AssertionError(f"evaluator '{name}': {key} = {got!r}, expected {value}")
    if "combine" in fns:
        check_scores("combine", fns["combine"]([scores, scores]))
    return scores


def check_task(spec: dict | str | Path, *, registry: Any = None, robots: Iterable[str] = ()) -> dict:
    """Check a task spec: it validates; with ``registry``, its results format exists and every robot in
    ``robots`` offers its actions and observations.

    Raises:
        AssertionError: a problem.
    """
    from benchbot.core.specs import validate

    spec = _load(spec)
    validate({k: v for k, v in spec.items() if k != "_file_path"}, "task", f"task '{spec.get('name')}'")
    problems = []
    if not spec["actions"] and not spec["observations"]:
        problems.append("a task needs actions or observations")
    if registry is not None:
        if spec.get("results_format") and spec["results_format"] not in registry.entries["formats"]:
            problems.append(f"results_format '{spec['results_format']}' is not installed")
        for robot_name in robots:
            offered = set(registry.get("robots", robot_name).get("connections", {}))
            missing = [n for n in [*spec["actions"], *spec["observations"]] if n not in offered]
            if missing:
                problems.append(f"robot '{robot_name}' lacks {', '.join(missing)}")
    _fail(f"task '{spec['name']}'", problems)
    return spec


try:  # the pytest plugin part: only when pytest is importable
    import pytest

    @pytest.fixture
    def benchbot_contract() -> ModuleType:
        """The contract checks of :mod:`benchbot.plugins.testing` (``benchbot_contract.check_robot_backend(...)``)."""
        return sys.modules[__name__]
except ImportError:  # pragma: no cover
    pass
