#!/bin/bash
# issue 59 follow-up: the 100-procedural-home profile (procedural_val_100) again after 27-28 Nov's world changes (the
# day homes' window lights, no model blacker than black paint), on one H200 from a fresh machine, as on 26 Nov:
# semslam_geometric first (cold: kernels compiled, homes made), then semslam_detector, then the report of both.
# Run from the repository root on the device machine, carrying .whl/lead3 (tools/device_bundle.sh).
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log30.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
rm -rf /tmp/site /tmp/bsite /tmp/semP /root/w
mkdir -p /tmp/site /tmp/bsite /tmp/semP /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/semP plugins/task_semslam || exit 7
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site /tmp/semP $(for p in numpy scipy yaml msgpack anyio h11 attr attrs pygments idna sniffio typing_extensions.py packaging PIL; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PATH=/tmp/site/bin:$PATH PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/semP:/tmp/site
cd /root/w
mkdir -p /tmp/rt && chmod 700 /tmp/rt
export XDG_RUNTIME_DIR=/tmp/rt BENCHBOT_CACHE_DIR=/root/w/cache
echo "installed at $(el) s"
( while sleep 2; do nvidia-smi --query-gpu=memory.used --format=csv,noheader,nounits; done ) > /root/w/gpu_mem.txt &
MEM=$!
for ex in semslam_geometric semslam_detector; do
  t=$(date +%s.%N)
  timeout $(( 560 - $(el) )) python3 -m benchbot.cli batch --example $ex --envs-batch procedural_val_100 --workers 16 \
    --arch cuda --no-tui --json --output-dir /root/w/$ex > "$OUT/batch_$ex.json" 2> /root/w/err_$ex.txt
  rc=$?
  echo "$ex: rc $rc, $(python3 -c "import time,sys; print(f'{time.time() - float(sys.argv[1]):.1f}')" $t) s, at $(el) s"
  [ $rc -eq 0 ] || tail -5 /root/w/err_$ex.txt
done
kill $MEM
echo "peak GPU memory $(sort -n /root/w/gpu_mem.txt | tail -1) MiB"
rd() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['run_dir'])" "$OUT/batch_$1.json"; }
G=$(rd semslam_geometric); D=$(rd semslam_detector); echo "runs: $G $D"
python3 -m benchbot.cli report "$G" "$D" --json > "$OUT/report30.json" \
  2> /root/w/err_report.txt; echo "report rc $?"; tail -3 /root/w/err_report.txt
tar -C /root/w -cJf "$OUT/runs30.tar.xz" --exclude='*.png' --exclude='*.npz' semslam_geometric semslam_detector 2>&1 | tail -2
ls -la "$OUT"
echo "== done at $(el) s"
