"""Summarise render pairs kept by BENCHBOT_SIM_CHECK_RENDERS=1 (issue 60): per file, which outputs differ, where,
and by how much. Usage: render_pairs.py FOLDER"""
import pathlib, sys
import numpy as np
files = sorted(pathlib.Path(sys.argv[1]).glob("*.npz")) if pathlib.Path(sys.argv[1]).is_dir() else []
print(f"{len(files)} kept pairs")
for f in files:
    z = np.load(f, allow_pickle=False)
    keys = sorted({k.split("_", 1)[1] for k in z.files})
    parts = []
    for k in keys:
        a, b = z[f"first_{k}"], z[f"second_{k}"]
        if a.shape != b.shape or a.tobytes() == b.tobytes():
            continue
        if a.ndim >= 2:
            m = (a != b).reshape(a.shape[:2] + (-1,)).any(-1)
            rr, cc = np.nonzero(m)
            d = np.abs(a.astype(np.float64) - b.astype(np.float64))
            parts.append(f"{k}: {m.sum()} px rows {rr.min()}..{rr.max()} cols {cc.min()}..{cc.max()} max|d| {d.max():.4g} mean|d| {d[m].mean():.4g}")
        else:
            parts.append(f"{k}: {(a != b).sum()} of {a.size}")
    print(f"  {f.name}: {'; '.join(parts) or 'equal'}")
