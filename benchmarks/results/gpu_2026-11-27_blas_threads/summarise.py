"""README command 1 warm on CUDA, a9833bd ("after": a lone episode leaves the solution's BLAS/OpenMP variables unset)
against the code before it ("before": every core's threads), from the service_warm.py files of gpu26 and gpu27
(2 x H200, 32 cores) and gpu29 (one H100, 16 cores) in this folder: median wall time per call, gpu26 and gpu27
together, and a two-sided Mann-Whitney U test of each (SciPy).

    uv run python benchmarks/results/gpu_2026-11-27_blas_threads/summarise.py
"""
import json
import statistics
from pathlib import Path

from scipy.stats import mannwhitneyu

here = Path(__file__).parent
walls: dict = {}
for f in sorted(here.glob("sw2*_*.json")):
    call, version, _ = f.stem.split("_")
    d = json.loads(f.read_text())["service"]
    walls.setdefault((call, version), []).extend(d["wall_s"])
for version in ("after", "before"):
    for call in ("sw26", "sw27", "sw29"):
        w = walls[call, version]
        print(f"{call[2:]} {version:6s} median {statistics.median(w):.2f} s of {len(w)} runs ({min(w):.2f}-{max(w):.2f})")
    every = walls["sw26", version] + walls["sw27", version]
    print(f"26+27 {version:6s} median {statistics.median(every):.2f} s of {len(every)} runs")
for name, calls in (("2 x H200 (gpu26, gpu27)", ("sw26", "sw27")), ("H100 (gpu29)", ("sw29",))):
    a = [w for c in calls for w in walls[c, "after"]]
    b = [w for c in calls for w in walls[c, "before"]]
    test = mannwhitneyu(a, b)
    print(f"{name}: after against before, Mann-Whitney U {test.statistic:.0f}, p = {test.pvalue:.3f}")
