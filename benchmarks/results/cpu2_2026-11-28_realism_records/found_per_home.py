"""found_per_home.py A B: per home of two benchmarks/realism.py runs (folders A and B, the same frames), its lighting
and the fast-mode objects found at score >= 0.3 under COCO's crowd rule (the sim side of --real-reference), A -> B,
then the totals. Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-28_realism_records/found_per_home.py A B
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402


def found(run: Path) -> dict:
    """{environment: (objects found, lighting)} of a run folder."""
    d = json.loads((run / "realism.json").read_text())
    out = {}
    for env, e in d["environments"].items():
        n = 0
        for fr in e["frames"]:
            truths = R.with_crowd_rule([R.Truth(**o) for o in fr["objects"]])
            hits = R.score_frame(truths, fr.get("detections_fast", []), 0.3, crowd_rule=True).hits
            n += sum(bool(hits[t.instance]) for t in truths if t.visible)
        out[env] = (n, e["lighting"])
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: found_per_home.py A B", file=sys.stderr)
        return 1
    for run in map(Path, argv):
        if not (run / "realism.json").is_file():
            print(f"error: {run / 'realism.json'} not found: give the --out folders of two realism.py runs",
                  file=sys.stderr)
            return 1
    a, b = (found(Path(r)) for r in argv)
    if set(a) != set(b):
        print("error: the two runs are of different environments", file=sys.stderr)
        return 1
    for env in a:
        print(f"{env:12s} {a[env][1]:12s} {a[env][0]:4d} -> {b[env][0]:4d}")
    print(f"all {sum(v[0] for v in a.values())} -> {sum(v[0] for v in b.values())}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
