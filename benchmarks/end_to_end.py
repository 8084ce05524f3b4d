"""API steps per second that a solution gets: a trivial agent and each example, in-process and native.

For every agent and path the benchmark builds a fresh episode (the Taichi simulator, task ``--task``, robot carter,
``--env``, ``--width``×``--height`` camera; the start-up is timed on its own, ``start_s``) and runs the agent through
the whole episode:

* ``inprocess``: :func:`benchbot.api.InProcessBenchBot` in this process (no HTTP, no serialisation), the path of
  ``gym.make`` and of a solution that imports BenchBot;
* ``native``: the agent in a process of its own, as ``benchbot submit --native`` runs a solution: a new Python
  (``sys.executable``) with ``BENCHBOT_SUPERVISOR_ADDRESS`` and ``BENCHBOT_RESULT_LOCATION`` set, talking to the
  backend over HTTP on 127.0.0.1 (MessagePack, large arrays through shared memory on the same host), the backend
  serving from a thread of this process as ``benchbot run`` does. Not sandboxed: the sandbox's cost is start-up,
  not per step.

Agents: ``trivial`` (``move_next`` until the trajectory is used up, nothing else: the API's own rate), then each
example that the registry lists for the task (``hello_passive`` saves PNGs every 10 steps; ``semslam_geometric``
fuses depth into a voxel map and fits cuboids at the end). The steps are timed where the backend sees them (its
``on_step`` observer): ``steps_per_s`` is (steps − 1) / (last step − first step), the rate a user feels while the
robot moves; ``episode_s`` is the agent's whole run (client start, steps, its results), ``start_s`` the backend's
start-up (scene build or cache load, renderer, first frame): the first run's includes what this process does once
(Taichi's start, kernels loaded or compiled); later runs reuse it.

    uv run python benchmarks/end_to_end.py [--env miniroom:1] [--arch cpu|cuda] [--agents trivial,...]
        [--paths inprocess,native] [--width 640 --height 480] [--json] [--smoke]

``--json`` prints one object: ``{machine, arch, env, task, width, height, runs: [{agent, path, steps, steps_per_s,
episode_s, start_s}]}``.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import inspect
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs

#: The trivial agent, as a native solution runs it (the in-process path uses the same class).
TRIVIAL_SOURCE = '''
from benchbot_api import ActionResult, Agent, BenchBot


class TrivialAgent(Agent):
    """move_next until the trajectory is used up; no work per step."""

    def is_done(self, action_result):
        return action_result != ActionResult.SUCCESS

    def pick_action(self, observations, action_list):
        return "move_next", {}

    def save_result(self, filename, empty_results, results_format_fns):
        import json
        with open(filename, "w") as f:
            json.dump(empty_results, f)


if __name__ == "__main__":
    BenchBot(agent=TrivialAgent()).run()
'''


def agent_script(registry, name: str, folder: Path) -> Path:
    """The Python file that runs agent ``name`` natively: the trivial agent written to ``folder``, or an example's
    script (its ``native_command``'s ``python FILE``, relative to the example's folder).

    Raises:
        SystemExit: an example whose command is no ``python FILE``.
    """
    if name == "trivial":
        path = folder / "trivial_agent.py"
        path.write_text(TRIVIAL_SOURCE)
        return path
    example = registry.entry("examples", name)
    command = str(example.spec.get("native_command", ""))
    parts = command.split()
    if len(parts) != 2 or parts[0] != "python" or example.path is None:
        raise SystemExit(f"example {name}: native_command is not 'python FILE' beside its spec ({command!r})")
    return Path(example.path).parent / parts[1]


def load_agent(script: Path, result_location: Path):
    """An instance of the ``Agent`` subclass defined in ``script`` (imported with its folder on ``sys.path`` and
    ``BENCHBOT_RESULT_LOCATION`` set first, as an example reads it at import)."""
    os.environ["BENCHBOT_RESULT_LOCATION"] = str(result_location)
    import benchbot.api.benchbot as api_module

    api_module.RESULT_LOCATION = str(result_location)
    from benchbot.api import Agent

    sys.path.insert(0, str(script.parent))
    try:
        spec = importlib.util.spec_from_file_location(f"bench_agent_{script.stem}", script)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(script.parent))
    classes = [c for _, c in inspect.getmembers(module, inspect.isclass)
               if issubclass(c, Agent) and c is not Agent and c.__module__ == module.__name__]
    if len(classes) != 1:
        raise SystemExit(f"{script}: expected one Agent subclass, found {[c.__name__ for c in classes]}")
    return classes[0]()


def one_run(args: argparse.Namespace, registry, agent: str, path: str, work: Path) -> dict:
    """Build an episode, run ``agent`` through it on ``path``; the figures of the run (module docstring)."""
    from benchbot.api import InProcessBenchBot
    from benchbot.server import ServerThread, build_app
    from benchbot.core.session import resolve_run, start_service

    stamps: list[float] = []
    spec = resolve_run(registry, args.task, "carter", args.env)
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(sys.stderr):
        service = start_service(registry, spec, options={"arch": args.arch, "width": args.width,
                                                         "height": args.height},
                                on_step=lambda info: stamps.append(time.perf_counter()))
    start_s = time.perf_counter() - t0
    folder = work / f"{agent}_{path}"
    folder.mkdir()
    results = folder / "results.json"
    script = agent_script(registry, agent, folder)
    try:
        if path == "inprocess":
            bot_agent = load_agent(script, results)
            t = time.perf_counter()
            with contextlib.redirect_stdout(sys.stderr):
                InProcessBenchBot(service, agent=bot_agent).run()
            episode_s = time.perf_counter() - t
        else:
            server = ServerThread(build_app(service)).start()
            env = dict(os.environ, BENCHBOT_SUPERVISOR_ADDRESS=server.address,
                       BENCHBOT_RESULT_LOCATION=str(results))
            t = time.perf_counter()
            try:
                proc = subprocess.run([sys.executable, script.name], cwd=script.parent, env=env,
                                      stdout=sys.stderr, stderr=sys.stderr, timeout=args.timeout)
            finally:
                episode_s = time.perf_counter() - t
                server.stop()
            if proc.returncode != 0:
                raise SystemExit(f"{agent} ({path}) exited with status {proc.returncode}")
    finally:
        service.close()
    if not results.is_file():
        raise SystemExit(f"{agent} ({path}) wrote no results file")
    steps = len(stamps)
    rate = (steps - 1) / (stamps[-1] - stamps[0]) if steps > 1 and stamps[-1] > stamps[0] else float("nan")
    return {"agent": agent, "path": path, "steps": steps, "steps_per_s": rate, "episode_s": episode_s,
            "start_s": start_s}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="miniroom:1")
    ap.add_argument("--task", default="semantic_slam:passive:ground_truth")
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"), help="cpu or cuda")
    ap.add_argument("--agents", default="", help="comma-separated: trivial and example names (default: trivial "
                                                 "and every example of the task)")
    ap.add_argument("--paths", default="inprocess,native")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds a native agent may run")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, env="miniroom:4", width=32, height=24, agents="trivial,hello_passive")

    from benchbot.core.errors import BenchbotError
    from benchbot.core.registry import get_registry

    registry = get_registry()
    if args.agents:
        agents = [a.strip() for a in args.agents.split(",") if a.strip()]
    else:
        task_examples = [name for name, entry in sorted(registry.entries.get("examples", {}).items())
                         if _example_fits(entry, args.task)]
        agents = ["trivial", *task_examples]
    paths = [p.strip() for p in args.paths.split(",") if p.strip()]
    if not set(paths) <= {"inprocess", "native"}:
        ap.error("--paths: inprocess and/or native")
    runs = []
    with tempfile.TemporaryDirectory(prefix="benchbot-e2e-") as tmp:
        for agent in agents:
            for path in paths:
                try:
                    run = one_run(args, registry, agent, path, Path(tmp))
                except BenchbotError as exc:  # a name the registry does not know (--env, --task, --agents)
                    raise SystemExit(f"error: {exc.message}" + (f"\nhint: {exc.hint}" if exc.hint else "")) \
                        from None
                runs.append(run)
                print(f"{agent:>22} {path:>9}: {run['steps']:4d} steps, {run['steps_per_s']:7.2f} steps/s, "
                      f"episode {run['episode_s']:6.2f} s, start-up {run['start_s']:5.2f} s", file=sys.stderr,
                      flush=True)
    report = {"machine": f"{platform.node()} ({os.cpu_count()} cores)", "arch": args.arch, "env": args.env,
              "task": args.task, "width": args.width, "height": args.height, "runs": runs}
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{args.env}, {args.task}, {args.width}x{args.height}, arch {args.arch}")
        print(f"{'agent':>22} {'path':>9} {'steps':>6} {'steps/s':>9} {'episode s':>10} {'start s':>8}")
        for r in runs:
            print(f"{r['agent']:>22} {r['path']:>9} {r['steps']:6d} {r['steps_per_s']:9.2f} "
                  f"{r['episode_s']:10.2f} {r['start_s']:8.2f}")
    return 0


def _example_fits(entry, task: str) -> bool:
    """Whether an example is measured on ``task``: one that reads the ground truth on purpose
    (``reads_ground_truth``, a check of the evaluation pipeline) measures nothing and is left out, and
    ``hello_active``, which drives with ``move_distance``/``move_angle``, needs an active task."""
    if entry.spec.get("reads_ground_truth"):
        return False
    return entry.spec.get("name") != "hello_active" or ":active:" in task


if __name__ == "__main__":
    sys.exit(main())
