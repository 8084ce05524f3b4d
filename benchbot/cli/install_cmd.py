"""``benchbot install`` / ``benchbot uninstall``: plugin distributions (through uv or pip, into benchbot's own
environment) and content packs (folders in the original add-on layout, copied into the data directory)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Optional

import typer

from benchbot.cli.common import err, handle_errors
from benchbot.core.content_packs import FOLDER_KINDS, PackError, install_pack, installed_packs, pack_name, uninstall_pack
from benchbot.core.errors import BenchbotError, UsageError

PROTECTED = {"benchbot"}


class InstallError(BenchbotError):
    """The package installer failed."""


def installer_command(action: str, targets: list[str]) -> list[str]:
    """The command that installs/uninstalls ``targets`` into the environment of ``sys.executable``.

    ``uv pip`` when ``uv`` is on PATH (or ``$BENCHBOT_INSTALLER=uv``), else ``python -m pip``
    (``$BENCHBOT_INSTALLER=pip`` forces it).

    Args:
        action: ``install`` or ``uninstall``.
        targets: requirement strings, paths or URLs.
    """
    choice = os.environ.get("BENCHBOT_INSTALLER", "").strip().lower()
    uv = shutil.which("uv") if choice != "pip" else None
    if uv:
        return [uv, "pip", action, "--python", sys.executable, *targets]
    cmd = [sys.executable, "-m", "pip", action]
    if action == "uninstall":
        cmd.append("-y")
    return [*cmd, *targets]


def is_content_pack(target: str) -> bool:
    """A local folder holding add-on type folders and no Python project file."""
    path = Path(target).expanduser()
    if not path.is_dir() or any((path / f).exists() for f in ("pyproject.toml", "setup.py", "setup.cfg")):
        return False
    return any(p.is_dir() for p in path.rglob("*") if p.name in FOLDER_KINDS)


def _run_installer(action: str, targets: list[str], dry_run: bool) -> None:
    cmd = installer_command(action, targets)
    err.print(("would run: " if dry_run else "running: ") + " ".join(cmd), highlight=False)
    if dry_run:
        return
    proc = subprocess.run(cmd)
    if proc.returncode != 0:
        raise InstallError(f"{Path(cmd[0]).name} {action} failed (exit code {proc.returncode}) for: {' '.join(targets)}",
                           "read the installer's output above; check the name, path or URL and the network")


def _print_details(exc: PackError) -> None:
    for line in exc.details:
        err.print(f"  {line}", highlight=False)


def register(app: typer.Typer) -> None:
    @app.command("install")
    @handle_errors
    def install(
        targets: list[str] = typer.Argument(..., help="Plugin distributions (PyPI name, path, URL) or content-pack folders."),
        allow_code: bool = typer.Option(False, "--allow-code", help="Allow content packs that contain Python functions or examples."),
        name: Optional[str] = typer.Option(None, "--name", help="Install a content pack under this name (one pack only)."),
        force: bool = typer.Option(False, "--force", help="Replace an installed content pack of the same name."),
        dry_run: bool = typer.Option(False, "--dry-run", help="Validate packs and print the installer command; change nothing."),
    ) -> None:
        """Install plugins (into benchbot's own environment, with uv or pip) or content packs (folders with
        tasks/, robots/, environments/, formats/, evaluation_methods/, ground_truths/, examples/, batches/).

        Example: benchbot install benchbot-sim-foo ./my_pack
        """
        packs = [t for t in targets if is_content_pack(t)]
        dists = [t for t in targets if t not in packs]
        if name and len(packs) != 1:
            raise UsageError("--name needs exactly one content pack", "install packs one at a time with --name")
        for target in packs:
            try:
                if dry_run:
                    from benchbot.core.content_packs import verify_pack

                    scan = verify_pack(target, name)
                    if scan.errors:
                        raise PackError(f"pack '{scan.name}' has {len(scan.errors)} problem(s)", "fix the files listed above", scan.errors)
                    err.print(f"pack '{scan.name}' is valid ({len(scan.files)} files)" + (f"; contains code: {len(scan.code)} place(s)" if scan.code else ""))
                    continue
                manifest = install_pack(target, name=name, allow_code=allow_code, force=force)
            except PackError as exc:
                _print_details(exc)
                raise
            what = "; ".join(f"{k}: {', '.join(v)}" for k, v in manifest["files"].items())
            err.print(f"[green]installed[/] content pack '{manifest['name']}' into {manifest['path']} ({what})", highlight=False)
            for line in manifest["code"]:
                err.print(f"  [yellow]code allowed:[/] {line}", highlight=False)
        if dists:
            _run_installer("install", dists, dry_run)
            if not dry_run:
                err.print("[green]installed[/]; `benchbot plugins` shows what they register and any load errors")

    @app.command("uninstall")
    @handle_errors
    def uninstall(
        names: list[str] = typer.Argument(..., help="Content-pack names or plugin distribution names."),
        dry_run: bool = typer.Option(False, "--dry-run", help="Print what would be removed; change nothing."),
    ) -> None:
        """Uninstall content packs (by pack name) or plugin distributions (by distribution name)."""
        pack_names = {p["name"] for p in installed_packs()}
        dists = []
        for target in names:
            try:
                is_pack = pack_name(target) in pack_names
            except PackError:
                is_pack = False
            if is_pack:
                if dry_run:
                    err.print(f"would remove content pack '{pack_name(target)}'")
                    continue
                where = uninstall_pack(target)
                err.print(f"[green]removed[/] content pack '{pack_name(target)}' ({where})", highlight=False)
            elif target.lower().replace("_", "-") in PROTECTED:
                raise UsageError(f"refusing to uninstall '{target}' (benchbot itself)", "use uv/pip directly if you mean it")
            else:
                dists.append(target)
        if dists:
            _run_installer("uninstall", dists, dry_run)
