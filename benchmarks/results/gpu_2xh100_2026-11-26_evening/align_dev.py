"""Does a float32 (N, 3) @ (3, 3) product or a reduction depend on the arrays' alignment on this CPU? (issue 60
diagnostics: results that differ between runs on the GPU hosts' Intel CPUs)"""
import os
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np
rng = np.random.default_rng(1)
def at(arr, off):
    buf = np.empty(arr.nbytes + 128, np.uint8)
    base = (-buf.ctypes.data) % 64
    a = buf[base + off: base + off + arr.nbytes].view(arr.dtype).reshape(arr.shape)
    a[...] = arr
    return a
diff = tried = 0
for n in (76800, 72531, 1000, 77):
    pc = (rng.random((n, 3)) * 5).astype(np.float32)
    R = rng.standard_normal((3, 3)).astype(np.float32)
    ref = pc @ R
    for off in (4, 8, 12, 16, 20, 32, 36, 48, 60):
        for roff in (0, 4, 8, 12):
            tried += 1
            diff += not np.array_equal(at(pc, off) @ at(R, roff), ref)
    x = pc[:, 2].astype(np.float64)
    r = [np.sum(x), np.median(x), np.percentile(x, 1), np.mean(pc, axis=0).tobytes()]
    for off in (8, 16, 24, 32, 40, 56):
        tried += 1
        y = at(x, off)
        diff += [np.sum(y), np.median(y), np.percentile(y, 1), np.mean(at(pc, off), axis=0).tobytes()] != r
print("alignment: differences", diff, "of", tried)
