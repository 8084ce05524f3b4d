"""The layouts of the small float32 rows the kernels read by index, one name per offset, in one place: what
:mod:`.renderer` packs (``pack_scene``'s ``world``, ``render_params``, ``camera_params``, ``sensor_pose``,
``frame_constants``) and what the kernels (:mod:`.kernels`, :mod:`.raster`, :mod:`.sensors`, :mod:`.pathtrace`,
:mod:`.lightmap`) read. The names are plain Python integers: inside a kernel they are compile-time constants, so
``row[CAM_FX]`` compiles to what ``row[12]`` did.

Frames and units: the map frame, metres, radians; the camera's rotation ``R`` is row-major, optical frame (x right,
y down, z forward) into map; intrinsics in pixels.
"""

from __future__ import annotations

# --- a camera row (camera_params, and the first 12 entries of a sensor pose row) -------------------------------------
#: (16,) float32: R (row-major, 9), origin (3), fx, fy, cx, cy.
CAM_R = 0
CAM_ORIGIN = 9
CAM_FX, CAM_FY, CAM_CX, CAM_CY = 12, 13, 14, 15
CAM_LEN = 16

# --- a sensor pose row (sensor_pose: one frame's poses) ---------------------------------------------------------------
#: (16,) float32: the camera's R (9) and origin (3) as in a camera row, then the lidar's x, y, z (3) and yaw (1).
POSE_LIDAR_XYZ = 12
POSE_LIDAR_YAW = 15
POSE_LEN = 16

# --- render parameters (render_params) ---------------------------------------------------------------------------------
#: (8,) float32: shadow rays per light, the sun's angular radius (rad), a lamp's radius (m), the seed, samples per
#: pixel, the most bounces of a path, the first bounce of Russian roulette (quality mode), and one unused entry.
P_SHADOW_SAMPLES, P_SUN_RADIUS, P_LAMP_RADIUS, P_SEED, P_SPP, P_BOUNCES, P_ROULETTE_FROM = range(7)
PARAMS_LEN = 8

# --- the scene's world row (pack_scene's ``world``) --------------------------------------------------------------------
#: (19,) float32: the room shell's min corner (3) and max corner (3), the floor, wall and ceiling albedos (3 × 3,
#: linear), the ambient radiance (3; also the sky's colour), the background class id (1).
WORLD_ROOM_MIN = 0
WORLD_ROOM_MAX = 3
WORLD_SHELL_ALBEDO = 6
WORLD_AMBIENT = 15
WORLD_BACKGROUND_CLASS = 18
WORLD_LEN = 19

# --- a frame's constants (frame_constants) -----------------------------------------------------------------------------
#: The world row (at 0), the render parameters, the camera's fx, fy, cx, cy, the camera model's 1/radiance_max and
#: vignetting, then its tone table (``camera_model.TABLE_STEPS`` entries).
FRAME_WORLD = 0  # must stay 0: the kernels hand the frame constants on where a world row is read
FRAME_PARAMS = FRAME_WORLD + WORLD_LEN  # 19
FRAME_INTRINSICS = FRAME_PARAMS + PARAMS_LEN  # 27: fx, fy, cx, cy
FRAME_RADIANCE_SCALE = FRAME_INTRINSICS + 4  # 31
FRAME_VIGNETTING = FRAME_RADIANCE_SCALE + 1  # 32
FRAME_TONE_TABLE = FRAME_VIGNETTING + 1  # 33

assert FRAME_WORLD == 0
