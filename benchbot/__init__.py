"""BenchBot: benchmark robotics research with tasks, robots, environments and evaluators as plugins.

The core is small: hookspecs, a plugin manager, a validating registry, the episode state machine, the backend
server and the client API. Every capability (simulators, robots, tasks, evaluators) ships as a plugin registered
through the entry-point group ``benchbot``.
"""

from importlib.metadata import PackageNotFoundError as _NotInstalled, version as _version

try:
    __version__ = _version("benchbot")  # one source: pyproject.toml's [project] version, as installed
except _NotInstalled:  # imported from a source tree that was never installed
    __version__ = "0+unknown"

import importlib as _importlib
import sys as _sys

if "gymnasium" in _sys.modules:  # registers BenchBot-v0 and BenchBotRemote-v0 (docs/gym.md); never imports gymnasium
    _importlib.import_module("benchbot.gym")
