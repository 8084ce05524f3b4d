"""issue 60 diagnostics: does the example's mapping give the same bits on a worker thread as on the main thread, and
with the main thread doing NumPy/BLAS work at the same time? (on the GPU host's own NumPy)"""
import os, sys, threading, hashlib, importlib.util
from concurrent.futures import ThreadPoolExecutor
import numpy as np
print("numpy", np.__version__, "OPENBLAS_NUM_THREADS", os.environ.get("OPENBLAS_NUM_THREADS"))
spec = importlib.util.find_spec("benchbot_task_semslam")
d = os.path.join(os.path.dirname(spec.origin), "examples", "semslam_geometric")
sys.path.insert(0, d)
import mapping
rng = np.random.default_rng(5)
K = np.array([[554.3, 0, 320.0], [0, 554.3, 240.0], [0, 0, 1]])
frames = []
for i in range(40):
    depth = (1.0 + 3.0 * rng.random((480, 640))).astype(np.float32)
    depth[rng.random((480, 640)) < 0.05] = 0.0
    rgb = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
    a = 0.05 * i
    R = np.array([[np.cos(a), 0, np.sin(a)], [-np.sin(a), 0, np.cos(a)], [0, -1, 0]]) @ np.eye(3)
    T = np.eye(4); T[:3, :3] = R; T[:3, 3] = [1.0 + 0.01 * i, 2.0, 0.55]
    frames.append((rgb, depth, K, T))
def run(mode):
    m = mapping.GeometricMapper()
    stop = threading.Event()
    if mode == "main":
        for f in frames: m.integrate(*f)
    else:
        ex = ThreadPoolExecutor(1)
        if mode == "thread+busy main":
            def busy():
                x = np.eye(4) * 1.0001
                while not stop.is_set():
                    y = x @ x; z = np.linalg.inv(x); w = (np.ones((64, 3), np.float32) @ np.eye(3, dtype=np.float32)).sum()
            t = threading.Thread(target=busy); t.start()
        for f in frames: ex.submit(m.integrate, *f).result()
        stop.set()
    return hashlib.sha256(b"".join(a.tobytes() for a in m.voxels())).hexdigest()[:12]
def denormal():
    return float(np.float32(1e-39) * np.float32(1.0)) != 0.0
print("denormals kept: main", denormal(), "thread", ThreadPoolExecutor(1).submit(denormal).result())
for mode in ("main", "thread", "thread+busy main", "main", "thread+busy main", "thread"):
    print(mode, run(mode))
import numpy
try:
    numpy.show_config()
except Exception as e:
    print(e)
