"""Compatibility: ``from benchbot_api import BenchBot, Agent, ActionResult`` for submissions written for the
original BenchBot. Everything here is :mod:`benchbot.api`."""

from benchbot.api import RESULT_LOCATION, ActionResult, Agent, BenchBot

__all__ = ["Agent", "ActionResult", "BenchBot", "RESULT_LOCATION"]
