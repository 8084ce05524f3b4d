"""Issue 60: the RGB images clients received (FRAME lines of patch_frames.py's solution) against those the backend
wrote (PACK lines of patch_pack.py). Usage: pack_vs_frames.py PACK_DIR RUN_DIR..."""
import collections, pathlib, re, sys
packed, mismatch, n_pack = set(), 0, 0
for f in pathlib.Path(sys.argv[1]).glob("*.log"):
    for line in f.read_text().splitlines():
        p = line.split()
        if p and p[0] == "PACK":
            n_pack += 1
            packed.add(p[1])
            mismatch += p[1] != p[2]
print(f"{n_pack} RGB images written by the backends ({len(packed)} distinct); slot bytes unlike the image right "
      f"after the write: {mismatch}")
frames = collections.defaultdict(list)  # (env, index) -> [(episode, rgb digest)]
for d in sys.argv[2:]:
    for log in pathlib.Path(d).rglob("logs/*.log"):
        env = re.sub(r"^\d+_|_r\d+\.log$", "", log.name)
        for line in log.read_text(errors="replace").splitlines():
            if line.startswith("FRAME "):
                p = line.split()
                frames[(env, int(p[1]))].append((f"{pathlib.Path(d).name}/{log.stem}", p[2]))
odd = 0
for (env, i), got in sorted(frames.items()):
    c = collections.Counter(h for _, h in got)
    if len(c) < 2:
        continue
    common = c.most_common(1)[0][0]
    for ep, h in got:
        if h != common:
            odd += 1
            print(f"  {env} frame {i} in {ep}: received {h} (commonest {common}); the backend wrote it: {h in packed}; "
                  f"wrote the commonest: {common in packed}")
print(f"frames received unlike their commonest: {odd} of {sum(len(v) for v in frames.values())}")
