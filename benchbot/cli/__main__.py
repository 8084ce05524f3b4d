"""``python -m benchbot.cli`` is the ``benchbot`` command."""

from benchbot.cli.main import main

main()
