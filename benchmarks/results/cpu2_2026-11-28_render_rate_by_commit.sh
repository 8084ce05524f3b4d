#!/bin/bash
# cpu2_2026-11-28_render_rate_by_commit.sh REV [REPO]: house:1's fast-mode render rate (fps, 60 frames) and Embree's
# (Mrays/s) with the code of commit REV, in a git worktree of REPO (default: this checkout) under /tmp, run by this
# checkout's virtual environment with REV's packages first on PYTHONPATH. Run from the repository root after `uv sync`.
rev=$1; repo=${2:-$PWD}; wt=/tmp/render-rate-$rev
[ -d $wt ] || git -C "$repo" worktree add -q $wt $rev
cd $wt && PP=$wt:$(ls -d $wt/plugins/*/ | tr '\n' ':')
timeout 400 env PYTHONPATH=$PP "$repo/.venv/bin/python" benchmarks/render.py --env house:1 --frames 60 --json 2>&1 | grep -o '"fps": [0-9.]*\|"triangles": [0-9]*\|"embree_mrays_per_s": [0-9.]*\|Error.*' | tr '\n' ' '; echo " $rev"
