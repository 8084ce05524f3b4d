"""A SIGTERM stops a command that waits for Ctrl-C (``benchbot run --no-tui``, ``benchbot replay``) even when the
kernel delivers it to another thread than the main one: before, the main thread waited on a lock with no timeout and
was never woken, so the signal stayed pending and ``kill`` left the process running (seen once in CI, the process
still alive minutes later in ``threading.Event().wait()``)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time

# The signal goes to a helper thread (pthread_kill), which is what the kernel may do with a process-wide ``kill``
# when servers' threads run; the handler is the CLI's own (SIGTERM ends a command as Ctrl-C does).
SCRIPT = textwrap.dedent("""
    import signal, threading, time
    from benchbot.cli.common import wait_until_interrupted
    from benchbot.cli.main import _stop_as_on_ctrl_c

    signal.signal(signal.SIGTERM, _stop_as_on_ctrl_c)

    def terminate_from_this_thread():
        time.sleep(0.3)
        signal.pthread_kill(threading.get_ident(), signal.SIGTERM)

    threading.Thread(target=terminate_from_this_thread, daemon=True).start()
    try:
        wait_until_interrupted()
    except KeyboardInterrupt:
        print("stopped", flush=True)
""")


def test_a_sigterm_delivered_to_another_thread_stops_the_wait_for_ctrl_c():
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "stopped"
    assert time.monotonic() - started < 20  # stopped within a poll, not by the timeout
