"""Print how two ``benchmarks/realism.py`` runs differ class by class: found / visible at score ≥ 0.3 (the first table
of each ``per_class.md``, all environments, fast mode) for every class that differs, then every class together, with
the recall in %. The runs may show different homes (a generator change moves objects), so a class's row compares
rates, not the same objects (``../cpu2_2026-11-30_mugs/paired.py`` does that for the same frames).

    uv run python benchmarks/results/cpu2_2026-11-30_workstations/class_changes.py BEFORE.md AFTER.md [BEFORE2.md AFTER2.md ...]

Pairs of files are summed class by class (e.g. two sets of homes). A missing or unreadable file is one line and exit 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def _sum(paths: list[Path]) -> dict[str, list[int]]:
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from realism_compare import per_class

    out: dict[str, list[int]] = {}
    for p in paths:
        for cls, (found, visible) in per_class(p).items():
            row = out.setdefault(cls, [0, 0])
            row[0] += found
            row[1] += visible
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="+", type=Path, help="BEFORE.md AFTER.md, repeated")
    args = ap.parse_args(argv)
    if len(args.files) % 2:
        ap.error("give the per_class.md files in pairs: BEFORE.md AFTER.md")
    for p in args.files:
        if not p.is_file():
            print(f"error: {p}: no such file; give the per_class.md of a realism.py run", file=sys.stderr)
            return 2
    before, after = _sum(args.files[0::2]), _sum(args.files[1::2])
    total = [0, 0, 0, 0]
    print("| class | before | after |\n|---|---|---|")
    for cls in sorted(set(before) | set(after)):
        a, b = before.get(cls, [0, 0]), after.get(cls, [0, 0])
        total = [total[0] + a[0], total[1] + a[1], total[2] + b[0], total[3] + b[1]]
        if a != b:
            print(f"| {cls} | {a[0]}/{a[1]} | {b[0]}/{b[1]} |")
    pct = [100 * total[0] / max(total[1], 1), 100 * total[2] / max(total[3], 1)]
    print(f"| all | {total[0]}/{total[1]} ({pct[0]:.1f} %) | {total[2]}/{total[3]} ({pct[1]:.1f} %) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
