"""compare_found.py A B: per-class found / visible (fast, crowd rule, score >= 0.3) of two runs of
benchmarks/realism.py (their realism.json), over the environments both have: the classes that differ, the totals and
the false positives."""
import collections
import json
import sys

da = json.load(open(sys.argv[1] + "/realism.json"))
db = json.load(open(sys.argv[2] + "/realism.json"))
envs = sorted(set(da["environments"]) & set(db["environments"]))


def counts(d):
    vis, det, fp, frames = collections.Counter(), collections.Counter(), 0.0, 0
    for env in envs:
        x = d["environments"][env]["detector"]["fast, crowd rule"]
        vis.update(x["visible"])
        det.update(x["score>=0.3"]["detected"])
        fp += x["score>=0.3"]["false_positives_per_frame"] * x["frames"]
        frames += x["frames"]
    return vis, det, fp, frames


va, fa, pa, na = counts(da)
vb, fb, pb, nb = counts(db)
print("envs", envs)
for c in sorted(set(va) | set(vb)):
    if (va[c], fa[c]) != (vb[c], fb[c]):
        print(f"  {c}: {fa[c]}/{va[c]} -> {fb[c]}/{vb[c]}")
print(f"  all: {sum(fa.values())}/{sum(va.values())} -> {sum(fb.values())}/{sum(vb.values())}")
print(f"  false positives: {pa:.0f} in {na} frames -> {pb:.0f} in {nb}")
