#!/bin/bash
# issue 60 call 7: does a frame's first copy to the host race its render? 30 processes on two GPUs render
# miniroom:3's trajectory 6 times each through the backend; each frame is copied as episodes copy it and again after
# cuCtxSynchronize.
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log17.txt") 2>&1
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
S="$R/.whl/lead3/render_stress.py"
timeout 240 python3 $S run miniroom:3 1 --recopy > /root/w/warm.txt 2> "$OUT/warm_err.txt"; echo "warm-up rc=$? at $(el) s"
python3 $S sum /root/w/warm.txt || { tail -5 "$OUT/warm_err.txt"; exit 9; }
P=""
for k in $(seq 0 29); do CUDA_VISIBLE_DEVICES=$((k % 2)) timeout 330 python3 $S run miniroom:3 6 --recopy > /root/w/rs_$k.txt 2>/root/w/rs_$k.err & P="$P $!"; done
wait $P; echo "30 processes done at $(el) s"
grep -L "^F 5 55 " /root/w/rs_*.txt | head -3
python3 $S sum /root/w/warm.txt /root/w/rs_*.txt
tail -3 /root/w/rs_0.err
tar -C /root/w -czf "$OUT/rs17.tgz" $(cd /root/w && ls rs_*.txt warm.txt)
echo "== done at $(el) s"
