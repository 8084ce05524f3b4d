"""doc_table.py PREFIX: docs/realism.md's three-detector table (*Where it stands*) from the per_class.md files of
three benchmarks/realism.py runs, PREFIXcenternet/, PREFIXnanodet/ and PREFIXssd/ (made with --real-reference)."""
import re, sys
prefix = sys.argv[1]
dets = ["centernet", "nanodet", "ssd"]
rows = {}
for d in dets:
    txt = open(f"{prefix}{d}/per_class.md").read()
    part = txt[txt.index("COCO val2017 photos, recall"):]
    for line in part.splitlines():
        m = re.match(r"\| (\**[^|]+?\**) \| (\d+) % \[[^]]*\](?: †)? \| (\d+) % \[[^]]*\](?: †)? \| ([^|]+) \| "
                     r"(\d+)/(\d+); (\d+)/(\d+) \|", line)  # († an exact interval: realism_real.boundary_intervals)
        if m:
            cls = m.group(1).strip("*")
            rows.setdefault(cls, {})[d] = m.groups()
tail = ["spoon", "toaster", "orange", "keyboard", "apple", "banana"]
order = [c for c in rows if c not in tail and not c.startswith("all")]
order.sort(key=lambda c: -int(rows[c]["centernet"][5]))
def cell(g):
    ratio = g[3].strip()
    r, iv = ratio.split(" ", 1)
    return f"{g[1]} · {g[2]} · **{r}** {iv}"
for c in order:
    g = rows[c]["centernet"]
    print(f"| {c} | {g[5]}; {g[7]} | " + " | ".join(cell(rows[c][d]) for d in dets) + " |")
objs_sim = sum(int(rows[c]["centernet"][5]) for c in tail); objs_real = sum(int(rows[c]["centernet"][7]) for c in tail)
print(f"| {', '.join(tail)} | {objs_sim}; {objs_real} | " + " | ".join(
    f"found: {sum(int(rows[c][d][4]) for c in tail)} of {objs_sim}; {sum(int(rows[c][d][6]) for c in tail)} of {objs_real}" for d in dets) + " |")
a = [k for k in rows if k.startswith("all")][0]
g = rows[a]["centernet"]
print(f"| **all (sim's class × size mix)** | {g[5]}; {g[7]} | " + " | ".join(cell(rows[a][d]) for d in dets) + " |")
for d in dets:
    g = rows[a][d]; print(d, "found", g[4], "/", g[5], "real", g[6], "/", g[7])
