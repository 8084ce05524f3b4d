"""What a long command is doing, before it prints its result: in a terminal a status line with a spinner (replaced
by the result), in a log a plain line per step (no escape sequences). ``benchbot report`` and ``benchbot
leaderboard`` use it; ``benchbot doctor`` does the same with its checks."""

from __future__ import annotations

from benchbot.cli.common import err, is_tty


class Steps:
    """``with Steps() as say: say("reading runs/batch-1 (1 of 3)")``: each call names the step now under way."""

    def __enter__(self) -> "Steps":
        self.status = err.status("starting …", spinner="dots") if is_tty() else None
        if self.status is not None:
            self.status.start()
        return self

    def __call__(self, what: str) -> None:
        if self.status is not None:
            self.status.update(f"{what} …")
        else:
            err.print(f"{what} …", highlight=False, markup=False)

    def __exit__(self, *exc: object) -> None:
        if self.status is not None:
            self.status.stop()
