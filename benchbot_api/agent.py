"""Compatibility alias of :mod:`benchbot.api.agent`."""
from benchbot.api.agent import Agent  # noqa: F401
