"""A contact sheet of an asset pack, to look at: each GLB (loaded with trimesh, as a renderer would) drawn in the
MAP frame (glTF (x, y, z) → map (x, -z, y): z up, the model's front towards -y), seen from the front-left and
above, orthographic, flat-shaded with each face's texture colour. A model whose front is right shows its front.

    uv run python plugins/assets_sh3d/tools/contact_sheet.py [PACK_DIR] -o sheet.png [--only SUBSTR ...]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

PACK = Path(__file__).resolve().parents[1] / "benchbot_assets_sh3d" / "pack"


def face_colours(geom) -> np.ndarray:
    """(F,3) sRGB colours: the texture at each face's centroid UV, else the material's base colour."""
    n = len(geom.faces)
    vis = geom.visual
    mat = getattr(vis, "material", None)
    base = np.array([0.7, 0.7, 0.7])
    if mat is not None and getattr(mat, "baseColorFactor", None) is not None:
        base = np.asarray(mat.baseColorFactor[:3], dtype=float) / (255.0 if np.max(mat.baseColorFactor) > 1 else 1)
        base = np.where(base <= 0.0031308, base * 12.92, 1.055 * base ** (1 / 2.4) - 0.055)  # linear → sRGB
    img = getattr(mat, "baseColorTexture", None) if mat is not None else None
    uv = getattr(vis, "uv", None)
    if img is not None and uv is not None and len(uv):
        arr = np.asarray(img.convert("RGB"), dtype=float) / 255
        h, w = arr.shape[:2]
        c = uv[geom.faces].mean(axis=1)
        x = (np.mod(c[:, 0], 1) * (w - 1)).astype(int)
        y = (np.mod(c[:, 1], 1) * (h - 1)).astype(int)  # trimesh flips V on load
        return arr[h - 1 - y, x]
    return np.tile(base, (n, 1))


def draw(ax, path: Path, title: str) -> None:
    import trimesh

    scene = trimesh.load(path, force="scene")
    tris, cols, norms = [], [], []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geom = scene.geometry[name]
        v = trimesh.transform_points(geom.vertices, transform)
        v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)  # glTF → map
        t = v[geom.faces]
        tris.append(t)
        cols.append(face_colours(geom))
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        norms.append(n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12))
    t, c, n = np.concatenate(tris), np.concatenate(cols), np.concatenate(norms)
    # camera: from the front (-y) and a little left (-x) and above
    yaw, pitch = np.radians(-30), np.radians(25)
    view = np.array([np.sin(yaw) * np.cos(pitch), -np.cos(yaw) * np.cos(pitch), np.sin(pitch)])  # towards camera
    right = np.cross([0, 0, 1], view)
    right /= np.linalg.norm(right)
    up = np.cross(view, right)
    px, py, depth = t @ right, t @ up, t @ view
    light = np.array([0.3, -0.6, 0.75])
    light /= np.linalg.norm(light)
    shade = 0.35 + 0.65 * np.abs(n @ light)
    order = np.argsort(depth.mean(axis=1))
    from matplotlib.collections import PolyCollection

    polys = np.stack([px, py], axis=2)[order]
    ax.add_collection(PolyCollection(polys, facecolors=np.clip(c[order] * shade[order, None], 0, 1),
                                     edgecolors="none"))
    ax.set_xlim(px.min(), px.max())
    ax.set_ylim(py.min(), py.max())
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=6)
    ax.axis("off")


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ap = argparse.ArgumentParser()
    ap.add_argument("pack", nargs="?", type=Path, default=PACK)
    ap.add_argument("-o", "--out", type=Path, default=Path("contact_sheet.png"))
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--cols", type=int, default=8)
    args = ap.parse_args()
    manifest = json.loads((args.pack / "manifest.json").read_text())
    assets = [a for a in manifest["assets"] if not args.only or any(s in a["id"] for s in args.only)]
    cols = args.cols
    rows = (len(assets) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(cols * 1.6, rows * 1.7), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, a in zip(axes.flat, assets):
        x, y, z = a["size_m"]
        draw(ax, args.pack / a["file"], f"{a['id'].split('__')[1]}\n{a['kind']} {x:.2f}x{y:.2f}x{z:.2f}")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(args.out)


if __name__ == "__main__":
    main()
