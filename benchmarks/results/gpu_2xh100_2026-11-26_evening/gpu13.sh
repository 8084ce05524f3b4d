#!/bin/bash
# issue 60 call 3: A/B on one host: the example's mapping at 8f9d338 (A) and the working tree (B): README command 1
# warm through the service on CUDA, and the ten-home sweep x 3 (30 workers, both GPUs); then two cold bakes compared.
set -u
R=$PWD
T0=$(date +%s)
el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log13.txt") 2>&1
echo "== $(date -u +%FT%TZ) B = worktree on $(git log -1 --format=%h 2>/dev/null || cat .whl/lead3/head.txt)"; nvidia-smi -L; nproc
mkdir -p /tmp/site /tmp/bsite /tmp/semA /tmp/semB /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
cp plugins/task_semslam/benchbot_task_semslam/models/*.onnx .whl/lead3/old/plugins/task_semslam/benchbot_task_semslam/models/
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semA .whl/lead3/old/plugins/task_semslam || exit 6
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semB plugins/task_semslam || exit 7
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site /tmp/semA /tmp/semB $(for p in numpy scipy yaml msgpack anyio h11 attr attrs pygments idna sniffio typing_extensions.py packaging; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PATH=/tmp/site/bin:$PATH PYTHONUNBUFFERED=1
cd /root/w
python3 -c "import time; t=time.perf_counter(); s=0
for i in range(10_000_000): s+=i
print('10M loop', round(time.perf_counter()-t,3))"
for v in A B; do
  PYTHONPATH=/tmp/sem$v:/tmp/site BENCHBOT_TAICHI_ARCH=cuda timeout 150 python3 "$R/benchmarks/service_warm.py" --runs 5 --modes service --json > "$OUT/cmd1_$v.json"
  echo "cmd1 $v rc=$? at $(el) s"; python3 -c "import json;d=json.load(open('$OUT/cmd1_$v.json'))['service'];print(' median',d['median_wall_s'],d['wall_s'],d['median_stages_s'])"
done
for v in A B; do
  PYTHONPATH=/tmp/sem$v:/tmp/site timeout 200 python3 "$R/benchmarks/sweep.py" --repeat 3 --envs-batch bear_all --arch cuda --modes service \
    --workers 30 --runs 2 --json-file "$OUT/sweep_$v.json" > /dev/null
  echo "sweep $v rc=$? at $(el) s"
  python3 - "$OUT/sweep_$v.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(" identical", d["byte_identical"], "differ", d.get("differing_files"))
for r in d["runs"]: print(" ", r.get("warm_up"), r["wall_s"], r["digest"], r["stages_s"].get("solution per frame"), r["gpu_utilisation"])
PY
done
echo "-- bakes at $(el) s"
export PYTHONPATH=/tmp/semB:/tmp/site
for c in A B; do
  BENCHBOT_CACHE_DIR=/tmp/c$c timeout 100 python3 -m benchbot.cli sim prepare --arch gpu house:1 house:4 miniroom:2 --json > "$OUT/prep_$c.json" 2>"$OUT/prep_$c.err"
  echo "prepare $c rc=$? at $(el) s"; tail -2 "$OUT/prep_$c.err"
  (cd /tmp/c$c && find . -type f | sort | xargs sha256sum | cut -c1-16,65- ) > "$OUT/prep_$c.sha"
done
diff "$OUT/prep_A.sha" "$OUT/prep_B.sha" && echo "bakes identical" || echo "bakes DIFFER"
wc -l "$OUT/prep_A.sha"
echo "== done at $(el) s"
