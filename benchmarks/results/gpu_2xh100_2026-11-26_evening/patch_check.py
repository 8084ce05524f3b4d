"""Make a diagnostic copy of semslam_geometric that checks, after fusing each frame on its thread, that the frame's
arrays still hold the bytes they held when pick_action handed them over (issue 60: is shared memory overwritten?)."""
import sys
path = sys.argv[1]
s = open(path).read()
old = "                self._fusing = self._fusion.submit(mapper.integrate, *frame)"
assert old in s
s = s.replace(old, "                self._fusing = self._fusion.submit(_checked, mapper, frame, _digest(frame))")
s = s.replace("    def save_result(self, filename, empty_results, results_format_fns):",
              "    def save_result(self, filename, empty_results, results_format_fns):\n"
              "        self._fused()\n"
              "        print(f'SHMCHECK changed {CHANGED[0]} of {CHECKED[0]} frames', flush=True)")
s = s.replace("def load_recording(", '''CHANGED, CHECKED = [0], [0]


def _digest(frame):
    import hashlib
    return hashlib.sha256(frame[0].tobytes() + frame[1].tobytes()).digest()


def _checked(mapper, frame, before):
    n = mapper.integrate(*frame)
    CHECKED[0] += 1
    if _digest(frame) != before:
        CHANGED[0] += 1
    return n


def load_recording(''', 1)
open(path, "w").write(s)
print("patched", path)
