"""Build the realism benchmark's real-photo reference set from COCO val2017 images and their annotations.

    python tools/realism_photos.py --source ANNOTATIONS.json IMAGE_DIR [--source ...] [--out benchmarks/realism/photos]
        [--quality 90] [--max-side 640]
    python tools/realism_photos.py --extend --box-source LABEL_DIR IMAGE_INFO.json IMAGE_DIR [--box-source ...]
        [--out benchmarks/realism/photos]

Each ``ANNOTATIONS.json`` is a COCO instances file of **val2017** images (the official ``instances_val2017.json`` or
a subset of it; train2017 images are refused: the detectors were trained on them) and its ``IMAGE_DIR`` holds its
images (``file_name``); several sources are merged (an image or box in two of them is kept once). It keeps the
photos with at least one box of a BEAR class other than ``person`` whose licence allows derivatives (no "NoDerivs")
(``benchbot_task_semslam.coco``'s names, ``dining table`` → ``table``), re-encodes them as JPEG (``--quality``,
longest side at most ``--max-side``, boxes and areas scaled with the image) and writes beside them
``coco_val2017.json``: the kept images (COCO id, file name, size, licence id, ``flickr_url``, ``coco_url``), their
boxes of every class (``bbox`` [x, y, w, h] pixels, mask ``area`` pixels, ``iscrowd``, ``category_id``; no
segmentation), COCO's categories and licences, and ``ATTRIBUTION.md``: where they come from (``--origin``, one line a
source) and, per photo, its COCO id, Flickr licence and Flickr URL.

``--extend`` adds photos to the set in ``--out`` whose boxes come without masks: each ``--box-source`` is a folder of
Ultralytics YOLO labels of val2017 (``<12-digit id>.txt``, one line ``class cx cy w h`` a box, the class an index
into the 80 COCO classes in COCO's order, the box's centre and size as fractions of the image; crowd regions left
out), a COCO file whose ``images`` and ``licenses`` give each image's size, licence and URLs (the official
``captions_val2017.json`` does, for all val2017 images) and a folder of the images. Only the images in that folder,
not yet in the set, go through the same filter and re-encoding. A box without a mask gets an estimated ``area``: its
box area times its class's median mask / box area ratio over the set's masked boxes (:func:`area_ratios`), and
``"area_from_box": 1``; its ``id`` is ``BOX_ID_BASE + 1000 × image id + line`` (COCO gives such boxes none). The
photos already in the set are kept byte for byte. Exit code 2 with one line on a bad file.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
from pathlib import Path

from benchbot.core import atomic

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "benchmarks" / "realism" / "photos"
MANIFEST = "coco_val2017.json"
#: A class's mask / box area ratio is its own median where the set holds at least this many masked boxes of it, else
#: the median over every masked box (:func:`area_ratios`).
MIN_RATIO_BOXES = 10
#: Ids of boxes without a COCO annotation (``--extend``) start here, above COCO's own (crowd ids reach 9.0e11).
BOX_ID_BASE = 10**12


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


def read_instances(path: Path, keys: tuple[str, ...] = ("images", "annotations", "categories")) -> dict:
    """A COCO instances file (JSON): an object whose ``keys`` (and ``licenses``, if given) are lists of objects
    (``keys=("images",)`` for a file that only lists images, as ``captions_val2017.json`` does for ``--extend``).

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
    for key in (*keys, "licenses"):
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


def build(data: dict, folder: dict, out: Path, max_side: int, quality: int, write: bool = True,
          origins: list[str] | None = None) -> dict:
    """Write the kept photos of ``data`` (each read from ``folder[image id]``) under ``out`` and return the manifest
    (see the module docstring; ``info.origins``: ``origins``), also written unless ``write`` is false.

    Raises:
        ValueError: an image is not the size its annotations give (checked for all before any is written: its boxes
            would not fit it).
    """
    from PIL import Image

    images = kept_images(data, bear_classes())
    for im in images:  # every image's size before any is written, so that a bad one leaves the set as it was
        with Image.open(folder[im["id"]] / im["file_name"]) as f:
            if tuple(f.size) != (im["width"], im["height"]):
                raise ValueError(f"{folder[im['id']] / im['file_name']}: {f.size[0]}x{f.size[1]} pixels, but its "
                                 f"annotations are of a {im['width']}x{im['height']} image; give the original "
                                 "val2017 image")
    out.mkdir(parents=True, exist_ok=True)
    manifest = {"info": {**data.get("info", {}), "subset": "COCO val2017 photos with a BEAR-class box, re-encoded "
                         f"JPEG q{quality}, longest side <= {max_side}; boxes scaled with them",
                         "origins": origins or []},
                "licenses": data.get("licenses", []), "categories": data["categories"], "images": [],
                "annotations": []}
    for im in images:
        jpeg, scale = reencode(folder[im["id"]] / im["file_name"], max_side, quality)
        atomic.write_bytes(out / im["file_name"], jpeg)
        keys = ("id", "file_name", "license", "flickr_url", "coco_url", "date_captured")
        manifest["images"].append({**{k: im[k] for k in keys if k in im},
                                   "width": round(im["width"] * scale), "height": round(im["height"] * scale)})
        for a in data["annotations"]:
            if a["image_id"] == im["id"]:
                manifest["annotations"].append({"id": a["id"], "image_id": a["image_id"],
                                                "category_id": a["category_id"], "iscrowd": int(a["iscrowd"]),
                                                "bbox": [round(v * scale, 2) for v in a["bbox"]],
                                                "area": round(a["area"] * scale * scale, 2),
                                                **({"area_from_box": 1} if a.get("area_from_box") else {})})
    if write:
        atomic.write_bytes(out / MANIFEST, (json.dumps(manifest, indent=0) + "\n").encode("utf-8"))
    return manifest


def area_ratios(manifest: dict) -> dict[int, float]:
    """{COCO category id: the median of mask ``area`` / box area} over the masked, non-crowd boxes of ``manifest``
    (a COCO instances dict; boxes marked ``area_from_box`` are left out), for every category of it: a category with
    fewer than :data:`MIN_RATIO_BOXES` such boxes takes the median over all of them. Ratios are dimensionless,
    rounded to 4 decimals.

    Raises:
        ValueError: ``manifest`` holds no masked box to measure.
    """
    import statistics

    per: dict[int, list[float]] = {}
    for a in manifest["annotations"]:
        w, h = a["bbox"][2:]
        if not a.get("iscrowd") and not a.get("area_from_box") and w * h > 0:
            per.setdefault(a["category_id"], []).append(a["area"] / (w * h))
    pooled = [r for rs in per.values() for r in rs]
    if not pooled:
        raise ValueError("the set holds no box with a mask area to estimate other boxes' areas from")
    everyone = statistics.median(pooled)
    return {c["id"]: round(statistics.median(per[c["id"]]) if len(per.get(c["id"], [])) >= MIN_RATIO_BOXES
                           else everyone, 4) for c in manifest["categories"]}


def read_yolo_labels(path: Path, width: int, height: int) -> list[tuple[int, list[float]]]:
    """The boxes of one Ultralytics YOLO label file as (COCO80 class index, [x, y, w, h] pixels of a ``width`` ×
    ``height`` image, rounded to 2 decimals), in file order.

    Raises:
        ValueError: a line is not ``class cx cy w h`` with a class in 0–79 and fractions in [0, 1] (the message names
            the file and line).
    """
    boxes = []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        fields = line.split()
        try:
            cls, cx, cy, w, h = int(fields[0]), *(float(v) for v in fields[1:])
            ok = len(fields) == 5 and 0 <= cls < 80 and all(0.0 <= v <= 1.0 for v in (cx, cy, w, h))
        except (ValueError, IndexError):
            ok = False
        if not ok:
            raise ValueError(f"{path}:{n}: not a YOLO label line `class cx cy w h` (class 0-79, fractions 0-1)")
        boxes.append((cls, [round(v, 2) for v in ((cx - w / 2) * width, (cy - h / 2) * height, w * width,
                                                   h * height)]))
    return boxes


def box_source(labels: Path, info: dict, image_dir: Path, categories: list[dict], ratios: dict[int, float],
               known: set[int]) -> dict:
    """A COCO instances dict of the images in ``image_dir`` that ``info`` (a COCO file's ``images`` and
    ``licenses``) names, ``labels`` holds a label file of, and ``known`` (image ids already in the set) does not
    hold: their boxes from the labels (:func:`read_yolo_labels`), each with ``category_id`` by COCO80 name in
    ``categories``, ``iscrowd`` 0, an ``area`` estimated as box area × ``ratios`` (pixels², 2 decimals),
    ``area_from_box`` 1 and an id from :data:`BOX_ID_BASE`.

    Raises:
        ValueError: a label file is malformed or holds more than 1,000 boxes (the ids' room), or ``categories``
            lacks a COCO80 class.
    """
    from benchbot_task_semslam.coco import COCO80

    by_name = {c["name"]: c["id"] for c in categories}
    missing = [n for n in COCO80 if n not in by_name]
    if missing:
        raise ValueError(f"the set's categories lack COCO classes {missing[:3]}: extend a COCO val2017 set")
    images, boxes = [], []
    for im in info["images"]:
        label = labels / f"{Path(im['file_name']).stem}.txt"
        if im["id"] in known or not (image_dir / im["file_name"]).is_file() or not label.is_file():
            continue
        images.append(im)
        rows = read_yolo_labels(label, im["width"], im["height"])
        if len(rows) > 1000:  # the ids below leave room for 1,000 boxes a photo (COCO's most is under 100)
            raise ValueError(f"{label}: {len(rows)} boxes, more than the 1000 a photo may hold; give val2017's labels")
        for k, (cls, bbox) in enumerate(rows):
            cat = by_name[COCO80[cls]]
            boxes.append({"id": BOX_ID_BASE + 1000 * im["id"] + k, "image_id": im["id"], "category_id": cat,
                          "iscrowd": 0, "bbox": bbox, "area": round(bbox[2] * bbox[3] * ratios[cat], 2),
                          "area_from_box": 1})
    return {"licenses": info.get("licenses", []), "categories": categories, "images": images, "annotations": boxes}


def extend(out: Path, sources: list[tuple[Path, Path, Path]], origins: list[str], max_side: int,
           quality: int) -> dict:
    """Add the photos of box-only ``sources`` ((label folder, COCO image-info file, image folder) each;
    :func:`box_source`) to the set in ``out``, which keeps its photos and boxes as they are; its mask / box ratios
    (:func:`area_ratios`) estimate the new boxes' areas. Writes the manifest (``info``: ``area_ratios`` by
    category id, ``origins`` the set's and the new ``origins`` not yet among them) and returns it (``main`` writes
    ``ATTRIBUTION.md`` from it).

    Raises:
        OSError, ValueError: the set or a source cannot be read, or a source is malformed.
    """
    manifest = read_instances(out / MANIFEST)
    ratios = area_ratios(manifest)
    known = {im["id"] for im in manifest["images"]}
    for labels, info_path, image_dir in sources:
        data = box_source(labels, read_instances(info_path, ("images",)), image_dir, manifest["categories"], ratios,
                          known)
        if licence_key(data["licenses"]) != licence_key(manifest["licenses"]):
            raise ValueError(f"{info_path}: its licence list differs from the set's")
        new = build(data, {im["id"]: image_dir for im in data["images"]}, out, max_side, quality, write=False)
        manifest["images"] += new["images"]
        manifest["annotations"] += new["annotations"]
        known |= {im["id"] for im in new["images"]}
    info = {k: v for k, v in manifest.get("info", {}).items() if k not in ("origins", "area_ratios")}
    held = manifest.get("info", {}).get("origins", [])
    manifest["info"] = {**info, "origins": [*held, *(o for o in origins if o not in held)],
                        "area_ratios": {str(k): v for k, v in ratios.items()}}
    atomic.write_bytes(out / MANIFEST, (json.dumps(manifest, indent=0) + "\n").encode("utf-8"))
    return manifest


ATTRIBUTION_HEAD = """# Attribution: real-photo reference (COCO val2017)

The photos in this folder are images of the **COCO 2017 validation set** (val2017; T.-Y. Lin et al., "Microsoft COCO:
Common Objects in Context", ECCV 2014, https://cocodataset.org), not of its training set: the realism benchmark's
detectors were trained on train2017. They are the val2017 images with at least one box of a BEAR class other than
`person`, from these public repositories, which commit val2017 images with COCO's annotations:

{origins}
{box_note}
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


BOX_NOTE = """
The photos whose boxes come from YOLO labels (the last source above; `"area_from_box": 1` on their boxes in
`coco_val2017.json`) have COCO's boxes, as Ultralytics converted COCO's annotations, without masks or crowd regions:
their mask areas are estimates, each box's area times its class's median mask / box area ratio over the photos with
masks (`info.area_ratios`, by COCO category id).
"""


def attribution(manifest: dict, quality: int, max_side: int) -> str:
    """The ``ATTRIBUTION.md`` text of a manifest: its sources (``info.origins``), licences, one row a photo."""
    lic = {entry["id"]: entry for entry in manifest["licenses"]}
    origins = manifest.get("info", {}).get("origins", [])
    estimated = any(a.get("area_from_box") for a in manifest["annotations"])
    head = ATTRIBUTION_HEAD.format(origins="\n".join(f"- {o}" for o in origins) or "- (not given)",
                                   box_note=BOX_NOTE if estimated else "", quality=quality, max_side=max_side)
    rows = []
    for im in manifest["images"]:
        entry = lic.get(im.get("license"), {"name": "unknown", "url": ""})
        url = entry["url"].replace("\\/", "/")
        rows.append(f"| {im['id']} | `{im['file_name']}` | [{entry['name']}]({url}) | {im.get('flickr_url', '')} |")
    return head + "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Build the set; 0 on success, 2 with one line on a bad file."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", nargs=2, action="append", default=[], metavar=("ANNOTATIONS", "IMAGE_DIR"),
                    help="a COCO instances file of val2017 images and their folder (builds a new set)")
    ap.add_argument("--extend", action="store_true",
                    help="add the photos of --box-source to the set in --out, keeping what it holds")
    ap.add_argument("--box-source", nargs=3, action="append", default=[],
                    metavar=("LABEL_DIR", "IMAGE_INFO", "IMAGE_DIR"),
                    help="with --extend: YOLO labels of val2017, a COCO file giving the images' sizes and licences "
                         "(captions_val2017.json), and a folder of images")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--origin", action="append", default=[],
                    help="where the sources come from (a repository and commit), one line each in ATTRIBUTION.md")
    ap.add_argument("--quality", type=int, default=90)
    ap.add_argument("--max-side", type=int, default=640)
    args = ap.parse_args(argv)
    if args.extend != bool(args.box_source) or args.extend == bool(args.source):
        ap.error("give --source (a new set) or --extend with --box-source (add to the set in --out)")
    try:
        if args.extend:
            manifest = extend(args.out, [tuple(map(Path, s)) for s in args.box_source], args.origin,
                              args.max_side, args.quality)
        else:
            data, folder = merge([(read_instances(Path(ann)), Path(d)) for ann, d in args.source])
            manifest = build(data, folder, args.out, args.max_side, args.quality, origins=args.origin)
        atomic.write_bytes(args.out / "ATTRIBUTION.md",
                           attribution(manifest, args.quality, args.max_side).encode("utf-8"))
    except (OSError, ValueError, KeyError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    size = sum(p.stat().st_size for p in args.out.glob("*.jpg"))
    print(f"wrote {len(manifest['images'])} photos ({size / 1e6:.1f} MB), {len(manifest['annotations'])} boxes, "
          f"{args.out / MANIFEST}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
