"""Each robot_ros2 test run holds a block of DDS domains of its own (``dds_domains.claim_domain_block``)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from dds_domains import DOMAIN_BASES, DOMAIN_BLOCK, MAX_DOMAIN, claim_domain_block  # noqa: E402


def test_blocks_are_valid_domains_and_the_tests_offsets_fit():
    # below the ephemeral ports: a full run's HTTP sockets once took the DDS ports of domain 109
    assert DOMAIN_BASES[0] > 0 and DOMAIN_BASES[-1] + DOMAIN_BLOCK - 1 <= MAX_DOMAIN
    # RTPS ports: 7400 + 250·domain, unicast + 10/11 + 2·participant index (at most 50 in our loopback profile)
    assert 7400 + 250 * MAX_DOMAIN + 11 + 2 * 50 < 32768
    offsets = set()
    for path in Path(__file__).parent.glob("test_*.py"):
        import re

        offsets |= {int(n) for n in re.findall(r"domain_id \+ (\d+)", path.read_text(encoding="utf-8"))}
    assert offsets and max(offsets) < DOMAIN_BLOCK


def test_a_held_block_is_not_given_to_another_run(domain_id):
    """This run holds ``domain_id``'s block; another process (another test run) gets a different one, and the
    block is free again once its holder exits."""
    code = ("import sys; sys.path.insert(0, %r); from dds_domains import claim_domain_block; "
            "print(claim_domain_block()[0])" % str(Path(__file__).parent))
    other = int(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    assert other != domain_id and other in DOMAIN_BASES
    mine, lock = claim_domain_block()  # a second claim in this process takes yet another block
    try:
        assert mine not in (domain_id,)
    finally:
        lock.close()
