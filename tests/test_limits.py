"""benchbot.core.limits: the one home of every resource limit — its table, its parsing, its errors."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from benchbot.core import limits
from benchbot.core.errors import UsageError
from benchbot.core.limits import Limit
from benchbot.solutions.process_group import run_child

BENCHBOT_PACKAGE = Path(limits.__file__).resolve().parents[1]


def docstring_table() -> dict[str, str]:
    """The rows of the module docstring's table, by the limit name in their first column."""
    rows = {}
    for line in limits.__doc__.splitlines():
        match = re.match(r"([A-Z][A-Z_]+)\s{2,}(.*)", line)
        if match:
            rows[match[1]] = match[2]
    return rows


def test_every_limit_is_in_the_module_docstring_table_with_its_default_and_variable():
    rows = docstring_table()
    assert set(rows) == set(limits.all_limits()), "the table and the module's Limit constants differ"
    for name, limit in limits.all_limits().items():
        row = rows[name]
        assert limit.describe(limit.default) in row, (name, row)
        assert (limit.env or "(none") in row, (name, row)
        if limit.zero_means:
            assert f"0: {limit.zero_means}" in row, (name, row)


def test_every_limit_is_in_the_table_of_docs_security_md():
    """Each overridable limit's variable is in a row of the table; a fixed one's default; no row names a variable
    that is not a limit's."""
    docs = (BENCHBOT_PACKAGE.parent / "docs" / "security.md").read_text(encoding="utf-8")
    rows = [line for line in docs.splitlines() if line.startswith("|")]
    variables = {limit.env for limit in limits.all_limits().values() if limit.env}
    for name, limit in limits.all_limits().items():
        needle = f"`{limit.env}`" if limit.env else f"| {limit.describe(limit.default).split()[0]} "
        assert any(needle in row for row in rows), f"{name} ({needle}) is not in docs/security.md's table"
    named = {v for row in rows for v in re.findall(r"`(BENCHBOT_[A-Z_]+)`", row)}
    assert named <= variables, f"docs/security.md's table names variables that are no limit's: {named - variables}"


def test_no_module_but_limits_defines_a_limit():
    for path in BENCHBOT_PACKAGE.rglob("*.py"):
        if path.name == "limits.py" and path.parent.name == "core":
            continue
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"\bclass Limit\b|(?<![A-Za-z_])Limit\(", text), path
        assert not re.search(r"environ(\.get)?[(\[]\s*['\"]BENCHBOT_(MAX_|STOP_GRACE)", text), path


@pytest.mark.parametrize(("limit", "raw", "expected"), [
    (limits.MAX_RESULTS_BYTES, "2M", 2 << 20),
    (limits.MAX_RESULTS_BYTES, " 512k ", 512 << 10),
    (limits.MAX_REQUEST_BYTES, "1G", 1 << 30),  # every byte limit takes the suffixes (before: only the file ones)
    (limits.MAX_LOG_BYTES, "0", 0),  # 0: no cap
    (limits.STOP_GRACE_S, "0", 0.0),  # 0: no grace
    (limits.STOP_GRACE_S, "2.5", 2.5),
    (limits.MAX_ZIP_MEMBERS, "7", 7),
    (limits.EPISODE_LEASE_S, "", 60.0),  # empty: the default
])
def test_values_from_the_environment(monkeypatch, limit, raw, expected):
    monkeypatch.setenv(limit.env, raw)
    value = limit.value()
    assert value == expected and type(value) is type(expected)


@pytest.mark.parametrize(("limit", "raw", "message"), [
    (limits.MAX_RESULTS_BYTES, "lots", "BENCHBOT_MAX_RESULTS_BYTES='lots' is not a positive whole number of bytes"),
    (limits.MAX_RESULTS_BYTES, "0", "BENCHBOT_MAX_RESULTS_BYTES='0' is not a positive whole number of bytes"),
    (limits.MAX_LOG_BYTES, "-1", "BENCHBOT_MAX_LOG_BYTES='-1' is not a whole number of bytes ≥ 0"),
    (limits.MAX_LOG_BYTES, "1.5M", "BENCHBOT_MAX_LOG_BYTES='1.5M' is not a whole number of bytes ≥ 0"),
    (limits.MAX_ZIP_MEMBERS, "5K", "BENCHBOT_MAX_ZIP_MEMBERS='5K' is not a positive whole number of members"),
    (limits.STOP_GRACE_S, "inf", "BENCHBOT_STOP_GRACE_S='inf' is not a number of seconds ≥ 0"),  # waited forever
    (limits.STOP_GRACE_S, "nan", "BENCHBOT_STOP_GRACE_S='nan' is not a number of seconds ≥ 0"),  # was accepted
    (limits.EPISODE_LEASE_S, "0", "BENCHBOT_EPISODE_LEASE_S='0' is not a positive number of seconds"),
    (limits.MAX_RESULTS_ARG_NUMBER, "1e400", "BENCHBOT_MAX_RESULTS_ARG_NUMBER='1e400' is not a positive number"),
    (limits.MAX_NESTING_DEPTH, "9" * 5000, "is not a positive whole number of levels"),  # no ValueError escapes
])
def test_a_bad_value_is_a_one_line_usage_error_naming_the_variable(monkeypatch, limit, raw, message):
    monkeypatch.setenv(limit.env, raw)
    with pytest.raises(UsageError) as caught:
        limit.value()
    assert message in caught.value.message and "\n" not in caught.value.message
    assert caught.value.hint.startswith(f"e.g. {limit.env}=") and limit.describe(limit.default) in caught.value.hint


def test_messages_name_the_limit_and_how_to_raise_it(monkeypatch):
    assert limits.MAX_ZIP_MEMBERS.describe() == "10000 members"
    assert limits.MAX_LOG_BYTES.describe(0) == "0 (no cap)"
    assert limits.MAX_MOVE_DISTANCE_M.describe(1) == "1 metre"
    assert limits.MAX_RESULTS_BYTES.raise_hint() == "set BENCHBOT_MAX_RESULTS_BYTES to raise it"
    monkeypatch.setenv("BENCHBOT_MAX_RESULTS_BYTES", "3M")
    assert limits.MAX_RESULTS_BYTES.hint() == ("raise the limit with the environment variable "
                                               "BENCHBOT_MAX_RESULTS_BYTES (e.g. BENCHBOT_MAX_RESULTS_BYTES=6M)")
    with pytest.raises(ValueError, match="integer=True"):
        Limit(10, "X", "bytes")


def test_a_child_log_cap_takes_a_suffix(tmp_path, monkeypatch):
    """A real child process: BENCHBOT_MAX_LOG_BYTES=1K keeps 1024 bytes (before: '1K' was a usage error)."""
    monkeypatch.setenv("BENCHBOT_MAX_LOG_BYTES", "1K")
    log_path = tmp_path / "child.log"
    with open(log_path, "wb") as log:
        outcome = run_child([sys.executable, "-c", "print('x' * 5000)"], cwd=tmp_path, env={}, log=log,
                            timeout_s=30)
    assert (outcome.returncode, outcome.log_truncated) == (0, True)
    text = log_path.read_bytes()
    assert text.startswith(b"x" * 1024) and not text.startswith(b"x" * 1025)
    assert b"[log truncated at 1024 bytes (5001 written): raise with BENCHBOT_MAX_LOG_BYTES]" in text


def test_an_endless_grace_is_refused_before_the_child_starts(tmp_path, monkeypatch):
    monkeypatch.setenv("BENCHBOT_STOP_GRACE_S", "inf")
    marker = tmp_path / "started"
    with pytest.raises(UsageError, match="BENCHBOT_STOP_GRACE_S='inf'"):
        run_child([sys.executable, "-c", f"open({str(marker)!r}, 'w')"], cwd=tmp_path, env={}, timeout_s=30)
    assert not marker.exists()
