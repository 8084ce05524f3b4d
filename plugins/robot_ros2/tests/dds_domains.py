"""DDS domains for the robot_ros2 tests: each test run on a host holds a block of domains of its own, so two runs at
once never hear each other's topics."""

from __future__ import annotations

import os
from pathlib import Path

#: DDS domains of one test run: ``domain_id`` + 0 … DOMAIN_BLOCK − 1 (the tests use offsets 0 to 30).
DOMAIN_BLOCK = 32
#: Highest domain whose ports (7400 + 250 · domain + …) stay below Linux's ephemeral ports (32768 and up): above
#: it, a socket any test opened on port 0 can take a DDS port and discovery fails (ROS 2 advises 0 … 101 on Linux).
MAX_DOMAIN = 101
#: The blocks' first domains: 2, 34, 66 (the last block ends at 97; domains 0 and 1 are left to real robots).
DOMAIN_BASES = tuple(range(2, MAX_DOMAIN - DOMAIN_BLOCK + 2, DOMAIN_BLOCK))


def claim_domain_block() -> tuple[int, object]:
    """The first domain of a block no other test run on this host holds, and the open lock file that holds it
    (an exclusive ``flock`` on ``$TMPDIR/benchbot-dds-block-<base>.lock``, released when the process exits, even by
    kill -9). Two BenchBot test runs at once (CI jobs, a developer's run beside an agent's) never share a domain.

    Raises:
        RuntimeError: every block is held (more than len(DOMAIN_BASES) runs at once).
    """
    import fcntl

    folder = Path(os.environ.get("TMPDIR", "/tmp"))
    start = os.getpid() % len(DOMAIN_BASES)  # runs started together try different blocks first
    for k in range(len(DOMAIN_BASES)):
        base = DOMAIN_BASES[(start + k) % len(DOMAIN_BASES)]
        lock = open(folder / f"benchbot-dds-block-{base}.lock", "a")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        return base, lock
    raise RuntimeError(f"all {len(DOMAIN_BASES)} DDS domain blocks are held by other test runs on this host")
