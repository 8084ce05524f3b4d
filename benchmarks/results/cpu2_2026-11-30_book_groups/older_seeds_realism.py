"""older_seeds_realism.py VERSION ARGS...: benchmarks/realism.py ARGS with the procedural generator's version set
back to VERSION (``benchbot_worlds.procedural.generator.GENERATOR_VERSION``, which picks every home's seed), the code
otherwise the tree's: that version's homes made with the current rules, so that a change is judged on the same
layouts. It made the *same homes* tables of *Books single or grouped as BEAR's are: generator v4*
(docs/history/realism-2026-11.md), with VERSION 3. Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_book_groups/older_seeds_realism.py 3 \\
        --env procedural_val_0:1 ... --env procedural_val_19:1 --every 4 --quality-frames 0 --reference-frames 0 \\
        --real-reference --detector nanodet --out runs/v3_seeds_nanodet
"""
import runpy
import sys

import benchbot_worlds.procedural.generator as generator

if len(sys.argv) < 2 or not sys.argv[1].isdigit() or not 1 <= int(sys.argv[1]) <= generator.GENERATOR_VERSION:
    sys.exit(f"usage: older_seeds_realism.py VERSION ARGS... (VERSION 1..{generator.GENERATOR_VERSION})")
generator.GENERATOR_VERSION = int(sys.argv[1])
sys.argv = ["benchmarks/realism.py"] + sys.argv[2:]
runpy.run_path("benchmarks/realism.py", run_name="__main__")
