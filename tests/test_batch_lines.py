"""A batch's plain lines (its finished episodes and its closing line) are written without the live view's Textual."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from benchbot.batch.narration import format_seconds


def test_format_seconds():
    assert (format_seconds(None), format_seconds(59.6), format_seconds(61), format_seconds(3725)) == \
        ("", "1:00", "1:01", "1:02:05")


def test_episode_and_closing_lines_do_not_import_textual():
    # a fresh interpreter (the subject is what gets imported): a batch into a log, or README command 1 run by a
    # script, prints these lines; Textual took 0.15 s to import on the 2-core CPU
    code = textwrap.dedent("""
        import sys
        from types import SimpleNamespace
        from benchbot.cli.batch_cmd import batch_summary, episode_line
        record = SimpleNamespace(status="ok", steps=48, wall_s=6.4, error=None, returncode=0)
        print(episode_line(record, "[1/1] miniroom:1"))
        outcome = SimpleNamespace(episodes=[SimpleNamespace(status="ok", env="miniroom:1")], evaluation=None)
        print(batch_summary(outcome, 7.2))
        print("textual" in sys.modules)
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    episode, summary, textual = proc.stdout.splitlines()[-3:]
    assert "ok" in episode and "48 steps" in episode and "0:06" in episode
    assert summary.startswith("1 episode: 1 ok in 0:07")
    assert textual == "False"
