#!/bin/bash
# issue 59: the 100-procedural-home profile again after the cabinet over the fridge (d06a386: every procedural
# refrigerator that backs onto a wall gets a wall cabinet over it), on one H200 from a fresh machine. The same steps
# as 28 Nov's runs: gpu_h200_2026-11-28_procedural_val_100/gpu30.sh, run unchanged. Its files come back under $OUT
# with that script's names; log30.txt and report30.json are kept here as log32.txt and report32.json (the batch
# JSONs and the runs' archive are not kept).
# Run from the repository root on the device machine, carrying .whl/lead3 (tools/device_bundle.sh).
exec bash benchmarks/results/gpu_h200_2026-11-28_procedural_val_100/gpu30.sh
