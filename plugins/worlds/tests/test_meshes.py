"""Mesh loading (GLB/glTF to the map frame, materials, textures, normals), instancing, the texture atlas and the
textured scene export. Test meshes are made here with trimesh (no binaries in the repository)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from benchbot.core.errors import BackendError


def _quadrant_image():
    """4 × 4 RGB image, top-left red, top-right green, bottom-left blue, bottom-right white (rows top first)."""
    img = np.zeros((4, 4, 3), np.uint8)
    img[:2, :2] = (255, 0, 0)
    img[:2, 2:] = (0, 255, 0)
    img[2:, :2] = (0, 0, 255)
    img[2:, 2:] = (255, 255, 255)
    return img


def write_textured_quad_glb(path, image=None, factor=(255, 255, 255, 255)):
    """A 1 m × 1 m quad in glTF coordinates facing +Z (its front), bottom edge at y = 0, centred on x = 0, with
    ``image`` (default :func:`_quadrant_image`) as its baseColorTexture mapped upright (u right, v up)."""
    import trimesh
    from PIL import Image

    v = np.array([[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 1.0, 0.0], [-0.5, 1.0, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])  # trimesh's convention: v = 0 at the bottom
    m = trimesh.Trimesh(v, f, process=False)
    img = Image.fromarray(_quadrant_image() if image is None else image)
    mat = trimesh.visual.material.PBRMaterial(baseColorTexture=img, baseColorFactor=list(factor), metallicFactor=0.0,
                                              roughnessFactor=0.5)
    m.visual = trimesh.visual.TextureVisuals(uv=uv, material=mat)
    m.export(str(path))
    return path


def test_glb_quad_loads_in_the_map_frame_with_its_texture(tmp_path):
    from benchbot_worlds.scene.meshes import load_mesh

    mesh = load_mesh(write_textured_quad_glb(tmp_path / "quad.glb", factor=(255, 128, 64, 255)))
    # glTF (x, y, z) → map (x, −z, y): the quad stands in the plane y = 0, z from 0 to 1, front facing −y
    np.testing.assert_allclose(mesh.bounds, [[-0.5, 0.0, 0.0], [0.5, 0.0, 1.0]], atol=1e-6)
    np.testing.assert_allclose(mesh.n, np.tile([0.0, -1.0, 0.0], (len(mesh.n), 1)), atol=1e-6)
    fn = np.cross(mesh.v[mesh.f[:, 1]] - mesh.v[mesh.f[:, 0]], mesh.v[mesh.f[:, 2]] - mesh.v[mesh.f[:, 0]])
    assert np.all(fn[:, 1] < 0)  # the winding still agrees with the normals
    (mat,) = mesh.materials
    assert mat.texture.shape == (4, 4, 3) and mat.texture.dtype == np.uint8
    np.testing.assert_array_equal(mat.texture, _quadrant_image())
    np.testing.assert_allclose(mat.albedo, [1.0, 128 / 255, 64 / 255], atol=1e-6)  # glTF factors are linear
    assert mat.metallic == 0.0 and mat.roughness == pytest.approx(0.5)
    # the top-left corner (map x = -0.5, z = 1) carries uv (0, 1): the image's top-left texel (red)
    tl = int(np.argmin(np.abs(mesh.v - [-0.5, 0.0, 1.0]).sum(axis=1)))
    np.testing.assert_allclose(mesh.uv[tl], [0.0, 1.0], atol=1e-6)
    assert load_mesh(tmp_path / "quad.glb") is mesh  # cached
    with pytest.raises(ValueError):
        mesh.v[0, 0] = 1.0  # cached arrays are read-only


def test_scene_file_nodes_materials_and_computed_normals(tmp_path):
    import trimesh

    from benchbot_worlds.scene.meshes import load_mesh

    sc = trimesh.Scene()
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    box.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=[255, 0, 0, 255]))
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.5)
    ball.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=[0, 0, 255, 255]))
    sc.add_geometry(box, node_name="box", transform=trimesh.transformations.translation_matrix([3.0, 0.0, 0.0]))
    sc.add_geometry(ball, node_name="ball", transform=trimesh.transformations.translation_matrix([0.0, 2.0, 0.0]))
    sc.export(str(tmp_path / "two.glb"))
    mesh = load_mesh(tmp_path / "two.glb")
    assert mesh.n_triangles == len(box.faces) + len(ball.faces)
    assert sorted(tuple(np.round(m.albedo, 3)) for m in mesh.materials) == [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0)]
    red = [i for i, m in enumerate(mesh.materials) if m.albedo[0] > 0.5][0]
    box_v = mesh.v[np.unique(mesh.f[mesh.f_material == red])]
    # node transform applied, then glTF → map: glTF (3, 0, 0) ± (0.5, 1, 1.5) → map x 2.5..3.5, y -1.5..1.5, z -1..1
    np.testing.assert_allclose(box_v.min(axis=0), [2.5, -1.5, -1.0], atol=1e-6)
    np.testing.assert_allclose(box_v.max(axis=0), [3.5, 1.5, 1.0], atol=1e-6)
    # the ball's centre, glTF (0, 2, 0), is map (0, 0, 2); its normals (from the file) point out of it
    ball_i = np.unique(mesh.f[mesh.f_material != red])
    p = mesh.v[ball_i] - [0.0, 0.0, 2.0]
    np.testing.assert_allclose(np.linalg.norm(p, axis=1), 0.5, atol=1e-5)
    assert np.all(np.einsum("ij,ij->i", mesh.n[ball_i], p / 0.5) > 0.95)


def test_blended_materials_keep_their_opacity_and_glass_becomes_panes(tmp_path):
    import trimesh

    from benchbot_worlds.scene.meshes import GLASS_OPACITY, load_mesh, with_glass_panes

    sc = trimesh.Scene()
    for name, rgba, mode, x in [("frame", [200, 200, 200, 255], None, 0.0), ("pane", [165, 165, 165, 128], "BLEND", 2.0),
                                ("curtain", [230, 230, 230, 168], "BLEND", 4.0),
                                ("masked", [90, 90, 90, 40], "MASK", 6.0)]:
        box = trimesh.creation.box(extents=(1.0, 0.1, 1.0))
        box.visual = trimesh.visual.TextureVisuals(
            material=trimesh.visual.material.PBRMaterial(name=name, baseColorFactor=rgba, alphaMode=mode))
        sc.add_geometry(box, node_name=name, transform=trimesh.transformations.translation_matrix([x, 0.0, 0.0]))
    sc.export(str(tmp_path / "window.glb"))
    mesh = load_mesh(tmp_path / "window.glb")
    opacity = {m.name: round(m.opacity, 3) for m in mesh.materials}
    # only BLEND materials are see-through; MASK (cut-outs) and OPAQUE keep opacity 1
    assert opacity == {"frame": 1.0, "pane": 0.502, "curtain": 0.659, "masked": 1.0}, opacity
    assert 0.502 < GLASS_OPACITY < 0.659
    glazed = with_glass_panes(mesh)
    assert {m.name: m.glass for m in glazed.materials} == {"frame": False, "pane": True, "curtain": False,
                                                            "masked": False}
    assert not any(m.glass for m in mesh.materials)  # the loaded mesh (maybe cached) is not changed
    assert glazed.f is mesh.f and glazed.n_triangles == mesh.n_triangles
    opaque = dataclasses.replace(mesh, materials=[m for m in mesh.materials if m.name != "pane"],
                                 f=mesh.f[:0], f_material=mesh.f_material[:0])  # (faces do not matter here)
    assert with_glass_panes(opaque) is opaque  # no glass: the same mesh


def test_smooth_normals_round_curves_and_keep_creases(tmp_path):
    import trimesh

    from benchbot_worlds.scene.meshes import load_mesh, make_mesh

    # an icosphere written as STL (no normals, no shared vertices): welded for the averaging, so the normals are
    # the radial direction, not the faces' (which differ from it by up to ~10° here)
    trimesh.creation.icosphere(subdivisions=2, radius=1.0).export(str(tmp_path / "ball.stl"))
    ball = load_mesh(tmp_path / "ball.stl")
    assert ball.v.shape[0] == 3 * ball.n_triangles
    radial = ball.v / np.linalg.norm(ball.v, axis=1, keepdims=True)
    assert np.min(np.einsum("ij,ij->i", ball.n, radial)) > 0.995
    # a box keeps flat faces: every corner normal is its face's normal (24 vertices)
    box = trimesh.creation.box(extents=(1, 1, 1))
    m = make_mesh(box.vertices, box.faces)
    assert m.v.shape[0] == 24
    fn = np.cross(m.v[m.f[:, 1]] - m.v[m.f[:, 0]], m.v[m.f[:, 2]] - m.v[m.f[:, 0]])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    for c in range(3):
        np.testing.assert_allclose(m.n[m.f[:, c]], fn, atol=1e-6)
    # an OBJ without materials: one default material (the scene gives it the class colour)
    box.export(str(tmp_path / "box.obj"))
    assert [mat.from_file for mat in load_mesh(tmp_path / "box.obj").materials] == [False]


def test_instances_flatten_with_inverse_transpose_normals():
    import trimesh

    from benchbot_worlds.scene.meshes import Material, MeshInstance, flatten_instances, make_mesh

    s = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    red = Material(np.array([1.0, 0.0, 0.0], np.float32))
    mesh = make_mesh(s.vertices, s.faces, n=s.vertices, materials=[red])
    M = np.diag([2.0, 1.0, 0.5, 1.0])
    M[:3, 3] = (1.0, 2.0, 3.0)
    flat = flatten_instances([MeshInstance(mesh, M, 4), MeshInstance(mesh, np.eye(4), -1)])
    T = len(s.faces)
    assert flat["tri_v"].shape == (2 * T, 3, 3) and flat["tri_uv"].shape == (2 * T, 3, 2)
    assert flat["materials"] == [red] and np.all(flat["tri_material"] == 0)
    np.testing.assert_array_equal(flat["tri_object"], [4] * T + [-1] * T)
    # the ellipsoid x²/4 + y² + z²/0.25 = 1: its normal is the gradient (x/4, y, z/0.25), normalised
    p = flat["tri_v"][:T].reshape(-1, 3).astype(np.float64) - (1.0, 2.0, 3.0)
    g = p / np.array([4.0, 1.0, 0.25])
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    np.testing.assert_allclose(flat["tri_n"][:T].reshape(-1, 3), g, atol=1e-5)
    with pytest.raises(ValueError, match="singular"):
        flatten_instances([MeshInstance(mesh, np.diag([1.0, 0.0, 1.0, 1.0]))])


def test_quad_mesh_gives_each_quad_four_flat_shaded_vertices_and_two_triangles():
    from benchbot_worlds.scene.meshes import Material, quad_mesh

    red, grey = Material(np.array([1.0, 0.0, 0.0], np.float32)), Material(np.full(3, 0.5, np.float32))
    floor = ([(0, 0, 0), (2, 0, 0), (2, 1, 0), (0, 1, 0)], (0, 0, 1), 1, lambda p: (p[0] / 2, p[1]))
    wall = ([(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)], (-1, 0, 0), 0, lambda p: (p[1], p[2]))
    mesh = quad_mesh([floor, wall], [red, grey])
    np.testing.assert_array_equal(mesh.f, [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    np.testing.assert_array_equal(mesh.f_material, [1, 1, 0, 0])
    np.testing.assert_array_equal(mesh.n, [(0, 0, 1)] * 4 + [(-1, 0, 0)] * 4)
    np.testing.assert_allclose(mesh.uv[:4], [(0, 0), (1, 0), (1, 1), (0, 1)])
    np.testing.assert_allclose(mesh.uv[4:], [(0, 0), (0, 1), (1, 1), (1, 0)])
    np.testing.assert_array_equal(mesh.bounds, [(0, 0, 0), (2, 1, 1)])
    with pytest.raises(ValueError, match="f_material"):
        quad_mesh([floor], [red])


def test_mip_chain_and_atlas_layout():
    from benchbot_worlds.scene.meshes import mip_chain, texture_atlas

    checker = np.zeros((8, 6, 3), np.uint8)
    checker[(np.arange(8)[:, None] + np.arange(6)[None, :]) % 2 == 1] = 255
    levels = mip_chain(checker)
    assert [lv.shape[:2] for lv in levels] == [(8, 6), (4, 3), (2, 1), (1, 1)]
    # black/white averaged in linear light is 0.5, i.e. sRGB 186 (not 128)
    assert np.all(levels[1] == 186) and np.all(levels[3] == 186)
    other = np.full((2, 2, 3), 7, np.uint8)
    texels, info = texture_atlas([checker, other])
    np.testing.assert_array_equal(info, [[0, 6, 8, 4], [48 + 12 + 2 + 1, 2, 2, 2]])
    assert texels.shape == (48 + 12 + 2 + 1 + 4 + 1, 3)
    np.testing.assert_array_equal(texels[48:60].reshape(4, 3, 3), levels[1])


def test_add_mesh_instances_to_a_scene_and_bad_object_index(synthetic_env):
    import trimesh

    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances, make_mesh
    from benchbot_worlds.scene.build import build_scene
    from benchbot_worlds.scene.model import PRIM_TRIANGLE

    env = synthetic_env([("chair", (2.5, 0.0, 0.5), (1.0, 1.0, 1.0))])
    env["style"] = "primitives"  # one room shell, no furnished house: only the meshes added here are textured
    scene = build_scene(env)
    n_prims = scene.prim_type.shape[0]
    tex = np.full((4, 4, 3), 200, np.uint8)
    mats = [Material(np.array([0.2, 0.4, 0.6], np.float32), texture=tex), Material(np.ones(3, np.float32))]
    box = trimesh.creation.box(extents=(1, 1, 1))
    mesh = make_mesh(box.vertices, box.faces, f_material=np.arange(12) % 2, materials=mats)
    first, end = add_mesh_instances(scene, [MeshInstance(mesh, np.eye(4), 0), MeshInstance(mesh, np.eye(4), -1)])
    assert (first, end) == (0, 24) and scene.tri_v.shape == (24, 3, 3) and scene.tri_n.shape == (24, 3, 3)
    assert scene.prim_type.shape[0] == n_prims + 24 and np.all(scene.prim_type[n_prims:] == PRIM_TRIANGLE)
    np.testing.assert_array_equal(scene.prim_object[n_prims:], [0] * 12 + [-1] * 12)
    np.testing.assert_array_equal(scene.mat_texture, [0, -1])  # one texture, shared by both instances
    assert scene.tex_info.shape == (1, 4) and scene.tex_texels.shape == (16 + 4 + 1, 3)
    np.testing.assert_allclose(scene.prim_albedo[n_prims::2], np.tile([0.2, 0.4, 0.6], (12, 1)))
    # a second call appends materials and textures after the first ones
    add_mesh_instances(scene, [MeshInstance(make_mesh(box.vertices, box.faces, materials=[
        Material(np.ones(3, np.float32), texture=np.zeros((2, 2, 3), np.uint8))]), np.eye(4), 0)])
    np.testing.assert_array_equal(scene.mat_texture, [0, -1, 1])
    np.testing.assert_array_equal(scene.tex_info[1], [21, 2, 2, 2])
    np.testing.assert_array_equal(scene.tri_material[24:], [2] * 12)
    with pytest.raises(ValueError, match="object_index 5"):
        add_mesh_instances(scene, [MeshInstance(mesh, np.eye(4), 5)])


def test_unreadable_and_empty_meshes_are_one_line_errors(tmp_path):
    from benchbot_worlds.scene.meshes import load_mesh

    with pytest.raises(BackendError, match="cannot read the mesh .*nope.glb"):
        load_mesh(tmp_path / "nope.glb")
    (tmp_path / "junk.glb").write_bytes(b"glTF not really")
    with pytest.raises(BackendError, match="junk.glb"):
        load_mesh(tmp_path / "junk.glb")
    (tmp_path / "empty.obj").write_text("v 0 0 0\n")
    with pytest.raises(BackendError, match="has no triangles"):
        load_mesh(tmp_path / "empty.obj")


def test_textured_scene_exports_to_glb_and_loads_back_in_the_map_frame(synthetic_env, tmp_path):
    import json

    import trimesh

    from benchbot_worlds.scene.export import export_scene
    from benchbot_worlds.scene.meshes import Material, MeshInstance, add_mesh_instances, load_mesh, make_mesh
    from benchbot_worlds.scene.build import build_scene

    env = synthetic_env([("chair", (2.5, 0.0, 0.5), (1.0, 1.0, 1.0))])
    env["style"] = "primitives"  # one room shell, no furnished house: only the meshes added here are textured
    scene = build_scene(env)
    tex = _quadrant_image()
    quad_v = np.array([[1.0, 1.0, 0.0], [1.0, 2.0, 0.0], [1.0, 2.0, 1.0], [1.0, 1.0, 1.0]])
    mat = Material(np.array([0.25, 0.5, 1.0], np.float32), texture=tex, roughness=0.3, metallic=0.0)
    mesh = make_mesh(quad_v, [[0, 1, 2], [0, 2, 3]], uv=[[0, 0], [1, 0], [1, 1], [0, 1]], materials=[mat])
    add_mesh_instances(scene, [MeshInstance(mesh, np.eye(4), 0)])
    written = export_scene(scene, tmp_path / "scene.glb")
    assert any(name.startswith(f"i{scene.box_instance[0]}_c0_") for name in written.graph.nodes_geometry)
    back = load_mesh(tmp_path / "scene.glb")
    textured = [k for k, m in enumerate(back.materials) if m.texture is not None]
    assert len(textured) == 1
    m = back.materials[textured[0]]
    np.testing.assert_array_equal(m.texture, tex)
    np.testing.assert_allclose(m.albedo, mat.albedo, atol=1 / 255)
    assert m.roughness == pytest.approx(0.3, abs=1e-6)
    f = back.f[back.f_material == textured[0]]
    got = back.v[f]  # the quad's two triangles, back in map coordinates, with their UVs
    assert got.shape == (2, 3, 3)
    np.testing.assert_allclose(np.sort(got.reshape(-1, 3), axis=0), np.sort(quad_v[[0, 1, 2, 0, 2, 3]], axis=0),
                               atol=1e-6)
    for tri, uvs in zip(got, back.uv[f]):
        for p, uv in zip(tri, uvs):
            np.testing.assert_allclose(uv, [p[1] - 1.0, p[2]], atol=1e-6)  # u along +y, v up, as given
    # every primitive and the room shell are there too, and the lights travel in the extras
    assert back.n_triangles > 2 + 12 + 12
    assert np.all(back.bounds[0] <= scene.room_min + 1e-5) and np.all(back.bounds[1] >= scene.room_max - 1e-5)
    gltf = trimesh.load_scene(str(tmp_path / "scene.glb"))
    extras = gltf.metadata.get("benchbot") or json.loads(json.dumps(gltf.metadata)).get("benchbot")
    assert extras is not None and len(extras["lights"]) == scene.light_kind.shape[0]
    with pytest.raises(ValueError, match=r"\.glb"):
        export_scene(scene, tmp_path / "scene.obj")


def test_sim_export_cli_writes_a_textured_glb_for_an_environment_with_mesh_objects(tmp_path):
    import yaml
    from typer.testing import CliRunner

    from benchbot_sim_taichi.cli import app
    from benchbot_worlds.scene.meshes import load_mesh

    write_textured_quad_glb(tmp_path / "quad.glb")
    (tmp_path / "env.yaml").write_text(yaml.safe_dump({
        "name": "quad_room", "variant": 1, "style": "primitives", "start_pose": [1, 0, 0, 0, -2.0, 0, 0],
        "objects": [{"mesh": "quad.glb", "class": "chair", "pose": [0.0, 0.0, 0.3, 0.0]}]}))
    res = CliRunner().invoke(app, ["export", str(tmp_path / "env.yaml"), "-o", str(tmp_path / "out" / "scene.glb")])
    assert res.exit_code == 0, res.output
    assert "scene.glb" in res.output and "triangles" in res.output
    back = load_mesh(tmp_path / "out" / "scene.glb")
    assert [m.texture.shape for m in back.materials if m.texture is not None] == [(4, 4, 3)]
    res = CliRunner().invoke(app, ["export", str(tmp_path / "env.yaml"), "-o", str(tmp_path / "scene.ply")])
    assert res.exit_code == 0 and (tmp_path / "scene.ply").stat().st_size > 0  # other formats: one coloured mesh


@pytest.mark.parametrize("command", ["render", "export", "plan"])
def test_an_environment_yaml_without_name_or_variant_is_one_line_error(tmp_path, command):
    """The sim commands seed the world from the environment's name and variant: a YAML without them gets an error
    naming the file and the fields, not a KeyError traceback."""
    import yaml
    from typer.testing import CliRunner

    from benchbot_sim_taichi.cli import app

    (tmp_path / "env.yaml").write_text(yaml.safe_dump({"style": "primitives", "start_pose": [1, 0, 0, 0, 0, 0, 0]}))
    res = CliRunner().invoke(app, [command, str(tmp_path / "env.yaml"), "-o", str(tmp_path / "out.png")])
    assert res.exit_code == 3, res.output
    assert f"the environment {tmp_path / 'env.yaml'} has no name and no variant" in res.output, res.output
    assert "Traceback" not in res.output and isinstance(res.exception, (SystemExit, type(None))), res.exception


# ---------------------------------------------------------------------------------------- textures that cannot be decoded
#: Makes Pillow unimportable in a fresh interpreter, as in an environment where it is not installed.
WITHOUT_PILLOW = "import sys; sys.modules['PIL'] = None\n"


def _run_without_pillow(code: str, tmp_path, *args: str):
    import subprocess
    import sys

    import os

    env = {**os.environ, "BENCHBOT_CACHE_DIR": str(tmp_path / "cache"), "BENCHBOT_SIM_STYLE": "furnished"}
    env.pop("BENCHBOT_DEBUG", None)
    return subprocess.run([sys.executable, "-c", WITHOUT_PILLOW + code, *args], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path, env=env)


def test_a_textured_pack_model_without_pillow_is_an_error_and_an_untextured_one_loads(tmp_path):
    """Without Pillow trimesh would load a textured GLB of the shipped pack without its images, saying nothing:
    load_mesh raises TextureDecodeError naming Pillow instead; a model without textures needs no Pillow."""
    pack = pytest.importorskip("benchbot_assets_sh3d.plugin").PACK_DIR
    code = (
        "import json, sys\n"
        "from benchbot_worlds.scene.meshes import TextureDecodeError, load_mesh\n"
        "from benchbot.core.errors import BenchbotError\n"
        "assert issubclass(TextureDecodeError, BenchbotError)\n"
        "mesh = load_mesh(sys.argv[2])\n"
        "print('untextured:', len(mesh.materials), 'materials')\n"
        "try:\n"
        "    load_mesh(sys.argv[1])\n"
        "except TextureDecodeError as e:\n"
        "    print(json.dumps([e.message, e.hint]))\n"
    )
    textured, untextured = pack / "chair__sc_children_chair.glb", pack / "chair__ccby_green_stool.glb"
    res = _run_without_pillow(code, tmp_path, str(textured), str(untextured))
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[0].startswith("untextured:")
    import json

    message, hint = json.loads(lines[1])
    assert message == (f"textures cannot be decoded: Pillow is not installed (the mesh {textured} has 1 textured "
                       "material)")
    assert "pip install pillow" in hint and "\n" not in message + hint


def test_a_furnished_scene_without_pillow_is_a_one_line_error(tmp_path):
    """The user's view: `benchbot sim export miniroom:1` where Pillow is missing exits 5 with one line naming Pillow
    and the hint, no traceback, and writes nothing (the scene cache's key records the decoder, so no scene decoded
    by a Pillow elsewhere is served either: the cache here starts empty)."""
    pytest.importorskip("benchbot_assets_sh3d")
    code = ("import sys\nfrom benchbot.cli.main import main\n"
            "sys.argv = ['benchbot', 'sim', 'export', 'miniroom:1', '-o', 'scene.glb']\nmain()\n")
    res = _run_without_pillow(code, tmp_path)
    assert res.returncode == 5, res.stdout + res.stderr
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert lines[0].startswith("error: textures cannot be decoded: Pillow is not installed (the mesh "), lines
    assert lines[1].startswith("hint: pip install pillow"), lines
    assert "Traceback" not in res.stderr and not (tmp_path / "scene.glb").exists()


def _damaged_png_glb(path, how: str):
    """A textured quad GLB whose PNG is damaged: ``signature`` (Pillow cannot even identify it, so trimesh leaves
    the material without its image) or ``data`` (its pixel data zeroed: Pillow opens it and fails decoding)."""
    import struct

    image = (np.random.default_rng(0).random((16, 16, 3)) * 255).astype(np.uint8)
    data = bytearray(write_textured_quad_glb(path, image=image).read_bytes())
    start = data.index(b"\x89PNG")
    if how == "signature":
        data[start:start + 8] = b"NOTAPNG!"
    else:
        at = data.index(b"IDAT", start)
        size = struct.unpack(">I", data[at - 4:at])[0]
        data[at + 4:at + 4 + size] = bytes(size)
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("how, reason", [
    ("signature", "1 of the 1 textured materials of the mesh .*signature.glb have no image that Pillow could read"),
    ("data", r"an image of the mesh .*data.glb is unreadable \(OSError: "),
])
def test_an_image_pillow_cannot_decode_is_an_error(tmp_path, how, reason):
    from benchbot_worlds.scene.meshes import TextureDecodeError, load_mesh

    with pytest.raises(TextureDecodeError, match="^textures cannot be decoded: " + reason) as info:
        load_mesh(_damaged_png_glb(tmp_path / f"{how}.glb", how))
    assert "\n" not in info.value.message and info.value.hint


def test_an_obj_whose_map_kd_cannot_be_read_is_an_error(tmp_path):
    from PIL import Image

    from benchbot_worlds.scene.meshes import TextureDecodeError, load_mesh

    Image.fromarray(_quadrant_image()).save(tmp_path / "tex.png")
    (tmp_path / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd tex.png\n")
    (tmp_path / "quad.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                       "usemtl a\nf 1/1 2/2 3/3\n")
    (mat,) = load_mesh(tmp_path / "quad.obj").materials
    assert mat.texture.shape == (4, 4, 3)
    (tmp_path / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd missing.png\n")
    (tmp_path / "quad2.obj").write_text((tmp_path / "quad.obj").read_text())
    with pytest.raises(TextureDecodeError, match="quad2.obj have no image"):
        load_mesh(tmp_path / "quad2.obj")


def test_an_obj_whose_textured_material_no_face_uses_loads_untextured(tmp_path):
    """The MTL declares a textured material that no ``usemtl`` picks: trimesh attaches only the used, plain one, and
    that is no decoding failure."""
    from benchbot_worlds.scene.meshes import load_mesh

    (tmp_path / "m.mtl").write_text("newmtl plain\nKd 1 1 1\nnewmtl textured\nKd 1 1 1\nmap_Kd missing.png\n")
    (tmp_path / "quad.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl plain\nf 1 2 3\n")
    (mat,) = load_mesh(tmp_path / "quad.obj").materials
    assert mat.texture is None


@pytest.mark.parametrize("materials", ['{"0": {}}', '[{"pbrMetallicRoughness": [1]}]'])
def test_a_gltf_whose_materials_have_another_shape_is_one_line(tmp_path, materials):
    """A glTF whose JSON does not have the spec's shapes gives the reader's one-line error, never a traceback of
    the texture count."""
    from benchbot_worlds.scene.meshes import load_mesh

    path = tmp_path / "odd.gltf"
    path.write_text('{"asset": {"version": "2.0"}, "materials": ' + materials
                    + ', "meshes": [{"primitives": [{"attributes": {}, "material": 0}]}]}')
    with pytest.raises(BackendError) as info:
        load_mesh(path)
    assert "\n" not in info.value.message
