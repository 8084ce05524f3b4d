#!/bin/bash
# issue 60 call 25: raster._keep always atomic (the working tree, F) against HEAD 55f1650's read-first _keep (H):
# house:1's render rate with one camera on CUDA, 4 rounds in turns on GPU 0, 2,000 frames a run (gpu24 had 2 rounds).
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log25.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
mkdir -p /tmp/site /tmp/bsite /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
SP=/opt/torch/.venv/lib/python3.12/site-packages
cp -a /tmp/site /tmp/siteH && cp .whl/lead3/raster_head.py /tmp/siteH/benchbot_sim_taichi/render/raster.py || exit 8
grep -c "plain read first" /tmp/site/benchbot_sim_taichi/render/raster.py /tmp/siteH/benchbot_sim_taichi/render/raster.py
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PYTHONUNBUFFERED=1
cd /root/w
v() { local a=$1; shift; local site=/tmp/site; [ $a = H ] && site=/tmp/siteH
  env PYTHONPATH=$site BENCHBOT_CACHE_DIR=/root/w/c$a TI_OFFLINE_CACHE_FILE_PATH=/root/w/c$a/ticache "$@"; }
RB="$R/benchmarks/render.py --env house:1 --arch cuda --host-copy none --no-embree --json"
CUDA_VISIBLE_DEVICES=0 v H timeout 200 python3 $RB --frames 3 > /dev/null 2> /root/w/wH.err & P1=$!
CUDA_VISIBLE_DEVICES=1 v F timeout 200 python3 $RB --frames 3 > /dev/null 2> /root/w/wF.err & P2=$!
wait $P1 $P2 || { tail -3 /root/w/wH.err /root/w/wF.err; exit 9; }; echo "warm-ups done at $(el) s"
for r in 1 2 3 4; do for a in H F; do
  CUDA_VISIBLE_DEVICES=0 v $a timeout 60 python3 $RB --batch 1 --frames 2000 2>/dev/null > /root/w/rb.json
  python3 -c "import json; d=json.load(open('/root/w/rb.json')); print('$a', 'batch', d['batch'], 'fps', round(d['fps']), 'ms_per_frame', round(d['ms_per_frame'], 4), d.get('gpu'))"
done; done; echo "== done at $(el) s"
