"""The optimal assignment loaded without ``scipy.optimize`` (benchbot_eval_omq.assignment)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np

from benchbot_eval_omq import assignment


def test_scoring_loads_the_assignment_without_scipy_optimize_and_it_is_scipys_own_function():
    # a fresh interpreter: what this test's process imported before cannot hide an import of scipy.optimize
    code = textwrap.dedent("""
        import sys
        import numpy as np
        from benchbot_eval_omq import assignment
        solve = assignment.linear_sum_assignment()
        rows, cols = solve(np.array([[4.0, 1.0, 3.0], [2.0, 0.0, 5.0]], np.float32))
        assert "scipy.optimize" not in sys.modules, "scipy.optimize was imported"
        assert (rows.tolist(), cols.tolist()) == ([0, 1], [1, 0]), (rows, cols)
        import scipy.optimize
        assert scipy.optimize.linear_sum_assignment is solve, "not the function scipy.optimize exports"
        print("ok")
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr[-2000:]


def test_falls_back_to_scipy_optimize_when_the_compiled_module_cannot_be_loaded(monkeypatch):
    from scipy.optimize import linear_sum_assignment as public

    monkeypatch.setattr(assignment, "_function", None)
    monkeypatch.setattr(assignment, "_load_compiled", lambda: None)
    assert assignment.linear_sum_assignment() is public
    rng = np.random.default_rng(0)
    cost = rng.random((5, 9)).astype(np.float32)
    rows, cols = assignment.linear_sum_assignment()(cost)
    assert rows.tolist() == [0, 1, 2, 3, 4] and len(set(cols.tolist())) == 5
