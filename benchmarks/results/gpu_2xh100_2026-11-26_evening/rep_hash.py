"""Distinct results per environment over batch run directories (issue 60 diagnostics)."""
import collections, hashlib, pathlib, re, sys
seen = collections.defaultdict(collections.Counter)
for d in sys.argv[1:]:
    for p in pathlib.Path(d).rglob("results/*.json"):
        env = re.sub(r"^\d+_|_r\d+\.json$", "", p.name)
        seen[env][hashlib.sha256(p.read_bytes()).hexdigest()[:12]] += 1
for env, c in sorted(seen.items()):
    print(f"  {env}: {sum(c.values())} episodes, {len(c)} distinct results {dict(c)}")
