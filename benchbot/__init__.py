"""BenchBot: benchmark robotics research with tasks, robots, environments and evaluators as plugins.

The core is small: hookspecs, a plugin manager, a validating registry, the episode state machine, the backend
server and the client API. Every capability (simulators, robots, tasks, evaluators) ships as a plugin registered
through the entry-point group ``benchbot``.
"""

__version__ = "0.1.0"

import importlib as _importlib
import sys as _sys

if "gymnasium" in _sys.modules:  # registers BenchBot-v0 and BenchBotRemote-v0 (docs/gym.md); never imports gymnasium
    _importlib.import_module("benchbot.gym")
