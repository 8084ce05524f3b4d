"""Build the realism benchmark's real-photo reference set from COCO val2017 images and their annotations.

    python tools/realism_photos.py --source ANNOTATIONS.json IMAGE_DIR [--source ...] [--out benchmarks/realism/photos]
        [--quality 90] [--max-side 640]

Each ``ANNOTATIONS.json`` is a COCO instances file of **val2017** images (the official ``instances_val2017.json`` or
a subset of it; train2017 images are refused: the detectors were trained on them) and its ``IMAGE_DIR`` holds its
images (``file_name``); several sources are merged (an image or box in two of them is kept once). It keeps the
photos with at least one box of a BEAR class other than ``person`` whose licence allows derivatives (no "NoDerivs")
(``benchbot_task_semslam.coco``'s names, ``dining table`` → ``table``), re-encodes them as JPEG (``--quality``,
longest side at most ``--max-side``, boxes and areas scaled with the image) and writes beside them
``coco_val2017.json``: the kept images (COCO id, file name, size, licence id, ``flickr_url``, ``coco_url``), their
boxes of every class (``bbox`` [x, y, w, h] pixels, mask ``area`` pixels, ``iscrowd``, ``category_id``; no
segmentation), COCO's categories and licences, and ``ATTRIBUTION.md``: where they come from (``--origin``, one line a
source) and, per photo, its COCO id, Flickr licence and Flickr URL. Exit code 2 with one line on a bad file.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "benchmarks" / "realism" / "photos"
MANIFEST = "coco_val2017.json"


def bear_classes() -> set[str]:
    """BEAR's class names a COCO detector can name, less ``person`` and ``background``."""
    from benchbot_task_semslam.coco import COCO80, COCO_TO_BEAR

    from benchbot_worlds.scene.build import BEAR_CLASS_LIST

    coco_as_bear = {COCO_TO_BEAR.get(n, n) for n in COCO80}
    return (set(BEAR_CLASS_LIST) & coco_as_bear) - {"person"}


def no_derivatives(data: dict) -> set[int]:
    """The licence ids of COCO instances ``data`` whose licence forbids derivatives (Creative Commons "NoDerivs"):
    their photos are left out, since re-encoding them at another size could count as altering them."""
    return {entry["id"] for entry in data.get("licenses", []) if "noderivs" in entry.get("name", "").lower()}


def kept_images(data: dict, classes: set[str]) -> list[dict]:
    """The images of COCO instances ``data`` with at least one box of ``classes`` (BEAR names) and a licence that
    allows derivatives (:func:`no_derivatives`), in file order.

    Raises:
        ValueError: an image is not a val2017 one (its ``coco_url`` names another split), or one with a box of
            ``classes`` has a licence id that ``data["licenses"]`` does not name (its licence cannot be checked).
    """
    from benchbot_task_semslam.coco import COCO_TO_BEAR

    names = {c["id"]: COCO_TO_BEAR.get(c["name"], c["name"]) for c in data["categories"]}
    with_class = {a["image_id"] for a in data["annotations"] if names[a["category_id"]] in classes}
    out, refused = [], no_derivatives(data)
    known = {entry["id"] for entry in data.get("licenses", [])}
    for im in data["images"]:
        if "/val2017/" not in im.get("coco_url", "/val2017/"):
            raise ValueError(f"image {im['id']} is not a val2017 image ({im['coco_url']}): the detectors trained "
                             "on train2017")
        if im["id"] in with_class and im.get("license") not in known:
            raise ValueError(f"image {im['id']}'s licence id {im.get('license')} is in no source's `licenses`: "
                             "give a source with COCO's licence list")
        if im["id"] in with_class and im.get("license") not in refused:
            out.append(im)
    return out


def reencode(src: Path, max_side: int, quality: int) -> tuple[bytes, float]:
    """JPEG bytes of the image at ``src`` (RGB, longest side at most ``max_side``, Lanczos) and the scale applied."""
    from PIL import Image

    with Image.open(src) as im:
        im = im.convert("RGB")
        scale = min(1.0, max_side / max(im.size))
        if scale < 1.0:
            im = im.resize((round(im.width * scale), round(im.height * scale)), Image.Resampling.LANCZOS)
        buf = io.BytesIO()
        im.save(buf, "JPEG", quality=quality, optimize=True)
    return buf.getvalue(), scale


def read_instances(path: Path) -> dict:
    """A COCO instances file (JSON): an object whose ``images``, ``annotations`` and ``categories`` (and
    ``licenses``, if given) are lists of objects.

    Raises:
        OSError: the file cannot be read. ValueError: it is not JSON, or not of that shape (the message names the
            file and the field).
    """
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not JSON ({exc}); give a COCO instances file") from exc
    if not isinstance(data, dict):
        raise ValueError(f"{path}: not a COCO instances file (a JSON object with images, annotations, categories)")
    for key in ("images", "annotations", "categories", "licenses"):
        value = data.get(key, [] if key == "licenses" else None)
        if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
            raise ValueError(f"{path}: `{key}` must be a list of objects, as in a COCO instances file")
    return data


def licence_key(licenses: list[dict]) -> list[tuple]:
    """A COCO ``licenses`` list as comparable (id, name, url) tuples, each URL with JSON's optional escape of
    ``/`` (``\\/``, written literally by some subsets) undone: two lists with equal keys name the same licences."""
    return [(e.get("id"), e.get("name"), str(e.get("url", "")).replace("\\/", "/")) for e in licenses]


def merge(sources: list[tuple[dict, Path]]) -> tuple[dict, dict]:
    """One COCO instances dict from several (``data``, image folder) sources, images and boxes kept once (by id),
    and {image id: its folder}.

    A source without COCO's ``licenses`` list (some subsets drop it) takes the other sources' list; lists that
    differ only in how their URLs escape ``/`` are the same (:func:`licence_key`), and the first source's is kept.

    Raises:
        ValueError: two sources give the same image or box different contents, or their categories or licence
            lists differ.
    """
    merged: dict = {"info": sources[0][0].get("info", {}), "licenses": [], "categories": sources[0][0]["categories"],
                    "images": [], "annotations": []}
    folder: dict[int, Path] = {}
    seen: dict[tuple[str, int], dict] = {}
    for data, image_dir in sources:
        if data["categories"] != merged["categories"]:
            raise ValueError(f"the categories of the source of {image_dir} differ from the first source's")
        if data.get("licenses") and merged["licenses"] and licence_key(data["licenses"]) != licence_key(
                merged["licenses"]):
            raise ValueError(f"the licences of the source of {image_dir} differ from an earlier source's")
        merged["licenses"] = merged["licenses"] or data.get("licenses", [])
        for kind in ("images", "annotations"):
            for item in data[kind]:
                key = (kind, item["id"])
                if key in seen:
                    if seen[key] != item:
                        raise ValueError(f"{kind[:-1]} {item['id']} differs between sources")
                    continue
                seen[key] = item
                merged[kind].append(item)
                if kind == "images":
                    folder[item["id"]] = image_dir
    return merged, folder


def build(data: dict, folder: dict, out: Path, max_side: int, quality: int) -> dict:
    """Write the kept photos of ``data`` (each read from ``folder[image id]``) under ``out`` and return the manifest
    (see the module docstring)."""
    images = kept_images(data, bear_classes())
    out.mkdir(parents=True, exist_ok=True)
    manifest = {"info": {**data.get("info", {}), "subset": "COCO val2017 photos with a BEAR-class box, re-encoded "
                         f"JPEG q{quality}, longest side <= {max_side}; boxes scaled with them"},
                "licenses": data.get("licenses", []), "categories": data["categories"], "images": [],
                "annotations": []}
    for im in images:
        jpeg, scale = reencode(folder[im["id"]] / im["file_name"], max_side, quality)
        (out / im["file_name"]).write_bytes(jpeg)
        keys = ("id", "file_name", "license", "flickr_url", "coco_url", "date_captured")
        manifest["images"].append({**{k: im[k] for k in keys if k in im},
                                   "width": round(im["width"] * scale), "height": round(im["height"] * scale)})
        for a in data["annotations"]:
            if a["image_id"] == im["id"]:
                manifest["annotations"].append({"id": a["id"], "image_id": a["image_id"],
                                                "category_id": a["category_id"], "iscrowd": int(a["iscrowd"]),
                                                "bbox": [round(v * scale, 2) for v in a["bbox"]],
                                                "area": round(a["area"] * scale * scale, 2)})
    (out / MANIFEST).write_text(json.dumps(manifest, indent=0) + "\n", encoding="utf-8")
    return manifest


ATTRIBUTION_HEAD = """# Attribution: real-photo reference (COCO val2017)

The photos in this folder are images of the **COCO 2017 validation set** (val2017; T.-Y. Lin et al., "Microsoft COCO:
Common Objects in Context", ECCV 2014, https://cocodataset.org), not of its training set: the realism benchmark's
detectors were trained on train2017. They are the val2017 images with at least one box of a BEAR class other than
`person`, from these public repositories, which commit val2017 subsets with COCO's own annotations:

{origins}

**The photos have been modified:** re-encoded as JPEG (quality {quality}, longest side at most {max_side} pixels) by
`tools/realism_photos.py`, which also wrote `coco_val2017.json` (their COCO annotations, boxes only, scaled with them).

- **Annotations** (`coco_val2017.json`: boxes, areas, categories): © COCO Consortium, licensed under
  [CC BY 4.0](https://creativecommons.org/licenses/by/4.0/) (COCO terms of use, https://cocodataset.org/#termsofuse).
- **Photos:** each is a Flickr photo under the licence below (COCO's licence id for it; COCO gives no author names:
  the Flickr URL leads to the photo's page and author). COCO's terms: the images are not COCO's; their use must
  abide by the Flickr terms of use and each photo's licence. Photos under no-derivatives (ND) licences are left out
  (re-encoding them could count as altering them). Several are non-commercial (NC) licences: they are shipped here
  for evaluation only, re-encoded and not otherwise edited; keep this attribution wherever they are redistributed,
  and leave out the NC ones where those terms do not fit.

| COCO id | file | licence | Flickr URL |
|---|---|---|---|
"""


def attribution(manifest: dict, origins: list[str], quality: int, max_side: int) -> str:
    """The ``ATTRIBUTION.md`` text of a manifest: sources, licences, one row a photo."""
    lic = {entry["id"]: entry for entry in manifest["licenses"]}
    head = ATTRIBUTION_HEAD.format(origins="\n".join(f"- {o}" for o in origins) or "- (not given)",
                                   quality=quality, max_side=max_side)
    rows = []
    for im in manifest["images"]:
        entry = lic.get(im.get("license"), {"name": "unknown", "url": ""})
        url = entry["url"].replace("\\/", "/")
        rows.append(f"| {im['id']} | `{im['file_name']}` | [{entry['name']}]({url}) | {im.get('flickr_url', '')} |")
    return head + "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Build the set; 0 on success, 2 with one line on a bad file."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", nargs=2, action="append", required=True, metavar=("ANNOTATIONS", "IMAGE_DIR"))
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--origin", action="append", default=[],
                    help="where the sources come from (a repository and commit), one line each in ATTRIBUTION.md")
    ap.add_argument("--quality", type=int, default=90)
    ap.add_argument("--max-side", type=int, default=640)
    args = ap.parse_args(argv)
    try:
        sources = [(read_instances(Path(ann)), Path(d)) for ann, d in args.source]
        data, folder = merge(sources)
        manifest = build(data, folder, args.out, args.max_side, args.quality)
        (args.out / "ATTRIBUTION.md").write_text(attribution(manifest, args.origin, args.quality, args.max_side),
                                                 encoding="utf-8")
    except (OSError, ValueError, KeyError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    size = sum(p.stat().st_size for p in args.out.glob("*.jpg"))
    print(f"wrote {len(manifest['images'])} photos ({size / 1e6:.1f} MB), {len(manifest['annotations'])} boxes, "
          f"{args.out / MANIFEST}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
