"""The simulator's GPU figures in one run: the furnished homes and a triangle-count sweep, each case a command here.

Runs, each in its own process (``sys.executable``), with ``--arch cuda`` and 640×480 fast-mode frames (RGB + depth +
class/instance segmentation + 360-beam laser):

* ``render.py`` on the furnished ``house:1`` and ``miniroom:1``, ``--batch`` 1, 64, 256 and 1024 cameras per
  launch: frames left in GPU memory (``fps``), copied to NumPy by the renderer (``fps_with_host_copy``) and by the
  benchmark's reused ordinary / page-locked buffers (``fps_host_reused``, ``fps_host_pinned``; 1024: page-locked
  only); at batch 256 also with the lights off (ambient only: no shadow rays, no shadow maps) and with shadow rays to
  every light instead of the shadow maps (``--shadow-maps off``), which show the lights' share of a frame;
* ``render_meshes.py``: 100 textured spheres of 100, 1,000 and 10,000 triangles (≈ 10k, 90k and 960k triangles),
  batch 1 and 256: BVH build time on the host, scene and BVH size, device memory in use and fps against triangle
  count.

    python benchmarks/render_gpu.py [--out FILE.json] [--quick] [--only SUBSTRING]

Writes one JSON object (``--out``, else stdout): ``date``, ``python``, ``cases`` (each ``command``: the exact
command line, run from the repository's root; ``wall_s``; ``result``: that command's JSON, or ``error``: the end of
its stderr). ``--quick`` runs few frames (a quick look, not figures). Prints a short table on stderr. ``--smoke``
runs one ``render.py`` case and one ``render_meshes.py`` case on the CPU, each in its own smoke mode (no GPU needed;
the CUDA cases are left out).
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs

ROOT = Path(__file__).resolve().parents[1]


#: The smoke run's cases: the two scripts' own smoke modes, on the CPU, with the GPU cases' flags that work there.
SMOKE_CASES = [["benchmarks/render.py", "--arch", "cpu", "--batch", "2", "--host-copy", "taichi,reused,pinned",
                "--no-embree", "--json", "--smoke"],
               ["benchmarks/render_meshes.py", "--arch", "cpu", "--batch", "2", "--json", "--smoke"]]


def cases(quick: bool) -> list[list[str]]:
    out = []
    for env in ("house:1", "miniroom:1"):
        for batch, frames, copies in ((1, 2000, "taichi,reused,pinned"), (64, 4096, "taichi,reused,pinned"),
                                      (256, 4096, "taichi,reused,pinned"), (1024, 16384, "pinned")):
            frames = batch * 2 if quick else frames
            out.append(["benchmarks/render.py", "--arch", "cuda", "--env", env, "--batch", str(batch), "--frames",
                        str(frames), "--host-copy", copies, "--no-embree", "--json"])
        for what in (["--lights", "off"], ["--shadow-maps", "off"]):  # where the time goes: the lights' share
            out.append(["benchmarks/render.py", "--arch", "cuda", "--env", env, "--batch", "256", "--frames",
                        "512" if quick else "4096", *what, "--host-copy", "none", "--no-embree", "--json"])
    for tris in (100, 1000, 10000):
        for batch, frames in ((1, 1000), (256, 4096)):
            frames = batch * 2 if quick else frames
            out.append(["benchmarks/render_meshes.py", "--arch", "cuda", "--count", "100", "--triangles", str(tris),
                        "--batch", str(batch), "--frames", str(frames), "--json"])
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="write the JSON here (default: stdout)")
    ap.add_argument("--quick", action="store_true", help="few frames per case: a quick look, not figures")
    ap.add_argument("--only", default="", help="run only the cases whose command line contains this")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per case")
    args = smoke.parse_args(ap, argv)
    if args.smoke:
        smoke.left_out("the CUDA cases", "a smoke run renders one case of each script on the CPU, tiny")
    result = {"date": datetime.date.today().isoformat(), "python": platform.python_version(),
              "quick": args.quick, "smoke": args.smoke, "cases": []}
    for cmd in SMOKE_CASES if args.smoke else cases(args.quick):
        line = " ".join(["python", *cmd])
        if args.only not in line:
            continue
        t0 = time.perf_counter()
        try:
            p = subprocess.run([sys.executable, *cmd], cwd=ROOT, capture_output=True, text=True,
                               timeout=args.timeout, check=False)
            ok, stdout, stderr = p.returncode == 0, p.stdout, p.stderr
        except subprocess.TimeoutExpired as e:
            ok, stdout, stderr = False, "", f"timed out after {args.timeout} s\n{e.stderr or ''}"
        case = {"command": line, "wall_s": round(time.perf_counter() - t0, 1)}
        if ok:
            case["result"] = json.loads(stdout.strip().splitlines()[-1])
        else:
            case["error"] = (stderr if isinstance(stderr, str) else stderr.decode(errors="replace"))[-3000:]
        result["cases"].append(case)
        r = case.get("result", {})
        fig = {k: round(v) for k, v in r.items() if k.startswith("fps") and isinstance(v, float)}
        print(f"{case['wall_s']:6.1f} s  {line[len('python benchmarks/'):]}\n         "
              f"{r.get('triangles', '?')} tris  {fig or case.get('error', '')[-300:]}", file=sys.stderr, flush=True)
        if args.out:  # after every case, so a run stopped early keeps what it measured
            Path(args.out).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    if not args.out:
        print(json.dumps(result, indent=1))
    return 0 if all("result" in c for c in result["cases"]) else 1


if __name__ == "__main__":
    sys.exit(main())
