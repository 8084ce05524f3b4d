#!/bin/bash
# issue 60 call 24: raster._keep always atomic (the working tree, F) against HEAD 55f1650's read-first _keep (H):
# house:1 render rate on CUDA in turns on GPU 0 (one camera; 256 cameras a launch); then the gpu18 batch with
# BENCHBOT_SIM_CHECK_RENDERS=1 on F (30 workers, both GPUs): any render-check warning, any episode unlike the others?
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log24.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
mkdir -p /tmp/site /tmp/bsite /tmp/semP /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semP plugins/task_semslam || exit 7
python3 .whl/lead3/patch_frames.py /tmp/semP/benchbot_task_semslam/examples/semslam_geometric/semslam_geometric.py || exit 8
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site /tmp/semP $(for p in numpy scipy yaml msgpack anyio h11 attr attrs pygments idna sniffio typing_extensions.py packaging PIL; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
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
for r in 1 2; do for a in H F; do for b in 1 256; do
  fr=$(( b == 1 ? 1000 : 5120 ))
  CUDA_VISIBLE_DEVICES=0 v $a timeout 100 python3 $RB --batch $b --frames $fr 2>/dev/null > /root/w/rb.json
  python3 -c "import json; d=json.load(open('/root/w/rb.json')); print('$a', 'batch', d['batch'], 'fps', round(d['fps']), 'ms_per_frame', round(d['ms_per_frame'], 4), d.get('gpu'))"
done; done; done; echo "render rates done at $(el) s"
mkdir -p /tmp/rt && chmod 700 /tmp/rt
export XDG_RUNTIME_DIR=/tmp/rt BENCHBOT_SERVICE=auto PYTHONPATH=/tmp/semP:/tmp/site BENCHBOT_CACHE_DIR=/root/w/cF TI_OFFLINE_CACHE_FILE_PATH=/root/w/cF/ticache PATH=/tmp/site/bin:$PATH
B="python3 -m benchbot.cli batch --example semslam_geometric --envs miniroom:3,miniroom:1,house:2 --repeat 10 --workers 30 --arch cuda --json --no-tui"
run() { s=$(date +%s.%N); BENCHBOT_SIM_CHECK_RENDERS=1 timeout 200 $B --output-dir /root/w/$1 > /dev/null 2>"/root/w/err_$1.txt"; rc=$?
  echo "run $1 rc=$rc $(python3 -c "print(round($(date +%s.%N)-$s,1))") s at $(el) s"; }
run S1_0; [ -n "$(ls /root/w/S1_0/*/results/ 2>/dev/null)" ] || { tail -5 "/root/w/err_S1_0.txt"; exit 10; }
for k in 1 2 3 4 5 6 7 8 9 10 11; do [ $(el) -lt 470 ] && run S1_$k; done
BENCHBOT_SIM_CHECK_RENDERS=1 python3 -m benchbot.cli service stop > /dev/null 2>&1
python3 "$R/.whl/lead3/frame_diff.py" /root/w/S1_*
echo "render-check warnings: $(grep -c "render check" cF/service/service.log)"; ls -la cF/service/
grep -h "render check" cF/service/service.log | cut -c1-300 | head -5
echo "== done at $(el) s"
