"""semslam_geometric: an honest RGB-D semantic-mapping baseline for ``semantic_slam:passive:ground_truth``.

Uses only the task's observations (``image_rgb``, ``image_depth``, ``image_rgb_info``, ``poses``) and never ground
truth. Each step fuses the frame into a voxel map (see ``mapping.py``); at the end the map is segmented into
axis-aligned cuboids with size/colour label probabilities and written as an ``object_map`` result.

Run against BenchBot (from the example's folder, as the core does)::

    python semslam_geometric/semslam_geometric.py

Run offline on recorded frames (an ``.npz`` with ``rgb`` (N, H, W, 3) uint8, ``depth`` (N, H, W) float32 metres,
``K`` (3, 3) or (N, 3, 3), ``T`` (N, 4, 4) T_map_camera of the optical frame)::

    python semslam_geometric.py --offline frames.npz --output result.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from concurrent.futures import Future, ThreadPoolExecutor

# One BLAS thread (unless the user set another count): the mapping's BLAS work is each frame's 76,800 × 3
# points times a 3 × 3 rotation, which OpenBLAS split over every core, and its threads then spin-wait for the
# next call, taking those cores from the simulator that renders the next frame meanwhile (on the 2-core CPU
# README command 1's 48 steps took 2.3 s of waiting for frames with them and 1.5 s without). The product is the
# same either way (its inner dimension, 3, is never split). Set here, before NumPy loads OpenBLAS, when this file
# runs as the solution (imported, it leaves its importer's environment alone).
if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mapping import GeometricMapper, pose_to_matrix  # noqa: E402

try:
    from benchbot_api import ActionResult, Agent, BenchBot
except ImportError:  # offline use only (no BenchBot API installed)
    ActionResult = BenchBot = None

    class Agent:  # minimal stand-in with the reference interface
        pass

#: The default object_map class list (docs/evaluation.md), used offline.
DEFAULT_CLASS_LIST = ["bottle", "cup", "knife", "bowl", "wine glass", "fork", "spoon", "banana", "apple", "orange",
                      "cake", "potted plant", "mouse", "keyboard", "laptop", "cell phone", "book", "clock", "chair",
                      "table", "couch", "bed", "toilet", "tv", "microwave", "toaster", "refrigerator", "oven",
                      "sink", "person", "background"]


def observation_frame(observations: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """``(rgb (H, W, 3) uint8, depth (H, W) float32 m, K (3, 3), T_map_camera (4, 4))`` from BenchBot observations,
    or None if something needed is missing."""
    try:
        rgb = np.asarray(observations["image_rgb"])
        depth = np.asarray(observations["image_depth"], dtype=np.float32)
        info = observations.get("image_depth_info") or observations["image_rgb_info"]
        K = info.get("matrix_intrinsics", info.get("matrix_instrinsics"))
        cam = observations["poses"]["camera"]
        T = pose_to_matrix(cam["translation_xyz"], cam["rotation_xyzw"])
    except (KeyError, TypeError, AttributeError):
        return None
    if depth.shape[:2] != rgb.shape[:2]:
        return None
    return rgb, depth, np.asarray(K, dtype=np.float64).reshape(3, 3), T


class GeometricAgent(Agent):
    """Passive agent: fuses every observation and follows the trajectory with ``move_next`` until it ends.

    A frame is fused on a thread of its own while the next step is on its way: :meth:`pick_action` hands the frame to
    that thread and answers at once, so the backend renders the next frame while this one is fused (NumPy releases
    the interpreter lock in its array work). One frame at a time, in order: before the next frame is handed over,
    and before the map is built, the last one is waited for, so the map is the same, bit for bit, as when each frame
    is fused in :meth:`pick_action` itself (``fuse_ahead=False``). An error of the fusion is raised again at the next
    :meth:`pick_action` or at :meth:`build_objects`. The thread holds the frame's arrays until it is fused; the API
    never reuses the shared memory of an array still held (``benchbot.protocol.shared_frames``).

    Args:
        fuse_ahead: fuse each frame on the thread (default) or in :meth:`pick_action`.
        mapper_kwargs: the :class:`~mapping.GeometricMapper`'s arguments.
    """

    #: The name its messages start with.
    NAME = "semslam_geometric"

    def __init__(self, fuse_ahead: bool = True, **mapper_kwargs):
        self._mapper_kwargs = mapper_kwargs
        self.mappers: dict[int, GeometricMapper] = {}
        self._fusion = ThreadPoolExecutor(max_workers=1, thread_name_prefix="fuse") if fuse_ahead else None
        self._fusing: Future | None = None

    def _mapper(self, scene: int) -> GeometricMapper:
        if scene not in self.mappers:
            self.mappers[scene] = GeometricMapper(**self._mapper_kwargs)
        return self.mappers[scene]

    def _fused(self) -> None:
        """Wait for the frame being fused (raising its error, if any)."""
        fusing, self._fusing = self._fusing, None
        if fusing is not None:
            fusing.result()

    def is_done(self, action_result) -> bool:
        return action_result != ActionResult.SUCCESS

    def pick_action(self, observations, action_list):
        frame = observation_frame(observations)
        self._fused()
        if frame is not None:
            mapper = self._mapper(int(observations.get("scene_number", 0) or 0))
            if self._fusion is None:
                mapper.integrate(*frame)
            else:
                self._fusing = self._fusion.submit(mapper.integrate, *frame)
        return "move_next", {}

    def build_objects(self, class_list) -> list[dict]:
        """Objects of the first scene's map (semantic SLAM has one scene), once the last frame is fused."""
        self._fused()
        if not self.mappers:
            return []
        return self.mappers[min(self.mappers)].build_map(class_list)

    def save_result(self, filename, empty_results, results_format_fns):
        results = empty_results.setdefault("results", {})
        class_list = results.get("class_list") or list(DEFAULT_CLASS_LIST)
        results["class_list"] = class_list
        objects = []
        for o in self.build_objects(class_list):
            obj = {}
            try:  # the format's own empty object (keeps any extra fields it defines)
                obj = dict(results_format_fns["create_object"](num_classes=len(class_list)))
            except Exception:
                obj = {}
            obj.update(o)
            objects.append(obj)
        results["objects"] = objects
        with open(filename, "w") as f:
            json.dump(empty_results, f)
        print(f"{self.NAME}: wrote {len(objects)} objects to {filename}")


def load_recording(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The frames recorded in ``path`` (.npz, see the module docstring): ``rgb`` (N, H, W, 3) uint8, ``depth``
    (N, H, W) float32 metres, ``K`` (N, 3, 3) intrinsics (one (3, 3) is repeated), ``T`` (N, 4, 4) T_map_camera of
    the optical frame.

    Raises:
        OSError: ``path`` cannot be read. ValueError: it is not an ``.npz`` of those four arrays, or their shapes
            disagree (the message names the array).
    """
    data = np.load(path)
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise ValueError("not an .npz of the arrays rgb, depth, K, T")
    with data:
        missing = [name for name in ("rgb", "depth", "K", "T") if name not in data.files]
        if missing:
            raise ValueError(f"no array {', '.join(missing)} (an .npz of rgb, depth, K, T is needed)")
        rgb, depth, K, T = data["rgb"], data["depth"], data["K"], data["T"]
    if rgb.ndim != 4 or rgb.shape[3] != 3:
        raise ValueError(f"rgb has shape {rgb.shape}, not (N, H, W, 3)")
    n = len(rgb)
    if depth.shape != rgb.shape[:3]:
        raise ValueError(f"depth has shape {depth.shape}, not {rgb.shape[:3]} (rgb's N, H, W)")
    if K.shape == (3, 3):
        K = np.broadcast_to(K, (n, 3, 3))
    if K.shape != (n, 3, 3):
        raise ValueError(f"K has shape {K.shape}, not (3, 3) or ({n}, 3, 3)")
    if T.shape != (n, 4, 4):
        raise ValueError(f"T has shape {T.shape}, not ({n}, 4, 4)")
    return rgb, depth, K, T


def run_offline(path: str, output: str, **mapper_kwargs) -> dict:
    """Fuse the frames recorded in ``path`` (.npz, see the module docstring) and write an object_map result.

    Raises:
        OSError, ValueError: ``path`` cannot be read or holds no valid recording (:func:`load_recording`).
    """
    return fuse_recording(GeometricAgent(**mapper_kwargs), path, output)


def fuse_recording(agent: "GeometricAgent", path: str, output: str) -> dict:
    """Integrate every frame recorded in ``path`` (:func:`load_recording`) into ``agent``'s mapper and write its
    object_map result to ``output`` (:meth:`GeometricAgent.save_result`); returns the result's frame (task and
    environment details of an offline run). The offline mode of this example and of ``semslam_detector``.

    Raises:
        OSError, ValueError: ``path`` cannot be read or holds no valid recording (:func:`load_recording`).
    """
    rgb, depth, K, T = load_recording(path)
    mapper = agent._mapper(0)
    for i in range(len(rgb)):
        mapper.integrate(rgb[i], depth[i], K[i], T[i])
    empty = {"task_details": {"name": "semantic_slam:passive:ground_truth", "results_format": "object_map"},
             "environment_details": [{"name": "offline", "variant": 1}],
             "results": {"objects": [], "class_list": list(DEFAULT_CLASS_LIST)}}
    agent.save_result(output, empty, {})
    return empty


def main(argv=None) -> None:
    """The example's command line (``argv``: its arguments, None for ``sys.argv``): run as a solution against the
    backend ``benchbot_api`` connects to, or with ``--offline NPZ`` fuse recorded frames into ``--output``.

    Exits (``SystemExit`` with a one-line message) when the recording cannot be read or ``benchbot_api`` is missing
    without ``--offline``."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--offline", metavar="NPZ", help="fuse recorded frames instead of connecting to BenchBot")
    p.add_argument("--output", default="semslam_geometric_result.json", help="results file in offline mode")
    p.add_argument("--voxel", type=float, default=0.04, help="voxel edge, metres")
    p.add_argument("--stride", type=int, default=2, help="pixel subsampling")
    args = p.parse_args(argv)
    kwargs = dict(voxel=args.voxel, stride=args.stride)
    if args.offline:
        try:
            run_offline(args.offline, args.output, **kwargs)
        except (OSError, ValueError) as exc:
            sys.exit(f"semslam_geometric: cannot read --offline {args.offline}: {exc}")
        return
    if BenchBot is None:
        sys.exit("benchbot_api is not installed: use --offline")
    BenchBot(agent=GeometricAgent(**kwargs)).run()


if __name__ == "__main__":
    main()
