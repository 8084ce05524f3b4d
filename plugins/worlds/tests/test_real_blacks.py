"""No model in a furnished home is blacker than black paint (benchbot_worlds.scene.meshes.with_real_blacks): the
rule on hand-made materials, then on every pack model placed in BEAR's house:1."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot_worlds.scene.meshes import MIN_BLACK_ALBEDO, Material, make_mesh, with_real_blacks

LUMA = np.array([0.2126, 0.7152, 0.0722])


def _mesh(*materials):
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] * len(materials))
    f = np.arange(3 * len(materials)).reshape(-1, 3)
    return make_mesh(v, f, f_material=np.arange(len(materials)), materials=list(materials))


def test_untextured_opaque_blacks_are_lifted_to_black_paint_by_a_black_level():
    black = Material(albedo=np.zeros(3, np.float32), name="placeholder black")
    red = Material(albedo=np.array([0.0863, 0.0, 0.0], np.float32), name="dark red")
    grey = Material(albedo=np.full(3, 0.5, np.float32), name="grey")
    textured = Material(albedo=np.zeros(3, np.float32), texture=np.zeros((2, 2, 3), np.uint8), name="photo")
    glass = Material(albedo=np.zeros(3, np.float32), opacity=0.2, name="pane")
    mesh = _mesh(black, red, grey, textured, glass)
    out = with_real_blacks(mesh)
    assert out is not mesh and out.v is mesh.v and out.f is mesh.f  # arrays shared
    np.testing.assert_allclose(out.materials[0].albedo, [MIN_BLACK_ALBEDO] * 3, rtol=1e-6)
    lifted = out.materials[1].albedo
    assert LUMA @ lifted == pytest.approx(MIN_BLACK_ALBEDO, rel=1e-5)  # lifted to the floor, no further...
    np.testing.assert_allclose(lifted - red.albedo, lifted[1], rtol=1e-6)  # ...by one amount in every channel
    assert lifted[0] > lifted[1] == lifted[2] > 0  # still red
    assert out.materials[2] is grey and out.materials[3] is textured and out.materials[4] is glass
    assert mesh.materials[0].albedo.max() == 0.0  # the loaded mesh is not changed
    assert with_real_blacks(mesh) is out  # one set of materials per model
    plain = _mesh(grey)
    assert with_real_blacks(plain) is plain


def test_no_pack_model_in_a_furnished_house_is_blacker_than_black_paint():
    """In house:1 as an episode builds it, every material of a placed pack model (not the walls, not what is made in
    code) that is untextured and opaque has a luminance of at least MIN_BLACK_ALBEDO; the pack has models at 0."""
    from benchbot.core.seeding import home_seed
    from benchbot.packs.assets import asset_library
    from benchbot_worlds.homes.floorplan import home_files
    from benchbot_worlds.homes.furnished import furnish_environment
    from benchbot_worlds.scene.meshes import load_mesh

    sys.path.insert(0, str(Path(__file__).parent))
    from test_furnished import _environment  # noqa: E402

    env = _environment("house_1")
    objects = json.loads(Path(env["map_path"]).read_text())["ground_truth"]["objects"]
    home = furnish_environment(objects, home_files(env), [], seed=home_seed(env["name"]))
    lib = asset_library()
    placed = [(p, inst) for p, inst in zip(home.furnishing.placements, home.instances[1:]) if p.mesh is None]

    def opaque_untextured(materials):
        return [m for m in materials if m.texture is None and not m.glass and m.opacity >= 0.99]

    darkest_file = min(float(LUMA @ m.albedo) for p, _ in placed
                       for m in opaque_untextured(load_mesh(lib.get(p.asset_id).path).materials))
    assert darkest_file < 0.005  # the files have blacks of 0 ...
    drawn = [m for _, inst in placed for m in opaque_untextured(inst.mesh.materials)]
    assert drawn and min(float(LUMA @ m.albedo) for m in drawn) >= MIN_BLACK_ALBEDO - 1e-6  # ... drawn as paint
