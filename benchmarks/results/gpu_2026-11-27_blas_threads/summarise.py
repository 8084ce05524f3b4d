"""README command 1 warm on CUDA, a9833bd ("after": a lone episode leaves the solution's BLAS/OpenMP variables unset)
against the code before it ("before": every core's threads), from the service_warm.py files of gpu26 and gpu27 in
this folder: median wall time per call and both calls together, and a two-sided Mann-Whitney U test (SciPy).

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
    for call in ("sw26", "sw27"):
        w = walls[call, version]
        print(f"{call[2:]} {version:6s} median {statistics.median(w):.2f} s of {len(w)} runs ({min(w):.2f}-{max(w):.2f})")
    every = walls["sw26", version] + walls["sw27", version]
    print(f"both  {version:6s} median {statistics.median(every):.2f} s of {len(every)} runs")
a = walls["sw26", "after"] + walls["sw27", "after"]
b = walls["sw26", "before"] + walls["sw27", "before"]
print(f"after < before: Mann-Whitney U {mannwhitneyu(a, b).statistic:.0f}, p = {mannwhitneyu(a, b).pvalue:.3f}")
