"""Reading the Sweet Home 3D furniture libraries (``.sh3f`` zips of OBJ/MTL/textures with a catalogue), for
``build_pack.py``. Build-time only: numpy and Pillow.

Catalogue conventions (``PluginFurnitureCatalog.properties``, Java properties, ISO-8859-1 with ``\\uXXXX``): item
``n`` has ``id#n``, ``name#n``, ``category#n``, ``model#n`` (path inside the zip), ``width#n``/``depth#n``/``height#n``
(cm), ``creator#n``, optional ``modelRotation#n`` (a 3x3 matrix, row-major, applied to the OBJ's points as
``p' = M p``) and ``elevation#n`` (cm above the floor). Sweet Home 3D rotates the OBJ by ``modelRotation`` and then
scales its bounds to ``width x height x depth`` (x, y, z): the model is y-up and its front faces +z (the viewer of
the catalogue icon), which are glTF's conventions.
"""

from __future__ import annotations

import io
import re
import zipfile
from dataclasses import dataclass, field
from pathlib import PurePosixPath

import numpy as np


def parse_properties(text: str) -> dict[str, str]:
    """A Java ``.properties`` file as a dict (continuation lines, ``\\uXXXX`` and ``\\`` escapes, ``=``/``:``)."""
    out: dict[str, str] = {}
    logical: list[str] = []
    buf = ""
    for raw in text.splitlines():
        line = raw.lstrip() if not buf else raw.lstrip()
        if not buf and (not line or line[0] in "#!"):
            continue
        if line.endswith("\\") and not line.endswith("\\\\"):
            buf += line[:-1]
            continue
        logical.append(buf + line)
        buf = ""
    if buf:
        logical.append(buf)
    for line in logical:
        m = re.match(r"((?:\\.|[^=:\s])+)\s*[=:\s]\s*(.*)$", line)
        if not m:
            continue
        out[_unescape(m.group(1))] = _unescape(m.group(2))
    return out


def _unescape(s: str) -> str:
    def rep(m: re.Match) -> str:
        e = m.group(1)
        if e.startswith("u"):
            return chr(int(e[1:], 16))
        return {"t": "\t", "n": "\n", "r": "\r", "f": "\f"}.get(e, e)

    return re.sub(r"\\(u[0-9a-fA-F]{4}|.)", rep, s)


@dataclass
class CatalogItem:
    """One catalogue entry (sizes in metres)."""

    index: int
    id: str
    name: str
    category: str
    model: str
    width: float
    depth: float
    height: float
    creator: str
    elevation: float = 0.0
    rotation: np.ndarray | None = None
    props: dict = field(default_factory=dict)


def read_catalog(zf: zipfile.ZipFile) -> dict[str, CatalogItem]:
    """The catalogue of a ``.sh3f`` zip, by item id (e.g. ``Scopia#toaster``)."""
    props = parse_properties(zf.read("PluginFurnitureCatalog.properties").decode("latin-1"))
    items: dict[int, dict] = {}
    for key, value in props.items():
        m = re.match(r"^(\w+)#(\d+)$", key)
        if m:
            items.setdefault(int(m.group(2)), {})[m.group(1)] = value
    out = {}
    for index, p in sorted(items.items()):
        rot = None
        if p.get("modelRotation"):
            rot = np.array([float(v) for v in p["modelRotation"].split()], dtype=np.float64).reshape(3, 3)
        out[p["id"]] = CatalogItem(
            index=index, id=p["id"], name=p.get("name", ""), category=p.get("category", ""), model=p["model"],
            width=float(p["width"]) / 100, depth=float(p["depth"]) / 100, height=float(p["height"]) / 100,
            creator=p.get("creator", ""), elevation=float(p.get("elevation", 0) or 0) / 100, rotation=rot, props=p)
    return out


@dataclass
class Material:
    """An MTL material: ``kd`` diffuse colour (as written, display values), ``ns`` specular exponent, ``d``
    opacity, ``map_kd`` texture path inside the zip (or None)."""

    name: str
    kd: tuple[float, float, float] = (0.8, 0.8, 0.8)
    ks: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ns: float = 10.0
    d: float = 1.0
    map_kd: str | None = None


_MAP_OPTION_ARITY = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1, "-imfchan": 1,
                     "-mm": 2, "-o": 3, "-s": 3, "-t": 3, "-texres": 1, "-type": 1}


def parse_mtl(text: str, folder: str) -> dict[str, Material]:
    """Materials of an MTL file whose textures are relative to ``folder`` (a zip path)."""
    mats: dict[str, Material] = {}
    cur: Material | None = None
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        key, _, rest = line.partition(" ")
        rest = rest.strip()
        if key == "newmtl":
            cur = mats.setdefault(rest, Material(rest))
        elif cur is None:
            continue
        elif key == "Kd":
            cur.kd = tuple(float(v) for v in rest.split()[:3])
        elif key == "Ks":
            cur.ks = tuple(float(v) for v in rest.split()[:3])
        elif key == "Ns":
            cur.ns = float(rest.split()[0])
        elif key == "d":
            cur.d = float(rest.split()[-1])
        elif key == "Tr":
            cur.d = 1.0 - float(rest.split()[-1])
        elif key == "map_Kd":
            tokens = rest.split(" ")
            i = 0
            while i < len(tokens) and tokens[i].startswith("-") and tokens[i] in _MAP_OPTION_ARITY:
                i += 1 + _MAP_OPTION_ARITY[tokens[i]]
            name = " ".join(tokens[i:]).strip()
            if name:
                cur.map_kd = str(PurePosixPath(folder) / name.replace("\\", "/"))
    return mats


@dataclass
class ObjModel:
    """An OBJ file, triangulated.

    Attributes:
        v: (V, 3) positions. vt: (T, 2) texture coordinates (may be empty).
        f_v: (F, 3) position indices. f_vt: (F, 3) texture-coordinate indices, -1 where none.
        f_group: (F,) index into ``groups``. f_mat: (F,) index into ``materials``.
        groups: group names. materials: material names (``""`` for faces without ``usemtl``).
        mtl: the materials by name.
    """

    v: np.ndarray
    vt: np.ndarray
    f_v: np.ndarray
    f_vt: np.ndarray
    f_group: np.ndarray
    f_mat: np.ndarray
    groups: list[str]
    materials: list[str]
    mtl: dict[str, Material]

    def subset(self, keep: np.ndarray) -> "ObjModel":
        """The same model with only the faces where ``keep`` (bool (F,)) is true."""
        return ObjModel(self.v, self.vt, self.f_v[keep], self.f_vt[keep], self.f_group[keep], self.f_mat[keep],
                        self.groups, self.materials, self.mtl)


def parse_obj(text: str, mtl: dict[str, Material]) -> ObjModel:
    """Parse OBJ text (``v``, ``vt``, ``f`` with negative indices, ``g``/``o``, ``usemtl``); polygons are fanned."""
    v: list[list[float]] = []
    vt: list[list[float]] = []
    f_v: list[tuple[int, int, int]] = []
    f_vt: list[tuple[int, int, int]] = []
    f_group: list[int] = []
    f_mat: list[int] = []
    groups: dict[str, int] = {}
    materials: dict[str, int] = {}
    group = groups.setdefault("default", 0)
    mat = materials.setdefault("", 0)
    for raw in text.splitlines():
        if not raw or raw[0] == "#":
            continue
        parts = raw.split()
        if not parts:
            continue
        key = parts[0]
        if key == "v":
            v.append([float(parts[1]), float(parts[2]), float(parts[3])])
        elif key == "vt":
            vt.append([float(parts[1]), float(parts[2]) if len(parts) > 2 else 0.0])
        elif key == "f":
            corners = []
            for token in parts[1:]:
                idx = token.split("/")
                vi = int(idx[0])
                vi = vi - 1 if vi > 0 else len(v) + vi
                ti = -1
                if len(idx) > 1 and idx[1]:
                    ti = int(idx[1])
                    ti = ti - 1 if ti > 0 else len(vt) + ti
                corners.append((vi, ti))
            for k in range(1, len(corners) - 1):
                a, b, c = corners[0], corners[k], corners[k + 1]
                f_v.append((a[0], b[0], c[0]))
                f_vt.append((a[1], b[1], c[1]))
                f_group.append(group)
                f_mat.append(mat)
        elif key in ("g", "o"):
            name = raw.split(None, 1)[1].strip() if len(parts) > 1 else "default"
            group = groups.setdefault(name, len(groups))
        elif key == "usemtl":
            name = raw.split(None, 1)[1].strip() if len(parts) > 1 else ""
            mat = materials.setdefault(name, len(materials))
    return ObjModel(
        v=np.asarray(v, dtype=np.float64).reshape(-1, 3), vt=np.asarray(vt, dtype=np.float64).reshape(-1, 2),
        f_v=np.asarray(f_v, dtype=np.int64).reshape(-1, 3), f_vt=np.asarray(f_vt, dtype=np.int64).reshape(-1, 3),
        f_group=np.asarray(f_group, dtype=np.int64), f_mat=np.asarray(f_mat, dtype=np.int64),
        groups=list(groups), materials=list(materials), mtl=mtl)


class Library:
    """One ``.sh3f`` library: its catalogue and its files."""

    def __init__(self, path, name: str) -> None:
        self.name = name
        self.zf = zipfile.ZipFile(path)
        self.catalog = read_catalog(self.zf)
        self._names = set(self.zf.namelist())

    def read(self, path: str) -> bytes:
        """A file of the zip by its catalogue-style path (leading ``/`` optional)."""
        return self.zf.read(path.lstrip("/"))

    def exists(self, path: str) -> bool:
        return path.lstrip("/") in self._names

    def files_in(self, folder: str) -> list[str]:
        """The files directly in a zip folder."""
        folder = folder.strip("/") + "/"
        return sorted(n for n in self._names if n.startswith(folder) and "/" not in n[len(folder):] and
                      not n.endswith("/"))

    def load_model(self, item: CatalogItem) -> ObjModel:
        """The item's OBJ with its MTL materials."""
        folder = str(PurePosixPath(item.model).parent)
        text = self.read(item.model).decode("latin-1")
        mtl: dict[str, Material] = {}
        for line in text.splitlines():
            if line.startswith("mtllib"):
                for name in line.split(None, 1)[1].strip().split(" "):
                    p = str(PurePosixPath(folder) / name)
                    if self.exists(p):
                        mtl.update(parse_mtl(self.read(p).decode("latin-1"), folder))
        for mat in mtl.values():
            if mat.map_kd:
                mat.map_kd = self.resolve_texture(mat.map_kd, folder)
        return parse_obj(text, mtl)

    def resolve_texture(self, path: str, folder: str) -> str | None:
        """A texture path that exists in the zip: as written; else its file name in the model's folder (some MTLs
        keep their author's absolute path, e.g. Kator Legaz's oriental rug); else the folder's only image; else
        None."""
        if self.exists(path):
            return path
        base = path.replace("\\", "/").rsplit("/", 1)[-1].lower()
        images = [n for n in self.files_in(folder) if n.lower().endswith((".jpg", ".jpeg", ".png", ".gif", ".bmp"))]
        same = [n for n in images if n.rsplit("/", 1)[-1].lower() == base]
        if same:
            return "/" + same[0]
        return "/" + images[0] if len(images) == 1 else None

    def image(self, path: str):
        """A texture as a PIL image, or None when the file is missing."""
        from PIL import Image

        if not self.exists(path):
            # case-insensitive fallback (some MTLs differ in case from the file)
            low = path.lstrip("/").lower()
            match = [n for n in self._names if n.lower() == low]
            if not match:
                return None
            path = match[0]
        img = Image.open(io.BytesIO(self.read(path)))
        img.load()
        return img
