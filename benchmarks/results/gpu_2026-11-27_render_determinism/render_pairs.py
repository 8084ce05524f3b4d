"""Summarise render pairs kept by BENCHBOT_SIM_CHECK_RENDERS=1 (issue 60): per file, what the render check's own
``differences`` says of the two renders, and the largest and mean absolute difference of the pixels that differ.
Usage: render_pairs.py FOLDER"""
import pathlib, sys
import numpy as np
from benchbot_sim_taichi.render_check import differences
folder = pathlib.Path(sys.argv[1])
files = sorted(folder.glob("*.npz")) if folder.is_dir() else []
print(f"{len(files)} kept pairs")
for f in files:
    with np.load(f, allow_pickle=False) as z:
        first = {k.removeprefix("first_"): z[k] for k in z.files if k.startswith("first_")}
        second = {k.removeprefix("second_"): z[k] for k in z.files if k.startswith("second_")}
    sizes = []
    for k in first:
        a, b = first[k].astype(np.float64), second.get(k)
        if b is not None and a.shape == b.shape and not np.array_equal(first[k], b):
            d = np.abs(a - b)
            sizes.append(f"{k} max|d| {d.max():.4g} mean|d| {d[d > 0].mean():.4g}")
    print(f"  {f.name}: {'; '.join(differences(first, second)) or 'equal'}{' (' + '; '.join(sizes) + ')' if sizes else ''}")
