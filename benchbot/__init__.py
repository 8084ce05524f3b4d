"""BenchBot: benchmark robotics research with tasks, robots, environments and evaluators as plugins.

The core is small: hookspecs, a plugin manager, a validating registry, the episode state machine, the backend
server and the client API. Every capability (simulators, robots, tasks, evaluators) ships as a plugin registered
through the entry-point group ``benchbot``.
"""

import importlib as _importlib
import sys as _sys

if "gymnasium" in _sys.modules:  # registers BenchBot-v0 and BenchBotRemote-v0 (docs/gym.md); never imports gymnasium
    _importlib.import_module("benchbot.gym")


def __getattr__(name: str) -> str:
    """``benchbot.__version__``: pyproject.toml's [project] version as installed (one source), ``0+unknown`` when
    imported from a source tree that was never installed. Read on first use (PEP 562), not at import: reading the
    installed metadata took 0.025 s of every solution's start (``benchbot_api`` imports this package) on the 2-core
    CPU.

    Raises:
        AttributeError: any other name."""
    if name != "__version__":
        raise AttributeError(f"module 'benchbot' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("benchbot")
    except PackageNotFoundError:
        value = "0+unknown"
    globals()["__version__"] = value
    return value
