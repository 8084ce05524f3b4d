"""Compatibility alias of :mod:`benchbot.api.benchbot`."""
from benchbot.api.benchbot import RESULT_LOCATION, ActionResult, BenchBot  # noqa: F401
