"""scores_across_machines.py A.json B.json: two records of the ten-home profile (the format of
``benchmarks/results/cpu2_2026-11-27_semslam_detector_ten_homes*.json``, made by
``cpu2_2026-11-27_realism_records/profile_json.py``), say of the same code on two machines: per example and
environment, both OMQs in full precision, their difference, and whether TP, FP and FN are the same; then per
example the largest difference. Run from the repository root:

    python3 benchmarks/results/cpu2_2026-11-29_realism_records/scores_across_machines.py \
        benchmarks/results/cpu2_2026-11-28_semslam_detector_ten_homes_real_blacks.json \
        benchmarks/results/cpu2_2026-11-29_semslam_detector_ten_homes_another_machine.json
"""
import json
import sys

if len(sys.argv) != 3:
    sys.exit("usage: scores_across_machines.py A.json B.json")


def batches(path: str) -> dict:
    """The ``batches`` of a profile record; exits with one line if the file is missing or not such a record."""
    try:
        with open(path) as f:
            return json.load(f)["batches"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f"{path}: not a ten-home profile record ({type(e).__name__}); give a file made by profile_json.py")


a, b = batches(sys.argv[1]), batches(sys.argv[2])
for batch in sorted(set(a) & set(b)):
    worst, counts_differ = 0.0, 0
    for env, sa in a[batch]["per_environment"].items():
        sb = b[batch]["per_environment"][env]
        d = sb["OMQ"] - sa["OMQ"]
        same = all(sa[k] == sb[k] for k in ("TP", "FP", "FN"))
        worst, counts_differ = max(worst, abs(d)), counts_differ + (not same)
        verdict = "same" if same else "differ"
        print(f"{batch:30s} {env:11s} {sa['OMQ']:.17f} {sb['OMQ']:.17f} {d:+.2e} TP/FP/FN {verdict}")
    print(f"{batch}: largest difference {worst:.2e}; TP/FP/FN differ in {counts_differ} environments")
