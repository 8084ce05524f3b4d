"""Quick compiles (render/compile_options.py): the listed kernels of the package compile without Taichi's CFG pass,
others with it; they render the same bit for bit; their compiled code is found in the offline cache by a later
process (also through the sensors' compiled graph, which compiles nothing again); the setting turns it off."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("taichi")

#: One fresh process with the kernel cache given: a table under a lamp, in the sun, its shadow maps traced, one fast
#: frame and scan rendered through the compiled graph; writes the arrays to an .npz and prints, as JSON, each
#: compile's kernel and whether Taichi's CFG pass was on.
SCRIPT = r"""
import json, sys
import numpy as np
from taichi._lib import core
from taichi.lang import kernel_impl

names, compiles = {}, []
real_materialize = kernel_impl.Kernel.materialize
def materialize(self, key=None, args=None, arg_features=None):
    real_materialize(self, key, args, arg_features)
    for k in self.compiled_kernels.values():
        names.setdefault(id(k), self.func.__name__)
kernel_impl.Kernel.materialize = materialize
real_compile = core.Program.compile_kernel
def compile_kernel(self, config, caps, kernel):
    compiles.append([names.get(id(kernel), "?"), bool(config.cfg_optimization)])
    return real_compile(self, config, caps, kernel)
core.Program.compile_kernel = compile_kernel

from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
from benchbot_worlds.scene.build import build_scene
from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL, LIGHT_POINT
scene = build_scene({**json.loads(sys.argv[2]), "procedural": False})
sun = np.array([0.45, 0.30, 0.84], np.float32)
scene.light_kind = np.array([LIGHT_POINT, LIGHT_DIRECTIONAL], np.int32)
scene.light_vec = np.array([[3.0, 0.0, 2.3], sun / np.linalg.norm(sun)], np.float32)
scene.light_colour = np.array([[1.5] * 3, [1.2] * 3], np.float32)
scene.light_range = np.array([6.0, 0.0], np.float32)
renderer = Renderer("cpu", shadow_maps=True)
renderer.set_scene(scene)
T = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 1.2], [0, 0, 0, 1]], np.float64)  # looking along +x
T_lidar = np.eye(4); T_lidar[2, 3] = 0.3
out = renderer.render(intrinsics(32, 24, 90.0), T, 32, 24, T_map_lidar=T_lidar, angles=np.linspace(-3, 3, 30))
maps = renderer.prepared_scene()
np.savez(sys.argv[1], **{k: np.asarray(v) for k, v in out.items()}, lamp_maps=maps["lamp_maps"],
         sun_map=maps["sun_map"])
print("COMPILES " + json.dumps(compiles))
"""


def _run(tmp_path: Path, name: str, cache: Path, quick: str, environment: dict) -> tuple[dict, list]:
    env = dict(os.environ, TI_OFFLINE_CACHE_FILE_PATH=str(cache), BENCHBOT_TAICHI_QUICK_COMPILE=quick)
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(tmp_path / f"{name}.npz"), json.dumps(environment)],
                          env=env, capture_output=True,
                          text=True, timeout=900, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = [x for x in proc.stdout.splitlines() if x.startswith("COMPILES ")][-1]
    return dict(np.load(tmp_path / f"{name}.npz")), json.loads(line[len("COMPILES "):])


@pytest.mark.slow
def test_quick_compiles_render_the_same_and_a_later_process_loads_them(tmp_path, synthetic_env):
    """A real compile into empty kernel caches, once with quick compiles and once without: the listed kernels compiled
    without the CFG pass, ``occluders_kernel`` and ``clusters_kernel`` never without it; shadow maps, images and scan
    equal bit for bit; a later quick process finds every kernel in the cache (it compiles, i.e. loads, each once, and
    the cache gains no file: the graph took the quick-compiled kernels' keys)."""
    from benchbot_sim_taichi.render.compile_options import QUICK_COMPILES

    room = synthetic_env([("table", (3.0, 0.0, 0.75), (0.8, 0.8, 0.1)), ("chair", (0.5, 3.0, 0.3), (0.4, 0.4, 0.6))])
    quick, quick_compiles = _run(tmp_path, "quick", tmp_path / "quick-cache", "1", room)
    full, full_compiles = _run(tmp_path, "full", tmp_path / "full-cache", "0", room)
    # (a launch asks again for a kernel compiled already, with the pass on: Taichi finds it in memory)
    without_pass = {name for name, on in quick_compiles if not on}
    assert {"lamp_map_kernel", "sun_map_kernel", "primitives_kernel", "shade_maps_kernel"} <= without_pass, \
        quick_compiles
    assert without_pass <= set(QUICK_COMPILES) and not {"occluders_kernel", "clusters_kernel"} & without_pass
    assert all(on for _, on in full_compiles), full_compiles
    assert sorted(quick) == sorted(full)
    for key in quick:
        assert np.array_equal(quick[key], full[key]), key
    assert quick["lamp_maps"].any() and quick["sun_map"].any() and quick["rgb"].any()

    files = sorted(p.name for p in (tmp_path / "quick-cache").iterdir())
    _again, again_compiles = _run(tmp_path, "again", tmp_path / "quick-cache", "1", room)
    assert sorted(p.name for p in (tmp_path / "quick-cache").iterdir()) == files
    assert sorted(again_compiles) == sorted(quick_compiles)


def test_every_quick_compile_names_a_kernel_of_the_package():
    from benchbot_sim_taichi.render import compile_options, kernels, lightmap, pathtrace, sensors

    defined = {}
    for module in (kernels, lightmap, pathtrace, sensors):
        for value in vars(module).values():
            primal = getattr(value, "_primal", None)
            if primal is not None and hasattr(primal, "func"):
                defined[primal.func.__name__] = primal
    for name, archs in compile_options.QUICK_COMPILES.items():
        assert name in defined, f"{name} is no kernel of the package"
        assert archs and archs <= {"cpu", "cuda"}
        assert compile_options.quick(defined[name], next(iter(archs)))
    assert not compile_options.quick(defined["occluders_kernel"], "cpu")
    assert not compile_options.quick(defined["bake_kernel"], "metal")


def test_a_listed_name_defined_elsewhere_compiles_as_taichi_does(monkeypatch):
    from benchbot_sim_taichi.render import compile_options
    from benchbot_sim_taichi.render.lightmap import bake_kernel

    assert compile_options.quick(bake_kernel._primal, "cpu")
    monkeypatch.setattr(compile_options, "PACKAGE_DIR", "/nowhere")
    assert not compile_options.quick(bake_kernel._primal, "cpu")


def test_quick_compiles_off_when_the_setting_says_0(monkeypatch):
    from benchbot.core.errors import UsageError
    from benchbot_sim_taichi.render import compile_options

    monkeypatch.setattr(compile_options, "_installed", False)
    monkeypatch.setenv("BENCHBOT_TAICHI_QUICK_COMPILE", "0")
    assert compile_options.use_quick_compiles() is False
    monkeypatch.setenv("BENCHBOT_TAICHI_QUICK_COMPILE", "yes")
    with pytest.raises(UsageError, match="BENCHBOT_TAICHI_QUICK_COMPILE='yes'"):
        compile_options.use_quick_compiles()
