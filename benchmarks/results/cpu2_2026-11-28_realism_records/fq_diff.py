"""fq_diff.py RUN [CLASS]: in a run of benchmarks/realism.py made with --quality-frames, the visible objects (of
CLASS, if given) found in quality mode and not in fast mode on the same frame, and the other way round (score >= the
run's first threshold, IoU >= 0.5, every visible object counted: no crowd rule). Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-28_realism_records/fq_diff.py RUN [CLASS]
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402


def main(argv: list[str]) -> int:
    if len(argv) not in (1, 2):
        print("usage: fq_diff.py RUN [CLASS]", file=sys.stderr)
        return 1
    path = Path(argv[0]) / "realism.json"
    if not path.is_file():
        print(f"error: {path} not found: give the --out folder of a realism.py run", file=sys.stderr)
        return 1
    only = argv[1] if len(argv) > 1 else None
    d = json.loads(path.read_text())
    threshold = d["thresholds"][0]
    gain, loss = [], []
    for env, e in d["environments"].items():
        for fr in e["frames"]:
            if "detections_quality" not in fr:
                continue
            truths = [R.Truth(**o) for o in fr["objects"]]
            fast = R.score_frame(truths, fr["detections_fast"], threshold).hits
            quality = R.score_frame(truths, fr["detections_quality"], threshold).hits
            for t in truths:
                if t.visible and (only is None or t.cls == only) and bool(fast[t.instance]) != bool(quality[t.instance]):
                    (gain if quality[t.instance] else loss).append(f"{env} pose {fr['pose_index']} {t.cls} "
                                                                   f"{t.instance} ({t.pixels} px)")
    if not gain and not loss and not any("detections_quality" in fr for e in d["environments"].values()
                                         for fr in e["frames"]):
        print(f"error: {path} has no quality-mode detections: run realism.py with --quality-frames", file=sys.stderr)
        return 1
    print(f"found in quality mode only: {len(gain)}", *gain, sep="\n  ")
    print(f"found in fast mode only: {len(loss)}", *loss, sep="\n  ")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
