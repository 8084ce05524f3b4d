#!/bin/bash
# The apple_pc monitor's screen drawn dark (docs/history/realism-2026-11.md, *A dark screen for the pack's monitor*):
# the 100-procedural-home profile on one H200 from a fresh machine. The profile's steps are 28 Nov's, run unchanged
# (../gpu_h200_2026-11-28_procedural_val_100/gpu30.sh); its log30.txt and report30.json are kept here as log36.txt
# and report36.json (the batch JSONs and the runs' archive are not kept). The homes are generator v2's, as in
# ../gpu_h200_2026-11-29_keyboards_val_100/; only the monitor's screen is drawn otherwise.
# Run from the repository root on the device machine, carrying .whl/lead3 (tools/device_bundle.sh).
set -u
bash benchmarks/results/gpu_h200_2026-11-28_procedural_val_100/gpu30.sh
