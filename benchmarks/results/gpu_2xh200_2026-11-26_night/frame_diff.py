"""Which frames differ between episodes of one environment (logs of a patch_frames.py solution), grouped by the
episode's results file (issue 60 diagnostics). Usage: frame_diff.py RUN_DIR..."""
import collections, hashlib, pathlib, re, sys
eps = collections.defaultdict(list)  # env -> [(run/episode, results hash, frames)]
for d in sys.argv[1:]:
    for log in sorted(pathlib.Path(d).rglob("logs/*.log")):
        env = re.sub(r"^\d+_|_r\d+\.log$|\.log$", "", log.name)
        res = log.parent.parent / "results" / (log.stem + ".json")
        rh = hashlib.sha256(res.read_bytes()).hexdigest()[:8] if res.is_file() else "none"
        frames = [l.split()[1:] for l in log.read_text(errors="replace").splitlines() if l.startswith("FRAME ")]
        eps[env].append((f"{pathlib.Path(d).name}/{log.stem}", rh, frames))
for env, lst in sorted(eps.items()):
    seqs = collections.Counter(tuple(tuple(f[1:5]) for f in fr) for _, _, fr in lst)
    res = collections.Counter(rh for _, rh, _ in lst)
    print(f"== {env}: {len(lst)} episodes, {len(res)} distinct results {dict(res)}, {len(seqs)} distinct frame "
          f"sequences, frames per episode {sorted(set(len(fr) for _, _, fr in lst))}")
    if len(seqs) < 2:
        continue
    ref_seq = seqs.most_common(1)[0][0]
    ref = next(fr for _, _, fr in lst if tuple(tuple(f[1:5]) for f in fr) == ref_seq)
    for name, rh, fr in lst:
        if tuple(tuple(f[1:5]) for f in fr) == ref_seq:
            continue
        diffs = []
        for i, (a, b) in enumerate(zip(ref, fr)):
            parts = [k for k, x, y in zip(("rgb", "depth", "K", "T"), a[1:5], b[1:5]) if x != y]
            if parts:
                ta = [a[5][k:k + 8] != b[5][k:k + 8] for k in range(0, 384, 8)]
                td = [a[6][k:k + 8] != b[6][k:k + 8] for k in range(0, 384, 8)]
                diffs.append(f"{i}:{'+'.join(parts)}(rgb tiles {[k for k, t in enumerate(ta) if t]}, depth tiles "
                             f"{[k for k, t in enumerate(td) if t]})")
        print(f"  {name} results {rh}: {len(diffs)} frames differ from the commonest; first: {diffs[:4]}")
