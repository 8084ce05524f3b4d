"""Compatibility alias of :mod:`benchbot.api.tools` (``from benchbot_api.tools import ObservationVisualiser``)."""
from benchbot.api.tools import ObservationVisualiser  # noqa: F401
