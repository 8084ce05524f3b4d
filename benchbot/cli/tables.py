"""Cells and labels of the CLI's score tables (``benchbot eval``, ``submit --evaluate-with``, ``batch``).

* Counts (the scores a method declares of kind ``count``, docs/evaluation.md) are integers: ``15``, not
  ``15.0000``; a mean of counts over several results keeps at most two decimals (``14.5``).
* Rows of the same environment (repeats, several robots, several files) are told apart by their results file (a
  batch's by its episode number, ``miniroom:1 #3``).
* Counts of things read "1 episode", "2 episodes" (:func:`plural`).
* A table too wide for the terminal drops its outer and vertical borders rather than cut a value (:func:`fit`).
"""

from __future__ import annotations

from pathlib import PurePath

from rich import box
from rich.console import Console
from rich.table import Table


def plural(n: int, noun: str) -> str:
    """``plural(1, 'episode')`` → ``'1 episode'``; ``plural(4, 'episode')`` → ``'4 episodes'``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def count_cell(value: object) -> str:
    """A count as text: ``15`` and ``15.0`` → ``'15'``; ``14.5`` → ``'14.5'``; ``37.333…`` → ``'37.33'``;
    anything that is not a number as ``str``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    if float(value).is_integer():
        return str(int(value))
    return f"{value:.2f}".rstrip("0").rstrip(".")


def row_labels(rows: list[tuple[str, str]]) -> list[str]:
    """Labels for ``(source, environment)`` rows: the environment, and where an environment appears more than once
    (repeats, a robot sweep, several files), the results file's name after it: ``miniroom:1 (mine)``, or for a
    batch's ``NNN_<env>.json`` files the episode number that the batch's table and logs use: ``miniroom:1 #1``."""
    seen: dict[str, int] = {}
    for _, env in rows:
        seen[env] = seen.get(env, 0) + 1
    labels = []
    for source, env in rows:
        if seen[env] > 1:
            name = PurePath(str(source).replace(":", "/")).name.removesuffix(".json")  # "a.zip:x.json" → "x"
            episode = name.split("_", 1)[0]
            if episode.isdigit() and name[len(episode):].strip("_").startswith(env.replace(":", "_")):
                labels.append(f"{env} #{int(episode)}")  # a batch's NNN_<env>.json: its episode number
            else:
                labels.append(f"{env} ({name})")
        else:
            labels.append(env)
    return labels


def fit(table: Table, console: Console) -> Table:
    """``table`` as it fits ``console``'s width: unchanged when it does, else without its outer edge and vertical
    borders (a simple rule under the header), which saves three characters a column, so that no value is cut."""
    # Rich crops rather than shrink a no-wrap column below its header, so count what the columns need
    needed = sum(max(c.min_width or 0, len(str(c.header)) if c.no_wrap else 0) + 3 for c in table.columns) + 1
    if needed > console.width:
        table.box, table.show_edge, table.pad_edge = box.SIMPLE_HEAD, False, False
    return table
