"""Compare a COCO detector's recall in two sets of homes from ``benchmarks/realism.py``'s ``per_class.md`` files:
the raw recall (found / visible over every class) and the recall of the first set standardised to the second's class
mix (each class's recall in the first set, weighted by its visible count in the second), so that homes that show
more tables or books — classes every detector misses more often — are compared class for class.

    uv run python benchmarks/realism_compare.py GENERATED/per_class.md BEAR/per_class.md [--json]
    uv run python benchmarks/realism_compare.py --smoke     # two files of benchmarks/results

Reads the first table of each file (all environments, fast mode, score ≥ 0.3); prints one line.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

ROW = re.compile(r"\| ([a-z ]+) \| (\d+)/(\d+) \|")


def per_class(path: Path) -> dict[str, tuple[int, int]]:
    """``{class: (found, visible)}`` of the first table of a ``per_class.md`` (up to its 'all classes' row)."""
    rows: dict[str, tuple[int, int]] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        if "all classes" in line:
            break
        m = ROW.match(line)
        if m and m[1] not in rows:
            rows[m[1]] = (int(m[2]), int(m[3]))
    return rows


def compare(first: dict, second: dict) -> dict:
    """Raw recalls of both, and the first's standardised to the second's mix over the classes both show."""
    common = [c for c in second if c in first and first[c][1] > 0 and second[c][1] > 0]
    weight = sum(second[c][1] for c in common)
    return {
        "raw_first": sum(f for f, _ in first.values()) / sum(v for _, v in first.values()),
        "raw_second": sum(f for f, _ in second.values()) / sum(v for _, v in second.values()),
        "first_in_second_mix": sum(second[c][1] * first[c][0] / first[c][1] for c in common) / weight,
        "second_same_classes": sum(second[c][0] for c in common) / weight,
        "classes": len(common),
    }


def main(argv: list[str] | None = None) -> int:
    import smoke

    results = Path(__file__).resolve().parent / "results"
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("first", type=Path, nargs="?")
    ap.add_argument("second", type=Path, nargs="?")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, style=None,  # the smoke run compares two files of benchmarks/results
                            first=results / "cpu2_2026-11-26_realism_procedural_val_10_every4_per_class.md",
                            second=results / "cpu2_2026-11-25_realism_10homes_every4_original_camera_per_class.md")
    if args.first is None or args.second is None:
        ap.error("give two per_class.md files")
    out = compare(per_class(args.first), per_class(args.second))
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        print(f"recall: first {out['raw_first']:.1%}, second {out['raw_second']:.1%}; the first in the second's class "
              f"mix {out['first_in_second_mix']:.1%} against {out['second_same_classes']:.1%} ({out['classes']} classes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
