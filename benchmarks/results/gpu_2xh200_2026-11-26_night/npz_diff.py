"""Compare the scene cache's prepared arrays of the same key across scene-cache folders (issue 60: is a CUDA bake
the same every time?). Usage: npz_diff.py FOLDER... (each a copy of <cache>/sim_taichi-scenes)."""
import collections, hashlib, pathlib, sys
import numpy as np
by_name = collections.defaultdict(dict)
for d in sys.argv[1:]:
    for f in sorted(pathlib.Path(d).glob("*.npz")):
        by_name[f.name][d] = f
for name, got in sorted(by_name.items()):
    files = list(got.values())
    whole = {hashlib.sha256(f.read_bytes()).hexdigest()[:10] for f in files}
    print(f"{name[:20]}… in {len(files)} folders, {len(whole)} distinct files")
    if len(whole) < 2:
        continue
    arrays = [np.load(f, allow_pickle=False) for f in files]
    for k in arrays[0].files:
        vals = [a[k] for a in arrays]
        digests = [hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest()[:10] for v in vals]
        if len(set(digests)) > 1:
            v0 = vals[0]
            n = [int(np.sum(v != v0)) if v.shape == v0.shape else -1 for v in vals]
            print(f"  array {k} {v0.dtype} {v0.shape}: differs; elements unlike the first folder's: {n}")
