#!/bin/bash
# issue 60 call 22: miniroom:3 frames 40-55 rendered over and over by 32 processes (16 a GPU) through the backend with
# a diagnostic shading step (diag_patch.py), first alone, then beside 24 busy CPU loops: which pixels change between
# two renders of one pose, and do their primitive, pane or radiance change?
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log22.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
mkdir -p /tmp/site /tmp/bsite /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
python3 .whl/lead3/diag_patch.py /tmp/site/benchbot_sim_taichi/render/sensors.py || exit 8
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site $(for p in numpy scipy yaml PIL; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/site BENCHBOT_CACHE_DIR=/root/w/cache
cd /root/w
S="$R/.whl/lead3/diag_stress.py"
timeout 200 python3 $S miniroom:3 40 55 1 warm > /root/w/warm.txt 2> "$OUT/warm_err.txt"; echo "warm-up rc=$? at $(el) s"
grep SUM /root/w/warm.txt || { tail -5 "$OUT/warm_err.txt"; exit 9; }
P=""; for k in $(seq 0 31); do CUDA_VISIBLE_DEVICES=$((k % 2)) timeout 200 python3 $S miniroom:3 40 55 90 quiet$k > /root/w/q_$k.txt 2>/root/w/q_$k.err & P="$P $!"; done
wait $P; echo "quiet: done at $(el) s"
B=""; for k in $(seq 0 23); do timeout 130 python3 -c "while True: pass" & B="$B $!"; done
P=""; for k in $(seq 0 31); do CUDA_VISIBLE_DEVICES=$((k % 2)) timeout 200 python3 $S miniroom:3 40 55 90 busy$k > /root/w/b_$k.txt 2>/root/w/b_$k.err & P="$P $!"; done
wait $P; kill $B 2>/dev/null; echo "busy: done at $(el) s"
cat /root/w/q_*.txt /root/w/b_*.txt | grep -v "^SUM" | cut -c1-700 | head -40
cat /root/w/q_*.txt | awk '/^SUM/{n+=$4; o+=$8; r+=$10} END {print "quiet total renders", n, "odd rgb", o, "radiance only", r}'
cat /root/w/b_*.txt | awk '/^SUM/{n+=$4; o+=$8; r+=$10} END {print "busy total renders", n, "odd rgb", o, "radiance only", r}'
ls /root/w/*.txt | wc -l; tail -2 /root/w/q_0.err
echo "== done at $(el) s"
