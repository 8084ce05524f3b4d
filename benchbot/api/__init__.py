"""The client API a solution uses: :class:`BenchBot`, :class:`Agent`, :class:`ActionResult`, ``RESULT_LOCATION``.

Semantics follow the original ``benchbot_api`` (docs/original-benchbot.md, docs/protocol.md); ``import benchbot_api``
gives the same names so submissions written for the original run unchanged. :func:`InProcessBenchBot` drives a backend in
the same process (no HTTP). ``benchbot.api.tools`` (the observation visualiser) imports matplotlib only when used.
"""

from benchbot.api.agent import Agent
from benchbot.api.benchbot import RESULT_LOCATION, ActionResult, BenchBot, InProcessBenchBot

__all__ = ["Agent", "ActionResult", "BenchBot", "InProcessBenchBot", "RESULT_LOCATION"]
