#!/bin/bash
# usage: force.sh CLASS MODEL TAG ENVS...
cd "$(dirname "$0")/../../.." && mkdir -p runs/forced
cls=$1; model=$2; tag=$3; shift 3
envs=""; for e in "$@"; do envs="$envs --env $e"; done
for det in centernet nanodet ssd; do
  echo "== $tag $det $(date -u +%T)"
  if [ "$model" = none ]; then
    BENCHBOT_SCENE_CACHE_BYTES=0 uv run --extra realism python benchmarks/realism.py $envs --every 4 --quality-frames 0 --reference-frames 0 \
      --real-reference --detector $det --out runs/forced/r_${tag}_$det > runs/forced/r_${tag}_$det.log 2>&1
  else
    FORCE_CLASS=$cls FORCE_MODEL=$model BENCHBOT_SCENE_CACHE_BYTES=0 uv run --extra realism python benchmarks/results/cpu2_2026-11-27_forced_models/force_model.py $envs --every 4 --quality-frames 0 --reference-frames 0 \
      --real-reference --detector $det --out runs/forced/r_${tag}_$det > runs/forced/r_${tag}_$det.log 2>&1
  fi
  echo "rc $?"
done
