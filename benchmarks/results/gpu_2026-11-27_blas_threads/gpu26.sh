#!/bin/bash
# issue 60 call 26: README command 1 warm on CUDA through the service (benchmarks/service_warm.py), in turns with a9833bd
# (a lone episode leaves the solution's BLAS/OpenMP thread variables unset, so the example takes one BLAS thread) and
# with the code before it (the batch set them to every core: executors.py's condition taken out again), on one host.
# First, what the solution is given in each (a native solution printing its variables).
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
N=${CALL:-26}  # gpu27: CALL=27 ORDER="before after", the same rounds in the other order; gpu29: CALL=29 on one H100
exec > >(tee -a "$OUT/log$N.txt") 2>&1
echo "== $(date -u +%FT%TZ) $(git -C "$R" rev-parse --short HEAD 2>/dev/null)"; nvidia-smi -L; nproc
rm -rf /tmp/site /tmp/bsite /tmp/semP /root/w
mkdir -p /tmp/site /tmp/bsite /tmp/semP /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semP plugins/task_semslam || exit 7
EX=/tmp/site/benchbot/batch/executors.py
cp $EX /tmp/after.py
sed 's/ and min(workers, len(todo)) > 1\]/]/' /tmp/after.py > /tmp/before.py
cmp -s /tmp/after.py /tmp/before.py && { echo "the patch did not apply"; exit 9; }
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site /tmp/semP $(for p in numpy scipy yaml msgpack anyio h11 attr attrs pygments idna sniffio typing_extensions.py packaging PIL; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX OMP_NUM_THREADS OPENBLAS_NUM_THREADS MKL_NUM_THREADS
export PATH=/tmp/site/bin:$PATH PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/semP:/tmp/site
cd /root/w
mkdir -p /tmp/rt && chmod 700 /tmp/rt
export XDG_RUNTIME_DIR=/tmp/rt BENCHBOT_SERVICE=auto BENCHBOT_CACHE_DIR=/root/w/cache
use() { cp /tmp/$1.py $EX && python3 -m py_compile $EX; }
REPORT="python3 -c \"import os; print('solution threads', *(os.environ.get(k) for k in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS')))\""
for v in after before; do
  use $v
  timeout 200 python3 -m benchbot.cli batch --native "$REPORT" --envs miniroom:1 --arch cuda --no-tui --camera-size 64x48 \
    --output-dir /root/w/threads_$v > /dev/null 2>"$OUT/err_threads_$v.txt"
  echo "$v: $(grep -h 'solution threads' /root/w/threads_$v/*/logs/* 2>/dev/null | head -1) (rc $?, at $(el) s)"
done
python3 -m benchbot.cli service stop > /dev/null 2>&1
for k in 1 2; do
  for v in ${ORDER:-after before}; do
    [ $(el) -lt 480 ] || break
    use $v
    echo "== README command 1 warm, CUDA, $v, round $k, at $(el) s"
    BENCHBOT_TAICHI_ARCH=cuda timeout $(( 580 - $(el) )) python3 "$R/benchmarks/service_warm.py" --runs 5 --modes service --json > "$OUT/sw${N}_${v}_$k.json" \
      && python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(json.dumps(d))" "$OUT/sw${N}_${v}_$k.json"
  done
done
echo "== done at $(el) s"
