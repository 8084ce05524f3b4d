"""``TaichiSimBackend``: the :class:`~benchbot.core.robot.RobotBackend` of robots of type ``sim_taichi``.

The robot is a differential-drive base with a circular footprint moving on the floor of a box scene
(:mod:`benchbot_worlds.scene.build`), driven by :class:`benchbot.core.motion.PoseController` in simulated time;
its RGB-D camera, segmentation and planar laser are ray cast with Taichi (:mod:`benchbot_sim_taichi.render.renderer`,
imported on first use). Use from one thread.

Frames (all ``T_map_<frame>`` (4, 4) float64): ``robot`` (x forward, y left, z up, ``sensors.robot_frame_height_m``
above the floor under the base centre; carter's is 0.244 m, as the original BenchBot's carter reported);
``camera`` (OPTICAL frame: z forward, x right, y down) at the mount of ``sensors.camera``; ``lidar`` (x forward,
z up) at ``sensors.laser.mount_xyz``. Mounts are given from the robot's *footprint*: the robot frame lowered to the
floor (the point on the floor under the base centre, the robot's axes), so a sensor's height is its height above the
floor whatever the robot frame's height.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from benchbot.core import noise as noise_models
from benchbot.core import stages
from benchbot.core.errors import BackendError, UsageError
from benchbot.core.limits import MAX_CAMERA_SIDE
from benchbot.core.geometry import rpy_to_matrix, se2_to_matrix
from benchbot.core.motion import ControllerGains
from benchbot.core.specs import first_error
from benchbot.core.robot import MotionOutcome, RobotBackend

from benchbot_sim_taichi.render.camera_model import CameraModel
from benchbot_sim_taichi import loaded_scenes
from benchbot_sim_taichi.kinematics import Obstacles, drive
from benchbot_sim_taichi.render_check import render_check
from benchbot_sim_taichi import scene_cache
from benchbot_worlds.scene.build import build_scene
from benchbot_worlds.scene.model import Scene

#: Defaults of the robot spec's ``sensors`` block.
DEFAULT_SENSORS: dict[str, Any] = {
    # mounts: where the original BenchBot's carter carried its left camera (1.054 m above the floor) and its lidar
    "camera": {"width": 640, "height": 480, "horizontal_fov_deg": 90.0, "mount_xyz": [0.11, 0.06, 1.054],
               "mount_rpy_deg": [0.0, 0.0, 0.0],
               # the camera model (camera_model.py): an ACES filmic tone curve at -0.5 EV (mid-tones as the plain
               # clip's, highlights roll off instead of burning out; docs/realism.md); 0.0, "clip": the image as rendered
               "exposure_ev": -0.5, "tone_curve": "filmic", "vignetting": 0.0,
               # quality mode meters each frame's exposure, as a camera's auto-exposure (camera_model.py, step 2)
               "auto_exposure": True,
               # pixel integration in fast mode (render/pixel_integration.py): 1 ray a pixel, or an n x n grid of
               # sub-pixels averaged in linear radiance (4, 9, 16)
               "samples_per_pixel": 1},
    "laser": {"mount_xyz": [0.0, 0.0, 0.62], "angle_min_deg": -180.0, "angle_max_deg": 180.0, "beams": 360,
              "range_min": 0.1, "range_max": 20.0},
    "footprint_radius_m": 0.25,
    "max_height_m": 1.1,
    # the robot frame's height above the floor (m, >= 0); the original BenchBot's carter reported 0.244
    "robot_frame_height_m": 0.0,
    # seeded sensor noise, off by default: rgb_sigma (0..255 levels, Gaussian), depth_sigma (m, Gaussian, scaled by
    # depth), depth_dropout (fraction of pixels set to 0), laser_sigma (m, Gaussian)
    "noise": {"rgb_sigma": 0.0, "depth_sigma": 0.0, "depth_dropout": 0.0, "laser_sigma": 0.0},
}

#: The schemas of what this backend reads beyond ``schemas/``: the robot spec's ``sensors`` block and the options
#: (package data, validated by :func:`benchbot.core.specs.first_error`).
SCHEMA_DIR = Path(__file__).resolve().parent / "schemas"
ROBOT_SCHEMA = SCHEMA_DIR / "robot.schema.json"
OPTIONS_SCHEMA = SCHEMA_DIR / "options.schema.json"

#: Rotation (3, 3) of the camera OPTICAL frame in the camera body frame (x forward, y left, z up).
R_BODY_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])

#: The method of :class:`TaichiSimBackend` that makes each observation it senses: ``method(scene, hand_out)``,
#: ``hand_out`` copying a cached array or giving a read-only view of it.
_PRODUCERS = {"image_rgb": "_image_rgb", "image_depth": "_image_depth", "image_rgb_info": "_camera_info",
              "image_depth_info": "_camera_info", "laser": "_laser", "image_segment": "_image_segment"}

#: What this simulator senses: observation kinds of :mod:`benchbot.core.observations` (their structures there).
OBSERVATIONS = tuple(_PRODUCERS)


def camera_mount(camera: dict | None = None) -> np.ndarray:
    """(4, 4) float64 ``T_footprint_camera``: the camera's optical frame (x right, y down, z forward) in the robot's
    footprint frame, from a ``sensors.camera`` block (``mount_xyz`` metres, ``mount_rpy_deg`` roll-pitch-yaw
    degrees of the camera body, x forward, y left, z up); ``DEFAULT_SENSORS``' camera when None. The one place a
    camera's mount is composed."""
    camera = DEFAULT_SENSORS["camera"] if camera is None else camera
    T = np.eye(4)
    T[:3, :3] = rpy_to_matrix(*np.radians(np.asarray(camera.get("mount_rpy_deg", (0.0, 0.0, 0.0)),
                                                     dtype=np.float64))) @ R_BODY_OPTICAL
    T[:3, 3] = np.asarray(camera["mount_xyz"], dtype=np.float64)
    return T


def camera_model(camera: dict | None = None) -> CameraModel:
    """The camera model (exposure, tone curve, vignetting, auto-exposure) of a ``sensors.camera`` block
    (``exposure_ev`` stops, ``tone_curve`` ``clip`` or ``filmic``, ``vignetting`` 0..1, ``auto_exposure`` true or
    false); ``DEFAULT_SENSORS``' camera when None: the images a robot of the default spec sees. The one place a
    camera's model is made from its spec.

    Raises:
        KeyError: the block lacks one of the four fields (:func:`sensor_config` fills them in);
        ValueError: a value :class:`CameraModel` refuses (the robot schema refuses it first, naming the field).
    """
    camera = DEFAULT_SENSORS["camera"] if camera is None else camera
    return CameraModel(float(camera["exposure_ev"]), str(camera["tone_curve"]), float(camera["vignetting"]),
                       bool(camera["auto_exposure"]))


def camera_at(x: float, y: float, yaw: float, z: float) -> np.ndarray:
    """(4, 4) float64 ``T_map_camera`` of an optical frame ``z`` metres above the floor at (``x``, ``y``) metres,
    looking level along ``yaw`` radians (map frame): a free viewpoint (``benchbot sim render --pose``, galleries)."""
    return se2_to_matrix(x, y, yaw, z=z) @ camera_mount({"mount_xyz": (0.0, 0.0, 0.0)})


def trajectory_cameras(scene: Scene) -> list[np.ndarray]:
    """(4, 4) float64 poses in ``map`` of the default camera's optical frame (mounted as ``DEFAULT_SENSORS``) at
    each pose of the scene's trajectory, or at its start pose when it has none: the views the benchmarks render."""
    mount = camera_mount()
    poses = scene.trajectory_se2 if len(scene.trajectory_se2) else np.asarray(scene.start_se2)[None]
    return [se2_to_matrix(*p) @ mount for p in poses]


def _over_defaults(defaults: dict, given: Any) -> Any:
    """``given`` (a ``sensors`` block) over ``defaults``, one level of sub-blocks deep (a ``None`` sub-block is its
    defaults); a block that is not a mapping is returned as it is, for the schema to refuse."""
    if not isinstance(given, dict):
        return given
    out = {**defaults, **given}
    for key, default in defaults.items():
        if isinstance(default, dict):
            block = given.get(key)
            out[key] = dict(default) if block is None else {**default, **block} if isinstance(block, dict) else block
    return out


def _numbers(value: Any, path: str):
    """``(path, number)`` of every number in a config (nested mappings and lists), booleans left out."""
    if isinstance(value, dict):
        for key, v in value.items():
            yield from _numbers(v, f"{path}.{key}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _numbers(v, f"{path}[{i}]")
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield path, value


def sensor_config(robot_spec: dict, options: dict | None = None) -> dict[str, Any]:
    """The robot spec's ``sensors`` block merged over :data:`DEFAULT_SENSORS`; ``options['width'/'height']``
    (pixels) override the camera size. Units: pixels (camera size), metres (mounts, ranges, radii, heights),
    degrees (angles); this package's ``schemas/robot.schema.json`` (:data:`ROBOT_SCHEMA`) gives each field.

    Raises:
        BackendError: one line ``robot '<name>': sensors.<field>: <problem>``: the merged block does not match
            :data:`ROBOT_SCHEMA` (a block that is not a mapping, a value that is not a number or integer, a
            non-positive size, beam count, footprint or range, a negative ``robot_frame_height_m``, a field of view
            outside (0°, 180°), an unknown or negative noise field, a ``depth_dropout`` above 1, a
            ``samples_per_pixel`` not 1, 4, 9 or 16), a number is not finite, ``range_max`` ≤ ``range_min``, or
            the sub-pixel image's side would pass ``MAX_CAMERA_SIDE``.
    """
    name = robot_spec.get("name", "?")

    def bad(field: str, why: str) -> BackendError:
        return BackendError(f"robot '{name}': {field}: {why}", "fix the field (plugins/sim_taichi/README.md, Sensors; "
                            "benchbot_sim_taichi/schemas/robot.schema.json)")

    src = robot_spec.get("sensors")
    cfg = _over_defaults(DEFAULT_SENSORS, {} if src is None else src)
    options = options or {}
    if isinstance(cfg, dict) and isinstance(cfg.get("camera"), dict):
        for field in ("width", "height"):
            if options.get(field):
                cfg["camera"][field] = int(options[field])
    error = first_error({"sensors": cfg}, ROBOT_SCHEMA)
    if error:
        raise bad(error[0].removeprefix("$."), error[1])
    # What JSON Schema cannot express: finite numbers (NaN passes every bound) and a range across two fields.
    for path, value in _numbers(cfg, "sensors"):
        if not math.isfinite(value):
            raise bad(path, f"expected a finite number, got {value!r}")
    if not cfg["laser"]["range_min"] < cfg["laser"]["range_max"]:
        raise bad("sensors.laser.range_max", f"expected range_min < range_max, got {cfg['laser']['range_min']!r} and "
                  f"{cfg['laser']['range_max']!r}")
    cfg["camera"]["samples_per_pixel"] = int(cfg["camera"]["samples_per_pixel"])  # the schema took 4.0 as 4
    side = max(cfg["camera"]["width"], cfg["camera"]["height"]) * math.isqrt(cfg["camera"]["samples_per_pixel"])
    if side > MAX_CAMERA_SIDE.value():
        raise bad("sensors.camera.samples_per_pixel", f"{cfg['camera']['samples_per_pixel']} sub-pixels a pixel "
                  f"render a {side}-pixel side, above {int(MAX_CAMERA_SIDE.value())}: use fewer or a smaller camera")
    for key, default in DEFAULT_SENSORS.items():
        if not isinstance(default, dict):
            cfg[key] = float(cfg[key])
    return cfg


class TaichiSimBackend(RobotBackend):
    """Simulated ``sim_taichi`` robot (see the module docstring for frames).

    Args:
        robot_spec: the robot spec (``sensors`` block optional, defaults :data:`DEFAULT_SENSORS`; ``speed_factor``
            optional).
        options: ``seed`` (int, default 0: the episode seed, of sensor noise), ``arch`` (``'cpu'``/``'gpu'``/
            ``'cuda'``; default env ``BENCHBOT_TAICHI_ARCH`` or cpu), ``width``/``height`` (camera size override,
            pixels), ``mode`` (``fast`` default / ``quality``), ``shadow_samples`` (shadow rays per light and pixel
            in fast mode, default 1 = hard shadows), ``noise`` (a preset of :mod:`benchbot.core.noise`, default
            ``none``); others ignored.

    The scene (colour variation, the furnished home's choices) and the renderer's sampling follow the world seed
    :meth:`load_scene` is given (the episode derives it from the environment's name and variant,
    :mod:`benchbot.core.seeding`). Sensor noise, drawn from ``numpy.random.default_rng([episode seed, world seed,
    frame, stream])`` (the episode seed: the ``seed`` option) so the same seeds give bit-identical observations and
    each repetition of one world its own noise: first the ``noise`` preset's physical models (range-dependent depth error and
    dropout, Poisson-Gaussian RGB noise, laser range noise; docs/noise.md), then the robot spec's own
    ``sensors.noise`` (all 0 = off by default): ``rgb_sigma``, ``depth_sigma`` (relative), ``depth_dropout``,
    ``laser_sigma`` (m). Segmentation and poses never get noise.

    Raises:
        BackendError: a malformed ``sensors`` block, an unknown render mode or noise preset.
    """

    #: this backend applies :mod:`benchbot.core.noise` presets to its observations
    noise_presets = True

    def __init__(self, robot_spec: dict, options: dict | None = None) -> None:
        self.robot_spec = dict(robot_spec)
        self.options = dict(options or {})
        self.sensors = sensor_config(self.robot_spec, self.options)
        cam = self.sensors["camera"]
        self.width, self.height = int(cam["width"]), int(cam["height"])
        fx = (self.width / 2.0) / math.tan(math.radians(float(cam["horizontal_fov_deg"])) / 2.0)
        self.K = np.array([[fx, 0.0, (self.width - 1) / 2.0], [0.0, fx, (self.height - 1) / 2.0], [0.0, 0.0, 1.0]])
        #: (4, 4) the camera's optical frame in the robot's footprint frame (the robot frame lowered to the floor)
        self.T_footprint_camera = camera_mount(cam)
        #: fast mode's pixel integration: sub-pixels a pixel (render/pixel_integration.py)
        self.samples_per_pixel = int(cam["samples_per_pixel"])
        las = self.sensors["laser"]
        #: (4, 4) the lidar frame in the robot's footprint frame
        self.T_footprint_lidar = np.eye(4)
        self.T_footprint_lidar[:3, 3] = np.asarray(las["mount_xyz"], dtype=np.float64)
        #: the robot frame's height above the floor, metres
        self.robot_frame_height = float(self.sensors["robot_frame_height_m"])
        #: (4, 4) the robot frame in its footprint frame: ``robot_frame_height`` straight up
        self.T_footprint_robot = np.eye(4)
        self.T_footprint_robot[2, 3] = self.robot_frame_height
        a0, a1, nb = math.radians(float(las["angle_min_deg"])), math.radians(float(las["angle_max_deg"])), int(las["beams"])
        full = abs((a1 - a0) - 2.0 * math.pi) < 1e-9
        inc = (a1 - a0) / nb if full else ((a1 - a0) / (nb - 1) if nb > 1 else 0.0)
        self.laser_angles = a0 + inc * np.arange(nb, dtype=np.float64)
        self.laser_angles_wrapped = (self.laser_angles + math.pi) % (2.0 * math.pi) - math.pi
        self.range_min, self.range_max = float(las["range_min"]), float(las["range_max"])
        self.radius = float(self.sensors["footprint_radius_m"])
        self.max_height = float(self.sensors["max_height_m"])
        self.gains = ControllerGains(speed_factor=float(self.robot_spec.get("speed_factor", 1.0) or 1.0))
        self.noise = {k: float(v) for k, v in self.sensors["noise"].items()}
        error = first_error(self.options, OPTIONS_SCHEMA)
        if error:
            raise BackendError(f"options{error[0].removeprefix('$')}: {error[1]}",
                               "see benchbot_sim_taichi/schemas/options.schema.json (mode: fast or quality)")
        name = str(self.options.get("noise") or "none")
        try:
            #: the ``noise`` option's preset (:data:`benchbot.core.noise.PRESETS`)
            self.noise_preset = noise_models.get_preset(name, flag="options.noise")
        except UsageError as exc:
            raise BackendError(exc.message, exc.hint) from None
        self.noise_preset_name = name
        self.mode = str(self.options.get("mode", "fast"))
        self.shadow_samples = int(self.options.get("shadow_samples", 1))
        #: the episode seed (option ``seed``, as an unsigned 64-bit int): sensor noise
        self._episode_seed = int(self.options.get("seed", 0)) % (1 << 64)
        self._seed = 0
        self._frame = 0
        self._renderer = None
        self.scene: Scene | None = None
        self.obstacles: Obstacles | None = None
        self._pose = np.zeros(3)
        self._cache: dict[str, Any] = {}
        #: the scene this backend renders, shared with the process's other backends of the same world
        self._loaded: loaded_scenes.LoadedScene | None = None
        #: ``BENCHBOT_SIM_CHECK_RENDERS=1``: every pose rendered twice and compared (:mod:`.render_check`)
        self._render_check = render_check()
        self._environment = ""

    # ------------------------------------------------------------------------------------------------ contract
    def load_scene(self, environment: dict, *, seed: int = 0) -> None:
        """Build the scene of ``environment`` (its ``map_path`` is a BEAR ground-truth JSON), place the robot at the
        normalised start pose (x, y, yaw; on the floor) and clear cached observations. It renders an 8 × 6 view and
        scan at the start pose in the episode's mode and drops them: before any client is served, Taichi compiles
        the kernels every frame runs (their code does not depend on the image size; on a cold kernel cache, minutes
        on a 2-core CPU), so that no client's request timeout (the API's default is 120 s) can run out during the
        compile.

        Raises:
            BackendError: the map file is missing or malformed, or the start pose collides with the scene.
        """
        seed = int(self.options.get("seed", 0) if seed is None else seed)
        key = scene_cache.scene_key(environment, seed) if scene_cache.max_bytes() else None
        camera = camera_model(self.sensors["camera"])
        sharing = None if key is None else (key, self.options.get("arch"), self.shadow_samples, seed, camera)
        if self._loaded is None or sharing is None or self._loaded.key != sharing:
            # not the scene this backend holds (an episode's reset loads it again: nothing to build or upload)

            def load() -> tuple[Any, Scene]:
                scene, built_key = scene_cache.scene_for(environment, seed, build=build_scene, key=key)
                with stages.stage("starting Taichi", detail=str(self.options.get("arch") or "auto")):
                    from benchbot_sim_taichi.render.renderer import Renderer  # Taichi is imported and initialised here

                    renderer = Renderer(self.options.get("arch"), shadow_samples=self.shadow_samples, seed=seed,
                                        camera=camera)
                try:
                    scene_cache.set_scene(renderer, scene, built_key)
                except BaseException:
                    renderer.close()
                    raise
                return renderer, scene

            self._let_go()
            self._loaded = loaded_scenes.acquire(sharing, load)
            self._renderer = self._loaded.renderer
        scene = self._loaded.scene
        self._seed = seed
        self._frame = 0
        self._environment = f"{environment.get('name')}:{environment.get('variant')}"
        self.scene = scene
        self.obstacles = Obstacles.from_scene(scene, self.radius, self.max_height)
        self._pose = scene.start_se2.copy()
        self._cache = {}
        clearance, what = self.obstacles.clearance(self._pose[:2])
        if clearance <= 0.0:
            raise BackendError(
                f"environment {environment.get('name')}:{environment.get('variant')}: the start pose "
                f"{self._pose.round(3).tolist()} collides with {what}",
                "move the start pose away from the objects, or reduce sensors.footprint_radius_m")
        self._compile_kernels()

    def _compile_kernels(self) -> None:
        """Render a tiny view and scan at the current pose and drop them (what :meth:`load_scene` warms up with)."""
        from benchbot_sim_taichi.render import kernel_cache
        from benchbot_sim_taichi.render.renderer import intrinsics

        T_map_footprint = se2_to_matrix(*self._pose)
        key = kernel_cache.kernels_key(str(getattr(self._renderer, "arch", "")), self.mode)
        cache = kernel_cache.offline_cache_dir()
        state = kernel_cache.kernels_state(key, cache)
        name, detail = kernel_cache.STAGES[state]  # says what happens: compiling, or loading cached kernels
        with stages.stage(name, detail=detail):
            self._renderer.render(intrinsics(8, 6, float(self.sensors["camera"]["horizontal_fov_deg"])),
                              T_map_footprint @ self.T_footprint_camera, 8, 6, mode=self.mode,
                              T_map_lidar=T_map_footprint @ self.T_footprint_lidar, angles=self.laser_angles)
        kernel_cache.mark_ready(key, state, cache)

    def _need_scene(self) -> Scene:
        if self.scene is None:
            raise BackendError("no scene is loaded in the sim_taichi backend", "call load_scene(environment) first")
        return self.scene

    def base_pose(self) -> np.ndarray:
        """(3,) float64 ``[x m, y m, yaw rad]`` of the robot frame in ``map``."""
        return self._pose.copy()

    def move_to(self, goal: np.ndarray) -> MotionOutcome:
        """Drive to ``goal`` (3,) ``[x, y, yaw]`` (map) with the pose controller in simulated time (no sleeping).
        Each step is checked first: if the footprint circle would touch a wall or an object box whose bottom is
        below ``max_height_m``, the robot stays where it is and ``collided`` is True.

        Raises:
            BackendError: no scene is loaded.
        """
        self._need_scene()
        pose, outcome = drive(self._pose, np.asarray(goal, dtype=np.float64).reshape(3), self.obstacles, self.gains)
        self.set_pose(pose)
        return outcome

    def set_pose(self, pose: np.ndarray) -> None:
        """Place the robot at ``pose`` (3,) ``[x m, y m, yaw rad]`` (map) without motion or collision checks (used
        by bridges that integrate their own velocity commands, e.g. the ROS 2 simulator bridge)."""
        pose = np.asarray(pose, dtype=np.float64).reshape(3).copy()
        if not np.array_equal(pose, self._pose):
            self._cache = {}
            self._frame += 1
        self._pose = pose

    @property
    def T_robot_camera(self) -> np.ndarray:
        """(4, 4) :attr:`T_footprint_camera`: the camera from the robot's footprint on the floor (the base frame of a
        bridge that publishes its robot on the floor, as ``benchbot ros2 serve-sim`` does), not from the robot frame
        when ``robot_frame_height_m`` > 0."""
        return self.T_footprint_camera

    @property
    def T_robot_lidar(self) -> np.ndarray:
        """(4, 4) :attr:`T_footprint_lidar` (see :attr:`T_robot_camera`)."""
        return self.T_footprint_lidar

    def frame_transforms(self) -> dict[str, np.ndarray]:
        """``{'robot': T_map_robot, 'camera': T_map_camera (optical), 'lidar': T_map_lidar}``, (4, 4) float64 each,
        plus the robot spec's ``robot_frame`` name if it is not ``robot``. The robot frame is
        ``robot_frame_height_m`` above the floor; the sensors are where their mounts put them above the floor."""
        T_map_footprint = se2_to_matrix(*self._pose)
        T_map_robot = se2_to_matrix(*self._pose, z=self.robot_frame_height)
        out = {"robot": T_map_robot, "camera": T_map_footprint @ self.T_footprint_camera,
               "lidar": T_map_footprint @ self.T_footprint_lidar}
        rf = self.robot_spec.get("robot_frame")
        if rf and rf not in out:
            out[rf] = T_map_robot.copy()
        return out

    def _render(self, with_scan: bool = False) -> dict[str, np.ndarray]:
        """This pose's camera images (cached); ``with_scan``: its laser scan too, from the same kernel launch."""
        if "render" not in self._cache:
            T_map_footprint = se2_to_matrix(*self._pose)
            lidar = (T_map_footprint @ self.T_footprint_lidar) if with_scan else None

            def render() -> dict[str, np.ndarray]:
                return self._renderer.render(self.K, T_map_footprint @ self.T_footprint_camera, self.width,
                                             self.height, mode=self.mode, T_map_lidar=lidar,
                                             angles=self.laser_angles, samples_per_pixel=self.samples_per_pixel)

            out = render()
            if self._render_check is not None:
                self._render_check.compare(out, render(), f"{self._environment} frame {self._frame}")
            if with_scan:
                self._cache_scan(out.pop("ranges"))
            self._cache_images(out)
        return self._cache["render"]

    def _scan(self) -> np.ndarray:
        if "laser" not in self._cache:
            T = se2_to_matrix(*self._pose) @ self.T_footprint_lidar
            self._cache_scan(self._renderer.scan(T, self.laser_angles))
        return self._cache["laser"]

    def _cache_images(self, out: dict[str, np.ndarray]) -> None:
        if not noise_models.is_none(self.noise_preset_name):
            out = self._add_preset_image_noise(out)
        if any(self.noise[k] > 0 for k in ("rgb_sigma", "depth_sigma", "depth_dropout")):
            out = self._add_image_noise(out)
        self._cache["render"] = out

    def _cache_scan(self, ranges: np.ndarray) -> None:
        if not noise_models.is_none(self.noise_preset_name):
            ranges = noise_models.add_laser_noise(ranges, self.noise_preset["laser"], self.range_max,
                                                  self._rng(noise_models.STREAM_LASER))
        if self.noise["laser_sigma"] > 0:
            ranges = ranges + self._rng(3).normal(0.0, self.noise["laser_sigma"], ranges.shape)
        ranges = np.clip(ranges, 0.0, self.range_max)
        self._cache["laser"] = np.stack([ranges, self.laser_angles_wrapped], axis=1)

    def _rng(self, what: int) -> np.random.Generator:
        """Noise generator of this frame: seeded by (episode seed, world seed, frame count, sensor) so reruns are
        bit-identical and repetitions of one world differ."""
        return np.random.default_rng([self._episode_seed, self._seed, self._frame, what])

    def _add_preset_image_noise(self, out: dict) -> dict:
        """The ``noise`` preset's RGB and depth models (:mod:`benchbot.core.noise`) on a render's ``rgb`` and
        ``depth``; the segmentation images are left as they are."""
        out = dict(out)
        preset = self.noise_preset
        if preset["rgb"] is not None:
            out["rgb"] = noise_models.add_rgb_noise(out["rgb"], preset["rgb"], self._rng(noise_models.STREAM_RGB))
        out["depth"] = noise_models.add_depth_noise(out["depth"], preset["depth"],
                                                    self._rng(noise_models.STREAM_DEPTH))
        return out

    def _add_image_noise(self, out: dict) -> dict:
        out = dict(out)
        nz = self.noise
        if nz["rgb_sigma"] > 0:
            g = self._rng(1).normal(0.0, nz["rgb_sigma"], out["rgb"].shape)
            out["rgb"] = np.clip(out["rgb"].astype(np.float64) + g, 0, 255).round().astype(np.uint8)
        if nz["depth_sigma"] > 0 or nz["depth_dropout"] > 0:
            rng = self._rng(2)
            d = out["depth"].astype(np.float64)
            d = d + rng.normal(0.0, 1.0, d.shape) * nz["depth_sigma"] * d
            d[rng.random(d.shape) < nz["depth_dropout"]] = 0.0
            out["depth"] = np.maximum(d, 0.0).astype(np.float32)
        return out

    def _info(self) -> dict[str, Any]:
        P = np.zeros((3, 4))
        P[:, :3] = self.K
        return {"frame_id": "camera", "height": self.height, "width": self.width,
                "matrix_intrinsics": self.K.copy(), "matrix_projection": P}

    def observe(self, names: Sequence[str]) -> dict[str, Any]:
        """Observations (docs/observations.md) for ``names`` among :data:`OBSERVATIONS`; rendered once per pose (images and
        laser in one kernel launch when both are asked for) and cached.

        Returns per name: ``image_rgb`` (H, W, 3) uint8 RGB; ``image_depth`` (H, W) float32 z-depth metres (0: no
        hit); ``image_rgb_info``/``image_depth_info`` ``{frame_id, height, width, matrix_intrinsics (3,3),
        matrix_projection (3,4) = [K|0]}``; ``laser`` ``{scans (N,2) float64 [range m (clipped to range_max),
        angle rad in [-π,π)], range_min, range_max}``; ``image_segment`` ``{class_segment_img (H,W) uint8,
        instance_segment_img (H,W) int32 class*1000+instance (0: background), class_ids {name: id}}``.

        Raises:
            KeyError: a name this backend cannot observe. BackendError: no scene is loaded.
        """
        return self._observations(names, owned=True)

    def observe_borrowed(self, names: Sequence[str]) -> dict[str, Any]:
        """As :meth:`observe`, but the images and the scan are read-only views of this pose's cached arrays, not
        copies (see :meth:`benchbot.core.robot.RobotBackend.observe_borrowed`; the renderer never writes into them
        again, so they stay valid). The class image is converted to uint8, a new array.

        Raises:
            KeyError: a name this backend cannot observe. BackendError: no scene is loaded.
        """
        return self._observations(names, owned=False)

    def _observations(self, names: Sequence[str], owned: bool) -> dict[str, Any]:
        """:meth:`observe` (``owned``: copies of the cached arrays) or :meth:`observe_borrowed` (the arrays)."""
        for n in names:
            if n not in OBSERVATIONS:
                raise KeyError(n)
        scene = self._need_scene()
        if "laser" in names and not self._cache and any(n in ("image_rgb", "image_depth", "image_segment")
                                                        for n in names):
            self._render(with_scan=True)  # one kernel launch for both
        hand_out = np.copy if owned else _read_only_view
        return {n: getattr(self, _PRODUCERS[n])(scene, hand_out) for n in names}

    def _image_rgb(self, scene: Scene, hand_out: Any) -> np.ndarray:
        return hand_out(self._render()["rgb"])

    def _image_depth(self, scene: Scene, hand_out: Any) -> np.ndarray:
        return hand_out(self._render()["depth"])

    def _camera_info(self, scene: Scene, hand_out: Any) -> dict[str, Any]:
        return self._info()

    def _image_segment(self, scene: Scene, hand_out: Any) -> dict[str, Any]:
        r = self._render()
        return {"class_segment_img": r["class"].astype(np.uint8),
                "instance_segment_img": hand_out(r["instance"].astype(np.int32, copy=False)),
                "class_ids": dict(scene.class_ids)}

    def _laser(self, scene: Scene, hand_out: Any) -> dict[str, Any]:
        return {"scans": hand_out(self._scan()), "range_min": self.range_min, "range_max": self.range_max}

    def batched(self, count: int):
        """``count`` robots in this scene, moved and sensed together: a
        :class:`~benchbot_sim_taichi.batched.TaichiBatchedRobots` sharing this backend's renderer, obstacles and
        sensors, at the start pose.

        Raises:
            BackendError: no scene is loaded, ``count`` < 1, quality mode or sensor noise (see that class).
        """
        from benchbot_sim_taichi.batched import TaichiBatchedRobots

        return TaichiBatchedRobots(self, count)

    def close(self) -> None:
        """Drop the scene and caches and let go of the renderer (the last backend of the process using its scene
        frees its GPU memory, :mod:`benchbot_sim_taichi.loaded_scenes`; Taichi's runtime stays up for the process).
        Runs on the backend thread, the thread that renders."""
        self._cache = {}
        self.scene = None
        self._let_go()

    def _let_go(self) -> None:
        """Release the loaded scene this backend holds, if any."""
        loaded, self._loaded, self._renderer = self._loaded, None, None
        if loaded is not None:
            loaded_scenes.release(loaded)


def _read_only_view(a: np.ndarray) -> np.ndarray:
    """A view of ``a`` that cannot be written through (``a`` itself stays writable)."""
    view = a.view()
    view.flags.writeable = False
    return view


def create_backend(robot_spec: dict, options: dict) -> TaichiSimBackend:
    """Factory of the ``sim_taichi`` robot type: ``create_backend(robot_spec, options) -> TaichiSimBackend``.
    Taichi is imported and initialised on the first ``load_scene``."""
    return TaichiSimBackend(robot_spec, options)
