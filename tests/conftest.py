"""Fixtures for the core tests: the real registry, the real Taichi simulator (small images), a real HTTP server."""

from __future__ import annotations

import os
import subprocess

import pytest

from benchbot.core.registry import Registry, get_registry
from benchbot.server import ServerThread, build_app
from benchbot.core.session import resolve_run, start_service

SMALL = {"width": 64, "height": 48}


@pytest.fixture(scope="session")
def registry() -> Registry:
    return get_registry()


@pytest.fixture
def data_dir(tmp_path, monkeypatch):
    """A fresh BenchBot data directory (``BENCHBOT_DATA_DIR``: installed packs live there) under ``tmp_path``; the
    folder is not created. A test module that needs it for every test says ``pytestmark = usefixtures``."""
    monkeypatch.setenv("BENCHBOT_DATA_DIR", str(tmp_path / "data"))
    return tmp_path / "data"


@pytest.fixture
def make_service(registry):
    """``make_service(task, env, robot='carter', seed=0)`` → a BackendService on the real simulator; closed after."""
    services = []

    def make(task: str, env: str, robot: str = "carter", seed: int = 0, **options):
        service = start_service(registry, resolve_run(registry, task, robot, env), seed=seed, options={**SMALL, **options})
        services.append(service)
        return service

    yield make
    for service in services:
        service.close()


@pytest.fixture
def served(make_service):
    """``served(task, env)`` → (service, ServerThread) listening on 127.0.0.1 (a free port); stopped after."""
    servers = []

    def serve(task: str, env: str, **kwargs):
        service = make_service(task, env, **kwargs)
        server = ServerThread(build_app(service)).start()
        servers.append(server)
        return service, server

    yield serve
    for server in servers:
        server.stop()


#: The base image of the test containers: BenchBot's own (original Dockerfiles start FROM it), made on first use with
#: `benchbot container-base` (no registry: a Debian root file system from the apt mirror); another local image with
#: BenchBot's client can be named instead.
CONTAINER_BASE_IMAGE = os.environ.get("BENCHBOT_TEST_BASE_IMAGE", "benchbot/submission:base")


@pytest.fixture(scope="session")
def container_engine_with_base_image() -> tuple[str, str]:
    """``(engine, base image)``: a working Docker/Podman with :data:`CONTAINER_BASE_IMAGE` present, made as
    ``benchbot container-base`` makes it when it is missing (a few minutes, once per machine: the engine keeps it).
    Skipped with the reason only where no engine answers, or where the image is missing and mmdebstrap, which makes
    it, is not installed; a failed build fails the test."""
    import fcntl
    import shutil
    import tempfile
    from pathlib import Path

    from benchbot.core.errors import BenchbotError, UsageError
    from benchbot.solutions.container_base import build_base
    from benchbot.solutions.container_engine import container_engine

    try:
        engine = container_engine()
    except UsageError as exc:
        pytest.skip(f"no working container engine: {exc.message}")
    image = CONTAINER_BASE_IMAGE
    # One maker at a time: CI's slow tests run in two pytest-xdist workers, and each has this session fixture.
    with open(Path(tempfile.gettempdir()) / "benchbot-test-base-image.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if subprocess.run([engine, "image", "inspect", image], capture_output=True, timeout=60).returncode == 0:
            return engine, image
        if image != "benchbot/submission:base" or shutil.which("mmdebstrap") is None:
            pytest.skip(f"base image {image} is not in {engine}, and tests never pull" +
                        ("" if image != "benchbot/submission:base" else
                         "; install mmdebstrap to make it (`benchbot container-base`)"))
        with tempfile.TemporaryFile("w+") as log:
            try:
                build_base(engine, log=log)  # what `benchbot container-base` does
            except BenchbotError as exc:
                log.seek(0)
                pytest.fail(f"making {image} failed: {exc.message}\n{log.read()[-4000:]}")
    return engine, image


@pytest.fixture(scope="module")
def realism():
    """``benchmarks/realism.py`` imported as a module (``realism_benchmark``), for tests of its parts."""
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "realism.py"
    spec = importlib.util.spec_from_file_location("realism_benchmark", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["realism_benchmark"] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    yield mod
    sys.modules.pop("realism_benchmark", None)


@pytest.fixture(scope="module")
def realism_detectors(realism):
    """``benchmarks/realism_detectors.py``, the module ``realism`` imported (the same object, so that what a test
    patches in it is what ``realism`` runs)."""
    import sys

    return sys.modules["realism_detectors"]


@pytest.fixture(scope="module")
def realism_counting(realism):
    """``benchmarks/realism_counting.py``, the module ``realism`` imported (the same object)."""
    import sys

    return sys.modules["realism_counting"]
