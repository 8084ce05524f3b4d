"""profile_json.py DETECTOR_RUN GEOMETRIC_RUN NOTE OUT.json: the ten-home profile's record (the format of
``benchmarks/results/cpu2_2026-11-27_semslam_detector_ten_homes*.json``) from two ``benchbot batch`` run folders:
each environment's scores from their ``episode_scores.json`` and the three summary lines of
``benchbot report GEOMETRIC DETECTOR --json``, run here; ``date`` is the day it runs (UTC). Run from the repository
root:

    uv run python benchmarks/results/cpu2_2026-11-27_realism_records/profile_json.py \
        runs/batch-A runs/batch-B "the tree of ..." benchmarks/results/NAME.json
"""
import datetime
import json
import subprocess
import sys
from pathlib import Path

if len(sys.argv) != 5:
    sys.exit("usage: profile_json.py DETECTOR_RUN GEOMETRIC_RUN NOTE OUT.json")
detector, geometric, note, out = sys.argv[1:5]


def per_environment(run: str) -> dict:
    """{environment: its episode's scores} of a batch run folder (its ``episode_scores.json``)."""
    path = Path(run) / "episode_scores.json"
    if not path.is_file():
        sys.exit(f"{path}: not found; give the folder of a finished `benchbot batch` run")
    return {e["env"]: e["scores"] for e in json.loads(path.read_text())}


done = subprocess.run(["uv", "run", "benchbot", "report", geometric, detector, "--json"], capture_output=True,
                      text=True)
if done.returncode != 0:
    sys.exit(f"benchbot report {geometric} {detector} failed: {(done.stderr.strip().splitlines() or ['?'])[-1]}")
report = json.loads(done.stdout)


def omq(run: dict) -> str:
    s = run["summary"]["OMQ"]
    return f"OMQ over {s['n']} environments {s['value']:.4g} [{s['low']:.4g}, {s['high']:.4g}]"


c = report["comparisons"][0]
d = c["difference"]
better = sum(x > 0 for x in c["differences"])
diff = (f"over {c['n']} environments: mean difference {d['value']:.4g} [{d['low']:.4g}, {d['high']:.4g}], paired "
        f"t-test p = {c['ttest_p']:.4g}, Wilcoxon p = {c['wilcoxon_p']:.4g}, better in {better} of {c['n']}")
record = {
    "date": datetime.datetime.now(datetime.timezone.utc).date().isoformat(),
    "machine": "2-core development CPU (no GPU)",
    "commands": ["uv run benchbot batch --example semslam_detector --envs-batch bear_all --no-tui",
                 "uv run benchbot batch --example semslam_geometric --envs-batch bear_all --no-tui",
                 "uv run benchbot report GEOMETRIC DETECTOR"],
    "note": note,
    "reports": {"semslam_detector": omq(report["runs"][1]), "semslam_geometric": omq(report["runs"][0]),
                "detector - geometric": diff},
    "batches": {"semslam_detector, furnished": {"run_dir": Path(detector).name,
                                                "per_environment": per_environment(detector)},
                "semslam_geometric, furnished": {"run_dir": Path(geometric).name,
                                                 "per_environment": per_environment(geometric)}},
}
Path(out).write_text(json.dumps(record, indent=1, ensure_ascii=False) + "\n")
print("\n".join(record["reports"].values()))
