"""headline_table.py CENTERNET.md NANODET.md SSD.md [YOLO.md]: docs/realism.md's table *Where it stands: against real
photos*, printed from the real-photo sections of three or four ``per_class.md`` files of ``benchmarks/realism.py
--real-reference`` (CenterNet, NanoDet, SSD and, given, YOLOv4-tiny, in that order). The classes with fewer than 10
sim objects share one row of found counts.
Run from the repository root, e.g.:

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/headline_table.py \\
        benchmarks/results/cpu2_2026-11-29_realism_10homes_every4_real_reference_bed_clear_{centernet,nanodet,ssd}_per_class.md
"""
import re
import sys
from pathlib import Path

FEW = 10  # sim objects under this: the class goes into the shared row
NAMES = ("CenterNet", "NanoDet", "SSD", "YOLOv4-tiny")  # the detectors, in the order of the files
ALL = "**all (sim's class × size mix)**"  # the all-classes row's first cell
ROW = re.compile(r"^\| (?P<cls>[^|]+?) \| (?P<sim>\d+) % [^|]*\| (?P<real>\d+) % [^|]*\| (?P<ratio>[^|]+?) \| "
                 r"(?P<fs>\d+)/(?P<ns>\d+); (?P<fr>\d+)/(?P<nr>\d+) \|$")


def real_section(path: Path) -> tuple[list[dict], dict]:
    """(the class rows in file order, the all-classes row) of ``path``'s real-photo table; exits with one line if
    the file cannot be read or has no such table."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        sys.exit(f"{path}: cannot read it ({e}); give the per_class.md files of benchmarks/realism.py")
    if "COCO val2017 photos" not in text:
        sys.exit(f"{path}: no real-photo table (run benchmarks/realism.py with --real-reference)")
    section = text[text.index("COCO val2017 photos"):].splitlines()
    rows = [m.groupdict() for line in section if (m := ROW.match(line))]
    total = [r for r in rows if r["cls"] == ALL]
    if not total:
        sys.exit(f"{path}: its real-photo table has no row {ALL}")
    return [r for r in rows if r["cls"] != ALL], total[0]


def cell(r: dict) -> str:
    """One detector's cell: sim recall · real recall · **ratio** [interval] (the ratio's † kept)."""
    ratio = r["ratio"].strip()
    head, _, rest = ratio.partition(" ")
    return f"{r['sim']} · {r['real']} · **{head}** {rest}"


def main(paths: list[str]) -> None:
    if len(paths) not in (3, 4):
        sys.exit("usage: headline_table.py CENTERNET.md NANODET.md SSD.md [YOLO.md]")
    tables = [real_section(Path(p)) for p in paths]
    by_class = [{r["cls"]: r for r in rows} for rows, _ in tables]
    for path, classes in zip(paths[1:], by_class[1:]):
        if classes.keys() != by_class[0].keys():
            sys.exit(f"{path}: its classes differ from {paths[0]}'s; give runs of the same homes")
    print("| class | objects sim; photos | " + " | ".join(NAMES[:len(paths)]) + " |")
    print("|---|---|" + "---|" * len(paths))
    few = []
    for r in tables[0][0]:
        c = r["cls"]
        if int(r["ns"]) < FEW:
            few.append(c)
            continue
        print(f"| {c} | {r['ns']}; {r['nr']} | " + " | ".join(cell(t[c]) for t in by_class) + " |")
    if few:
        ns, nr = (sum(int(by_class[0][c][k]) for c in few) for k in ("ns", "nr"))
        found = [f"found: {sum(int(t[c]['fs']) for c in few)} of {ns}; {sum(int(t[c]['fr']) for c in few)} of {nr}"
                 for t in by_class]
        print(f"| {', '.join(few)} | {ns}; {nr} | " + " | ".join(found) + " |")
    t0 = tables[0][1]
    print(f"| {ALL} | {t0['ns']}; {t0['nr']} | "
          + " | ".join(cell(t) for _, t in tables) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
