#!/bin/bash
# issue 59: the 100-procedural-home profile again after the book piles (d01efd4: every procedural book cuboid, thicker
# than one book could be, drawn as a pile of books instead of one brick), on one H200 from a fresh machine. The same
# steps as 28 Nov's run before the change: gpu_h200_2026-11-28_procedural_val_100/gpu30.sh, run unchanged. Its files
# come back under $OUT with that script's names; log30.txt and report30.json are kept here as log31.txt and
# report31.json (the batch JSONs and the runs' archive are not kept).
# Run from the repository root on the device machine, carrying .whl/lead3 (tools/device_bundle.sh).
exec bash benchmarks/results/gpu_h200_2026-11-28_procedural_val_100/gpu30.sh
