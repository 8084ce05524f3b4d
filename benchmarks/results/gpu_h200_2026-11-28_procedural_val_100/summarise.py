"""summarise.py [REPORT [BEFORE]]: the figures of a `benchbot report --json` of the two 100-home sweeps (REPORT,
default gpu30.sh's report30.json here) beside those of an earlier one for the same 100 homes (BEFORE, default 26
Nov's, 5b9fc67's): each solution's OMQ with its 95 % BCa interval, the paired difference, and how far each home
moved. Run from the repository root:

    uv run python benchmarks/results/gpu_h200_2026-11-28_procedural_val_100/summarise.py
    uv run python benchmarks/results/gpu_h200_2026-11-28_procedural_val_100/summarise.py \
        benchmarks/results/gpu_h200_2026-11-28_book_piles_val_100/report31.json \
        benchmarks/results/gpu_h200_2026-11-28_procedural_val_100/report30.json
"""
import json
import sys
from pathlib import Path

HERE = Path(__file__).parent
BEFORE = HERE.parent / "gpu_h200_2026-11-26_procedural_val_100_final_report.json"


def interval(v: dict) -> str:
    """'value [low, high]' of one of `benchbot report --json`'s interval dicts, to 4 decimals."""
    return f"{v['value']:.4f} [{v['low']:.4f}, {v['high']:.4f}]"


def main() -> None:
    """Print each solution's OMQ then and now, how its homes moved, and the paired difference then and now."""
    paths = [Path(a) for a in sys.argv[1:3]]
    paths += [HERE / "report30.json", BEFORE][len(paths):]
    for p in paths:
        if not p.is_file():
            sys.exit(f"summarise.py: {p}: no such file; give the JSON of `benchbot report RUN_A RUN_B --json`")
    now, then = (json.loads(p.read_text()) for p in paths)
    for run_now, run_then in zip(now["runs"], then["runs"]):
        homes_now = {k: v["value"] for k, v in run_now["environments"].items()}
        homes_then = {k: v["value"] for k, v in run_then["environments"].items()}
        moved = sorted(homes_now[k] - homes_then[k] for k in homes_then)
        print(f"{run_now['label']}: OMQ {interval(run_then['summary']['OMQ'])} (before) -> "
              f"{interval(run_now['summary']['OMQ'])}; homes up {sum(d > 0 for d in moved)}, "
              f"down {sum(d < 0 for d in moved)}, by {moved[0]:+.4f} to {moved[-1]:+.4f}")
    for label, report in (("before", then), ("now", now)):
        c = report["comparisons"][0]
        a, b = (r["environments"] for r in report["runs"])
        higher = sum(b[k]["value"] > a[k]["value"] for k in a)
        print(f"{label}: {c['b']} - {c['a']} {interval(c['difference'])}, d_z {c['cohens_dz']:.2f}, "
              f"t-test p {c['ttest_p']:.1e}; higher in {higher} of {len(a)} homes")


if __name__ == "__main__":
    main()
