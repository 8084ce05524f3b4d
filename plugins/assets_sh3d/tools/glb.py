"""A minimal, deterministic glTF 2.0 binary (GLB) writer for ``build_pack.py``: one mesh, one primitive per
material, POSITION/NORMAL (float32), TEXCOORD_0 where textured, uint16/uint32 indices, PBR metallic-roughness
materials with an optional embedded JPEG/PNG base-colour texture (one image per distinct texture). Same input, same
bytes (no timestamps)."""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass

import numpy as np


@dataclass
class Primitive:
    """One material's triangles: ``positions`` (V,3), ``normals`` (V,3) unit, ``uvs`` (V,2) or None, ``indices``
    (F,3); ``material`` index into the materials list."""

    positions: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray | None
    indices: np.ndarray
    material: int


@dataclass
class PbrMaterial:
    """glTF material: ``base_color`` linear RGBA factor, ``texture`` (image bytes, mime type) or None, roughness,
    metallic, ``alpha_mode`` OPAQUE/MASK/BLEND, ``double_sided``."""

    name: str
    base_color: tuple[float, float, float, float]
    texture: tuple[bytes, str] | None = None
    roughness: float = 0.8
    metallic: float = 0.0
    alpha_mode: str = "OPAQUE"
    double_sided: bool = True


def _pad(data: bytes, fill: bytes = b"\x00") -> bytes:
    return data + fill * ((4 - len(data) % 4) % 4)


def write_glb(primitives: list[Primitive], materials: list[PbrMaterial], name: str) -> bytes:
    """The GLB bytes of one mesh node named ``name``."""
    binary = bytearray()
    buffer_views: list[dict] = []
    accessors: list[dict] = []

    def add_view(data: bytes, target: int | None) -> int:
        while len(binary) % 4:
            binary.append(0)
        view = {"buffer": 0, "byteOffset": len(binary), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        binary.extend(data)
        buffer_views.append(view)
        return len(buffer_views) - 1

    def add_accessor(array: np.ndarray, kind: str, component: int, target: int | None, minmax: bool = False) -> int:
        view = add_view(array.tobytes(), target)
        acc = {"bufferView": view, "componentType": component, "count": int(array.shape[0]), "type": kind}
        if minmax:
            acc["min"] = [float(x) for x in array.min(axis=0)]
            acc["max"] = [float(x) for x in array.max(axis=0)]
        accessors.append(acc)
        return len(accessors) - 1

    images: list[dict] = []
    textures: list[dict] = []
    gl_materials: list[dict] = []
    texture_of: dict[bytes, int] = {}  # one image per distinct texture, shared by the materials using it
    for mat in materials:
        pbr: dict = {"baseColorFactor": [round(float(c), 6) for c in mat.base_color],
                     "metallicFactor": round(float(mat.metallic), 4), "roughnessFactor": round(float(mat.roughness), 4)}
        if mat.texture is not None:
            data, mime = mat.texture
            if data not in texture_of:
                images.append({"bufferView": add_view(data, None), "mimeType": mime})
                textures.append({"source": len(images) - 1, "sampler": 0})
                texture_of[data] = len(textures) - 1
            pbr["baseColorTexture"] = {"index": texture_of[data]}
        entry = {"name": mat.name, "pbrMetallicRoughness": pbr, "doubleSided": bool(mat.double_sided)}
        if mat.alpha_mode != "OPAQUE":
            entry["alphaMode"] = mat.alpha_mode
            if mat.alpha_mode == "MASK":
                entry["alphaCutoff"] = 0.5
        gl_materials.append(entry)

    gl_prims = []
    for prim in primitives:
        attrs = {
            "POSITION": add_accessor(np.ascontiguousarray(prim.positions, dtype="<f4"), "VEC3", 5126, 34962, True),
            "NORMAL": add_accessor(np.ascontiguousarray(prim.normals, dtype="<f4"), "VEC3", 5126, 34962),
        }
        if prim.uvs is not None:
            attrs["TEXCOORD_0"] = add_accessor(np.ascontiguousarray(prim.uvs, dtype="<f4"), "VEC2", 5126, 34962)
        n_vertices = prim.positions.shape[0]
        if n_vertices < 65536:
            idx, comp = np.ascontiguousarray(prim.indices.reshape(-1), dtype="<u2"), 5123
        else:
            idx, comp = np.ascontiguousarray(prim.indices.reshape(-1), dtype="<u4"), 5125
        gl_prims.append({"attributes": attrs, "indices": add_accessor(idx, "SCALAR", comp, 34963),
                         "material": prim.material, "mode": 4})

    gltf: dict = {
        "asset": {"version": "2.0", "generator": "benchbot-assets-sh3d build_pack.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": name, "mesh": 0}],
        "meshes": [{"name": name, "primitives": gl_prims}],
        "materials": gl_materials,
        "accessors": accessors,
        "bufferViews": buffer_views,
        "buffers": [{"byteLength": len(binary)}],
    }
    if images:
        gltf["images"] = images
        gltf["textures"] = textures
        gltf["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]
    json_chunk = _pad(json.dumps(gltf, separators=(",", ":"), sort_keys=True).encode(), b" ")
    bin_chunk = _pad(bytes(binary))
    total = 12 + 8 + len(json_chunk) + 8 + len(bin_chunk)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(json_chunk), b"JSON") + json_chunk
            + struct.pack("<I4s", len(bin_chunk), b"BIN\x00") + bin_chunk)
