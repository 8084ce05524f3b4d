"""Geometric RGB-D semantic mapping: voxel fusion, room-shell removal, clustering, cuboids, size/colour labels.

Pure NumPy / SciPy, no BenchBot server needed. Typical use::

    mapper = GeometricMapper()
    for rgb, depth, K, T_map_camera in frames:
        mapper.integrate(rgb, depth, K, T_map_camera)
    objects = mapper.build_map(class_list)   # [{'label_probs', 'centroid', 'extent'}, ...]

Frames and units: ``map`` is the world frame (z up, metres). The camera frame is the OPTICAL frame (z forward along
the optical axis, x right, y down in the image): a pixel (u, v) with depth d (metres along z) is ``d · K⁻¹ [u, v, 1]ᵀ``
in the camera frame and ``T_map_camera`` (4, 4) maps it to ``map``. Everything the mapper reports is in ``map``.

Nothing here reads ground truth: the only inputs are RGB-D images, intrinsics and camera poses; everything else
(typical object sizes and colours) is hand-written domain knowledge in :data:`CLASS_PRIORS`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

# --------------------------------------------------------------------------------------------------------------
# Pose helpers
# --------------------------------------------------------------------------------------------------------------


def pose_to_matrix(translation_xyz: Sequence[float], rotation_xyzw: Sequence[float]) -> np.ndarray:
    """Homogeneous transform (4, 4) float64 from a translation (3,) in metres and a quaternion (4,) ``[x, y, z, w]``
    (ROS order; normalised here). With a BenchBot ``poses['camera']`` entry this is ``T_map_camera``.

    The rotation is SciPy's ``Rotation.from_quat(q).as_matrix()`` computed in the same float64 operations, in the
    same order (the unit quaternion's standard matrix, e.g. Shoemake, "Animating rotation with quaternion curves",
    SIGGRAPH 1985), so the matrices are equal bit for bit (the example's tests compare them on 200,000
    quaternions); importing ``scipy.spatial`` for it took 0.1 s of the solution's start on the 2-core CPU.

    Raises:
        ValueError: the quaternion has zero length.
    """
    q = np.asarray(rotation_xyzw, dtype=np.float64)
    if q.shape != (4,):
        raise ValueError(f"a quaternion has 4 values [x, y, z, w], got shape {q.shape}")
    if not np.any(q):
        raise ValueError("quaternion has zero length")
    T = np.eye(4)
    T[:3, :3] = _unit_quaternion_matrix(*(float(v) for v in q))
    T[:3, 3] = np.asarray(translation_xyz, dtype=np.float64)
    return T


def _unit_quaternion_matrix(x: float, y: float, z: float, w: float) -> list[list[float]]:
    """The rotation matrix (3 × 3, row-major) of quaternion ``[x, y, z, w]`` divided by its length first: SciPy's
    ``Rotation.from_quat`` and ``as_matrix`` (see :func:`pose_to_matrix`)."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    x2, y2, z2, w2 = x * x, y * y, z * z, w * w
    xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
    return [[x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)],
            [2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)],
            [2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2]]


# --------------------------------------------------------------------------------------------------------------
# Domain knowledge: typical sizes, colours, placement per class (hand-written, NOT ground truth)
# --------------------------------------------------------------------------------------------------------------

#: Named reference colours (sRGB 0..255) used to describe a cluster's mean colour.
COLOUR_NAMES: dict[str, tuple[int, int, int]] = {
    "black": (25, 25, 27),
    "grey": (95, 97, 100),
    "silver": (185, 188, 192),
    "white": (238, 238, 235),
    "cream": (225, 205, 160),
    "brown": (105, 68, 38),
    "wood": (150, 100, 55),
    "green": (55, 120, 50),
    "yellow": (235, 200, 60),
    "orange": (235, 135, 30),
    "red": (170, 30, 28),
    "blue": (45, 70, 130),
    "skin": (205, 160, 130),
    "purple": (90, 50, 100),
}

#: Per class: typical cuboid (long side, short side, height) in metres, the log-space spread σ of those sizes,
#: P(the object stands on the floor), and P(named colour | class) (unnormalised; a floor is added to every colour).
#: Sizes are "an average real-world object of this class", colours "what such objects usually look like".
CLASS_PRIORS: dict[str, dict] = {
    "bottle": dict(size=(0.08, 0.08, 0.26), sigma=0.35, floor=0.1,
                   colour=dict(green=3, brown=2, silver=2, white=1.5, blue=1)),
    "cup": dict(size=(0.09, 0.09, 0.10), sigma=0.35, floor=0.05, colour=dict(white=4, red=1, blue=1, black=1, grey=1)),
    "knife": dict(size=(0.22, 0.03, 0.02), sigma=0.4, floor=0.05, colour=dict(silver=6, grey=2, black=1)),
    "bowl": dict(size=(0.16, 0.16, 0.07), sigma=0.35, floor=0.05,
                 colour=dict(white=4, cream=2, blue=1, red=1, grey=1)),
    "wine glass": dict(size=(0.08, 0.08, 0.20), sigma=0.35, floor=0.05, colour=dict(silver=5, white=3, grey=1)),
    "fork": dict(size=(0.19, 0.03, 0.02), sigma=0.4, floor=0.05, colour=dict(silver=6, grey=2)),
    "spoon": dict(size=(0.17, 0.04, 0.02), sigma=0.4, floor=0.05, colour=dict(silver=6, grey=2)),
    "banana": dict(size=(0.19, 0.05, 0.04), sigma=0.35, floor=0.05, colour=dict(yellow=8, cream=2)),
    "apple": dict(size=(0.08, 0.08, 0.08), sigma=0.3, floor=0.05, colour=dict(red=6, green=3, yellow=1)),
    "orange": dict(size=(0.08, 0.08, 0.08), sigma=0.3, floor=0.05, colour=dict(orange=9, yellow=1)),
    "cake": dict(size=(0.25, 0.25, 0.10), sigma=0.4, floor=0.05, colour=dict(cream=4, brown=3, white=2, skin=1)),
    "potted plant": dict(size=(0.40, 0.40, 0.60), sigma=0.5, floor=0.7, colour=dict(green=9, brown=1)),
    "mouse": dict(size=(0.11, 0.06, 0.04), sigma=0.35, floor=0.05, colour=dict(black=6, grey=2, white=1, silver=1)),
    "keyboard": dict(size=(0.44, 0.14, 0.03), sigma=0.35, floor=0.05, colour=dict(black=7, grey=2, white=1)),
    "laptop": dict(size=(0.34, 0.24, 0.12), sigma=0.5, floor=0.05, colour=dict(grey=4, black=4, silver=3)),
    "cell phone": dict(size=(0.15, 0.075, 0.01), sigma=0.4, floor=0.05, colour=dict(black=8, grey=1, silver=1)),
    "book": dict(size=(0.23, 0.16, 0.04), sigma=0.45, floor=0.2,
                 colour=dict(red=2, blue=2, green=1, white=1.5, cream=1.5, brown=1, yellow=1, orange=1, black=1,
                             purple=1)),
    "clock": dict(size=(0.30, 0.06, 0.30), sigma=0.45, floor=0.05,
                  colour=dict(white=3, silver=2, black=3, wood=2)),
    "chair": dict(size=(0.50, 0.50, 0.90), sigma=0.3, floor=0.95,
                  colour=dict(wood=4, brown=3, black=1.5, grey=1, white=0.5)),
    "table": dict(size=(1.40, 0.80, 0.75), sigma=0.4, floor=0.95,
                  colour=dict(wood=5, brown=3, white=1, black=1)),
    "couch": dict(size=(2.00, 0.90, 0.85), sigma=0.3, floor=0.95,
                  colour=dict(grey=3, blue=2, brown=2, cream=2, wood=1, red=1, green=0.5)),
    "bed": dict(size=(2.10, 1.60, 0.60), sigma=0.3, floor=0.95, colour=dict(white=4, cream=4, grey=1, blue=1)),
    "toilet": dict(size=(0.70, 0.40, 0.75), sigma=0.3, floor=0.95, colour=dict(white=9, cream=1)),
    "tv": dict(size=(1.10, 0.15, 0.65), sigma=0.45, floor=0.3, colour=dict(black=9, grey=1)),
    "microwave": dict(size=(0.50, 0.35, 0.30), sigma=0.3, floor=0.05,
                      colour=dict(silver=3, black=3, white=2, grey=1)),
    "toaster": dict(size=(0.28, 0.18, 0.20), sigma=0.3, floor=0.05, colour=dict(silver=6, black=2, red=1, white=1)),
    "refrigerator": dict(size=(0.80, 0.70, 1.80), sigma=0.25, floor=0.95, colour=dict(white=5, silver=5, grey=1)),
    "oven": dict(size=(0.60, 0.60, 0.90), sigma=0.3, floor=0.9, colour=dict(black=4, grey=3, silver=3, white=2)),
    "sink": dict(size=(0.60, 0.45, 0.40), sigma=0.55, floor=0.5, colour=dict(white=6, silver=4)),
    "person": dict(size=(0.50, 0.30, 1.70), sigma=0.25, floor=0.9,
                   colour=dict(skin=3, blue=2, black=2, grey=1, red=1, white=0.5)),
}

# --------------------------------------------------------------------------------------------------------------
# Calibration constants (see README "Label probabilities")
# --------------------------------------------------------------------------------------------------------------

#: Softmax temperature applied to the per-class log-likelihood scores. T = 1 would be the Bayes posterior of the
#: hand-written generative model if the model were right; partial views and merged clusters make sizes wrong in
#: correlated ways the model ignores. T was set with :func:`calibrate_temperature` (minimum negative
#: log-likelihood of the true class on boxes sampled from CLASS_PRIORS and corrupted by partial views,
#: colour/shading noise, merged clusters): the NLL is lowest between T = 0.75 (1.01 nats) and T = 1.0 (1.03 nats)
#: and rises steadily above (2.0: 1.33 nats); we take the softer 1.0 because real failures are worse than modelled.
TEMPERATURE = 1.0
#: Log-likelihood score of "none of the classes" (background). A cluster whose best class scores far below this
#: puts most of its mass on background, which also lowers its false-positive cost in OMQ.
BACKGROUND_SCORE = -9.0
#: Clusters with fewer voxels than this get extra background mass, log(N / n_voxels) (weak evidence).
EVIDENCE_VOXELS = 10
#: Floor for P(named colour | class) after normalisation.
COLOUR_FLOOR = 0.02


@dataclass
class Cluster:
    """One object hypothesis (all in the ``map`` frame).

    Attributes:
        lo, hi: (3,) float64 box corners, metres.
        colour: (3,) float64 mean sRGB 0..255.
        n_voxels: occupied voxels in the cluster.
        on_floor: whether its bottom was snapped to (or near) the floor.
    """

    lo: np.ndarray
    hi: np.ndarray
    colour: np.ndarray
    n_voxels: int
    on_floor: bool = False
    elevation: float = 0.0

    @property
    def centroid(self) -> np.ndarray:
        return 0.5 * (self.lo + self.hi)

    @property
    def extent(self) -> np.ndarray:
        return self.hi - self.lo


@dataclass
class RoomShell:
    """What :meth:`GeometricMapper.build_map` found of the room (``None`` where not found). Metres, ``map`` frame.

    Attributes:
        floor_z, ceiling_z: heights of the floor and the ceiling planes.
        walls: list of ``(axis, position, lo, hi)``: a vertical plane ``coord[axis] == position`` (axis 0 = x,
            1 = y) spanning ``lo..hi`` along the other horizontal axis.
    """

    floor_z: float | None = None
    ceiling_z: float | None = None
    walls: list = field(default_factory=list)


_KEY_BITS = 21
_KEY_OFF = 1 << (_KEY_BITS - 1)
_KEY_MASK = (1 << _KEY_BITS) - 1


def _encode(ijk: np.ndarray) -> np.ndarray:
    """(N, 3) int64 voxel indices → (N,) int64 keys (21 bits per axis)."""
    ijk = ijk + _KEY_OFF
    return (ijk[:, 0] << (2 * _KEY_BITS)) | (ijk[:, 1] << _KEY_BITS) | ijk[:, 2]


def _unique_inverse(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, return_inverse=True)`` of a frame's (N,) int64 voxel keys, equal to it element for element
    (same dtypes), in a third of its time: neighbouring pixels mostly fall in one voxel, so the keys come in runs
    (76,800 keys of a 640 × 480 frame at stride 2 make ~30,000 runs); only the runs' first keys are sorted
    (:func:`_sorted_unique_inverse`), and each run's index is repeated over the run."""
    if len(keys) == 0:
        return np.unique(keys, return_inverse=True)
    starts = np.flatnonzero(np.concatenate(([True], keys[1:] != keys[:-1])))
    unique, run_index = _sorted_unique_inverse(keys[starts])
    return unique, np.repeat(run_index, np.diff(starts, append=len(keys)))


def _sorted_unique_inverse(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, return_inverse=True)`` of (N,) int64 keys, equal to it element for element (unique keys
    (M,) int64 ascending, inverse (N,) intp), sorted by a stable sort instead of NumPy's quicksort: for int64 that is
    Timsort, which merges the sorted runs it finds: the map's keys and a few frames' sorted keys are such runs. Over
    house:1's 270 frames the mapping took 8.6 ms a frame instead of 12.7 ms with ``np.unique`` (2-core CPU,
    ``benchmarks/example_mapping.py``, the same map bit for bit)."""
    if len(keys) == 0:
        return np.unique(keys, return_inverse=True)
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    first = np.empty(len(ordered), bool)
    first[0] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    inverse = np.empty(len(keys), np.intp)
    inverse[order] = np.cumsum(first) - 1
    return ordered[first], inverse


def _dilate_by_cube(grid: np.ndarray) -> np.ndarray:
    """(X, Y, Z) bool ``grid`` dilated by the 3 × 3 × 3 cube (outside the grid counts as False): equal to
    ``scipy.ndimage.binary_dilation(grid, structure=np.ones((3, 3, 3), bool))``, as the cube is the sum of three
    segments of 3 voxels, one per axis, and so done one axis at a time (with this, house:1's objects took 0.27 s
    instead of 0.46 s: ``benchmarks/example_mapping.py``'s objects from the map, before and after feaf26a)."""
    for axis in range(3):
        out = grid.copy()
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        out[tuple(hi)] |= grid[tuple(lo)]
        out[tuple(lo)] |= grid[tuple(hi)]
        grid = out
    return grid


def _decode(keys: np.ndarray) -> np.ndarray:
    """(N,) int64 keys → (N, 3) int64 voxel indices."""
    return np.stack([(keys >> (2 * _KEY_BITS)) & _KEY_MASK, (keys >> _KEY_BITS) & _KEY_MASK, keys & _KEY_MASK],
                    axis=1) - _KEY_OFF


class GeometricMapper:
    """Fuses RGB-D frames into a sparse coloured voxel map and turns it into axis-aligned labelled cuboids.

    Memory is bounded by the number of occupied voxels (surfaces only): per voxel an int64 key, a hit count and
    float64 sums of positions and colours (~64 bytes), e.g. ~25 MB for a 11 × 18 m house at 4 cm.

    Args:
        voxel: voxel edge, metres.
        stride: keep every ``stride``-th pixel in u and v (2 → 320 × 240 points from a 640 × 480 frame).
        min_depth, max_depth: depth range used, metres (far points are sparse and thin out clusters).
        merge_every: frames buffered before they are merged into the map (amortises the sort of the map's keys).
            The map is the same bit for bit whatever it is: each voxel's sums start at 0.0 and add the frames'
            in the order they were fused either way. 32 instead of 8 took house:1's mapping from 6.5 to 5.8 ms a
            frame (2-core CPU, ``benchmarks/example_mapping.py``: merged every 8 frames, and as it is).
        plane_margin: distance (metres) from the floor / ceiling / wall planes within which points are removed.
        min_cluster_voxels: clusters with fewer voxels are dropped.
        bridge_voxels: gaps of up to this many voxels are bridged when clustering (sparse far-away surfaces).
        max_object_size: clusters bigger than this (metres, any side) are structure, not objects.
        split_supports: split objects standing on a large horizontal surface (table tops) from that surface.
    """

    def __init__(self, voxel: float = 0.04, stride: int = 2, min_depth: float = 0.1, max_depth: float = 6.0,
                 merge_every: int = 32, plane_margin: float = 0.04, min_cluster_voxels: int = 4,
                 bridge_voxels: int = 1, max_object_size: float = 3.0, split_supports: bool = True):
        self.voxel = float(voxel)
        self.stride = int(stride)
        self.min_depth, self.max_depth = float(min_depth), float(max_depth)
        self.merge_every = int(merge_every)
        self.plane_margin = float(plane_margin)
        self.min_cluster_voxels = int(min_cluster_voxels)
        self.bridge_voxels = int(bridge_voxels)
        self.max_object_size = float(max_object_size)
        self.split_supports = bool(split_supports)
        self._keys = np.zeros(0, np.int64)
        self._count = np.zeros(0, np.float64)
        self._sum_xyz = np.zeros((0, 3), np.float64)
        self._sum_rgb = np.zeros((0, 3), np.float64)
        self._buffer: list[tuple] = []
        self._ray_cache: dict = {}
        self.n_frames = 0
        self.camera_positions: list[np.ndarray] = []
        self.shell = RoomShell()

    # ----------------------------------------------------------------------------------------------------------
    # Integration
    # ----------------------------------------------------------------------------------------------------------

    def integrate(self, rgb: np.ndarray, depth: np.ndarray, K: np.ndarray, T_map_camera: np.ndarray) -> int:
        """Add one RGB-D frame.

        Args:
            rgb: (H, W, 3) uint8, RGB order.
            depth: (H, W) float32, metres along the optical axis; 0 (or non-finite) = no return.
            K: (3, 3) camera intrinsics (pixels).
            T_map_camera: (4, 4) pose of the OPTICAL camera frame in ``map``.

        Returns:
            The number of points added.
        """
        s = self.stride
        d = np.asarray(depth, dtype=np.float32)[::s, ::s]
        h, w = d.shape
        K = np.asarray(K, dtype=np.float64)
        ck = (h, w, s, K.tobytes())
        rays = self._ray_cache.get(ck)
        if rays is None:  # K⁻¹ [u, v, 1]ᵀ for the kept pixels, (h·w, 3)
            v, u = np.mgrid[0:h * s:s, 0:w * s:s]
            pix = np.stack([u.ravel(), v.ravel(), np.ones(u.size)], axis=0).astype(np.float64)
            rays = (np.linalg.inv(K) @ pix).T.astype(np.float32)
            self._ray_cache = {ck: rays}
        d = d.ravel()
        ok = np.isfinite(d) & (d > self.min_depth) & (d < self.max_depth)
        n_ok = int(np.count_nonzero(ok))
        if n_ok == 0:
            return 0
        every = n_ok == len(d)  # every pixel kept (a closed room): the same arrays without the masks' copies
        # np.compress takes the kept rows as boolean indexing does, in half its time
        pts_c = rays * d[:, None] if every else np.compress(ok, rays, axis=0) * np.compress(ok, d)[:, None]
        T = np.asarray(T_map_camera, dtype=np.float64)
        pts = pts_c @ T[:3, :3].T.astype(np.float32) + T[:3, 3].astype(np.float32)
        rgb_kept = np.asarray(rgb)[::s, ::s]
        cols = rgb_kept.astype(np.float32).reshape(-1, 3) if every \
            else np.compress(ok, rgb_kept.reshape(-1, 3), axis=0).astype(np.float32)
        ijk = np.floor(pts / self.voxel).astype(np.int64)
        keys = _encode(ijk)
        uk, inv = _unique_inverse(keys)
        n = len(uk)
        cnt = np.bincount(inv, minlength=n).astype(np.float64)
        sxyz = np.stack([np.bincount(inv, pts[:, i], minlength=n) for i in range(3)], axis=1)
        srgb = np.stack([np.bincount(inv, cols[:, i], minlength=n) for i in range(3)], axis=1)
        self._buffer.append((uk, cnt, sxyz, srgb))
        self.n_frames += 1
        self.camera_positions.append(T[:3, 3].copy())
        if len(self._buffer) >= self.merge_every:
            self._flush()
        return n_ok

    def _flush(self) -> None:
        if not self._buffer:
            return
        keys = np.concatenate([self._keys] + [b[0] for b in self._buffer])
        cnt = np.concatenate([self._count] + [b[1] for b in self._buffer])
        sxyz = np.concatenate([self._sum_xyz] + [b[2] for b in self._buffer])
        srgb = np.concatenate([self._sum_rgb] + [b[3] for b in self._buffer])
        self._buffer = []
        uk, inv = _sorted_unique_inverse(keys)
        n = len(uk)
        self._keys = uk
        self._count = np.bincount(inv, cnt, minlength=n)
        self._sum_xyz = np.stack([np.bincount(inv, sxyz[:, i], minlength=n) for i in range(3)], axis=1)
        self._sum_rgb = np.stack([np.bincount(inv, srgb[:, i], minlength=n) for i in range(3)], axis=1)

    def voxels(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The fused map: ``(ijk (N, 3) int64 voxel indices, mean xyz (N, 3) float64 metres in map,
        mean rgb (N, 3) float64 0..255, hits (N,) float64)``."""
        self._flush()
        c = self._count
        return _decode(self._keys), self._sum_xyz / c[:, None], self._sum_rgb / c[:, None], c.copy()

    # ----------------------------------------------------------------------------------------------------------
    # Room shell
    # ----------------------------------------------------------------------------------------------------------

    def _find_shell(self, ijk: np.ndarray, xyz: np.ndarray) -> RoomShell:
        """Floor / ceiling = lowest / highest dense horizontal layer; walls = axis-aligned vertical planes that are
        dense in the band just under the ceiling (where only walls reach)."""
        v = self.voxel
        shell = RoomShell()
        kz = ijk[:, 2]
        zmin = kz.min()
        hist = np.bincount(kz - zmin)
        dense = np.flatnonzero(hist >= max(0.2 * hist.max(), 50))
        if len(dense):
            k0 = dense[0]
            sel = (kz - zmin >= k0 - 1) & (kz - zmin <= k0 + 1)
            shell.floor_z = float(np.median(xyz[sel, 2]))
            k1 = dense[-1]
            ztop = float(np.median(xyz[(kz - zmin >= k1 - 1) & (kz - zmin <= k1 + 1), 2]))
            if k1 > k0 and shell.floor_z is not None and ztop - shell.floor_z > 2.0:
                shell.ceiling_z = ztop
        if shell.floor_z is None:
            return shell
        if shell.ceiling_z is not None:
            band = (xyz[:, 2] > max(shell.floor_z + 2.0, shell.ceiling_z - 0.45)) & (
                xyz[:, 2] < shell.ceiling_z - self.plane_margin)
        else:
            band = xyz[:, 2] > shell.floor_z + 2.0
        if band.sum() < 10:
            return shell
        band_rows = max(1, int(np.unique(kz[band]).size))
        for axis in (0, 1):
            other = 1 - axis
            k = ijk[band, axis]
            kmin = k.min()
            h = np.bincount(k - kmin)
            # a wall: ≥ 1 m long at ≥ 50 % coverage of the band's rows
            thr = 0.5 * band_rows * (1.0 / v)
            peaks = np.flatnonzero(h >= thr)
            if not len(peaks):
                continue
            groups = np.split(peaks, np.flatnonzero(np.diff(peaks) > 1) + 1)
            for g in groups:
                m = (k - kmin >= g[0]) & (k - kmin <= g[-1])
                pos = float(np.median(xyz[band][m, axis]))
                span = xyz[band][m, other]
                lo, hi = np.percentile(span, [0.5, 99.5])
                shell.walls.append((axis, pos, float(lo) - 0.2, float(hi) + 0.2))
        return shell

    def _shell_mask(self, xyz: np.ndarray, shell: RoomShell) -> np.ndarray:
        """(N,) bool: points on (or outside) the room shell."""
        m = self.plane_margin
        out = np.zeros(len(xyz), bool)
        if shell.floor_z is not None:
            out |= xyz[:, 2] < shell.floor_z + m
        if shell.ceiling_z is not None:
            out |= xyz[:, 2] > shell.ceiling_z - m
        for axis, pos, lo, hi in shell.walls:
            o = xyz[:, 1 - axis]
            out |= (np.abs(xyz[:, axis] - pos) < m) & (o > lo) & (o < hi)
        for axis in (0, 1):  # beyond the outermost walls of an axis = outside the room
            ps = [p for a, p, _, _ in shell.walls if a == axis]
            if len(ps) >= 2 and max(ps) - min(ps) > 1.0:
                out |= (xyz[:, axis] < min(ps)) | (xyz[:, axis] > max(ps))
        return out

    # ----------------------------------------------------------------------------------------------------------
    # Clustering and cuboids
    # ----------------------------------------------------------------------------------------------------------

    def _components(self, ijk: np.ndarray, bridge: int) -> np.ndarray:
        """Connected components (26-connectivity) of the voxels ``ijk`` (N, 3), bridging gaps of ``bridge`` voxels.
        Returns (N,) int labels 0..C-1."""
        if len(ijk) == 0:
            return np.zeros(0, int)
        # SciPy's ndimage is imported here, at the clustering, not with this module: its import (0.17 s on the 2-core
        # CPU: SciPy's array-API layer, which loads numpy.testing and numpy.f2py, and scipy.special) was half of the
        # solution's start, before its first step. Imported on a thread during the steps instead, it gained nothing
        # measurable: it took the interpreter lock from the mapping and, on a CPU, the cores from the renderer.
        from scipy import ndimage

        lo = ijk.min(axis=0) - bridge
        idx = ijk - lo
        shape = tuple(idx.max(axis=0) + bridge + 1)
        grid = np.zeros(shape, bool)
        grid[idx[:, 0], idx[:, 1], idx[:, 2]] = True
        for _ in range(bridge):
            grid = _dilate_by_cube(grid)
        lab, _ = ndimage.label(grid, structure=np.ones((3, 3, 3), int))
        lab = lab[idx[:, 0], idx[:, 1], idx[:, 2]]
        _, out = np.unique(lab, return_inverse=True)
        return out.ravel()

    def _split_on_support(self, ijk: np.ndarray) -> tuple[np.ndarray, int | None]:
        """Split a cluster at a supporting horizontal surface (a table top with things on it).

        Returns (N,) int sub-labels (0 = the support and below) and the support layer index (or None)."""
        kz = ijk[:, 2]
        z0 = kz.min()
        hist = np.bincount(kz - z0)
        if len(hist) < 4:
            return np.zeros(len(ijk), int), None
        top = int(np.argmax(hist))
        if hist[top] < 30 or hist[top] < 3 * np.median(hist):
            return np.zeros(len(ijk), int), None
        upper = kz - z0 > top + 1
        if upper.sum() < self.min_cluster_voxels:
            return np.zeros(len(ijk), int), None
        # the parts above must be smaller than the support surface (objects standing on it)
        fp_up = np.unique(ijk[upper][:, :2], axis=0).shape[0]
        if fp_up > 0.7 * hist[top]:
            return np.zeros(len(ijk), int), None
        sub = np.zeros(len(ijk), int)
        sub[upper] = 1 + self._components(ijk[upper], 0)
        return sub, top + z0

    def _fit_box(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Robust axis-aligned box (lo, hi) of the points (N, 3): min/max for small clusters, 1–99th percentiles
        for large ones; at least half a voxel thick."""
        if len(xyz) < 60:
            lo, hi = xyz.min(axis=0), xyz.max(axis=0)
        else:
            lo, hi = np.percentile(xyz, [1, 99], axis=0)
        c, e = 0.5 * (lo + hi), np.maximum(hi - lo, 0.5 * self.voxel)
        return c - e / 2, c + e / 2

    def clusters(self) -> list[Cluster]:
        """Segment the fused map into object cuboids (room shell removed). See the README for the steps."""
        ijk, xyz, rgb, hits = self.voxels()
        if len(ijk) == 0:
            return []
        shell = self._find_shell(ijk, xyz)
        self.shell = shell
        keep = ~self._shell_mask(xyz, shell)
        ijk, xyz, rgb, hits = ijk[keep], xyz[keep], rgb[keep], hits[keep]
        labels = self._components(ijk, self.bridge_voxels)
        order = np.argsort(labels, kind="stable")
        bounds = np.flatnonzero(np.diff(labels[order])) + 1
        out: list[Cluster] = []
        snap = self.plane_margin + 1.5 * self.voxel
        for members in np.split(order, bounds):
            if len(members) < self.min_cluster_voxels:
                continue
            parts = [(members, None)]
            if self.split_supports and len(members) >= 40:
                sub, top = self._split_on_support(ijk[members])
                if top is not None:
                    support_z = float(np.median(xyz[members][ijk[members][:, 2] == top, 2]))
                    parts = [(members[sub == s], None if s == 0 else support_z) for s in np.unique(sub)]
            for pm, support_z in parts:
                if len(pm) < self.min_cluster_voxels:
                    continue
                lo, hi = self._fit_box(xyz[pm])
                on_floor = False
                if support_z is not None:
                    lo[2] = min(lo[2], support_z)
                elif shell.floor_z is not None and lo[2] - shell.floor_z < snap:
                    lo[2], on_floor = shell.floor_z, True
                for axis, pos, wlo, whi in shell.walls:  # snap faces against a wall onto it
                    if not (wlo < 0.5 * (lo[1 - axis] + hi[1 - axis]) < whi):
                        continue
                    if 0 < lo[axis] - pos < snap:
                        lo[axis] = pos
                    elif 0 < pos - hi[axis] < snap:
                        hi[axis] = pos
                if np.any(hi - lo > self.max_object_size):
                    continue
                w = hits[pm]
                colour = (rgb[pm] * w[:, None]).sum(axis=0) / w.sum()
                elev = 0.0 if shell.floor_z is None else float(lo[2] - shell.floor_z)
                out.append(Cluster(lo=lo, hi=hi, colour=colour, n_voxels=len(pm), on_floor=on_floor, elevation=elev))
        return out

    # ----------------------------------------------------------------------------------------------------------
    # Results
    # ----------------------------------------------------------------------------------------------------------

    def build_map(self, class_list: Sequence[str]) -> list[dict]:
        """The object map: one dict per cluster, ``{'label_probs': list[float] (len(class_list)), 'centroid':
        [x, y, z], 'extent': [dx, dy, dz]}`` (metres, ``map`` frame, full side lengths of an axis-aligned box).
        Probabilities of classes we have no prior for are 0; the rest of the mass goes to ``background`` if present
        (or is left unassigned, which OMQ also gives to background)."""
        objects = []
        for c in self.clusters():
            probs = label_probabilities(c, class_list)
            objects.append({"label_probs": [float(p) for p in probs],
                            "centroid": [float(x) for x in c.centroid],
                            "extent": [float(x) for x in c.extent]})
        return objects


# --------------------------------------------------------------------------------------------------------------
# Classification
# --------------------------------------------------------------------------------------------------------------

_COLOUR_KEYS = list(COLOUR_NAMES)


#: Linear sRGB → CIE XYZ, D65 (IEC 61966-2-1), each row divided by the D65 white's X, Y, Z (0.950456, 1, 1.088754).
_RGB_TO_XYZ_WHITE = np.array([[0.412453, 0.357580, 0.180423],
                              [0.212671, 0.715160, 0.072169],
                              [0.019334, 0.119193, 0.950227]]) / np.array([[0.950456], [1.0], [1.088754]])


def _lab(rgb255: np.ndarray) -> np.ndarray:
    """(N, 3) sRGB 0..255 → (N, 3) float64 CIE 1976 L*a*b* (L 0..100), D65 white: the sRGB transfer function undone
    (IEC 61966-2-1), XYZ relative to the white, then CIE 15's L*, a*, b* with their linear segment below
    (6/29)³ = 0.008856. (NumPy, in float64: OpenCV's float conversion, used before, differs by < 0.7 and took
    0.1–0.3 s of every solution's start to build its tables.)"""
    c = np.asarray(rgb255, np.float64).reshape(-1, 3) / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = linear @ _RGB_TO_XYZ_WHITE.T
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16.0 / 116.0)
    lightness = np.where(xyz[:, 1] > 0.008856, 116.0 * f[:, 1] - 16.0, 903.3 * xyz[:, 1])
    return np.stack([lightness, 500.0 * (f[:, 0] - f[:, 1]), 200.0 * (f[:, 1] - f[:, 2])], axis=1)


_COLOUR_LAB = _lab(np.array([COLOUR_NAMES[k] for k in _COLOUR_KEYS]))


def colour_memberships(rgb255: np.ndarray, sigma: float = 18.0) -> np.ndarray:
    """Soft membership (len(COLOUR_NAMES),) summing to 1 of a mean colour (3,) sRGB 0..255 in the named colours.

    Distance in Lab with lightness down-weighted by 2 (shading and lighting change L more than hue)."""
    lab = _lab(np.asarray(rgb255).reshape(1, 3))[0]
    d = _COLOUR_LAB - lab
    d2 = (d[:, 0] / 2.0) ** 2 + d[:, 1] ** 2 + d[:, 2] ** 2
    s = -d2 / (2 * sigma * sigma)
    s = np.exp(s - s.max())
    return s / s.sum()


def _colour_table() -> tuple[list[str], np.ndarray]:
    names = list(CLASS_PRIORS)
    tab = np.zeros((len(names), len(_COLOUR_KEYS)))
    for i, n in enumerate(names):
        for cname, wgt in CLASS_PRIORS[n]["colour"].items():
            tab[i, _COLOUR_KEYS.index(cname)] = wgt
        tab[i] /= tab[i].sum()
        tab[i] = (tab[i] + COLOUR_FLOOR) / (1 + COLOUR_FLOOR * len(_COLOUR_KEYS))
    return names, tab


_CLASS_NAMES, _P_COLOUR = _colour_table()
_SIZES = np.log(np.array([CLASS_PRIORS[n]["size"] for n in _CLASS_NAMES]))
_SIGMAS = np.array([CLASS_PRIORS[n]["sigma"] for n in _CLASS_NAMES])
_P_FLOOR = np.array([CLASS_PRIORS[n]["floor"] for n in _CLASS_NAMES])


def class_scores(extent: np.ndarray, colour: np.ndarray, on_floor: bool) -> np.ndarray:
    """Log-likelihood scores (len(CLASS_PRIORS),) of each class for a cuboid.

    Args:
        extent: (3,) full side lengths, metres (z = height).
        colour: (3,) mean sRGB 0..255.
        on_floor: whether the cuboid stands on the floor.

    Score = size term (log-normal on sorted horizontal sides and the height; observed sides smaller than typical
    are penalised 1.5× less, since partial views shrink boxes) + log P(colour | class) + log P(on floor | class).
    """
    e = np.maximum(np.asarray(extent, np.float64), 0.01)
    obs = np.log(np.array([max(e[0], e[1]), min(e[0], e[1]), e[2]]))
    diff = obs[None, :] - _SIZES
    sig = _SIGMAS[:, None] * np.where(diff < 0, 1.5, 1.0)
    size = -0.5 * ((diff / sig) ** 2).sum(axis=1) - np.log(sig).sum(axis=1) + 3 * np.log(0.3)
    col = np.log(_P_COLOUR @ colour_memberships(colour))
    place = np.log(np.where(on_floor, _P_FLOOR, 1 - _P_FLOOR))
    return size + col + place


def label_probabilities(cluster: Cluster, class_list: Sequence[str], temperature: float = TEMPERATURE,
                        background_score: float = BACKGROUND_SCORE) -> np.ndarray:
    """Calibrated label probabilities (len(class_list),) float64 summing to ≤ 1 for a cluster.

    softmax([scores, background_score + evidence penalty] / temperature); the background mass goes to the
    ``background`` entry of ``class_list`` if there is one (else it is left out: the sum is then < 1)."""
    s = class_scores(cluster.extent, cluster.colour, cluster.on_floor)
    bg = background_score + max(0.0, math.log(EVIDENCE_VOXELS / max(cluster.n_voxels, 1)))
    z = np.append(s, bg) / temperature
    p = np.exp(z - z.max())
    p /= p.sum()
    out = np.zeros(len(class_list))
    index = {n.lower(): i for i, n in enumerate(class_list)}
    for j, n in enumerate(_CLASS_NAMES):
        if n in index:
            out[index[n]] += p[j]
    if "background" in index:  # everything not given to a listed class (incl. the background score's share)
        b = index["background"]
        out[b] = max(0.0, 1.0 - (out.sum() - out[b]))
    return out


# --------------------------------------------------------------------------------------------------------------
# Temperature calibration (offline; how TEMPERATURE was chosen)
# --------------------------------------------------------------------------------------------------------------


def calibrate_temperature(n: int = 3000, seed: int = 0,
                          temperatures: Sequence[float] = (0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0)) -> dict:
    """Mean negative log-likelihood of the true class per temperature, on synthetic cuboids sampled from
    :data:`CLASS_PRIORS` and corrupted the way the mapper corrupts them: log-normal size jitter, with probability
    0.5 one horizontal side seen only partially (× U(0.3, 1)), height cut by up to 20 %, a colour drawn from the
    class's colour table with ±25 per-channel shading noise and a global brightness factor U(0.5, 1.1), and the
    floor flag flipped with probability 0.1, and 20 % "bad clusters" (merged with a neighbour: one side × U(1, 2.5),
    colour averaged with a random named colour). Returns ``{temperature: mean NLL}``; no ground truth involved."""
    rng = np.random.default_rng(seed)
    names = _CLASS_NAMES
    samples = []
    for _ in range(n):
        k = rng.integers(len(names))
        pr = CLASS_PRIORS[names[k]]
        size = np.array(pr["size"]) * np.exp(rng.normal(0, pr["sigma"] * 0.7, 3))
        if rng.random() < 0.5:
            size[rng.integers(2)] *= rng.uniform(0.3, 1.0)
        size[2] *= rng.uniform(0.8, 1.0)
        cn = list(pr["colour"])
        w = np.array([pr["colour"][c] for c in cn], float)
        cname = cn[rng.choice(len(cn), p=w / w.sum())]
        col = np.clip(np.array(COLOUR_NAMES[cname]) * rng.uniform(0.5, 1.1) + rng.normal(0, 25, 3), 0, 255)
        floor = (rng.random() < pr["floor"]) != (rng.random() < 0.1)
        if rng.random() < 0.2:  # a bad cluster: merged with a neighbour (one side too long, colours mixed)
            size[rng.integers(3)] *= rng.uniform(1.0, 2.5)
            other = np.array(COLOUR_NAMES[_COLOUR_KEYS[rng.integers(len(_COLOUR_KEYS))]])
            col = 0.5 * (col + other)
        samples.append((k, class_scores(size, col, floor)))
    out = {}
    for t in temperatures:
        nll = 0.0
        for k, s in samples:
            z = np.append(s, BACKGROUND_SCORE) / t
            z = z - z.max()
            nll -= z[k] - math.log(np.exp(z).sum())
        out[float(t)] = nll / n
    return out
