"""Writing procedural homes as a content pack (``benchbot worlds generate``): a folder in the original add-on
layout that ``benchbot install`` validates like any other — ``ground_truths/<home>_<variant>.json`` (the five
variants' BEAR-format files), ``environments/<home>_<variant>.yaml`` (type ``world``; ``map_path`` and
``home_files`` relative to the environment file), ``batches/<pack>.yaml`` (variant 1 of every home) and
``README.md`` (what made it). The pack is built in a temporary folder beside the target and moved into place, so a
failed or interrupted run leaves no half pack.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

import yaml

from benchbot.core.errors import UsageError
from benchbot.core.limits import MAX_GENERATED_HOMES
from benchbot_worlds.procedural import splits
from benchbot_worlds.procedural.worlds import environment_spec, home_files, home_name


def _environment_yaml(spec: dict, home: str, variant: int) -> str:
    spec = dict(spec)
    spec["map_path"] = f"../ground_truths/{home}_{variant}.json"
    spec["home_files"] = [f"../ground_truths/{home}_{v}.json" for v in range(1, 6)]
    return yaml.safe_dump(spec, sort_keys=False, width=120)


def check_request(split: str, start: int, count: int, out: Path, *, force: bool) -> None:
    """Refuse, in one line with the fix, an unknown split, a negative start, a count outside
    1..:data:`~benchbot.core.limits.MAX_GENERATED_HOMES`, or an existing ``out`` without ``force``.

    Raises:
        UsageError: one of those.
    """
    if split not in splits.SPLITS:
        raise UsageError(f"--split {split!r} is no split of procedural homes", f"use one of: {', '.join(splits.SPLITS)}")
    if start < 0:
        raise UsageError(f"--start {start} is negative", "home indices start at 0")
    most = int(MAX_GENERATED_HOMES.value())
    if not 1 <= count <= most:
        raise UsageError(f"--count {count} is outside 1..{most}",
                         f"a pack holds at most {most} homes (BENCHBOT_MAX_GENERATED_HOMES); write several packs with "
                         "--start")
    if out.exists() and not force:
        raise UsageError(f"{out} exists", "choose another folder, or --force to replace it")


def write_pack(split: str, start: int, count: int, out: Path, *, force: bool = False,
               advance: Callable[[str], None] | None = None) -> Path:
    """Write homes ``start`` .. ``start + count - 1`` of ``split`` as a content pack at ``out`` (module docstring);
    ``advance(home)`` is called after each home. Returns ``out``.

    Raises:
        UsageError: as :func:`check_request`. SpecError: the test split without this host's key.
    """
    check_request(split, start, count, out, force=force)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        for sub in ("environments", "ground_truths", "batches"):
            (tmp / sub).mkdir()
        homes = []
        for index in range(start, start + count):
            home = home_name(split, index)
            files = home_files(split, index)
            for variant, path in enumerate(files, start=1):
                shutil.copyfile(path, tmp / "ground_truths" / f"{home}_{variant}.json")
                spec = environment_spec(path, files, split, index)
                (tmp / "environments" / f"{home}_{variant}.yaml").write_text(
                    _environment_yaml(spec, home, variant), encoding="utf-8")
            homes.append(home)
            if advance is not None:
                advance(home)
        name = out.name.replace("-", "_")
        (tmp / "batches" / f"{name}.yaml").write_text(yaml.safe_dump(
            {"name": name, "description": f"variant 1 of procedural homes {start}..{start + count - 1} of split "
                                          f"{split}", "environments": [f"{h}:1" for h in homes]}, sort_keys=False),
            encoding="utf-8")
        from benchbot_worlds.procedural.generator import GENERATOR_VERSION

        (tmp / "README.md").write_text(
            f"# {out.name}\n\nProcedural homes {start}..{start + count - 1} of split `{split}`, written by "
            f"`benchbot worlds generate` (benchbot-worlds procedural generator v{GENERATOR_VERSION}). Each home has "
            "five variants (lighting base, day, night, day_extra, night_extra; objects added, removed and moved as "
            "in BEAR). Install with `benchbot install` and run with `--envs-batch " + name + "`.\n"
            + ("\nThis is the held-out **test** split: keep the pack on the scoring host; its ground truth must not "
               "reach a solution.\n" if split == splits.HELD_OUT else ""), encoding="utf-8")
        if out.exists():
            shutil.rmtree(out)
        os.replace(tmp, out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return out
