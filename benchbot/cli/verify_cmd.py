"""``benchbot verify RUN``: check a signed run directory (docs/challenge.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from benchbot.cli.common import err, handle_errors, out
from benchbot.core.errors import ExitCode


def register(app: typer.Typer) -> None:
    @app.command("verify")
    @handle_errors
    def verify(
        run: Path = typer.Argument(..., help="A run directory with a signature.json (`benchbot challenge evaluate`)."),
        key: Optional[list[Path]] = typer.Option(None, "--key", help="A trusted host's public key "
                                                 "(host_key.pub.pem; repeat the flag for several); without it only "
                                                 "the signature's own key is used."),
    ) -> None:
        """Check a signed run: the signature over the results files' hashes, the scores, the conditions, the
        versions and the isolation is valid, by a trusted key, and every covered file is as it was signed. Prints
        one line, "verified: …" (exit 0) or what fails (exit 1)."""
        from benchbot.batch.signing import check_run, load_public_key

        trusted = [load_public_key(k) for k in key or []]
        result = check_run(run, trusted)
        if result.ok:
            out.print(f"verified: {result.message}", highlight=False, markup=False)
            return
        word = {"unsigned": "not verified", "untrusted": "not verified"}.get(result.status, "verification failed")
        err.print(f"{word}: {result.message}", highlight=False, markup=False)
        raise typer.Exit(int(ExitCode.FAILURE))
