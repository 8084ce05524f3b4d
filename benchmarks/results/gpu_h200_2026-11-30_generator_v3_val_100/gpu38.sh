#!/bin/bash
# Generator v3 (the floor in front of every refrigerator kept clear; every procedural home new): the
# 100-procedural-home profile on one H200 from a fresh machine, then the digests of the same 100 homes as this host
# made them, to compare with the 2-core CPU's (tools/world_digests.py --compare). The profile's steps are 28 Nov's,
# run unchanged (../gpu_h200_2026-11-28_procedural_val_100/gpu30.sh); its log30.txt and report30.json are kept here
# as log38.txt and report38.json, with digests38.json (the batch JSONs and the runs' archive are not kept).
# Run from the repository root on the device machine, carrying .whl/lead3 (tools/device_bundle.sh).
set -u
R=$PWD
bash benchmarks/results/gpu_h200_2026-11-28_procedural_val_100/gpu30.sh
cd /root/w || exit 9
T=$(date +%s.%N)
PYTHONPATH=/tmp/semP:/tmp/site BENCHBOT_CACHE_DIR=/root/w/cache python3 "$R/tools/world_digests.py" --split val \
  --count 100 -o "$OUT/digests38.json" > /root/w/digests.txt 2>&1
echo "digests rc $?, $(python3 -c "import time,sys; print(f'{time.time() - float(sys.argv[1]):.1f}')" $T) s" | tee -a "$OUT/log30.txt"
tail -2 /root/w/digests.txt | tee -a "$OUT/log30.txt"
