"""``benchbot submit``: run a solution against a running backend (docs/cli.md)."""

from __future__ import annotations

import datetime as _dt
import http.client
import json
import tempfile
from pathlib import Path
from typing import Optional

import typer

from benchbot.core import settings
from benchbot.api.benchbot import TOKEN_HEADER, ConnectTimeout, ReadTimeout, request_once, tls_context
from benchbot.cli.common import err, handle_errors, registry, writing
from benchbot.cli.eval_cmd import print_scores
from benchbot.cli.options import native_words, refused
from benchbot.core import atomic
from benchbot.core.errors import BackendError, ExitCode, UsageError
from benchbot.core.evaluation import evaluate
from benchbot.solutions.result_files import ORIGINAL_RESULT_LOCATION, ResultWatch, submission_result_location
from benchbot.solutions.sandbox import INSIDE_OUTPUTS, check_available, check_sandboxable, not_verifiable_note
from benchbot.solutions.solution_lease import supervised_solution
from benchbot.solutions.container_engine import container_engine, container_files
from benchbot.solutions.submission import example_submission, make_submission_archive, native_submission, run_submission

DEFAULT_ADDRESS = "http://127.0.0.1:10000/"


def _token_header() -> dict[str, str]:
    token = settings.get("BENCHBOT_TOKEN")
    return {TOKEN_HEADER: token} if token else {}


def _run_info(address: str) -> dict:
    """Task, robot, environments and seed of the backend, or ``{}`` when none answers."""
    try:
        status, body = request_once(address, "GET", "robot/run_info", headers=_token_header())
        info = json.loads(body) if status == 200 else {}
    except (OSError, http.client.HTTPException, ValueError):
        return {}
    return info if isinstance(info, dict) else {}


def env_seconds(name: str) -> float:
    """The setting ``name`` (:mod:`benchbot.core.settings`: its variable, else its default) as seconds.

    Raises:
        UsageError: the variable is not a positive number (naming it).
    """
    raw = settings.get(name) or ""
    try:
        value = float(raw)
    except ValueError:
        value = -1.0
    if not 0 < value < float("inf"):
        raise UsageError(f"${name}={raw!r} is not a positive number of seconds",
                         f"unset it for the default ({settings.default(name)} s)")
    return value


def check_backend(address: str) -> None:
    """Make sure a BenchBot backend answers ``GET /`` at ``address`` (sending ``$BENCHBOT_TOKEN`` when set), so that
    a submission never starts against nothing: nothing listening fails at once; a connection not accepted within
    ``$BENCHBOT_BACKEND_CHECK_TIMEOUT_S`` (1 s) fails then; a backend that accepted but is still starting is waited
    for (said on stderr) up to ``$BENCHBOT_BACKEND_START_WAIT_S`` (60 s).

    Raises:
        BackendError: nothing listens there, it did not answer in time, it wants a token, or it answered with an
            error status (one line naming the address, and the fix).
        UsageError: a bad ``$BENCHBOT_BACKEND_CHECK_TIMEOUT_S`` or ``$BENCHBOT_BACKEND_START_WAIT_S``, or an
            ``address`` whose port is not a number of 0-65535.
    """
    import urllib.parse

    try:
        urllib.parse.urlsplit(address).port
    except ValueError as exc:
        raise UsageError(f"backend address {address}: {exc}",
                         "give --address (or BENCHBOT_SUPERVISOR_ADDRESS) as http://HOST:PORT/, e.g. "
                         "http://127.0.0.1:10000/") from None
    timeout = env_seconds("BENCHBOT_BACKEND_CHECK_TIMEOUT_S")
    start_wait = env_seconds("BENCHBOT_BACKEND_START_WAIT_S")
    fix = "start one in another terminal: `benchbot run --env miniroom:1` (or give --address / " \
          "BENCHBOT_SUPERVISOR_ADDRESS of a running one)"

    def get(read_s: float) -> int:
        return request_once(address, "GET", "", headers=_token_header(), connect_timeout_s=timeout,
                            read_timeout_s=read_s)[0]

    try:
        try:
            status = get(timeout)
        except ReadTimeout:
            err.print(f"the backend at {address} accepted the connection but has not answered yet; waiting up to "
                      f"{start_wait:g} s for it to finish starting", highlight=False)
            try:
                status = get(start_wait)
            except ReadTimeout:
                raise BackendError(f"the backend at {address} accepted the connection but did not answer within "
                                   f"{timeout + start_wait:g} s", "is it stuck? restart `benchbot run`; "
                                   "$BENCHBOT_BACKEND_START_WAIT_S waits longer") from None
    except ConnectTimeout:
        raise BackendError(f"nothing at {address} accepted a connection within {timeout:g} s",
                           fix + "; $BENCHBOT_BACKEND_CHECK_TIMEOUT_S waits longer") from None
    except (OSError, http.client.HTTPException) as exc:
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        raise BackendError(f"no BenchBot backend answers at {address} ({reason})", fix) from None
    if status == 401:
        raise BackendError(f"the backend at {address} wants a token (HTTP 401)",
                           "export BENCHBOT_TOKEN=<the token `benchbot run` printed>")
    if status != 200:
        raise BackendError(f"{address} answered GET / with HTTP {status}: not a BenchBot backend?",
                           "give --address of the `benchbot run` backend")


def _run_sandboxed(reg, sub, address: str, location: Path, timeout: float | None) -> int:
    """Run ``sub`` in the sandbox (:func:`benchbot.solutions.sandbox.run_sandboxed`) against the backend at ``address``,
    reached through a Unix socket relayed to it (:class:`~benchbot.solutions.socket_relay.UnixToTcpRelay`); copy the
    results file it wrote to ``location`` (never through a link) and say where its other files are. Returns its
    exit status (-9 when it timed out).

    Raises:
        UsageError: no sandbox can be made here, or the command cannot be started.
    """
    import urllib.parse

    from benchbot.solutions.sandbox import inside_address, run_sandboxed
    from benchbot.solutions.socket_relay import UnixToTcpRelay

    parts = urllib.parse.urlsplit(address)
    port = parts.port or {"http": 80, "https": 443}.get(parts.scheme)
    outputs = Path(tempfile.mkdtemp(prefix="benchbot-submit-outputs-"))
    with UnixToTcpRelay(parts.hostname or "127.0.0.1", port) as relay:
        run = run_sandboxed(sub.argv, sub.cwd, registry=reg, backend_socket=relay.path,
                            address=inside_address(address)[0], outputs=outputs, result_name=location.name,
                            timeout_s=timeout, stdin="inherit")
    _hand_back(run.problem or run.limit, run.results, outputs, location)
    return -9 if run.outcome.timed_out else run.outcome.returncode


def _run_containerised(tool: str, dockerfile: Path, context: Path, address: str, location: Path, args: str,
                       timeout: float | None) -> int:
    """Build ``dockerfile`` and run its image (:func:`benchbot.solutions.containers.run_container`: no network, the
    sandbox's limits) against the backend at ``address``, reached through a Unix socket relayed to it; copy its
    results file to ``location`` and say where its other files are. Returns its exit status (-9 when it timed out).

    Raises:
        BenchbotError: the build failed, or the engine could not start the container.
    """
    import urllib.parse

    from benchbot.solutions.container_engine import build_image
    from benchbot.solutions.containers import run_container
    from benchbot.solutions.socket_relay import UnixToTcpRelay

    parts = urllib.parse.urlsplit(address)
    port = parts.port or {"http": 80, "https": 443}.get(parts.scheme)
    tag = build_image(tool, dockerfile, context)
    outputs = Path(tempfile.mkdtemp(prefix="benchbot-submit-outputs-"))
    with UnixToTcpRelay(parts.hostname or "127.0.0.1", port) as relay:
        run = run_container(tool, tag, backend_socket=relay.path, address=address, outputs=outputs,
                            result_name=location.name, args=args, token=settings.get("BENCHBOT_TOKEN"),
                            timeout_s=timeout, stdin="inherit")
    _hand_back(run.limit, run.results, outputs, location)
    return -9 if run.outcome.timed_out else run.outcome.returncode


def _hand_back(problem: str, results: Path | None, outputs: Path, location: Path) -> None:
    """After an isolated solution: say ``problem`` (a refused results file, a resource limit), copy its results file
    to ``location`` (never through a link), and say where its other files are (``outputs``, removed when empty)."""
    from benchbot.solutions.sandbox import read_results

    if problem:
        err.print(f"[red]{problem}[/]", highlight=False)
    if results is not None:
        atomic.write_bytes(location, read_results(results))
        results.unlink()
    if any(outputs.iterdir()):
        err.print(f"the solution's other files (it wrote them in {INSIDE_OUTPUTS}): {outputs}", highlight=False)
    else:
        outputs.rmdir()


def register(app: typer.Typer) -> None:
    @app.command("submit", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
    @handle_errors
    def submit(
        command: Optional[list[str]] = typer.Argument(None, callback=native_words, help="With --native CMD: more words of the command (--native python my.py runs python my.py)."),
        native: Optional[str] = typer.Option(None, "--native", "-n", help="Run CMD (and the words after it) on this machine, in this folder, e.g. --native python my.py."),
        containerised: Optional[Path] = typer.Option(None, "--containerised", "-c", help="Build and run DIR/Dockerfile (or a Dockerfile) with Docker or Podman; the build context is its folder."),
        submission: Optional[Path] = typer.Option(None, "--submission", "-s", help="Package DIR as a .tgz plus a manifest (--args: output path; default ../submission.tgz relative to DIR)."),
        example: Optional[str] = typer.Option(None, "--example", "-E", help="Run an installed example (`benchbot list examples`)."),
        example_containerised: bool = typer.Option(False, "--example-containerised", help="Run the example in a container."),
        args: str = typer.Option("", "--args", "-a", help="Arguments appended to the command (containers: the variable `args`; -s: output path)."),
        evaluate_with: Optional[str] = typer.Option(None, "--evaluate-with", help="Evaluate the results afterwards (e.g. omq; the original's -e, which is --env in every command now)."),
        results_location: Optional[Path] = typer.Option(None, "--results-location", help="Also copy the results here (the original's -r, which is --robot in every command now)."),
        address: str = typer.Option(settings.get("BENCHBOT_SUPERVISOR_ADDRESS"), "--address", help="The backend (`benchbot run`)."),
        scores: Path = typer.Option(Path("scores.json"), "--scores", "--output", "-o", help="Where --evaluate-with writes scores."),
        timeout: Optional[float] = typer.Option(None, "--timeout", min=1.0, help="Kill the submission (native, or the container once built) after this many seconds."),
        no_sandbox: bool = typer.Option(False, "--no-sandbox", help="Run a native solution or example as a plain process of your user instead of in the bubblewrap sandbox (for development: it could read the ground truth, so its scores are not verifiable; docs/security.md)."),
        _env: Optional[str] = typer.Option(None, "--env", "-e", hidden=True, help="Refused: benchbot run chooses the environment.", callback=refused("-e", "submit runs against the environment `benchbot run --env` chose; to evaluate, use --evaluate-with METHOD (the original's -e)")),
        _robot: Optional[str] = typer.Option(None, "--robot", "-r", hidden=True, help="Refused: benchbot run chooses the robot.", callback=refused("-r", "submit runs against the robot `benchbot run --robot` chose; to copy the results, use --results-location FILE (the original's -r)")),
    ) -> None:
        """Run a solution against the backend started by `benchbot run`.

        Examples: `benchbot submit --native python my_solution.py`, `benchbot submit --example hello_passive --evaluate-with omq`,
        `benchbot submit --containerised my_dir/`, `benchbot submit --submission my_dir/`.
        """
        reg = registry()
        modes = [m for m, on in (("--native", native), ("--containerised", containerised is not None),
                                 ("--submission", submission is not None)) if on]
        if example and modes:
            raise UsageError(f"give either --example or {modes[0]}, not both", "e.g. --example hello_passive --example-containerised")
        if example_containerised and not example:
            raise UsageError("--example-containerised needs --example NAME", "e.g. --example hello_passive --example-containerised")
        if len(modes) > 1:
            hint = "one of --native, --containerised, --submission"
            if native is not None:  # `--native python -c CODE`: the solution's own flags were read as benchbot's
                hint += "; quote a command whose words start with -, e.g. --native 'python -c \"...\"'"
            raise UsageError(f"give one mode, not {' and '.join(modes)}", hint)
        if not modes and not example:
            raise UsageError("give exactly one of --native COMMAND..., --containerised DIR, --submission DIR or --example NAME", "e.g. --native python my.py")
        if command and not native:
            raise UsageError(f"unexpected arguments: {' '.join(command)}", "use --args to pass arguments")
        if submission is not None and (evaluate_with or results_location):
            raise UsageError("--submission only packages: it cannot be combined with --evaluate-with/--results-location", "submit natively to evaluate")
        if evaluate_with:
            reg.get("evaluators", evaluate_with)
        try:
            tls_context(address)  # a bad BENCHBOT_CA_FILE is said here, not in the solution's traceback
        except ValueError as exc:
            raise UsageError(str(exc), "give a PEM file of the authorities that signed the backend's certificate") \
                from None

        if submission is not None:
            output = Path(args) if args else submission / ".." / "submission.tgz"
            info = _run_info(address)
            archive, manifest = make_submission_archive(submission, output, manifest={
                "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                "task": info.get("task"), "robot": info.get("robot"), "environments": info.get("environments"),
                "seeds": [info["seed"]] if "seed" in info else [],
            })
            err.print(f"submission archive {archive}; manifest {manifest}")
            return

        # the submission first (its files, the container engine), then the backend: each fails in one line
        in_container = containerised is not None or example_containerised
        sandboxed = not in_container and not no_sandbox
        if in_container:
            dockerfile, context = container_files(reg, path=containerised, example=example if example_containerised else None)
            engine = container_engine()
        else:
            sub = example_submission(reg, example, args) if example else native_submission(command or [], args)
        if sandboxed:
            check_sandboxable(sub, reg)
            check_available()  # before the backend is asked: one line when bubblewrap is missing
        elif not in_container:
            err.print(f"[yellow]warning:[/] {not_verifiable_note('none')}", highlight=False)
        check_backend(address)
        location = submission_result_location()
        with writing(location, "BENCHBOT_RESULT_LOCATION"):
            location.parent.mkdir(parents=True, exist_ok=True)
        # the episode must be free; the solution's client gets an id of ours, whose hold ends when the solution does
        with supervised_solution(address):
            if in_container:
                err.print(f"building and running {dockerfile} with {engine} against {address} (no network but "
                          "the backend)", highlight=False)
                watch = ResultWatch(location)  # the container's own results file, copied to location
                code = _run_containerised(engine, dockerfile, context, address, location, args, timeout)
            elif sandboxed:
                err.print(f"running {sub.label} against {address} in the sandbox (bubblewrap: it sees no ground "
                          "truth)")
                watch = ResultWatch(location)  # the sandbox's own results file, copied to location
                code = _run_sandboxed(reg, sub, address, location, timeout)
            else:
                err.print(f"running {sub.label} against {address}")
                watch = ResultWatch(location, fallback=ORIGINAL_RESULT_LOCATION)
                outcome = run_submission(sub, address=address, result_location=location, timeout_s=timeout,
                                         stdin="inherit")
                code = -9 if outcome.timed_out else outcome.returncode
        result = watch.found()
        if result == location:
            err.print(f"results saved to {result}")
        elif result is not None:
            err.print(f"results saved to {result}, written by this submission in place of "
                      f"BENCHBOT_RESULT_LOCATION={location} (an original benchbot_api client always writes "
                      f"{ORIGINAL_RESULT_LOCATION}); that file is the one used", highlight=False)
        if code != 0:
            err.print(f"[red]the submission exited with status {code}[/]")
            raise typer.Exit(code if 0 < code < 256 else int(ExitCode.FAILURE))
        if result is None:
            older = " (the file there is older than this submission: not used)" if watch.stale() else ""
            if not (evaluate_with or results_location):
                err.print(f"[yellow]warning:[/] the submission saved no results at {location}{older}")
                return
            err.print(f"[yellow]warning:[/] the submission saved no results at {location}{older}; using {{}}")
        with tempfile.TemporaryDirectory(prefix="benchbot-submit-") as tmp:
            if result is None:
                result = Path(tmp) / "empty_result.json"
                atomic.write_text(result, "{}")
            if results_location is not None:
                with writing(results_location, "--results-location"):
                    atomic.write_text(results_location, result.read_text())
                err.print(f"results copied to {results_location}")
            if evaluate_with:
                evaluation = evaluate([result], evaluate_with, reg)
                with writing(scores, "--scores"):
                    atomic.write_json(scores, evaluation.to_json())
                print_scores(evaluation)
                err.print(f"scores written to {scores} (from {result})")
