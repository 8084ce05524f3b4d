"""``benchmarks/run_warm_start.py``'s ``start_once`` against a fake ``benchbot run`` (a script in place of the
interpreter that says ``backend ready`` and then behaves): a run that exits 130 on Ctrl-C is timed; one that ignores
Ctrl-C (started with SIGINT ignored) is killed after ``STOP_TIMEOUT_S`` and named in one error, instead of hanging the
benchmark and leaving the run behind. The real commands run in the benchmark's smoke mode
(``tests/test_benchmarks_smoke.py``)."""

from __future__ import annotations

import importlib.util
import os
import sys
import time
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "run_warm_start.py"

FAKE_RUN = '''#!{python}
import signal, sys, time
{handling}
try:
    sys.stderr.write("backend ready at http://127.0.0.1:1/\\n")
    sys.stderr.flush()
    time.sleep(30)
except KeyboardInterrupt:
    sys.exit(130)
sys.exit(0)
'''


@pytest.fixture()
def warm_start(monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))  # the script imports its neighbour benchmarks/smoke.py
    spec = importlib.util.spec_from_file_location("run_warm_start_benchmark", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _fake(tmp_path: Path, handling: str) -> str:
    path = tmp_path / "fake_python"
    path.write_text(FAKE_RUN.format(python=sys.executable, handling=handling))
    path.chmod(0o755)
    return str(path)


def test_a_run_that_exits_130_on_ctrl_c_is_timed(warm_start, tmp_path, monkeypatch):
    monkeypatch.setattr(warm_start.sys, "executable", _fake(tmp_path, "signal.signal(signal.SIGINT, "
                                                                       "signal.default_int_handler)"))
    result = warm_start.start_once(["--env", "miniroom:1"], dict(os.environ))
    assert result["stop_s"] < 10 and result["ready_s"] < 10 and result["started"] is False


def test_a_run_that_ignores_ctrl_c_is_killed_and_named(warm_start, tmp_path, monkeypatch):
    monkeypatch.setattr(warm_start.sys, "executable", _fake(tmp_path, "signal.signal(signal.SIGINT, signal.SIG_IGN)"))
    monkeypatch.setattr(warm_start, "STOP_TIMEOUT_S", 1.0)
    t = time.monotonic()
    with pytest.raises(RuntimeError, match=r"did not exit within 1 s of Ctrl-C \(SIGINT\); killed it"):
        warm_start.start_once(["--env", "miniroom:1"], dict(os.environ))
    assert time.monotonic() - t < 10  # not the fake's 30 s
