#!/bin/bash
# The held-out evaluation of 100 test homes of generator v3 on one H200: ../gpu_h200_2026-11-29_keyboards_val_100/gpu35.sh
# run unchanged (its header says what it carries and does); its log35.txt and challenge_signature.json are kept here
# as log39.txt and challenge_signature.json.
set -u
bash benchmarks/results/gpu_h200_2026-11-29_keyboards_val_100/gpu35.sh
