"""Reference renders for ``benchmarks/realism.py``: Blender Cycles (the ``bpy`` package) path-traces the exported
scene.

Runs in its own environment, because ``bpy`` pins NumPy < 2 and exactly Python 3.11 (``realism.py`` starts it as
``uv run --no-project --python 3.11 --with bpy==5.0.1 python cycles_reference.py JOB.json``); it imports nothing
of BenchBot. The job (JSON, written by ``realism.py``) names:

- ``glb``: the scene in glTF 2.0 (+Y up; Blender's importer turns it into the map frame, z up); nodes named
  ``shell_*`` are the room shell, drawn as ``shell`` says: ``camera-only`` (seen by the camera, invisible to
  shadow and bounce rays: our renderer's shell casts no shadows) or ``solid`` (physical).
- ``lights``: ``ambient`` (3,) linear sky radiance, ``suns`` [{direction (towards the sun), colour, angle_rad}],
  ``points`` [{position, colour, radius}], in our renderer's units (radiance = albedo · colour · n·l, point lamps
  falling off as 1/d²). Converted: sun strength = π · colour (W/m²), point power = 4π² · colour (W), sky radiance
  ``ambient · (0.8 + 0.3 · ω_z)`` (a Lambertian surface under it receives ``ambient · (0.8 + 0.2 · n_z)``, our
  renderer's ambient term).
- ``frames``: [{name, width, height, lens_mm, sensor_mm, shift_x, shift_y, matrix_world (4x4, Blender camera:
  looks down −z, +y up)}]; ``spp`` (the converged reference), ``ladder`` (lower sample counts, timed, seeded apart);
  ``seed``; ``out_dir``.

Writes ``<out_dir>/<frame>_spp<N>.npy`` (H, W, 3) float32 linear radiance (no tone mapping, no clamping), and
``<out_dir>/timings.json`` {frame: {spp: seconds}} plus ``import_s``. Materials: glTF metallic-roughness as imported
(Principled BSDF); a material with roughness 1 and metallic 0 (what the exporter writes for flat colours) is made
purely diffuse, as our renderer's surfaces are; a window pane (a material named ``glass_*``) is the renderer's thin
glass (``_thin_glass``). No denoising, no adaptive sampling, a 1-pixel box filter.
"""

import json
import math
import os
import sys
import time

import bpy
import numpy as np


def _reset(job: dict) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.use_denoising = False
    cy.use_adaptive_sampling = False
    cy.max_bounces = cy.diffuse_bounces = 8
    cy.glossy_bounces = cy.transmission_bounces = cy.transparent_max_bounces = 8
    cy.sample_clamp_direct = cy.sample_clamp_indirect = 0.0  # unbiased
    cy.caustics_reflective = cy.caustics_refractive = True
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    sc.render.threads_mode = "AUTO"
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"


def _import_scene(job: dict) -> None:
    bpy.ops.import_scene.gltf(filepath=job["glb"])
    solid = job.get("shell", "camera-only") == "solid"
    for obj in list(bpy.context.scene.objects):
        if obj.type != "MESH":
            continue
        if obj.name.startswith("shell") and not solid:
            obj.visible_shadow = obj.visible_diffuse = obj.visible_glossy = False
            obj.visible_transmission = obj.visible_volume_scatter = False
        mesh = obj.data
        if not mesh.has_custom_normals:  # flat-coloured primitives: boxes stay sharp, tessellated curves smooth
            bpy.context.view_layer.objects.active = obj
            for o in bpy.context.selected_objects:
                o.select_set(False)
            obj.select_set(True)
            try:
                bpy.ops.object.shade_smooth_by_angle(angle=math.radians(35.0))
            except (AttributeError, RuntimeError):
                pass
    for mat in bpy.data.materials:
        if not mat.use_nodes:
            continue
        if mat.name.startswith("glass_"):
            _thin_glass(mat)
            continue
        for node in mat.node_tree.nodes:
            if node.type == "BSDF_PRINCIPLED":
                rough = node.inputs["Roughness"]
                metal = node.inputs["Metallic"]
                if (not rough.is_linked and not metal.is_linked and rough.default_value >= 0.999
                        and metal.default_value <= 1e-6):
                    node.inputs["Specular IOR Level"].default_value = 0.0  # Lambertian, like our renderer


def _thin_glass(mat) -> None:
    """A window pane as our renderer draws it: at each face, a mirror weighted by Schlick's reflectance
    F = 0.04 + 0.96 (1 − |n·ω|)⁵ and a Transparent BSDF (straight through, and letting shadow rays through) with the
    rest — no refraction, no tint."""
    nt = mat.node_tree
    nt.nodes.clear()
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    dot = nt.nodes.new("ShaderNodeVectorMath")
    dot.operation = "DOT_PRODUCT"
    nt.links.new(geo.outputs["Incoming"], dot.inputs[0])
    nt.links.new(geo.outputs["Normal"], dot.inputs[1])
    value = dot.outputs["Value"]
    for op, arg in (("ABSOLUTE", None), ("SUBTRACT", None), ("POWER", 5.0), ("MULTIPLY_ADD", (0.96, 0.04))):
        node = nt.nodes.new("ShaderNodeMath")
        node.operation = op
        node.use_clamp = True
        if op == "SUBTRACT":  # 1 − |cos|
            node.inputs[0].default_value = 1.0
            nt.links.new(value, node.inputs[1])
        else:
            nt.links.new(value, node.inputs[0])
            if op == "POWER":
                node.inputs[1].default_value = arg
            elif op == "MULTIPLY_ADD":
                node.inputs[1].default_value, node.inputs[2].default_value = arg
        value = node.outputs[0]
    clear = nt.nodes.new("ShaderNodeBsdfTransparent")
    mirror = nt.nodes.new("ShaderNodeBsdfGlossy")
    mirror.inputs["Roughness"].default_value = 0.0
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(value, mix.inputs["Fac"])
    nt.links.new(clear.outputs[0], mix.inputs[1])
    nt.links.new(mirror.outputs[0], mix.inputs[2])
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(mix.outputs[0], out.inputs["Surface"])


def _world(ambient) -> None:
    sc = bpy.context.scene
    world = bpy.data.worlds.new("sky")
    sc.world = world
    world.use_nodes = True
    nt = world.node_tree
    nt.nodes.clear()
    coords = nt.nodes.new("ShaderNodeTexCoord")  # world "Generated" = the ray direction
    split = nt.nodes.new("ShaderNodeSeparateXYZ")
    grad = nt.nodes.new("ShaderNodeMath")
    grad.operation = "MULTIPLY_ADD"
    grad.inputs[1].default_value = 0.3
    grad.inputs[2].default_value = 0.8
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = (float(ambient[0]), float(ambient[1]), float(ambient[2]), 1.0)
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(coords.outputs["Generated"], split.inputs[0])
    nt.links.new(split.outputs["Z"], grad.inputs[0])
    nt.links.new(grad.outputs[0], bg.inputs["Strength"])
    nt.links.new(bg.outputs[0], out.inputs["Surface"])


def _lights(lights: dict) -> None:
    from mathutils import Vector

    sc = bpy.context.scene
    for i, sun in enumerate(lights.get("suns", [])):
        col = np.asarray(sun["colour"], dtype=float)
        peak = float(col.max()) or 1.0
        data = bpy.data.lights.new(f"sun{i}", "SUN")
        data.energy = math.pi * peak
        data.color = tuple(col / peak)
        data.angle = float(sun.get("angle_rad", 0.0))
        obj = bpy.data.objects.new(f"sun{i}", data)
        sc.collection.objects.link(obj)
        obj.rotation_euler = Vector(sun["direction"]).to_track_quat("Z", "Y").to_euler()  # emits along −z
    for i, lamp in enumerate(lights.get("points", [])):
        col = np.asarray(lamp["colour"], dtype=float)
        peak = float(col.max()) or 1.0
        data = bpy.data.lights.new(f"lamp{i}", "POINT")
        data.energy = 4.0 * math.pi * math.pi * peak
        data.color = tuple(col / peak)
        data.shadow_soft_size = float(lamp.get("radius", 0.0))
        obj = bpy.data.objects.new(f"lamp{i}", data)
        sc.collection.objects.link(obj)
        obj.location = tuple(lamp["position"])


def _camera(frame: dict):
    from mathutils import Matrix

    sc = bpy.context.scene
    cam = bpy.data.cameras.get("cam") or bpy.data.cameras.new("cam")
    obj = bpy.data.objects.get("cam") or bpy.data.objects.new("cam", cam)
    if obj.name not in sc.collection.objects:
        sc.collection.objects.link(obj)
    cam.sensor_fit = "HORIZONTAL"
    cam.sensor_width = float(frame["sensor_mm"])
    cam.lens = float(frame["lens_mm"])
    cam.shift_x = float(frame.get("shift_x", 0.0))
    cam.shift_y = float(frame.get("shift_y", 0.0))
    cam.clip_start = 0.01
    cam.clip_end = 1000.0
    obj.matrix_world = Matrix(frame["matrix_world"])
    sc.camera = obj
    sc.render.resolution_x = int(frame["width"])
    sc.render.resolution_y = int(frame["height"])
    sc.render.resolution_percentage = 100


def _render(path: str, spp: int, seed: int) -> tuple[np.ndarray, float]:
    sc = bpy.context.scene
    sc.cycles.samples = int(spp)
    sc.cycles.seed = int(seed)
    sc.render.filepath = path + ".exr"
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - t0
    img = bpy.data.images.load(sc.render.filepath, check_existing=False)
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    os.remove(sc.render.filepath)
    rgb = px.reshape(h, w, 4)[::-1, :, :3]  # Blender's rows run bottom-up
    return np.ascontiguousarray(rgb), seconds


def main(job_path: str) -> int:
    with open(job_path) as f:
        job = json.load(f)
    t0 = time.perf_counter()
    _reset(job)
    _import_scene(job)
    _world(job["lights"]["ambient"])
    _lights(job["lights"])
    timings: dict = {"import_s": time.perf_counter() - t0, "blender": bpy.app.version_string, "frames": {}}
    seed = int(job.get("seed", 0))
    for frame in job["frames"]:
        _camera(frame)
        per = timings["frames"].setdefault(frame["name"], {})
        for k, spp in enumerate(list(job.get("ladder", [])) + [int(job["spp"])]):
            base = f"{job['out_dir']}/{frame['name']}_spp{spp}"
            rgb, seconds = _render(base, spp, seed + 7919 * (k + 1))
            np.save(base + ".npy", rgb)
            per[str(spp)] = seconds
            print(f"cycles: {frame['name']} {spp} spp {seconds:.1f} s", flush=True)
    with open(f"{job['out_dir']}/timings.json", "w") as f:
        json.dump(timings, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[-1]))
