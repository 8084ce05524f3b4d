"""v2_seeds_realism.py ARGS...: benchmarks/realism.py ARGS with the procedural generator's version set back to 2
(``benchbot_worlds.procedural.generator.GENERATOR_VERSION``, which picks every home's seed), the code otherwise the
tree's: generator v2's homes made with the current rules. It made YOLOv4-tiny's table of
*The floor in front of the fridge kept clear: generator v3* (docs/history/realism-2026-11.md) after the version was
raised. Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_realism_records/v2_seeds_realism.py \\
        --env procedural_val_0:1 ... --env procedural_val_19:1 --every 4 --quality-frames 0 --reference-frames 0 \\
        --real-reference --detector yolo --out runs/v2_seeds_yolo
"""
import runpy
import sys

import benchbot_worlds.procedural.generator as generator

generator.GENERATOR_VERSION = 2
sys.argv = ["benchmarks/realism.py"] + sys.argv[1:]
runpy.run_path("benchmarks/realism.py", run_name="__main__")
