"""Built-in plugin: the example solutions that work with any task (``hello_passive``, ``hello_active``)."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl

EXAMPLES = Path(__file__).parent / "examples"


@hookimpl
def benchbot_examples() -> list[Path]:
    """The YAML specs in ``benchbot/plugins/examples/``."""
    return sorted(EXAMPLES.glob("*.yaml"))
