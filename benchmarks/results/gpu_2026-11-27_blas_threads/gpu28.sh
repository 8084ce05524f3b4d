#!/bin/bash
# issue 60 call 28: the ten-home sweep x 3 (30 episodes, semslam_geometric, 30 workers through the service, both GPUs),
# warm, on the code of 79b50cd (the rasteriser's atomic always, a6a5fe2; the minirooms' basin kept open, 11535dc):
# its wall time, whether every run's results are byte-identical, and the GPUs' utilisation (benchmarks/sweep.py).
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log28.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
rm -rf /tmp/site /tmp/bsite /tmp/semP /root/w
mkdir -p /tmp/site /tmp/bsite /tmp/semP /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semP plugins/task_semslam || exit 7
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site /tmp/semP $(for p in numpy scipy yaml msgpack anyio h11 attr attrs pygments idna sniffio typing_extensions.py packaging PIL; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX OMP_NUM_THREADS OPENBLAS_NUM_THREADS MKL_NUM_THREADS
export PATH=/tmp/site/bin:$PATH PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/semP:/tmp/site
cd /root/w
python3 -c "import time; t=time.perf_counter(); s=0
for i in range(10_000_000): s+=i
print('10M loop', round(time.perf_counter()-t,3))"
timeout $(( 570 - $(el) )) python3 "$R/benchmarks/sweep.py" --repeat 3 --envs-batch bear_all --arch cuda --modes service \
  --workers 30 --runs 3 --json-file "$OUT/sweep28.json" > /dev/null
echo "sweep rc=$? at $(el) s"
python3 - "$OUT/sweep28.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(" identical", d["byte_identical"], "differ", d.get("differing_files"))
for r in d["runs"]: print(" ", r.get("warm_up"), r["wall_s"], r["digest"], r["stages_s"].get("solution per frame"), r["gpu_utilisation"])
PY
echo "== done at $(el) s"
