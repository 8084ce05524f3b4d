"""One client at a time: who sends a request (:func:`client_identity`) and whom the episode belongs to
(:class:`EpisodeOwnership`; docs/protocol.md, "One client at a time")."""

from __future__ import annotations

import re
import time
from typing import Callable

from starlette.requests import Request

from benchbot.core import limits
from benchbot.protocol import wire
from benchbot.server.http_errors import BadRequestError, EpisodeInUseError

#: The header naming a client (8–128 of ``A-Z a-z 0-9 _ . : -``, e.g. a random hex id): the episode belongs to one
#: client at a time (:class:`EpisodeOwnership`).
CLIENT_HEADER = wire.CLIENT_HEADER.lower()
CLIENT_ID_PATTERN = re.compile(r"[A-Za-z0-9_.:-]{8,128}")
#: Robot commands that only read the episode: any client may ask them, and asking does not claim the episode.
READ_ONLY_COMMANDS = frozenset({"", "is_collided", "is_dirty", "is_finished", "selected_environment", "state",
                                "run_info"})
#: How :func:`client_identity` names a client that sent no ``X-BenchBot-Client`` (followed by its address).
ANONYMOUS_PREFIX = "anonymous@"


class EpisodeOwnership:
    """Which client the episode belongs to: one client at a time (docs/protocol.md, "One client at a time").

    A client is named by its ``X-BenchBot-Client`` header (:data:`CLIENT_HEADER`), else it is the anonymous client
    of its address: the original ``benchbot_api`` sends no header, so original clients on one host count as one
    client, as they did in the original. The first client whose request uses the episode (an action, an
    observation, a native step, a robot command other than :data:`READ_ONLY_COMMANDS`) owns it; until the owner
    releases it (``/robot/release``) or sends no request for ``lease_s`` seconds (none in flight), every other
    client's episode request is refused with :class:`~benchbot.server.http_errors.EpisodeInUseError` (409). A
    client whose lease ran out and whose episode another client then took is told so (409) on its next episode
    request: a client never carries on in an episode that someone else has reset. The supervisor of a solution
    (``benchbot submit``) ends its client's hold once the solution's processes have ended
    (:meth:`release_ended`), even when the solution never released it (killed, or an original client).

    Args:
        lease_s: idle seconds after which another client may take the episode.
        clock: monotonic seconds (tests pass their own).

    Use on the event loop only (not thread-safe).
    """

    #: Clients remembered as having lost the episode to another, and clients ended by their supervisor (older ones
    #: are forgotten).
    MAX_LOST = 1024

    def __init__(self, lease_s: float, clock: Callable[[], float] = time.monotonic) -> None:
        self.lease_s, self.clock = lease_s, clock
        self.owner: str | None = None
        self.last_seen = 0.0
        self.in_flight = 0
        self._lost: dict[str, None] = {}
        self._ended: dict[str, None] = {}
        self._release_when_done = False  # the owner was ended while a request of it was in flight

    @staticmethod
    def _remember(clients: dict[str, None], client: str) -> None:
        clients[client] = None
        while len(clients) > EpisodeOwnership.MAX_LOST:
            clients.pop(next(iter(clients)))

    def _idle_s(self) -> float:
        return self.clock() - self.last_seen

    def held_by_other(self, client: str) -> bool:
        """Whether another client holds the episode now."""
        return (self.owner is not None and self.owner != client
                and (self.in_flight > 0 or self._idle_s() < self.lease_s))

    def refusal(self, client: str) -> EpisodeInUseError | None:
        """What :meth:`acquire` would refuse ``client`` with now (None: it would let it through); claims
        nothing."""
        if client in self._ended:
            return EpisodeInUseError(
                "this client's solution has ended: its supervisor (benchbot submit) released the episode and "
                "refuses this client id from now on",
                "a process of the ended solution lives on; start the solution again (a new run gets a new id)",
            )
        if self.held_by_other(client):
            if self._release_when_done:
                wait = "its solution has ended, and the episode is free once its last request (still running) ends"
            elif self.in_flight:
                wait = (f"a request of it is running; it frees the episode when it ends, or after {self.lease_s:g} s "
                        "without a request")
            else:
                wait = (f"it frees it when it ends, or after {self.lease_s:g} s without a request (at most "
                        f"{max(1.0, self.lease_s - self._idle_s()):.0f} s from now)")
            if client in self._lost:
                message = (f"the episode was handed to another client after yours sent no request for "
                           f"{self.lease_s:g} s")
            else:
                message = "the episode belongs to another client"
            return EpisodeInUseError(
                f"{message}: {wait}",
                f"wait and try again, or give this client a backend of its own (`benchbot run --env ENV --port "
                f"10001`); ${limits.EPISODE_LEASE_S.env} on the backend sets the idle time",
            )
        return None

    def acquire(self, client: str) -> None:
        """Claim (or keep) the episode for one request of ``client``; pair with :meth:`done`.

        Raises:
            EpisodeInUseError: another client holds it (the message says for how long at most), or ``client`` was
                ended by its supervisor (:meth:`release_ended`).
        """
        refused = self.refusal(client)
        if refused is not None:
            raise refused
        if self.owner != client:
            if self.owner is not None:
                self._remember(self._lost, self.owner)
            self._lost.pop(client, None)
            self.owner = client
        self._release_when_done = False  # a live request of the owner: it holds the episode again
        self.in_flight += 1
        self.last_seen = self.clock()

    def done(self, client: str) -> None:
        """The end of a request that :meth:`acquire` let through."""
        if self.owner == client:
            self.in_flight = max(0, self.in_flight - 1)
            self.last_seen = self.clock()
            if self._release_when_done and not self.in_flight:
                self.owner, self._release_when_done = None, False

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

    def release_ended(self, client: str | None = None, anonymous: bool = False) -> bool:
        """A supervisor's release: the solution whose client is ``client`` (``id:<id>``), or an original client
        (``anonymous``: whichever anonymous client holds the episode), has ended, so its hold ends now, or as soon
        as its requests still in flight end (a solution killed during an action). ``client`` is refused from then
        on (409): a request the dead solution left in the network, or a process of it that outlived it, never takes
        the episode back. Anonymous clients are not refused afterwards: one address's original clients are one
        client, and the next submission's may be one of them.

        Returns:
            True when the episode was held by ``client`` (or by an anonymous client, with ``anonymous``).
        """
        if client is not None:
            self._remember(self._ended, client)
        owner = self.owner
        if owner is None or not (owner == client or (anonymous and owner.startswith(ANONYMOUS_PREFIX))):
            return False
        if self.in_flight:
            self._release_when_done = True
        else:
            self.owner = None
        return True


def client_identity(request: Request) -> str:
    """The name of the client sending ``request``: ``id:<X-BenchBot-Client>``, else ``anonymous@<address>``.

    Raises:
        BadRequestError: the header is there but is not 8–128 of ``A-Z a-z 0-9 _ . : -``.
    """
    given = request.headers.get(CLIENT_HEADER)
    if given is None:
        return f"{ANONYMOUS_PREFIX}{request.client.host if request.client else 'unknown'}"
    if not CLIENT_ID_PATTERN.fullmatch(given):
        raise BadRequestError("X-BenchBot-Client must be 8-128 characters of A-Z a-z 0-9 _ . : -",
                              "send a random id, e.g. secrets.token_hex(16), with every request")
    return f"id:{given}"
