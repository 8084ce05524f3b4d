#!/bin/bash
# issue 60 call 5: why the fusion thread changes results on a GPU host: FP state per thread, concurrent BLAS, or a
# frame's shared memory overwritten while the fusion thread reads it (a patched copy checks each frame's bytes).
set -u
R=$PWD
T0=$(date +%s)
el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log15.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nproc
mkdir -p /tmp/site /tmp/bsite /tmp/semB /tmp/semD /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semB plugins/task_semslam || exit 7
cp -a /tmp/semB/. /tmp/semD/
python3 .whl/lead3/patch_check.py /tmp/semD/benchbot_task_semslam/examples/semslam_geometric/semslam_geometric.py || exit 8
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site /tmp/semB /tmp/semD $(for p in numpy scipy yaml msgpack anyio h11 attr attrs pygments idna sniffio typing_extensions.py packaging; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PATH=/tmp/site/bin:$PATH PYTHONUNBUFFERED=1
cd /root/w
echo "-- threads, OPENBLAS_NUM_THREADS=1"; OPENBLAS_NUM_THREADS=1 PYTHONPATH=/tmp/semB:/tmp/site python3 "$R/.whl/lead3/thread_fp.py" 2>&1 | head -9
echo "-- threads, OPENBLAS_NUM_THREADS unset"; PYTHONPATH=/tmp/semB:/tmp/site python3 "$R/.whl/lead3/thread_fp.py" 2>&1 | head -9
mkdir -p /tmp/rt && chmod 700 /tmp/rt
export XDG_RUNTIME_DIR=/tmp/rt BENCHBOT_SERVICE=auto PYTHONPATH=/tmp/semD:/tmp/site
B="python3 -m benchbot.cli batch --example semslam_geometric --envs miniroom:3,miniroom:1,house:2 --repeat 10 --workers 30 --arch cuda --json --no-tui"
for k in 0 1 2; do
  s=$(date +%s.%N); timeout 150 $B --output-dir /root/w/D$k > /dev/null 2>"$OUT/err_D$k.txt"; rc=$?
  echo "D run $k rc=$rc $(python3 -c "print(round($(date +%s.%N)-$s,1))") s at $(el) s"
  grep -rh "SHMCHECK" /root/w/D$k/*/logs/ | sort | uniq -c
done
python3 "$R/.whl/lead3/rep_hash.py" /root/w/D0 /root/w/D1 /root/w/D2
grep -rl "SHMCHECK changed [1-9]" /root/w/D*/*/logs/ | head -5
python3 -m benchbot.cli service stop > /dev/null 2>&1
echo "== done at $(el) s"
