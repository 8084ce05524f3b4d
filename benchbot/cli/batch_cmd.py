"""``benchbot batch``: run a solution over many environments (and robots, and repetitions), score it, print it."""

from __future__ import annotations

import shutil
import threading
import time
from pathlib import Path
from typing import Optional

import typer
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from benchbot.batch.plan import EpisodeRecord, expected_steps
from benchbot.cli.common import backend_options, err, handle_errors, is_tty, out, print_json, registry
from benchbot.cli.eval_cmd import print_scores
from benchbot.cli.options import at_most, check_count
from benchbot.cli.run_cmd import DEFAULT_ROBOT, DEFAULT_TASK
from benchbot.core.errors import ExitCode, UsageError
from benchbot.core.limits import MAX_REPEAT, MAX_RETRIES, MAX_SEED, MAX_WORKERS
from benchbot.solutions.sandbox import not_verifiable_note


def _joined(values: list[str] | None) -> str | None:
    """A repeated comma-list option (``--envs a,b --envs c``) as one comma list (``a,b,c``), or None if not given."""
    return ",".join(values) if values else None


def register(app: typer.Typer) -> None:
    @app.command("batch")
    @handle_errors
    def batch(
        envs: Optional[list[str]] = typer.Option(None, "--envs", "--env", "-e", help="Comma list of environments, e.g. miniroom:1,house:1 (scene pairs: miniroom:1:2); repeat it to add more (--envs miniroom:1 --envs house:1)."),
        envs_batch: Optional[str] = typer.Option(None, "--envs-batch", help="A named batch of environments (`benchbot list batches`)."),
        task: str = typer.Option(DEFAULT_TASK, "--task", "-t", help="Task name (`benchbot list tasks`)."),
        robot: str = typer.Option(DEFAULT_ROBOT, "--robot", "-r", help="Robot name (`benchbot list robots`)."),
        robots: Optional[list[str]] = typer.Option(None, "--robots", help="Comma list of robots to sweep (instead of --robot); repeat it to add more."),
        native: Optional[str] = typer.Option(None, "--native", "-n", help="A command to run as the solution, e.g. 'python my.py'."),
        example: Optional[str] = typer.Option(None, "--example", "-E", help="An installed example as the solution (`benchbot list examples`)."),
        containerised: Optional[Path] = typer.Option(None, "--containerised", "-c", help="Build and run DIR/Dockerfile (or a Dockerfile) with Docker or Podman as the solution."),
        example_containerised: bool = typer.Option(False, "--example-containerised", help="Run the --example in a container."),
        args: str = typer.Option("", "--args", "-a", help="Arguments appended to the solution's command."),
        repeat: int = typer.Option(1, "--repeat", help=f"Run every (robot, environment) this many times, each with its own recorded seed ({at_most(MAX_REPEAT, 1)})."),
        workers: int = typer.Option(1, "--workers", "-w", help=f"Episodes run in parallel (each in its own process with its own backend and cores/N simulator threads; the longest episodes start first; {at_most(MAX_WORKERS, 1)})."),
        retries: int = typer.Option(0, "--retries", help=f"Re-run failed episodes up to this many times ({at_most(MAX_RETRIES)})."),
        executor: str = typer.Option("local", "--executor", help="local (this machine; with --workers N, N processes each with its own simulator), batched (this process: --workers episodes at a time on ONE simulator, kernels compiled once, episodes of one environment sharing its scene: the least GPU memory; on a machine with a core per worker, local is faster) or ray (Ray tasks, each reserving a CPU on its node; results come back through Ray; docs/cluster.md)."),
        ray_address: Optional[str] = typer.Option(None, "--ray-address", help="With --executor ray: the cluster's head HOST:PORT, ray://HOST:10001 (Ray Client) or local; default as ray.init: $RAY_ADDRESS, else the cluster `ray start` began on this machine, else a local Ray with --workers CPUs."),
        resume: Optional[Path] = typer.Option(None, "--resume", help="Resume the batch in this run directory: only unfinished episodes run."),
        prefix: str = typer.Option("batch", "--prefix", "-p", help="Name prefix of the run directory (and of the --zip archive)."),
        zip_results: bool = typer.Option(False, "--zip", "-z", help="Also write PREFIX.zip of the results files, as the original did."),
        output_dir: Path = typer.Option(Path("runs"), "--output-dir", help="Where run directories are made."),
        evaluate_with: str = typer.Option("auto", "--evaluate-with", help="Evaluation method; 'auto' picks one when every environment has a ground truth."),
        no_evaluate: bool = typer.Option(False, "--no-evaluate", help="Do not evaluate."),
        seed: int = typer.Option(0, "--seed", help=f"Seed of the first episode (episode i uses seed + i; {at_most(MAX_SEED)})."),
        arch: str = typer.Option("auto", "--arch", help="Simulator device: auto (a GPU when an NVIDIA device is present, else the CPU), cpu or gpu."),
        camera_size: Optional[str] = typer.Option(None, "--camera-size", help="Camera resolution WIDTHxHEIGHT (default: the robot's, 640x480 for carter)."),
        timeout: Optional[float] = typer.Option(None, "--episode-timeout", help="Stop a solution (its whole process group) after this many seconds; default from the task (passive: 300 s + 10 s per trajectory pose, active: 3600 s per scene); 0: none."),
        as_json: bool = typer.Option(False, "--json", help="Print the outcome as JSON on stdout."),
        record: bool = typer.Option(False, "--record", help="Record every episode as MCAP (ROS 2 messages) in RUN_DIR/recordings/NNN_<env>.mcap."),
        no_tui: bool = typer.Option(False, "--no-tui", help="Progress bars instead of the live episode table (the default when stderr is not a terminal)."),
        noise: Optional[str] = typer.Option(None, "--noise", help="Sensor and motion noise preset: none (default), low, realistic or high (docs/noise.md); recorded in the manifest."),
        sweep: Optional[str] = typer.Option(None, "--sweep", help="Run the batch at every level of one factor and plot the score against it: noise=none,low,realistic,high, robot=A,B, variant=1,2,3 or lighting=day,night (docs/noise.md)."),
        no_sandbox: bool = typer.Option(False, "--no-sandbox", help="Run native solutions as plain processes of your user instead of in the bubblewrap sandbox (for development: they could read the ground truth, so the scores are marked not verifiable; docs/security.md)."),
        no_service: bool = typer.Option(False, "--no-service", help="Build the simulator in this process instead of the resident simulator service (which keeps Taichi, its kernels and scenes loaded between commands; BENCHBOT_SERVICE=off does the same; docs/service.md)."),
        ground_truths: Optional[str] = typer.Option(None, "--ground-truths", help="Score against this set of ground truths (`benchbot list ground_truths`: isaac_develop, the default, or bear_develop, what the original's default install used); the manifest and the scores say which set each score used."),
    ) -> None:
        """Run a solution on every environment, each episode with its own backend on 127.0.0.1, then score it.

        Results, scores, logs, the resolved configuration and a manifest (versions, seeds, timings) are kept in a run
        directory under --output-dir, named on stderr; a batch stopped at any moment continues with --resume.
        Exit status 0 when every episode produced results.
        """
        from benchbot.batch.request import BatchRequest, new_batch, resume_batch

        for flag, value, limit, least in (("--repeat", repeat, MAX_REPEAT, 1), ("--workers", workers, MAX_WORKERS, 1),
                                          ("--retries", retries, MAX_RETRIES, 0), ("--seed", seed, MAX_SEED, 0)):
            check_count(flag, value, limit, least)  # first: nothing is planned for an absurd count
        reg = registry()
        _check_executor(executor, ray_address)
        _check_service_settings(no_service)  # before anything is made: a bad BENCHBOT_SERVICE is one line
        if resume is not None:
            batch = resume_batch(reg, resume, no_sandbox)
            done = sum(r.status == "ok" for r in batch.records)
            cluster = _connect_ray(executor, ray_address, workers, batch.run_dir)
            err.print(f"resuming {batch.run_dir}: {done} of {len(batch.specs)} episodes already done")
        else:
            batch = new_batch(reg, BatchRequest(
                task=task, robot=robot, robots=_joined(robots), envs=_joined(envs), envs_batch=envs_batch,
                native=native, example=example, containerised=containerised,
                example_containerised=example_containerised,
                args=args, repeat=repeat, seed=seed, timeout_s=timeout, record=record, noise=noise, sweep=sweep,
                backend_options=lambda: backend_options(arch, camera_size), no_sandbox=no_sandbox, workers=workers,
                prefix=prefix, output_dir=output_dir, zip_results=zip_results,
                evaluate_with=None if no_evaluate else evaluate_with, ground_truths=ground_truths,
            ), say=lambda line: err.print(line, highlight=False))
            cluster = _connect_ray(executor, ray_address, workers, batch.run_dir, new=True)
            err.print(f"run directory: {batch.run_dir}")
        if not_verifiable_note(batch.specs[0].sandbox):
            err.print(f"[yellow]warning:[/] {not_verifiable_note(batch.specs[0].sandbox)}", highlight=False)
        service = _start_service(no_service, executor, workers, batch.specs)
        outcome = _run_shown(reg, batch, no_tui=no_tui, workers=workers, retries=retries, executor=executor,
                             ray_address=ray_address, ray_cluster=cluster, service=service)
        print_outcome(outcome, batch.run_dir, as_json)
        if not outcome.ok:
            raise typer.Exit(int(ExitCode.FAILURE))


def _check_executor(executor: str, ray_address: str | None) -> None:
    """Check ``--executor`` and ``--ray-address``.

    Raises:
        UsageError: an unknown executor, or ``--ray-address`` without ``--executor ray``.
    """
    from benchbot.batch.executors import EXECUTORS

    if executor not in EXECUTORS:
        raise UsageError(f"--executor '{executor}' is not an executor", f"use one of {', '.join(EXECUTORS)}")
    if ray_address is not None and executor != "ray":
        raise UsageError("--ray-address is for --executor ray", "add --executor ray, or leave --ray-address out")


def episode_labels(specs: list) -> dict[int, str]:
    """``{index: label}`` of a batch's episodes as its lines and progress rows name them: ``[2/4] house:1``, with the
    robot, noise preset and repetition where the batch varies them (``[3/8] house:1 jackal noise=high r1``)."""
    total = len(specs)
    return {s.index: f"[{s.index + 1}/{total}] {s.env}" + (f" {s.robot}" if len({x.robot for x in specs}) > 1 else "")
            + (f" noise={s.noise}" if len({x.noise for x in specs}) > 1 else "")
            + (f" r{s.repeat}" if s.repeat else "") for s in specs}


def _run_shown(reg, batch, *, no_tui: bool, **run):
    """Run ``batch`` (:func:`benchbot.batch.runner.run_batch` with ``run``) as stderr can show it: the live episode
    table on a terminal (:func:`_run_with_tui`; progress bars with ``no_tui``), a line per finished episode and what
    the running ones are doing in a log (:class:`benchbot.batch.narration.Narrator`); then the closing line
    (:func:`batch_summary`). Ctrl-C stops it within the bound of :class:`benchbot.batch.stopping.StopDeadline`
    (:func:`stopped_by_user`).

    Raises:
        typer.Exit: interrupted (``ExitCode.INTERRUPTED``).
    """
    from benchbot.batch.narration import Narrator
    from benchbot.batch.runner import run_batch
    from benchbot.batch.stopping import StopDeadline, interrupts_arm

    label = episode_labels(batch.specs)
    runs = {s.index: batch.runs.get((s.robot, s.env)) for s in batch.specs}  # None: no longer resolves (--resume)
    expected = {i: expected_steps(run.task, run.environments) if run else None for i, run in runs.items()}
    # what an episode is doing, in plain lines, where nothing live shows it (a log; the view closed with q)
    deadline = StopDeadline(batch.run_dir, say=lambda line: err.print(line, highlight=False, markup=False))
    narrator = Narrator(lambda line: err.print(line, highlight=False, markup=False), label, expected,
                        speaking=not is_tty(), muted=lambda: deadline.armed_at is not None)

    def print_line(record: EpisodeRecord) -> None:  # one line per finished episode, as it finishes
        err.print(episode_line(record, label[record.index]), highlight=False)

    def on_log_event(kind: str, index: int, info: dict | None) -> None:
        narrator.event(kind, index, info)
        if kind == "lost":  # a Ray episode lost with its node
            err.print(lost_line(info or {}, label[index]), highlight=False)

    started = time.monotonic()
    try:
        with interrupts_arm(deadline), narrator:  # Ctrl-C: the command is gone within STOP_BOUND_S, by design
            if is_tty() and not no_tui:
                outcome = _run_with_tui(reg, batch, print_line, deadline, narrator, on_event=on_log_event, **run)
            elif not is_tty():  # a log (CI, SLURM, `> file`): lines, never a live display
                outcome = run_batch(reg, batch, on_record=print_line, on_event=on_log_event, **run)
            else:
                outcome = _run_with_progress(reg, batch, label, expected, **run)
    except KeyboardInterrupt:
        deadline.arm(signal_sent=True)
        stopped_by_user(batch.run_dir, deadline)
    err.print(batch_summary(outcome, time.monotonic() - started), highlight=False)
    return outcome


def _run_with_progress(reg, batch, label: dict[int, str], expected: dict[int, int | None], **run):
    """Run ``batch`` (:func:`benchbot.batch.runner.run_batch` with ``run``) under rich progress bars on stderr: a row
    per episode as it starts (``label``), its steps out of ``expected``, the backend's stage before the first step,
    and its status when it ends."""
    from benchbot.batch.runner import run_batch

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("steps"),
                  TimeElapsedColumn(), console=err) as progress:
        rows: dict[int, int] = {}

        def on_event(kind: str, index: int, info: dict | None) -> None:
            if kind == "start":
                rows[index] = progress.add_task(label[index], total=expected[index])
            elif kind == "stage" and index in rows:  # what the backend does before the first step
                stage = f" [dim]{info['stage']} …[/]" if info.get("stage") else ""
                progress.update(rows[index], description=label[index] + stage)
            elif kind == "step" and index in rows:
                progress.update(rows[index], completed=info["step"])
            elif kind == "lost" and index in rows:  # its re-run, if any, gets a row of its own
                progress.update(rows[index], description=f"{label[index]} [yellow]lost[/]")
                err.print(lost_line(info or {}, label[index]), highlight=False)

        def on_record(record: EpisodeRecord) -> None:
            colour = "green" if record.status == "ok" else "red"
            if record.index in rows:
                progress.update(rows[record.index],
                                description=f"{label[record.index]} [{colour}]{record.status}[/]")

        return run_batch(reg, batch, on_event=on_event, on_record=on_record, **run)


def print_outcome(outcome, run_dir: Path, as_json: bool) -> None:
    """What a finished batch says: each episode that is not ``ok`` and why (with its log), an evaluation that failed
    (stderr); the outcome as JSON (``as_json``) or the scores and a sweep's robustness summary (stdout); where the
    results are, or why nothing was scored (stderr)."""
    for record in outcome.episodes:
        if record.status != "ok":
            why = record.error or f"exit status {record.returncode}"
            err.print(f"[red]{record.env}: {record.status}[/] ({why}); see {run_dir / record.log}", highlight=False)
    if outcome.evaluation_error:
        err.print(f"[red]evaluation failed:[/] {outcome.evaluation_error}", highlight=False)
    if as_json:
        print_json({
            "run_dir": str(run_dir), "episodes": [vars(e) for e in outcome.episodes],
            "scores": outcome.evaluation.to_json() if outcome.evaluation else None,
            "robustness": outcome.robustness,
        }, default=lambda o: o.tolist())
    elif outcome.evaluation is not None:
        print_scores(outcome.evaluation)
        if outcome.robustness is not None:
            print_robustness(outcome.robustness, run_dir)
    if outcome.evaluation is not None:
        err.print(f"results and scores in {run_dir}")
    else:
        why = ("evaluation failed" if outcome.evaluation_error
               else "no episode produced results" if not any(e.status == "ok" for e in outcome.episodes)
               else "not evaluated: --no-evaluate, or an environment without ground truth")
        err.print(f"nothing was scored ({why}); results, logs and the manifest are in {run_dir}")

def stopped_by_user(run_dir: Path, deadline=None) -> None:
    """Ctrl-C ended the batch in ``run_dir``: its ``progress.json`` says so for the episodes it left running
    (:func:`benchbot.batch.progress.mark_interrupted`), one line says how to finish it, and the command exits with
    ``ExitCode.INTERRUPTED`` (within ``deadline``'s bound, :class:`benchbot.batch.stopping.StopDeadline`).

    Raises:
        typer.Exit: always.
    """
    from benchbot.batch.progress import mark_interrupted

    if deadline is not None:
        deadline.finish()  # nothing the batch started outlives it
    try:
        mark_interrupted(run_dir)
    except OSError:  # a marker only: the manifest and the episodes' records say what ran
        pass
    from benchbot.batch.stopping import resume_line

    err.print(resume_line(run_dir), highlight=False, markup=False)
    if deadline is not None:
        deadline.said_resume()
    raise typer.Exit(int(ExitCode.INTERRUPTED))


def print_robustness(summary: dict, run_dir: Path) -> None:
    """A sweep's robustness summary (:func:`benchbot.batch.sweep.robustness`) on stdout, as ``benchbot report``
    prints its numbers: a table of the levels (mean and interval, or why there is none), then one line per level
    compared with the baseline (the mean difference, then its interval, d_z, p-values and their Holm adjustment,
    rank-biserial r, or why there is no test); 4 significant digits. Where its plot is goes to stderr."""
    from rich.table import Table

    from benchbot.batch.figures import comparison_text, fmt, interval_text

    pct = round(summary["policy"]["confidence"] * 100)
    table = Table(summary["factor"], "environments", f"mean {summary['score']}", f"{pct} % CI", "episodes",
                  "mean", f"{pct} % CI (episodes)", title=f"{summary['score']} vs {summary['factor']}",
                  title_justify="left")
    for lv in summary["levels"]:
        ep = lv.get("episodes") or {}
        table.add_row(lv["level"], str(lv["n"]), fmt(lv["value"]), interval_text(lv), str(ep.get("n", "")),
                      fmt(ep.get("value")), interval_text(ep) if ep else "")
    out.print(table)
    for c in summary["differences"]:
        unpaired = f", {c['unpaired']} episodes unpaired" if c["unpaired"] else ""
        out.print(f"{c['level']} − {c['baseline']} ({summary['score']}{unpaired}): "
                  f"{comparison_text(c)}", highlight=False, markup=False)
    if summary.get("plots"):
        err.print(f"robustness plot: {', '.join(str(run_dir / p) for p in summary['plots'])}")
    elif summary.get("plot_error"):
        err.print(f"no robustness plot: {summary['plot_error']}")


def _check_service_settings(no_service: bool) -> None:
    """Check ``BENCHBOT_SERVICE`` (and, where the service is wanted, ``BENCHBOT_SERVICE_IDLE_S``) before the batch is
    planned or its run directory made.

    Raises:
        UsageError: either has a value it cannot take (the message names the variable and its values)."""
    from benchbot.service import client

    if client.wanted(no_service):
        client.idle_seconds()


def _start_service(no_service: bool, executor: str, workers: int, specs: list):
    """The simulator service's location (:class:`benchbot.service.location.ServiceLocation`, for
    :func:`benchbot.batch.runner.run_batch`) when the batch's episodes get their backends from it
    (:mod:`benchbot.service`), else False: with the
    local executor (one worker: the service's backend thread; several, or a GPU: warm worker processes of its pool),
    episodes not recorded, unless ``--no-service`` or ``BENCHBOT_SERVICE=off``. The
    service is started here (saying so once), before the progress display; one of another installation that is busy
    leaves the batch in this process (said in one line)."""
    from benchbot.service import client

    if executor != "local" or any(s.record for s in specs) or not client.wanted(no_service):
        return False
    from benchbot.service.location import locate

    location = locate()  # found once per command: it hashes the installation's files
    try:
        client.start(location, say=lambda line: err.print(line, highlight=False)).close()
    except client.ServiceBusy as exc:
        err.print(f"{exc.message}: {exc.hint}", highlight=False)
        return False
    return location


def _connect_ray(executor: str, address: str | None, workers: int, run_dir: Path, new: bool = False):
    """For ``--executor ray``: connect to Ray now (:func:`benchbot.batch.executors.connect_ray`), in the main
    thread and before any live table (``ray.init`` needs the terminal's real stderr, which the table takes over),
    and say where the episodes will run; None for ``local``. ``new``: ``run_dir`` was made for this batch, and is
    removed when this fails (nothing ran: no empty run directory is left behind).

    Raises:
        UsageError: Ray missing, or its cluster unreachable (one line, with the fix).
    """
    if executor != "ray":
        return None
    from benchbot.batch.executors import RAY_LOG, connect_ray

    try:
        cluster = connect_ray(address, workers=workers, log=run_dir / RAY_LOG)
        err.print(cluster.describe(), highlight=False)
        if workers > 1 and not cluster.started_here:
            err.print("(--workers is not used on an existing cluster: its free CPUs decide how many episodes run "
                      "at once)", highlight=False)
    except BaseException:
        if new:
            shutil.rmtree(run_dir, ignore_errors=True)
        raise
    return cluster


def lost_line(info: dict, label: str) -> str:
    """One line (rich markup) for an episode Ray lost with its node or worker process: ``[2/4] house:1  lost: its
    node died on node 10.0.0.7 (3f2a1b2c); running it again on another node``."""
    from benchbot.batch.executors import node_name

    node = info.get("node") or {}
    where = f" on node {node_name(node)}" if node else ""
    then = "running it again on another node" if info.get("again") else "no retries left"
    return f"{label}  [yellow]lost[/]: {escape(str(info.get('error', '')))}{where}; {then}"


def episode_line(record: EpisodeRecord, label: str) -> str:
    """One line (rich markup) for a finished episode: ``[2/4] house:1  ok  269 steps  1:12``."""
    from benchbot.batch.narration import format_seconds

    colour = "green" if record.status == "ok" else "red"
    line = f"{label}  [{colour}]{record.status}[/]  {record.steps} step{'s' if record.steps != 1 else ''}"
    line += f"  {format_seconds(record.wall_s)}"
    if record.status != "ok":
        line += f"  ({record.error or f'exit status {record.returncode}'})"
    return line


def batch_summary(outcome, elapsed_s: float) -> str:
    """The closing line of a batch: episode counts by status, the time taken, the combined primary score of the
    evaluation method when scored (its name as the method declares it), and the standing of its worlds
    (:func:`benchbot.batch.signing.worlds_standing`: ``held-out worlds``, or ``development — ground truth public``
    when any environment is a public world, BEAR or procedural train/val)."""
    from benchbot.batch.signing import HELD_OUT, worlds_standing
    from benchbot.batch.narration import format_seconds

    counts: dict[str, int] = {}
    for record in outcome.episodes:
        counts[record.status] = counts.get(record.status, 0) + 1
    n = len(outcome.episodes)
    text = f"{n} episode{'s' if n != 1 else ''}: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
    text += f" in {format_seconds(elapsed_s)}"
    evaluation = outcome.evaluation
    combined = evaluation.combined if evaluation is not None else None
    primary = evaluation.score_set.primary.name if evaluation is not None and evaluation.score_set else None
    value = (combined.get("scores", combined) if isinstance(combined, dict) else {}).get(primary) if primary else None
    if isinstance(value, (int, float)):
        text += f"; {primary} {value:.4f}"
    envs = [str(r.env) for r in outcome.episodes if getattr(r, "env", None)]
    if envs:
        standing = worlds_standing(envs)
        text += "; held-out worlds" if standing == HELD_OUT else f"; {standing}"
    return text


def _run_with_tui(reg, batch, on_record, deadline, narrator, **kwargs):
    """Run the batch (``run_batch(reg, batch, **kwargs)``) in a background thread and the episode table
    (:class:`benchbot.tui.batch_app.BatchApp`) in the foreground; the table closes itself when the batch ends.

    ``q`` closes the table and the batch goes on, printing a line per finished episode (``on_record``) and what the
    running ones are doing (``narrator``, :class:`benchbot.batch.narration.Narrator`, which ``kwargs['on_event']``
    feeds); Ctrl-C in
    the table stops the batch as Ctrl-C does without it: ``deadline`` is armed
    (:class:`benchbot.batch.stopping.StopDeadline`: the command is gone within its bound, whatever the thread is
    doing), KeyboardInterrupt is raised in the thread (:func:`stop_batch_thread`) and here.
    """
    from benchbot.batch.runner import run_batch
    from benchbot.tui.batch_app import BatchApp

    result: dict = {}
    view_open = threading.Event()
    view_open.set()

    def record(rec: EpisodeRecord) -> None:
        if not view_open.is_set():
            on_record(rec)

    def work() -> None:
        try:
            result["outcome"] = run_batch(reg, batch, on_record=record, **kwargs)
        except BaseException as exc:  # re-raised in the main thread
            result["error"] = exc

    thread = threading.Thread(target=work, name="benchbot-batch", daemon=True)
    thread.start()
    run_dir = batch.run_dir
    app = BatchApp(run_dir, is_done=lambda: not thread.is_alive())
    # the view reads Ctrl-C as a key (no process got SIGINT): the bound starts at the key press, quietly while the
    # view still owns the screen
    app.on_interrupt = lambda: deadline.arm(signal_sent=False, quiet=True)
    deadline.view_open = True
    try:
        app.run()
    finally:
        deadline.view_open = False
    view_open.clear()
    try:
        if app.interrupted:
            deadline.arm(signal_sent=False)
            deadline.announce()
            raise KeyboardInterrupt
        if thread.is_alive():
            err.print("the table was closed; the batch goes on (Ctrl-C stops it)", highlight=False)
            err.print(f"watch it again: benchbot tui {run_dir}", highlight=False, markup=False)
            narrator.speak()
            while thread.is_alive():
                thread.join(0.2)
    except KeyboardInterrupt:
        deadline.arm(signal_sent=True)
        stop_batch_thread(thread, deadline)
        raise
    if "error" in result:
        raise result["error"]
    return result["outcome"]


def stop_batch_thread(thread: threading.Thread, deadline) -> None:
    """Stop a batch running in ``thread`` as Ctrl-C stops one in the main thread: raise KeyboardInterrupt in it
    (its episode's clean-up runs: the solution's group is stopped, the server stopped, the backend closed) and wait
    for it until ``deadline``'s bound is near (after which the deadline ends the process anyway)."""
    import ctypes

    if not thread.is_alive() or thread.ident is None:
        return
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread.ident), ctypes.py_object(KeyboardInterrupt))
    thread.join(deadline.left_s())
