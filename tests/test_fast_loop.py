"""The fast loop (root conftest.py): the default run leaves out tests marked slow and says so; ``-m slow``,
``--run-slow`` and a named file run them. Checked with pytest itself on a two-test project that uses this
repository's conftest, in this process (pytester's in-process run; the environment variables that conftest sets
when imported are put back after each run)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def environment_kept():
    """The process's environment, put back after the test (the conftest under test sets BENCHBOT_* variables)."""
    saved = dict(os.environ)
    yield
    os.environ.clear()
    os.environ.update(saved)


@pytest.fixture
def project(environment_kept, pytester, monkeypatch):
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")  # only pytest and this conftest: seconds faster
    pytester.makeconftest((ROOT / "conftest.py").read_text())
    pytester.makeini("[pytest]\ntestpaths = suite\nmarkers =\n    slow: slow\n")
    suite = pytester.mkdir("suite")
    (suite / "test_two.py").write_text(
        "import pytest\n\n\ndef test_quick():\n    pass\n\n\n@pytest.mark.slow\ndef test_long():\n    pass\n")
    return pytester


@pytest.mark.parametrize("args, passed, deselected", [
    ((), ["test_quick"], 1),                       # the default run: the fast loop
    (("-m", "slow"), ["test_long"], 1),             # CI's second step
    (("--run-slow",), ["test_quick", "test_long"], 0),
    (("suite/test_two.py",), ["test_quick", "test_long"], 0),  # a named file runs all of it
])
def test_the_default_run_leaves_out_slow_tests(project, args, passed, deselected):
    result = project.runpytest_inprocess("-v", "-p", "no:cacheprovider", *args)
    outcomes = result.parseoutcomes()
    assert outcomes.get("passed") == len(passed) and outcomes.get("deselected", 0) == deselected, result.stdout.str()
    for name in passed:
        result.stdout.fnmatch_lines([f"*::{name} PASSED*"])
    if not args:
        result.stdout.fnmatch_lines(["*tests marked slow are left out*", "1 slow tests left out of this fast run*"])


def test_ctrl_c_reaches_the_tests_commands_when_pytest_was_started_with_sigint_ignored(project):
    """A background start (`pytest … &` in a script, nohup) ignores SIGINT, and the children would inherit that: the
    conftest gives pytest Python's handler back, so a command a test starts handles Ctrl-C."""
    import signal
    import subprocess
    import sys

    (project.path / "suite" / "test_child.py").write_text(
        "import subprocess, sys\n\n\ndef test_child_handles_ctrl_c():\n"
        "    code = 'import signal, sys; sys.exit(signal.getsignal(signal.SIGINT) is not signal.default_int_handler)'\n"
        "    assert subprocess.run([sys.executable, '-c', code]).returncode == 0\n")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "suite/test_child.py"],
                          cwd=project.path, capture_output=True, text=True, timeout=120,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    assert proc.returncode == 0, proc.stdout[-2000:]
