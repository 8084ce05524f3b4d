#!/bin/bash
# issue 60 call 21: the gpu18 batch (30 workers, miniroom:3, miniroom:1, house:2, 8 batches through one service) with
# BENCHBOT_SIM_CHECK_RENDERS=1: does a pose rendered twice at once give two images where an episode received an odd one?
# Then README command 1 warm through a service of its own (benchmarks/service_warm.py, CUDA).
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log21.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
mkdir -p /tmp/site /tmp/bsite /tmp/semP /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semP plugins/task_semslam || exit 7
python3 .whl/lead3/patch_frames.py /tmp/semP/benchbot_task_semslam/examples/semslam_geometric/semslam_geometric.py || exit 8
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site /tmp/semP $(for p in numpy scipy yaml msgpack anyio h11 attr attrs pygments idna sniffio typing_extensions.py packaging PIL; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PATH=/tmp/site/bin:$PATH PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/semP:/tmp/site
cd /root/w
mkdir -p /tmp/rt && chmod 700 /tmp/rt
export XDG_RUNTIME_DIR=/tmp/rt BENCHBOT_SERVICE=auto BENCHBOT_CACHE_DIR=/root/w/cache
B="python3 -m benchbot.cli batch --example semslam_geometric --envs miniroom:3,miniroom:1,house:2 --repeat 10 --workers 30 --arch cuda --json --no-tui"
run() { s=$(date +%s.%N); BENCHBOT_SIM_CHECK_RENDERS=1 timeout 240 $B --output-dir /root/w/$1 > /dev/null 2>"$OUT/err_$1.txt"; rc=$?
  echo "run $1 rc=$rc $(python3 -c "print(round($(date +%s.%N)-$s,1))") s at $(el) s"; }
run S1_0; [ -n "$(ls /root/w/S1_0/*/results/ 2>/dev/null)" ] || { tail -5 "$OUT/err_S1_0.txt"; exit 10; }
for k in 1 2 3 4 5 6 7 8 9; do [ $(el) -lt 360 ] && run S1_$k; done
BENCHBOT_SIM_CHECK_RENDERS=1 python3 -m benchbot.cli service stop > /dev/null 2>&1
python3 "$R/.whl/lead3/frame_diff.py" /root/w/S1_*
echo "== render-check warnings in the service log:"
grep -h "render check" cache/service/service.log | cut -c1-400
echo "kept: $(ls cache/sim_taichi-render-checks 2>/dev/null | wc -l)"
python3 "$R/.whl/lead3/render_pairs.py" cache/sim_taichi-render-checks
tar -C /root/w -czf "$OUT/logs21.tgz" cache/service/service.log $(ls cache/sim_taichi-render-checks/*.npz 2>/dev/null | head -6) 2>/dev/null
echo "== README command 1 warm, CUDA, at $(el) s"
[ $(el) -lt 470 ] && BENCHBOT_TAICHI_ARCH=cuda timeout $(( 570 - $(el) )) python3 "$R/benchmarks/service_warm.py" --runs 5 --modes service --json > "$OUT/service_warm21.json" && python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(json.dumps(d)[:1500])" "$OUT/service_warm21.json"
echo "== done at $(el) s"
