#!/bin/bash
# issue 60 call 23: the flips of gpu22 (a pixel's hit going from primitive k to k+1 now and then) under four builds
# of the kernels, 8 processes each (4 a GPU), 100 s: A as gpu22; B with raster._keep always atomic (keep_patch.py);
# C with Taichi's cache_loop_invariant_global_vars off; D with Taichi's advanced_optimization off.
set -u
R=$PWD; T0=$(date +%s); el() { echo $(( $(date +%s) - T0 )); }
exec > >(tee -a "$OUT/log23.txt") 2>&1
echo "== $(date -u +%FT%TZ)"; nvidia-smi -L; nproc
mkdir -p /tmp/site /tmp/bsite /root/w
tar -C /tmp/site -xJf .whl/lead3/site312_slim.tar.xz && tar -C /tmp/bsite -xJf .whl/lead3/build312.tar.xz || exit 3
PIP="python3 -m pip install -q --no-index --no-deps --no-build-isolation --no-compile"
PYTHONPATH=/tmp/bsite:/tmp/site $PIP --target /tmp/site . plugins/worlds plugins/sim_taichi plugins/eval_omq plugins/assets_sh3d || exit 5
python3 .whl/lead3/diag_patch.py /tmp/site/benchbot_sim_taichi/render/sensors.py || exit 8
SP=/opt/torch/.venv/lib/python3.12/site-packages
python3 -m compileall -q -j 0 /tmp/site $(for p in numpy scipy yaml PIL; do [ -e $SP/$p ] && echo $SP/$p; done) > /dev/null 2>&1
cp -a /tmp/site /tmp/siteB && python3 .whl/lead3/keep_patch.py /tmp/siteB/benchbot_sim_taichi/render/raster.py || exit 8
unset PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX
export PYTHONUNBUFFERED=1
cd /root/w
S="$R/.whl/lead3/diag_stress.py"
arm() {  # arm name, then env assignments
  local a=$1; shift
  local site=/tmp/site; [ $a = B ] && site=/tmp/siteB
  env "$@" PYTHONPATH=$site BENCHBOT_CACHE_DIR=/root/w/c$a TI_OFFLINE_CACHE_FILE_PATH=/root/w/c$a/ticache "${RUN[@]}"
}
ENVS_A=(); ENVS_B=(); ENVS_C=(TI_CACHE_LOOP_INVARIANT_GLOBAL_VARS=0); ENVS_D=(TI_ADVANCED_OPTIMIZATION=0)
P=""
for a in A B C D; do eval "E=(\"\${ENVS_$a[@]}\")"; RUN=(timeout 300 python3 $S miniroom:3 40 55 1 warm$a)
  arm $a "${E[@]}" > /root/w/warm$a.txt 2> /root/w/warm$a.err & P="$P $!"; done
wait $P; echo "warm-ups done at $(el) s"; grep -h SUM /root/w/warm?.txt; for a in A B C D; do grep -q SUM /root/w/warm$a.txt || tail -3 /root/w/warm$a.err; done
P=""
for a in A B C D; do eval "E=(\"\${ENVS_$a[@]}\")"; for k in 0 1 2 3 4 5 6 7; do RUN=(timeout 200 python3 $S miniroom:3 40 55 100 $a$k)
  CUDA_VISIBLE_DEVICES=$((k % 2)) arm $a "${E[@]}" > /root/w/r$a$k.txt 2> /root/w/r$a$k.err & P="$P $!"; done; done
wait $P; echo "runs done at $(el) s"
for a in A B C D; do cat /root/w/r$a?.txt | awk -v a=$a '/^SUM/{n+=$4; o+=$8; r+=$10} END {print "arm", a, "renders", n, "odd rgb", o, "radiance only", r}'; done
for a in A B C D; do grep -h "^ODD\|^RADONLY" /root/w/r$a?.txt | cut -c1-260 | head -4; done
tail -2 /root/w/rD0.err
echo "== done at $(el) s"
