"""``benchbot run``'s live view of an episode the simulator service serves: the service writes the episode's snapshots
(:class:`benchbot.plugins.live_state.LiveStateWriter`: ``state.json`` and the camera preview) to a folder the command
made, and the command's view (:class:`benchbot.tui.run_app.RunApp`) reads them there, as it reads those of an
episode served in the command's own process (:class:`benchbot.tui.run_support.RunObservers`).

The writer is fed the episode's steps from the service's ``on_step`` (not registered as a plugin: the service's
registry is shared by every episode it serves) and refreshed twice a second on the backend thread.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

#: Seconds between two refreshes of the snapshot while no step comes (the client observes after each action).
REFRESH_S = 0.5


class ServiceLiveView:
    """The snapshots of ``service``'s episode, written to ``folder`` until :meth:`close`.

    Args:
        service: the episode's :class:`~benchbot.server.BackendService` (built).
        folder: the command's live-state folder (an existing folder of the same user).

    Raises:
        OSError: ``folder`` cannot be written.
    """

    def __init__(self, service: Any, folder: Path) -> None:
        from benchbot.plugins.live_state import LiveStateWriter

        self.service = service
        self.writer = LiveStateWriter(folder)
        service.call(self.writer.attach, service.episode)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._refresh_loop, name="benchbot-service-live-view", daemon=True)
        self._thread.start()

    def step(self, info: dict) -> None:
        """After every action (backend thread, the episode's ``on_step``): to the writer."""
        self.writer.benchbot_step(info)

    def _refresh_loop(self) -> None:
        while not self._stop.wait(REFRESH_S):
            try:
                self.service.call(self.writer.refresh)
            except Exception:  # noqa: BLE001 - the episode is closing
                return

    def close(self) -> None:
        """Stop refreshing (waits up to 5 s for the refresher)."""
        self._stop.set()
        self._thread.join(timeout=5)
