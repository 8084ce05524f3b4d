"""The client API a solution uses: :class:`BenchBot`, :class:`Agent`, :class:`ActionResult`, ``RESULT_LOCATION``.

Semantics follow the original ``benchbot_api`` (docs/benchbot-reference.md §4); ``import benchbot_api`` gives the
same names so submissions written for the original run unchanged.
"""

from benchbot.api.agent import Agent
from benchbot.api.benchbot import RESULT_LOCATION, ActionResult, BenchBot

__all__ = ["Agent", "ActionResult", "BenchBot", "RESULT_LOCATION"]
