"""Running one batch episode: a backend on a free 127.0.0.1 port (built in this process, or in the user's simulator
service: :mod:`benchbot.service`), the submission as a child process of this one, the record.

:func:`run_episode` runs in the batch process (one worker) or in a worker process (several workers, Ray); it
reports steps through an optional ``events`` queue as ``("step", index, info)`` tuples.
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path
from typing import Any

from benchbot.batch.plan import EpisodeRecord, EpisodeSpec, new_record
from benchbot.core import stages
from benchbot.core.errors import BenchbotError, ResultsError
from benchbot.solutions.leftovers import owned_tempdir
from benchbot.core.registry import get_registry
from benchbot.core.session import RunSpec
from benchbot.service.episodes import open_episode
from benchbot.solutions.submission import Submission, run_submission


#: An episode's error when it did not end ``ok`` and its solution read standard input (its log has the line).
READ_STDIN_ERROR = ("the solution read its standard input, which a batch does not give (end-of-file); "
                    "an interactive solution runs with `benchbot submit`")


def run_directories(run_dir: Path) -> list[Path]:
    """``run_dir`` and the other run directories beside it (folders holding a ``manifest.json``): what a sandboxed
    solution must not see of the batches' outputs (others' results and scores included). ``run_dir`` is left out
    where it does not exist (a Ray node that does not share the batch's file system): bubblewrap cannot make its
    empty folder inside a read-only shown folder, and there is nothing there to hide.

    Raises:
        OSError: ``run_dir``'s parent folder cannot be listed."""
    siblings = [p for p in run_dir.parent.iterdir() if p.is_dir() and (p / "manifest.json").is_file()]
    return [run_dir, *siblings] if run_dir.is_dir() else siblings


def service_folders() -> list[Path]:
    """The simulator service's socket folders (:func:`benchbot.service.location.socket_folders`) that exist: hidden
    from sandboxed solutions, whose own shown folder may hold them (the service refuses them all the same,
    :func:`benchbot.service.protocol.peer_problem`)."""
    from benchbot.service.location import socket_folders

    return [folder.resolve() for folder in socket_folders() if folder.is_dir()]


def _run_sandboxed(spec: EpisodeSpec, registry, folder: Path, backend_socket: Path, log,
                   record: EpisodeRecord, hide: tuple = ()) -> tuple[bool, bool]:
    """Run ``spec``'s solution in the sandbox (:func:`benchbot.solutions.sandbox.run_sandboxed`): it writes only to its
    outputs folder (``spec.outputs``, made afresh) and reaches the backend through ``backend_socket`` at
    ``http://127.0.0.1:10000/``; its results file is then moved to ``spec.results``. The run directories beside
    ``folder``, the simulator service's socket folder (:func:`service_folders`) and the folders ``hide`` lists are
    hidden from it. Sets ``record.returncode`` (and ``record.error``
    when its results file is refused; ``record.status`` ``resource_limit`` and the reason when the solution went
    past a resource limit, :mod:`benchbot.solutions.sandbox_limits`); returns (whether it timed out, whether it read its
    standard input)."""
    from benchbot.solutions.sandbox import run_sandboxed

    outputs = folder / spec.outputs
    shutil.rmtree(outputs, ignore_errors=True)
    outputs.mkdir(parents=True)
    run = run_sandboxed(list(spec.argv), Path(spec.cwd), registry=registry, backend_socket=backend_socket,
                        address="http://127.0.0.1:10000/", outputs=outputs, result_name=Path(spec.results).name,
                        hide=[*run_directories(folder), *service_folders(), *hide], log=log,
                        timeout_s=spec.timeout_s)
    record.returncode = run.outcome.returncode
    if run.limit:
        record.status, record.error = "resource_limit", run.limit
    elif run.problem:
        record.error = run.problem
    elif run.results is not None:
        os.replace(run.results, folder / spec.results)
    return run.outcome.timed_out, run.outcome.read_stdin


def write_trajectory(path: Path, run: RunSpec, driven: list[tuple[int, list[float]]]) -> None:
    """Write an episode's trajectory log: per scene, its start pose and the robot's ground-truth pose after every
    action, ``{"frame": "map", "units": "x, y in metres, yaw in radians", "scenes": [{"scene", "environment",
    "start": [x, y, yaw], "poses": [[x, y, yaw], ...]}]}`` (what report maps draw as the driven path). Written
    atomically; never fails the episode (a write error leaves no log)."""
    from benchbot.core import atomic
    from benchbot.core.geometry import start_pose_to_se2

    scenes = []
    for k, env in enumerate(run.environments):
        try:  # where the robot was placed: the start pose read as the original read it (a quaternion as written)
            start = [round(float(v), 6) for v in start_pose_to_se2(env["start_pose"])]
        except (KeyError, TypeError, ValueError):
            start = None
        poses = [p for scene, p in driven if scene == k]
        if start is not None or poses:
            scenes.append({"scene": k, "environment": f"{env.get('name')}:{env.get('variant')}",
                           "start": start if start is not None else poses[0], "poses": poses})
    try:
        path.parent.mkdir(exist_ok=True)
        atomic.write_json(path, {"frame": "map", "units": "x, y in metres, yaw in radians", "scenes": scenes})
    except OSError:
        pass


def _log_error(path: Path, message: str) -> None:
    """Append ``message`` (an episode's error) to its log ``path``, so that the log the record names exists and
    says why; a log that cannot be written is left as it is (the record holds the error)."""
    try:
        with open(path, "a") as log:
            log.write(f"benchbot: the episode ended with an error: {message}\n")
    except OSError:
        pass


def _run_solution(spec: EpisodeSpec, registry, folder: Path, backend_socket: Path, address: str, log,
                  record: EpisodeRecord, hide: tuple) -> tuple[bool, bool]:
    """Run ``spec``'s solution as its isolation level says: sandboxed or in its container (both through
    ``backend_socket``: :func:`_run_sandboxed`, :func:`~benchbot.batch.container_episode.run_container_episode`), or
    as a plain process (reaching the backend at ``address``).
    Sets ``record.returncode`` (and what :func:`_run_sandboxed` sets); returns (whether it timed out, whether it
    read its standard input)."""
    if spec.sandbox == "bwrap":
        return _run_sandboxed(spec, registry, folder, backend_socket, log, record, hide)
    if spec.container:  # through backend_socket too: the container has no network
        from benchbot.batch.container_episode import run_container_episode

        return run_container_episode(spec, folder, backend_socket, log, record)
    submission = Submission(list(spec.argv), Path(spec.cwd), "submission")
    outcome = run_submission(submission, address=address, result_location=folder / spec.results, log=log,
                             timeout_s=spec.timeout_s)
    record.returncode = outcome.returncode
    return outcome.timed_out, outcome.read_stdin


def run_episode(spec: EpisodeSpec, run: RunSpec, run_dir: str, events: Any = None, *,
                hide: tuple = (), in_service: bool = False, pool: dict | None = None,
                service_location=None) -> EpisodeRecord:
    """Run ``spec`` and return its record (never raises for an episode's own failure: the record says it).

    Args:
        spec: the episode.
        run: its task, robot and environment resolved (:func:`benchbot.core.session.resolve_run`), once per
            combination by the batch process (:class:`benchbot.batch.runner.Batch`); plain data, it is pickled
            to worker processes and Ray tasks with ``spec``.
        run_dir: absolute path of the run directory (results and logs go there).
        events: a queue receiving ``("start", index, None)``, ``("stage", index, {"stage": what the backend is
            doing, "" when done})`` while it starts (:mod:`benchbot.core.stages`), ``("step", index, info)`` and
            ``("end", index, None)``.
        hide: more folders a sandboxed solution must not see (a Ray node runs the episode in a run directory of
            its own and hides the batch's, :func:`benchbot.batch.executors.run_ray`).
        in_service: build and serve the backend in the user's simulator service (:mod:`benchbot.service`; started
            when none answers) instead of this process; a recorded episode runs here all the same. What the
            solution observes, its results and the record's fields but ``wall_s`` are the same either way.
        pool: with ``in_service``, ``{"threads", "gpus"}``: served by a warm worker process of the service's pool
            (:mod:`benchbot.service.pool`) with that many Taichi threads on one of those GPUs (``[]``: the CPU);
            the record's ``node`` then says which GPU (``{"gpu": {"index", "name"}}``).
        service_location: with ``in_service``, the service's :class:`~benchbot.service.location.ServiceLocation`,
            found once for the batch (finding it hashes the installation's files); None: found here.
    """
    record = new_record(spec)
    folder = Path(run_dir)
    (folder / "results").mkdir(exist_ok=True)
    (folder / "logs").mkdir(exist_ok=True)
    stale = folder / spec.results
    if stale.is_symlink() or not stale.is_dir():  # a folder there is refused below, never deleted
        stale.unlink(missing_ok=True)  # a stale file from a killed attempt must not count
    if events is not None:
        events.put(("start", spec.index, None))
    t0 = time.monotonic()
    try:
        if stale.is_dir():
            raise ResultsError(f"{stale}: a folder, where the episode's results file goes",
                               "move it away, then run the batch again with --resume")
        registry = get_registry()

        driven: list[tuple[int, list[float]]] = []

        def on_step(info: dict) -> None:
            pose = info.get("pose")
            if pose is not None:
                driven.append((int(info.get("scene_number", 0)), [round(float(v), 6) for v in pose]))
            if events is not None:
                events.put(("step", spec.index, {"step": info["step"], "result": info["result"]}))

        def on_stage(event: stages.StageEvent) -> None:  # what the backend is doing before the first step
            if events is not None:
                events.put(("stage", spec.index, {"stage": "" if event.kind == "end" else event.text()}))

        options = spec.options if spec.noise == "none" else {**spec.options, "noise": spec.noise}
        timed_out = read_stdin = False
        # the log first: an episode whose backend cannot start has its reason there too (see below)
        with open(folder / spec.log, "w") as log, owned_tempdir("benchbot-episode-") as private:
            backend_socket = Path(private) / "backend.sock"  # the sandbox's way to the backend; marked as ours
            # only this episode's backend: episodes run together in one process build theirs one after another
            served = open_episode(registry, run, in_service=in_service, seed=spec.seed, options=options,
                                  world_seed=spec.world_seed, on_step=on_step, on_stage=on_stage,
                                  unix_socket=backend_socket if spec.sandbox in ("bwrap", "container") else None,
                                  recording=folder / spec.recording if spec.record else None, pool=pool,
                                  location=service_location)
            try:
                timed_out, read_stdin = _run_solution(spec, registry, folder, backend_socket, served.address,
                                                      log, record, tuple(hide))
                end = served.finish()
            finally:
                served.close()
        record.steps, record.collided, record.backend = end.steps, end.collided, end.backend
        record.node = dict(end.node)
        write_trajectory(folder / spec.trajectory, run, driven)
        if record.status == "resource_limit":  # past a limit of the sandbox: the reason is in record.error
            pass
        elif record.error:  # the sandbox refused what the solution left as its results
            record.status = "bad_results"
        elif timed_out:
            record.status = "timeout"
            record.error = f"stopped after the episode timeout of {spec.timeout_s:g} s"
        elif record.returncode != 0:
            record.status = "failed"
        elif not (folder / spec.results).is_file():
            record.status = "no_results"
        else:  # read (once) by the batch process as the record arrives: benchbot.batch.episode_results
            record.status = "ok"
        if read_stdin and record.status != "ok" and not record.error:
            record.error = READ_STDIN_ERROR
    except BenchbotError as exc:
        record.status, record.error = "error", exc.message
        _log_error(folder / spec.log, exc.message)
    record.wall_s = round(time.monotonic() - t0, 3)
    if events is not None:
        events.put(("end", spec.index, None))
    return record
