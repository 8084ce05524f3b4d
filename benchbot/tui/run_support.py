"""The observers of ``benchbot run``: an MCAP recorder (``--record FILE``) and the live view (``--tui``).

``benchbot run`` builds its service and server, then::

    observers = RunObservers(reg, service, spec, record=record, tui=tui, seed=seed, options=options,
                             address=server.address)
    try:
        observers.wait()          # the live view in the foreground, or until Ctrl-C
    finally:
        observers.close()         # finishes the recording

Everything touching the episode runs on the backend thread (observer hooks, ``BackendService.call``).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any


class RunObservers:
    """Attach the recorder and/or the live-state writer to ``service``'s episode.

    Args:
        registry: the registry whose plugin manager the episode's observer hooks go through.
        service: the :class:`~benchbot.server.BackendService`.
        spec: its :class:`~benchbot.core.session.RunSpec`.
        record: an ``.mcap`` path to record to, or None.
        tui: show the live view; None: when stderr is a terminal.
        seed, options: stored in the recording's metadata.
        address: the backend's address (shown by the live view).
        state_dir: the live-state folder (default: a new temporary one).
    """

    def __init__(self, registry: Any, service: Any, spec: Any, *, record: Path | str | None = None,
                 tui: bool | None = None, seed: int = 0, options: dict | None = None, address: str = "",
                 state_dir: Path | str | None = None) -> None:
        self.registry, self.service, self.address = registry, service, address
        self.tui = sys.stderr.isatty() if tui is None else tui
        self.recorder = self.writer = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._own_state_dir: Path | None = None  # made here: removed by close()
        if record:
            from benchbot.plugins.recorder import attach_recorder

            self.recorder = attach_recorder(registry, service, spec, Path(record), seed=seed, options=options)
        if self.tui:
            from benchbot.plugins.live_state import LiveStateWriter

            if state_dir is None:
                state_dir = self._own_state_dir = Path(tempfile.mkdtemp(prefix="benchbot-live-"))
            self.state_dir = Path(state_dir)
            self.writer = LiveStateWriter(self.state_dir)
            service.call(self.writer.attach, service.episode)
            registry.plugin_manager.register(self.writer)
            self._thread = threading.Thread(target=self._refresh_loop, name="benchbot-live-state", daemon=True)
            self._thread.start()

    def _refresh_loop(self) -> None:
        # the client observes after each action: pick up the new image without waiting for the next step
        while not self._stop.wait(0.5):
            try:
                self.service.call(self.writer.refresh)
            except Exception:  # the service is closing
                return

    def wait(self) -> None:
        """Block: the live view in the foreground (until it is quit: q returns, Ctrl-C raises KeyboardInterrupt), else
        until Ctrl-C."""
        if self.tui:
            from benchbot.tui.run_app import RunApp

            app = RunApp(self.state_dir, address=self.address)
            app.run()
            if app.interrupted:  # Ctrl-C in the view: stop as Ctrl-C without it does
                raise KeyboardInterrupt
        else:
            from benchbot.cli.common import wait_until_interrupted

            wait_until_interrupted()

    def close(self) -> None:
        """Stop the live view's refresher, unregister the observers, finish the recording, and remove the live-state
        folder if it was made here."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        pm = self.registry.plugin_manager
        if self.writer is not None and pm.is_registered(self.writer):
            pm.unregister(self.writer)
        if self.recorder is not None:
            from benchbot.plugins.recorder import detach_recorder

            detach_recorder(self.registry, self.service, self.recorder)
        if self._own_state_dir is not None:
            shutil.rmtree(self._own_state_dir, ignore_errors=True)
