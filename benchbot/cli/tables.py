"""Cells and labels of the CLI's score tables (``benchbot eval``, ``submit --evaluate-with``, ``batch``).

* Counts (``TP``, ``FP``, ``FN``) are integers: ``15``, not ``15.0000``; a mean of counts over several results
  keeps at most two decimals (``14.5``).
* Rows of the same environment (repeats, several robots, several files) are told apart by their results file.
* Counts of things read "1 episode", "2 episodes" (:func:`plural`).
"""

from __future__ import annotations

from pathlib import PurePath

#: Score keys that count objects: shown as integers.
COUNT_KEYS = frozenset({"TP", "FP", "FN"})


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
    (repeats, a robot sweep, several files), the results file's name after it: ``miniroom:1 (001_miniroom_1_r1)``."""
    seen: dict[str, int] = {}
    for _, env in rows:
        seen[env] = seen.get(env, 0) + 1
    labels = []
    for source, env in rows:
        if seen[env] > 1:
            name = PurePath(str(source).replace(":", "/")).name  # a zip member "a.zip:x.json" → "x.json"
            labels.append(f"{env} ({name.removesuffix('.json')})")
        else:
            labels.append(env)
    return labels
