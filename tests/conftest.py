"""Fixtures for the core tests: the real registry, the real Taichi simulator (small images), a real HTTP server."""

from __future__ import annotations

import pytest

from benchbot.core.registry import Registry, get_registry
from benchbot.core.server import ServerThread, build_app
from benchbot.core.session import resolve_run, start_service

SMALL = {"width": 64, "height": 48}


@pytest.fixture(scope="session")
def registry() -> Registry:
    return get_registry()


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
