"""fast_quality_table.py RUN: from a run of benchmarks/realism.py made with --quality-frames and --real-reference,
the quality frames in fast and in quality mode against the photos: found / objects (COCO's crowd rule) and sim / real
with its 95 % interval, overall and per class (most sim objects first). Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-28_realism_records/fast_quality_table.py RUN
"""
import json
import sys
from pathlib import Path


def cell(v: dict) -> str:
    def f(x):
        return "–" if x is None else "∞" if x == "inf" else f"{x:.2f}"
    return f"{f(v['value'])} [{f(v['ci95'][0])}, {f(v['ci95'][1])}]"


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: fast_quality_table.py RUN", file=sys.stderr)
        return 1
    path = Path(argv[0]) / "realism.json"
    if not path.is_file():
        print(f"error: {path} not found: give the --out folder of a realism.py run", file=sys.stderr)
        return 1
    real = json.loads(path.read_text()).get("real_reference", {})
    if "quality" not in real:
        print(f"error: {path} has no quality-mode comparison: run realism.py with --quality-frames and "
              "--real-reference", file=sys.stderr)
        return 1
    fast, quality = real["fast_same_frames"], real["quality"]
    print(f"{quality['images_sim']} frames, {quality['images_real']} photos")
    print("| class | fast: found; sim / real | quality: found; sim / real |\n|---|---|---|")
    names = ["overall"] + sorted(quality["classes"], key=lambda c: -quality["classes"][c]["objects_sim"])
    for name in names:
        a = fast["overall"] if name == "overall" else fast["classes"][name]
        b = quality["overall"] if name == "overall" else quality["classes"][name]
        print(f"| {name} | {a['found_sim']}/{a['objects_sim']}; {cell(a['ratio'])} "
              f"| {b['found_sim']}/{b['objects_sim']}; {cell(b['ratio'])} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
