"""Issue 60 diagnostics: patch a copy of benchbot_sim_taichi's shading step so that the render's outputs say more
about each pixel: 'depth' holds the pixel's green radiance before the tone curve (float32), 'class' the index of the
nearest window pane in front of the surface (-1 none) and 'instance' the index of the primitive hit (-1 none)."""
import sys
path = sys.argv[1]
s = open(path).read()
reps = [("            col *= consts[FRAME_RADIANCE_SCALE]  # radiance / radiance_max: exposure and tone curve are in the table\n",
         "            col *= consts[FRAME_RADIANCE_SCALE]  # radiance / radiance_max: exposure and tone curve are in the table\n            t = col[1]\n"),
        ("        cls[b, v, u] = c_id\n        inst[b, v, u] = i_id\n",
         "        cls[b, v, u] = pane_k\n        inst[b, v, u] = k\n")]
for a, b in reps:
    assert s.count(a) == 1, a
    s = s.replace(a, b)
open(path, "w").write(s)
print("patched", path)
