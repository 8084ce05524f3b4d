"""A batch episode's containerised solution (``benchbot batch --containerised``): its image built, then run with no
network but the episode's backend and the sandbox's resource limits (:mod:`benchbot.solutions.containers`)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import IO

from benchbot.batch.plan import EpisodeRecord, EpisodeSpec
from benchbot.solutions.container_engine import build_image
from benchbot.solutions.containers import run_container

#: The backend's address inside the container (its relay listens there; ``benchbot_supervisor:10000`` too).
INSIDE_ADDRESS = "http://127.0.0.1:10000/"


def run_container_episode(spec: EpisodeSpec, folder: Path, backend_socket: Path, log: IO,
                          record: EpisodeRecord) -> tuple[bool, bool]:
    """Build ``spec.container``'s image (``{engine, dockerfile, context, args}``; the engine's cache makes every
    build after the first quick) and run it against the backend serving the Unix socket ``backend_socket``. Its
    outputs folder comes back to ``spec.outputs`` (made afresh), its results file is moved to ``spec.results``.

    Sets ``record.returncode``, and ``record.status`` ``resource_limit`` with the one-line reason in
    ``record.error`` when it went past a limit. Returns (whether it timed out, whether it read its standard input:
    always False, a container's standard input is closed).

    Raises:
        BenchbotError: the build failed, or the engine could not start the container (the episode ends
            ``error``).
    """
    container = spec.container or {}
    outputs = folder / spec.outputs
    shutil.rmtree(outputs, ignore_errors=True)
    outputs.mkdir(parents=True)
    tag = build_image(container["engine"], Path(container["dockerfile"]), Path(container["context"]), log=log)
    log.flush()
    run = run_container(container["engine"], tag, backend_socket=backend_socket, address=INSIDE_ADDRESS,
                        outputs=outputs, result_name=Path(spec.results).name, args=container.get("args", ""),
                        name_suffix=f"_{spec.index}", log=log, timeout_s=spec.timeout_s)
    record.returncode = run.outcome.returncode
    if run.limit:
        record.status, record.error = "resource_limit", run.limit
    elif run.results is not None:
        os.replace(run.results, folder / spec.results)
    return run.outcome.timed_out, False
