"""best_scores.py A B CLASS: for each visible object of CLASS in two runs of benchmarks/realism.py (run folders A and
B, the same frames), the best score of a detection of that class at IoU >= 0.5 with its box, at any score the run
kept (0 where none); then the mean over the objects and how many rose or fell by more than 0.02.
Run from the repository root: uv run --extra realism python benchmarks/results/cpu2_2026-11-27_realism_records/best_scores.py A B couch"""
import json, sys
import numpy as np
sys.path.insert(0, 'benchmarks')
import realism as R
def best(run, cls):
    d = json.load(open(run + '/realism.json')); out = {}
    for env, e in d['environments'].items():
        for fr in e['frames']:
            for o in fr['objects']:
                if o['cls'] != cls: continue
                bb = o['box']; s = 0.0
                for det in fr['detections_fast']:
                    if R.bear_name(int(det[5])) == cls and R.box_iou(np.array(bb, float), np.array(det[:4], float)) >= 0.5:
                        s = max(s, det[4])
                out[(env, fr['pose_index'], o['instance'])] = s
    return out
a, b = best(sys.argv[1], sys.argv[3]), best(sys.argv[2], sys.argv[3])
for k in sorted(a):
    if k in b: print(k, round(a[k], 2), '->', round(b[k], 2))
va = np.array([a[k] for k in a if k in b]); vb = np.array([b[k] for k in a if k in b])
print('mean', va.mean().round(3), '->', vb.mean().round(3), ' up', (vb > va + 0.02).sum(), 'down', (vb < va - 0.02).sum())
