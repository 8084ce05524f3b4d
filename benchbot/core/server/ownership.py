"""One client at a time: who sends a request (:func:`client_identity`) and whom the episode belongs to
(:class:`EpisodeOwnership`; docs/protocol.md, "One client at a time")."""

from __future__ import annotations

import re
import time
from typing import Callable

from starlette.requests import Request

from benchbot.core import limits
from benchbot.core.server.http_errors import BadRequestError, EpisodeInUseError

#: The header naming a client (8–128 of ``A-Z a-z 0-9 _ . : -``, e.g. a random hex id): the episode belongs to one
#: client at a time (:class:`EpisodeOwnership`).
CLIENT_HEADER = "x-benchbot-client"
CLIENT_ID_PATTERN = re.compile(r"[A-Za-z0-9_.:-]{8,128}")
#: Robot commands that only read the episode: any client may ask them, and asking does not claim the episode.
READ_ONLY_COMMANDS = frozenset({"", "is_collided", "is_dirty", "is_finished", "selected_environment", "state",
                                "run_info"})


class EpisodeOwnership:
    """Which client the episode belongs to: one client at a time (docs/protocol.md, "One client at a time").

    A client is named by its ``X-BenchBot-Client`` header (:data:`CLIENT_HEADER`), else it is the anonymous client
    of its address: the original ``benchbot_api`` sends no header, so original clients on one host count as one
    client, as they did in the original. The first client whose request uses the episode (an action, an
    observation, a native step, a robot command other than :data:`READ_ONLY_COMMANDS`) owns it; until the owner
    releases it (``/robot/release``) or sends no request for ``lease_s`` seconds (none in flight), every other
    client's episode request is refused with :class:`~benchbot.core.server.http_errors.EpisodeInUseError` (409). A
    client whose lease ran out and whose episode another client then took is told so (409) on its next episode
    request: a client never carries on in an episode that someone else has reset.

    Args:
        lease_s: idle seconds after which another client may take the episode.
        clock: monotonic seconds (tests pass their own).

    Use on the event loop only (not thread-safe).
    """

    #: Clients remembered as having lost the episode to another (older ones are forgotten).
    MAX_LOST = 1024

    def __init__(self, lease_s: float, clock: Callable[[], float] = time.monotonic) -> None:
        self.lease_s, self.clock = lease_s, clock
        self.owner: str | None = None
        self.last_seen = 0.0
        self.in_flight = 0
        self._lost: dict[str, None] = {}

    def _idle_s(self) -> float:
        return self.clock() - self.last_seen

    def held_by_other(self, client: str) -> bool:
        """Whether another client holds the episode now."""
        return (self.owner is not None and self.owner != client
                and (self.in_flight > 0 or self._idle_s() < self.lease_s))

    def acquire(self, client: str) -> None:
        """Claim (or keep) the episode for one request of ``client``; pair with :meth:`done`.

        Raises:
            EpisodeInUseError: another client holds it (the message says for how long at most).
        """
        if self.held_by_other(client):
            wait = "until its request ends" if self.in_flight else f"for at most {self.lease_s - self._idle_s():.0f} s"
            if client in self._lost:
                message = (f"the episode was handed to another client after yours sent no request for "
                           f"{self.lease_s:g} s")
            else:
                message = "the episode belongs to another client"
            raise EpisodeInUseError(
                f"{message}; it holds it {wait} (then idle {self.lease_s:g} s frees it, or it sends /robot/release)",
                f"one client per episode: start another backend for a second client "
                f"(the idle time is ${limits.EPISODE_LEASE_S.env} on the backend)",
            )
        if self.owner != client:
            if self.owner is not None:
                self._lost[self.owner] = None
                while len(self._lost) > self.MAX_LOST:
                    self._lost.pop(next(iter(self._lost)))
            self._lost.pop(client, None)
            self.owner = client
        self.in_flight += 1
        self.last_seen = self.clock()

    def done(self, client: str) -> None:
        """The end of a request that :meth:`acquire` let through."""
        if self.owner == client:
            self.in_flight = max(0, self.in_flight - 1)
            self.last_seen = self.clock()

    def touch(self, client: str) -> None:
        """Any other request of ``client``: the owner's renews its lease."""
        if self.owner == client:
            self.last_seen = self.clock()

    def release(self, client: str) -> bool:
        """Give the episode up; True when ``client`` held it and no other request of it is in flight."""
        if self.owner != client or self.in_flight:
            return False
        self.owner = None
        return True


def client_identity(request: Request) -> str:
    """The name of the client sending ``request``: ``id:<X-BenchBot-Client>``, else ``anonymous@<address>``.

    Raises:
        BadRequestError: the header is there but is not 8–128 of ``A-Z a-z 0-9 _ . : -``.
    """
    given = request.headers.get(CLIENT_HEADER)
    if given is None:
        return f"anonymous@{request.client.host if request.client else 'unknown'}"
    if not CLIENT_ID_PATTERN.fullmatch(given):
        raise BadRequestError("X-BenchBot-Client must be 8-128 characters of A-Z a-z 0-9 _ . : -",
                              "send a random id, e.g. secrets.token_hex(16), with every request")
    return f"id:{given}"
