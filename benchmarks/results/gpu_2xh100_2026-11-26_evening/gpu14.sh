#!/bin/bash
# issue 60 call 4: are the example's results the same in every episode of the same environment on a GPU host, with
# the fusion thread (B) and without it (C)? And does a product depend on alignment on this CPU?
set -u
R=$PWD
T0=$(date +%s)
el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log14.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc; lscpu | grep "Model name"
mkdir -p /tmp/site /tmp/bsite /tmp/semB /tmp/semC /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semB plugins/task_semslam || exit 7
cp -a /tmp/semB/. /tmp/semC/
G=/tmp/semC/benchbot_task_semslam/examples/semslam_geometric/semslam_geometric.py
sed -i 's/def __init__(self, fuse_ahead: bool = True/def __init__(self, fuse_ahead: bool = False/' $G; grep -c "fuse_ahead: bool = False" $G
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site /tmp/semB /tmp/semC $(for p in numpy scipy yaml msgpack anyio h11 attr attrs pygments idna sniffio typing_extensions.py packaging; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PATH=/tmp/site/bin:$PATH PYTHONUNBUFFERED=1
cd /root/w
PYTHONPATH=/tmp/site python3 "$R/.whl/lead3/align_dev.py"
mkdir -p /tmp/rt && chmod 700 /tmp/rt
export XDG_RUNTIME_DIR=/tmp/rt BENCHBOT_SERVICE=auto
B="python3 -m benchbot.cli batch --example semslam_geometric --envs miniroom:3,miniroom:1,house:2 --repeat 10 --workers 30 --arch cuda --json --no-tui"
for v in B C; do
  export PYTHONPATH=/tmp/sem$v:/tmp/site
  for k in 0 1 2 3; do
    s=$(date +%s.%N); timeout 150 $B --output-dir /root/w/$v$k > /dev/null 2>"$OUT/err_$v$k.txt"; rc=$?
    echo "$v run $k rc=$rc $(python3 -c "print(round($(date +%s.%N)-$s,1))") s at $(el) s"
  done
  echo "-- $v (fuse ahead: $([ $v = B ] && echo on || echo off)), runs 1-3 (run 0 warmed up):"
  python3 "$R/.whl/lead3/rep_hash.py" /root/w/${v}1 /root/w/${v}2 /root/w/${v}3
  echo "-- $v with run 0:"; python3 "$R/.whl/lead3/rep_hash.py" /root/w/${v}0 /root/w/${v}1 /root/w/${v}2 /root/w/${v}3
  python3 -m benchbot.cli service stop > /dev/null 2>&1
done
echo "== done at $(el) s"
