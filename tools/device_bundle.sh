#!/usr/bin/env bash
# Build the dependencies that the GPU-host scripts under benchmarks/results/gpu_* unpack into /tmp/site: the lent GPU
# hosts run Python 3.12 with NumPy, SciPy, Pillow, PyYAML and Pygments of their own and reach no package registry,
# and a call carries at most 64 MiB, the repository's tracked files included (about 40 MiB counted as a tar archive).
#
#   tools/device_bundle.sh            # writes .whl/lead3/site312_slim.tar.xz and .whl/lead3/build312.tar.xz
#
# site312_slim: the locked runtime dependencies of every workspace package for Python 3.12, without what the host
# has (above), what the scripts never load (cyclonedds, OpenCV, cryptography, Textual, Open Image Denoise's libraries,
# Taichi's C API and examples), with Taichi's Python module stripped of its symbol tables, and typer 0.28 instead of
# the lock's (0.29 needs pydantic, 2 MB more). build312: hatchling, to install the workspace's packages there with
# `pip install --no-build-isolation`. .whl/ is ignored by git. Needs uv, xz, strip and a Python 3.12 (PY312, default
# pyenv's 3.12.1).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PY312:-$(pyenv root 2>/dev/null || echo /root/.pyenv)/versions/3.12.1/bin/python3}
OUT=.whl/lead3
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
mkdir -p "$OUT"

uv export --format requirements-txt --no-dev --no-hashes --no-emit-workspace --all-packages --quiet \
  | grep -v '^ *#' | grep -Ev '^(numpy|scipy|pillow|pyyaml|pygments|cyclonedds|opencv-python-headless|cryptography|cffi|pycparser|textual|typer)==' \
  > "$WORK/requirements.txt"
echo "typer==0.28.0" >> "$WORK/requirements.txt"
uv pip install --quiet --python "$PY" --target "$WORK/site" --no-deps -r "$WORK/requirements.txt"
(cd "$WORK/site" && rm -rf taichi/_lib/c_api taichi/examples pyoidn/oidn/bin pyoidn/oidn/lib include lib share \
  pydantic* typing_inspection* annotated_types* mdit_py_plugins* linkify_it* \
  && find . -name __pycache__ -prune -exec rm -rf {} +)
strip --strip-unneeded "$WORK"/site/taichi/_lib/core/taichi_python.*.so
tar -C "$WORK/site" -cf - . | xz -T0 -9e > "$OUT/site312_slim.tar.xz"

uv pip install --quiet --python "$PY" --target "$WORK/build" hatchling
tar -C "$WORK/build" -cJf "$OUT/build312.tar.xz" .

tracked=$(git ls-files -z | xargs -0 stat -c %s | awk '{s += 512 + int(($1 + 511) / 512) * 512} END {print s}')
bundle=$(du -cb "$OUT" | tail -1 | cut -f1)
echo "site312_slim.tar.xz $(du -h "$OUT/site312_slim.tar.xz" | cut -f1), build312.tar.xz $(du -h "$OUT/build312.tar.xz" | cut -f1);" \
     "tracked files as tar + $OUT: $(( (tracked + bundle) / 1048576 )) MiB of the 64 MiB a call carries"
# Over the limit (28 Nov 2026: 47 MiB tracked + 23 MiB), a call can still go with folders no device script reads moved
# out of the checkout for it and back after, e.g. benchmarks/realism (the photos, 12 MiB) and docs/gallery (7 MiB).
if [ $(( (tracked + bundle) / 1048576 )) -ge 64 ]; then
  echo "over the limit: move folders the device script does not read (benchmarks/realism, docs/gallery) out for the call"
fi
