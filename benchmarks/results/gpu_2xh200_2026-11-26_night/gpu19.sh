#!/bin/bash
# issue 60 call 9: resident workers' lives in 30 processes on two GPUs (resident_stress.py): do frames of an
# environment differ between its episodes in one process, and where?
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log19.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
mkdir -p /tmp/site /tmp/bsite /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site $(for p in numpy scipy yaml PIL; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PYTHONUNBUFFERED=1 PYTHONPATH=/tmp/site
cd /root/w
S="$R/.whl/lead3/resident_stress.py"
timeout 200 python3 $S --main-thread 0 3 miniroom:3 miniroom:1 house:2 2>/root/w/warm.err | grep -v "^\[Taichi\]"; echo "warm-up rc=$? at $(el) s"
P=""
for k in $(seq 1 30); do CUDA_VISIBLE_DEVICES=$((k % 2)) timeout $((380 - $(el))) python3 $S --main-thread $k 12 miniroom:3 miniroom:1 house:2 > /root/w/r_$k.txt 2>/root/w/r_$k.err & P="$P $!"; done
wait $P; echo "30 processes done at $(el) s"
cat /root/w/r_*.txt | grep "^DIFF" | head -20
cat /root/w/r_*.txt | grep "^SUM" | awk '{f+=$4; o+=$(NF-4)} END {print "frames", f, "unlike", o}'
grep -L "^SUM" /root/w/r_*.txt | head; tail -2 /root/w/r_1.err
echo "== done at $(el) s"
