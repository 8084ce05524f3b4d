"""Compatibility: ``from benchbot_api import BenchBot, Agent, ActionResult`` for submissions written for the
original BenchBot. Everything here is :mod:`benchbot.api`; ``benchbot_api.api_callbacks`` holds the original's
API-side callbacks and ``benchbot_api.tools`` the observation visualiser (matplotlib imported on use)."""

from benchbot.api import RESULT_LOCATION, ActionResult, Agent, BenchBot, InProcessBenchBot

__all__ = ["Agent", "ActionResult", "BenchBot", "InProcessBenchBot", "RESULT_LOCATION"]
