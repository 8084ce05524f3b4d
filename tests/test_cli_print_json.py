"""``--json`` outputs (benchbot.cli.common.print_json): into a pipe they are written as they are, byte for byte what
Rich's highlighted printing gives there, without its cost; in a terminal Rich highlights them."""

from __future__ import annotations

import io
import json
import subprocess
import sys

import numpy as np
from rich.console import Console

from benchbot.cli import common

DATA = {"run_dir": "/tmp/runs/batch-ü", "episodes": [{"env": "miniroom:1", "wall_s": 1.25, "node": {}}],
        "scores": {"OMQ": float("nan"), "ok": True, "none": None}, "array": np.arange(3)}


def test_into_a_pipe_the_bytes_are_richs_without_rich(monkeypatch, capsys):
    monkeypatch.setattr(common, "out", Console(file=io.StringIO(), force_terminal=False, width=160))
    common.print_json(DATA, default=lambda o: o.tolist())
    written = capsys.readouterr().out
    rich = Console(file=io.StringIO(), force_terminal=False, soft_wrap=True, width=160)
    rich.print_json(json.dumps(DATA, default=lambda o: o.tolist()))
    assert written == rich.file.getvalue()
    assert "ü" in written and json.loads(written.replace("NaN", "null"))["array"] == [0, 1, 2]


def test_in_a_terminal_rich_highlights_it(monkeypatch):
    screen = Console(file=io.StringIO(), force_terminal=True, color_system="standard", width=160)
    monkeypatch.setattr(common, "out", screen)
    common.print_json({"OMQ": 0.5})
    shown = screen.file.getvalue()
    assert "\x1b[" in shown and "OMQ" in shown


def test_a_command_prints_json_a_pipe_can_read():
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "list", "robots", "--json"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert any(row.get("name") == "carter" for row in json.loads(proc.stdout))
