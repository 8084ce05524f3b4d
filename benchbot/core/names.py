"""'Did you mean …?': the hint of every unknown name (environments, tasks, robots, formats, evaluators, examples,
batches, ground truths, actions, and the kinds of ``benchbot list``).

:func:`close_names` finds candidates close to a mistyped name: whole-name similarity (difflib), similarity to one
``:``-separated part (``semslam`` → ``semantic_slam:passive:ground_truth``), or containment. :func:`did_you_mean`
turns that into the hint line the CLI prints; when nothing is close it lists what exists (up to
:data:`MAX_LISTED` names) instead of leaving the user with nothing.
"""

from __future__ import annotations

import difflib

#: A candidate is "close" from this similarity on (difflib ratio, 0..1; difflib's own default cutoff).
CLOSE_RATIO = 0.6
#: At most this many close names are suggested.
MAX_SUGGESTED = 3
#: Only names this close to the best match are suggested (``move_nxt``: move_next, not also move_angle).
CLOSE_MARGIN = 0.1
#: When nothing is close, a hint lists every known name if there are at most this many (else it points to
#: ``benchbot list``).
MAX_LISTED = 12


def _similarity(query: str, candidate: str) -> float:
    q, c = query.lower(), candidate.lower()
    ratios = [difflib.SequenceMatcher(None, q, part).ratio() for part in [c, *c.split(":")] if part]
    best = max(ratios, default=0.0)
    if len(q) >= 3 and (q in c or c in q):
        best = max(best, CLOSE_RATIO)
    return best


def close_names(name: str, candidates: list[str], limit: int = MAX_SUGGESTED) -> list[str]:
    """Up to ``limit`` of ``candidates`` close to ``name`` (case-insensitive), closest first (ties by name); only
    those within :data:`CLOSE_MARGIN` of the closest. ``name`` itself is never suggested; ``[]`` when nothing is
    close. Raises nothing."""
    scored = [(s, c) for c in candidates if c != name and (s := _similarity(name, c)) >= CLOSE_RATIO]
    best = max((s for s, _ in scored), default=0.0)
    return [c for s, c in sorted(scored, key=lambda sc: (-sc[0], sc[1])) if s >= best - CLOSE_MARGIN][:limit]


def _grouped(names: list[str]) -> list[str]:
    """``house:1 … house:5, miniroom:1`` → ``house:1..5``-style groups: ``['house (variants 1, 2, 3, 4, 5)',
    'miniroom (variant 1)']``; names without a variant are kept."""
    groups: dict[str, list[str]] = {}
    for n in names:
        base, sep, variant = n.partition(":")
        groups.setdefault(base if sep else n, []).append(variant if sep else "")
    out = []
    for base, variants in groups.items():
        variants = [v for v in variants if v]
        out.append(f"{base} (variant{'s' if len(variants) > 1 else ''} {', '.join(variants)})" if variants else base)
    return out


def did_you_mean(name: str, candidates: list[str], kind: str) -> str:
    """The hint for an unknown ``name`` among ``candidates`` (the names of ``kind``, e.g. ``environments``).

    Environments and ground truths (``name:variant``): a known name with an unknown variant lists that name's
    variants. Otherwise close names are suggested; failing that every name is listed when there are at most
    :data:`MAX_LISTED` (environments grouped by name), else the hint points to ``benchbot list KIND``.
    """
    listing = f"`benchbot list {kind}`"
    if kind in ("environments", "ground_truths") and ":" in name:
        base = name.split(":", 1)[0]
        variants = [c.split(":", 1)[1] for c in candidates if c.split(":", 1)[0] == base]
        if variants:
            return f"{base} has variant{'s' if len(variants) > 1 else ''} {', '.join(variants)}, e.g. {base}:{variants[0]}"
    close = close_names(name, candidates)
    if close:
        return f"did you mean {', '.join(close)}?"
    if not candidates:
        return f"none is installed (see {listing}, `benchbot plugins`)"
    shown = _grouped(candidates) if kind in ("environments", "ground_truths") else list(candidates)
    if len(shown) <= MAX_LISTED:
        return f"known {kind.replace('_', ' ')}: {', '.join(shown)} (see {listing})"
    return f"see {listing}"
