"""``benchbot install`` / ``benchbot uninstall``: plugin distributions (through uv or pip, into benchbot's own
environment) and content packs (folders in the original add-on layout, copied into the data directory)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path
from typing import Optional

import typer

from benchbot.core import settings
from benchbot.cli.common import err, handle_errors
from rich.markup import escape

from benchbot.packs.content_packs import install_pack, installed_packs, pack_name, uninstall_pack
from benchbot.packs.pack_layout import PackError
from benchbot.packs.original_addons import is_addon_folder
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
    choice = (settings.get("BENCHBOT_INSTALLER") or "").lower()
    uv = shutil.which("uv") if choice != "pip" else None
    if uv:
        return [uv, "pip", action, "--python", sys.executable, *targets]
    cmd = [sys.executable, "-m", "pip", action]
    if action == "uninstall":
        cmd.append("-y")
    return [*cmd, *targets]


def is_content_pack(target: str) -> bool:
    """A local folder without a Python project file that holds add-on type folders or an original add-on's
    ``.remote``/``.dependencies`` (:func:`benchbot.packs.original_addons.is_addon_folder`): never handed to pip."""
    return is_addon_folder(target)


def _looks_like_a_path(target: str) -> bool:
    """True for a target written as a local path (``./x``, ``../x``, ``/x``, ``~/x``, ``a/b``), not a requirement,
    URL or VCS reference (``name``, ``name==1.0``, ``https://…``, ``git+…``, ``name @ url``)."""
    if "://" in target or "@" in target or target.startswith("git+"):
        return False
    return target.startswith((".", "/", "~")) or "/" in target or "\\" in target


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
        err.print(f"  {escape(line)}", highlight=False)


def _print_pack(manifest: dict) -> None:
    """What installing a pack did (or, for --dry-run, would do): specs already provided, overrides, notes."""
    for line in manifest["provided"]:
        err.print(f"  {escape(line)}", highlight=False)
    for line in manifest["overridden"]:
        err.print(f"  [yellow]override:[/] {escape(line)}", highlight=False)
    for line in manifest["notes"]:
        err.print(f"  [dim]note:[/] {escape(line)}", highlight=False)
    for line in manifest.get("warnings", []):
        err.print(f"  [yellow]warning:[/] {escape(line)}", highlight=False)
    built_in = manifest.get("built_in") or {}
    new = {k: [n for n in v if n not in built_in.get(k, [])] for k, v in manifest["files"].items()}
    what = escape("; ".join(f"{k}: {', '.join(v)}" for k, v in new.items() if v) or "nothing new")
    if any(built_in.values()):
        what += escape("; already provided: " + "; ".join(f"{k}: {', '.join(v)}" for k, v in built_in.items() if v))
    where = f"content pack '{manifest['name']}' into {escape(manifest['path'])} ({what})"
    if manifest["dry_run"]:
        err.print(f"[green]would install[/] {where}; --dry-run: nothing changed", highlight=False)
    else:
        err.print(f"[green]installed[/] {where}", highlight=False)
    allowed = "code would be allowed:" if manifest["dry_run"] else "code allowed:"
    for line in manifest["code"]:
        err.print(f"  [yellow]{allowed}[/] {escape(line)}", highlight=False)


def register(app: typer.Typer) -> None:
    @app.command("install")
    @handle_errors
    def install(
        targets: list[str] = typer.Argument(..., help="Plugin distributions (PyPI name, path, URL) or content-pack folders."),
        allow_code: bool = typer.Option(False, "--allow-code", help="Allow content packs that contain Python functions or examples."),
        name: Optional[str] = typer.Option(None, "--name", help="Install a content pack under this name (one pack only)."),
        force: bool = typer.Option(False, "--force", help="Replace an installed content pack of the same name."),
        override: bool = typer.Option(False, "--override", help="Let a content pack's specs replace installed specs "
                                      "of the same name that differ (until the pack is uninstalled)."),
        dry_run: bool = typer.Option(False, "--dry-run", help="Run every check of the install and print the installer "
                                     "command; change nothing (same exit code as the install)."),
    ) -> None:
        """Install plugins (into benchbot's own environment, with uv or pip) or content packs (folders with
        tasks/, robots/, environments/, formats/, evaluation_methods/, ground_truths/, examples/, batches/,
        such as the original BenchBot add-ons).

        A spec identical in meaning to an installed one, or an original add-on's spec that a built-in plugin
        re-implements, is reported as already provided (the rest installs); a robot that no installed plugin can
        run is listed as unavailable, never put in place of a working one; a second ground truth of an environment
        is another set (benchbot eval --ground-truths). Any other spec that differs is a clash (exit 3) unless
        --override. An add-on whose content is a download (.remote) is explained, not installed (exit 3).

        Example: benchbot install benchbot-sim-foo ./my_pack
        """
        packs = [t for t in targets if is_content_pack(t)]
        dists = [t for t in targets if t not in packs]
        for target in dists:
            if _looks_like_a_path(target) and not Path(target).expanduser().exists():
                raise UsageError(f"no such file or folder: {target}",
                                 "check the path (a PyPI name has no '/'; a URL starts with https://)")
        if name and len(packs) != 1:
            raise UsageError("--name needs exactly one content pack", "install packs one at a time with --name")
        if override and not packs:
            raise UsageError("--override applies to content packs only", "give the folder of a content pack")
        # --dry-run takes the same path: every check, the same errors and exit code, nothing copied; one registry
        # for all its packs, into which each checked pack is staged as the real install would have installed it
        # (a real install checks each pack against what is installed when its turn comes)
        from benchbot.core.registry import Registry

        staging = Registry() if dry_run and packs else None
        for target in packs:
            try:
                manifest = install_pack(target, name=name, allow_code=allow_code, force=force, override=override,
                                        dry_run=dry_run, registry=staging if staging is not None else Registry())
            except PackError as exc:
                _print_details(exc)
                raise
            _print_pack(manifest)
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
