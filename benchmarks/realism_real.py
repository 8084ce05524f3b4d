"""The realism benchmark's real-photo reference: a detector's recall in the simulator's frames against its recall on
real photos of the same classes at the same pixel sizes (``benchmarks/realism.py --real-reference``).

The photos are the COCO val2017 images of ``benchmarks/realism/photos`` (``coco_val2017.json``: their COCO boxes;
``ATTRIBUTION.md``: sources and licences; built by ``tools/realism_photos.py``): not in the training set of the COCO
detectors the benchmark runs (train2017). Each photo goes to the detector as it is (no crop or colour change), and
its objects are scored by the rules the simulator's frames are (``realism.score_frame``, at the same score threshold
and IoU): an object counts when its mask has at least ``--min-pixels`` pixels (COCO's ``area``; for the photos whose
boxes come without masks, marked ``area_from_box``, an estimate from the box and its class; a photo's objects have
no truncation figure, so none is applied), and COCO's ``iscrowd`` boxes are crowd regions
(``realism.with_crowd_rule``), as BEAR's group boxes are in the sim column ``fast, crowd rule``, which is the sim
side here. ``--real-drop-border`` also leaves out the photos' objects whose box touches the photo's border, the
nearest stand-in for the sim's truncation rule.

An object's size is the square root of its mask pixels, binned at :data:`SIZE_EDGES`. Per class, the real recall
is weighted to the sim's size mix of that class (the sim's objects per size bin, over the bins where the photos have
boxes of that class; the sim's recall is taken over the same bins); overall, both are weighted to the sim's class ×
size mix over the classes and bins both sides have. Intervals: SciPy's ``stats.bootstrap`` (percentile, 95 %,
:data:`BOOTSTRAP_RESAMPLES` resamples), resampling **images** — the sim's frames and the photos independently, an
image's objects staying together — since objects of one image are not independent; a class's interval is taken over
the resamples that hold it on both sides. Where a side found none or all of a class's objects (in the bins both
sides have), no resample can vary its recall and the percentile interval is a point: there that side's interval is
the exact (Clopper–Pearson) 95 % binomial interval of its counts, SciPy's ``stats.binomtest(...).proportion_ci()``,
and the ratio's interval reaches the quotients of the sides' opposite ends (:func:`boundary_intervals`). Only BEAR
classes are compared (the photos' other COCO classes are
scored, so their detections are no false positives, but not counted).

Each table ends with the goal's verdict for its detector (:func:`goal`): the overall ratio against
:data:`GOAL_RATIO`, the classes whose interval lies wholly below 1, and the classes of both sides the detector found
none of in the sim, each with what the photos' recall would find of its sim objects and the chance it finds none
(:func:`at_photos_rate`), and the most that chance can be when an object's views are found together
(:func:`chance_none_views_together`). ``realism.py --verdict RUN/realism.json ...`` prints it again from finished runs
(:func:`verdict`).
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
PHOTOS = HERE / "realism" / "photos"
MANIFEST = "coco_val2017.json"
#: Bin edges of an object's size, √(mask pixels) in pixels: [20, 32), [32, 64), [64, 128), [128, ∞) at the
#: benchmark's 400-pixel visibility floor (COCO's small/medium split is at 32).
SIZE_EDGES = (32, 64, 128)
SIZE_LABELS = ("<32 px", "32-64 px", "64-128 px", ">=128 px")
#: ``--real-drop-border``: an object whose box comes closer than this to a photo's edge (pixels) is not counted.
BORDER_PX = 1.0
BOOTSTRAP_RESAMPLES = 2000
CONFIDENCE = 0.95
#: The realism goal's bar: sim / real recall overall, at matched class and size, for every detector (:func:`goal`).
GOAL_RATIO = 0.9


@dataclass
class Photo:
    """One reference photo: its ``path``, COCO ``image_id`` and ground truth as ``realism.Truth`` rows."""

    path: Path
    image_id: int
    truths: list


def size_bin(pixels: float) -> int:
    """The size bin (index into :data:`SIZE_LABELS`) of an object with ``pixels`` mask pixels."""
    return int(np.searchsorted(SIZE_EDGES, np.sqrt(float(pixels)), side="right"))


def load_photos(realism, folder: Path = PHOTOS, min_pixels: int = 400, limit: int | None = None,
                drop_border: bool = False) -> list[Photo]:
    """The photos of ``folder`` with their COCO boxes as ``realism.Truth`` (BEAR class names; ``box`` [x1, y1, x2,
    y2] pixels; ``pixels`` the COCO mask area, or its estimate where ``area_from_box``; ``crowd`` COCO's
    ``iscrowd``; ``visible``: ``pixels`` ≥ ``min_pixels`` and, with ``drop_border``, a box at least
    :data:`BORDER_PX` from every edge of the photo: the nearest stand-in for the sim's truncation rule, which COCO's
    boxes cannot give); the first ``limit`` photos only when given.

    Raises:
        realism.RealismError: the manifest or a photo is missing or unreadable.
    """
    from benchbot_task_semslam.coco import COCO_TO_BEAR

    try:
        data = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
        names = {c["id"]: COCO_TO_BEAR.get(c["name"], c["name"]) for c in data["categories"]}
        per_image: dict[int, list] = {im["id"]: [] for im in data["images"]}
        size = {im["id"]: (im["width"], im["height"]) for im in data["images"]}
        for a in data["annotations"]:
            x, y, w, h = a["bbox"]
            W, H = size[a["image_id"]]
            inside = min(x, y, W - x - w, H - y - h) >= BORDER_PX
            per_image[a["image_id"]].append(realism.Truth(
                int(a["id"]), names[a["category_id"]], [x, y, x + w, y + h], int(round(a["area"])), 0.0,
                a["area"] >= min_pixels and (inside or not drop_border), "", bool(a["iscrowd"])))
        photos = [Photo(folder / im["file_name"], int(im["id"]), per_image[im["id"]]) for im in data["images"]]
    except (OSError, ValueError, KeyError) as exc:
        raise realism.RealismError(f"{folder / MANIFEST}: {exc}", "rebuild it with tools/realism_photos.py") from exc
    photos = photos[:limit] if limit is not None else photos
    missing = [p.path.name for p in photos if not p.path.is_file()]
    if missing:
        raise realism.RealismError(f"{folder}: photos missing: {', '.join(missing[:3])}",
                                   "restore benchmarks/realism/photos from the repository")
    return photos


def records(realism, truths: list, detections: list, threshold: float, iou: float,
            object_prefix: str | None = None) -> list[tuple]:
    """``(class, size bin, found)`` of each object of one image counted under COCO's crowd rule, its detections
    (rows ``[x1, y1, x2, y2, score, coco_class]``) matched by ``realism.score_frame`` at ``threshold`` and ``iou``;
    with ``object_prefix``, a fourth element names the object, ``"<object_prefix>#<instance>"``."""
    as_crowd = realism.with_crowd_rule(truths)
    hits = realism.score_frame(as_crowd, detections, threshold, iou, crowd_rule=True).hits
    out = []
    for t in as_crowd:
        if not t.visible:
            continue
        row = (t.cls, size_bin(t.pixels), bool(hits[t.instance]))
        out.append(row if object_prefix is None else (*row, f"{object_prefix}#{t.instance}"))
    return out


def bear_classes() -> frozenset[str]:
    """BEAR's class names (``BEAR_CLASS_LIST`` less ``background``)."""
    from benchbot_worlds.scene.build import BEAR_CLASS_LIST

    return frozenset(BEAR_CLASS_LIST) - {"background"}


def photo_records(realism, detector, photos: list[Photo], threshold: float, iou: float,
                  detections: dict | None = None) -> list[list]:
    """Per photo, :func:`records` of its BEAR-class objects against the ``detector``'s detections on it
    (``detector=None``: none, every object missed, for the smoke run); each photo's detections also go into
    ``detections`` (COCO image id → rows) when given."""
    from PIL import Image

    keep = bear_classes()
    out = []
    for p in photos:
        with Image.open(p.path) as im:
            rgb = np.asarray(im.convert("RGB"))
        dets = detector.detect(rgb) if detector is not None else []
        if detections is not None:
            detections[p.image_id] = dets
        out.append([r for r in records(realism, p.truths, dets, threshold, iou) if r[0] in keep])
    return out


def sim_records(realism, sections: dict, threshold: float, iou: float, mode: str = "fast",
                only_with: str | None = None) -> list[list]:
    """Per frame of ``realism.judge_environment``'s sections, :func:`records` of its objects and its ``mode``
    ("fast" or "quality") detections (frames without detections: every object missed), each with the object it
    views as a fourth element, ``"<environment>#<instance>"`` (one object seen in several frames); ``only_with`` a
    mode: only the frames that were also rendered and detected in that mode (the quality frames are the first
    ``--quality-frames`` of each environment)."""
    out = []
    for env, section in sections.items():
        for fr in section["frames"]:
            if only_with is not None and f"detections_{only_with}" not in fr:
                continue
            truths = [realism.Truth(**o) for o in fr["objects"]]
            out.append(records(realism, truths, fr.get(f"detections_{mode}", []), threshold, iou, object_prefix=env))
    return out


def count_table(per_image: list[list], classes: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """``(objects, found)``: int arrays (images, classes, size bins) of :func:`records` lists (a row's elements
    after the third, :func:`sim_records`' object, are not read)."""
    index = {c: k for k, c in enumerate(classes)}
    n = np.zeros((len(per_image), len(classes), len(SIZE_LABELS)), np.int64)
    h = np.zeros_like(n)
    for i, rows in enumerate(per_image):
        for cls, b, found, *_ in rows:
            if cls in index:
                n[i, index[cls], b] += 1
                h[i, index[cls], b] += int(found)
    return n, h


def weighted(ns, hs, nr, hr) -> np.ndarray:
    """Sim recall, real recall and their ratio per class, then overall (rows 3·classes + 3), from summed counts
    ``(..., classes, bins)`` of sim objects/found ``ns``/``hs`` and real ``nr``/``hr`` (any leading batch axes; NaN
    where undefined, ∞ for a ratio over a real recall of 0). Per class: the bins where the photos have objects,
    the real recall weighted by the sim's objects per bin; overall: every class and bin both have, weighted by the
    sim's objects per (class, bin)."""
    both = (nr > 0) & (ns > 0)
    w = np.where(both, ns, 0).astype(np.float64)
    real_cell = np.divide(hr, nr, out=np.zeros(hr.shape, np.float64), where=nr > 0)
    hs_in = np.where(both, hs, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        sim_c = hs_in.sum(-1) / w.sum(-1)
        real_c = (w * real_cell).sum(-1) / w.sum(-1)
        sim_all = hs_in.sum((-1, -2)) / w.sum((-1, -2))
        real_all = (w * real_cell).sum((-1, -2)) / w.sum((-1, -2))
        ratio_c, ratio_all = sim_c / real_c, sim_all / real_all
    return np.concatenate([np.moveaxis(a, -1, 0) for a in (sim_c, real_c, ratio_c)]
                          + [a[None] for a in (sim_all, real_all, ratio_all)], axis=0)


def intervals(ns, hs, nr, hr, seed: int, resamples: int) -> tuple[np.ndarray, np.ndarray]:
    """Ends of the 95 % intervals of :func:`weighted`'s rows, from per-image counts ``(images, classes, bins)`` of
    sim objects/found ``ns``/``hs`` and real ``nr``/``hr``: SciPy's ``stats.bootstrap`` resampling the sim's images
    and the photos independently (percentile method), each end taken over the resamples where the figure is
    defined (a class in both resamples) as the outer order statistic, so that an unbounded ratio reads ∞."""
    from scipy import stats

    def statistic(i, j, axis=-1):
        i, j = i.astype(np.int64), j.astype(np.int64)
        return weighted(ns[i].sum(-3), hs[i].sum(-3), nr[j].sum(-3), hr[j].sum(-3))

    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # resamples without a class: NaN there, and SciPy's own interval NaN
        res = stats.bootstrap((np.arange(ns.shape[0]), np.arange(nr.shape[0])), statistic, paired=False,
                              vectorized=True, n_resamples=resamples, batch=50, method="percentile",
                              confidence_level=CONFIDENCE, random_state=seed)
        tail = 100 * (1 - CONFIDENCE) / 2
        low = np.nanpercentile(res.bootstrap_distribution, tail, axis=-1, method="lower")
        high = np.nanpercentile(res.bootstrap_distribution, 100 - tail, axis=-1, method="higher")
    return low, high


def boundary_intervals(k_sim: int, n_sim: int, k_real: int, n_real: int, sim: list, real: list, ratio: list,
                       confidence: float = CONFIDENCE) -> dict:
    """Intervals where the bootstrap cannot give one: a side that found none or all of its ``n`` objects (``k`` = 0
    or ``n``, counted in the bins both sides have) recalls the same in every resample, so its percentile interval
    is a point. Such a side's ``[low, high]`` (lists of floats, changed in place) widens to the exact Clopper–Pearson
    interval of ``k`` of ``n`` (SciPy's ``stats.binomtest(k, n).proportion_ci(confidence)``), and the ratio's to
    ``[sim low / real high, sim high / real low]`` (∞ over a real low of 0; 0/0 counts as 0). Returns the interval
    method of each figure: ``{"sim": "bootstrap" | "clopper-pearson", "real": …, "ratio": "bootstrap" |
    "bounds of the sides"}``."""
    from scipy import stats

    methods = {"sim": "bootstrap", "real": "bootstrap", "ratio": "bootstrap"}
    for name, k, n, ends in (("sim", k_sim, n_sim, sim), ("real", k_real, n_real, real)):
        if n > 0 and k in (0, n):
            ci = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
            ends[0], ends[1] = min(ends[0], ci.low), max(ends[1], ci.high)
            methods[name] = "clopper-pearson"
    if "clopper-pearson" in (methods["sim"], methods["real"]):
        low = sim[0] / real[1] if real[1] > 0 else 0.0
        high = sim[1] / real[0] if real[0] > 0 else (np.inf if sim[1] > 0 else 0.0)
        ratio[0], ratio[1] = min(ratio[0], low), max(ratio[1], high)
        methods["ratio"] = "bounds of the sides"
    return methods


def photo_rate(found_real, n_real) -> np.ndarray:
    """The photos' recall per class and size bin, float array ``(classes, bins)`` from int counts of the same shape
    (found ``found_real`` of ``n_real`` objects); 0 in a bin without photo objects. Raises nothing."""
    return np.divide(found_real, n_real, out=np.zeros(np.shape(found_real), np.float64), where=np.asarray(n_real) > 0)


def at_photos_rate(n_sim, found_real, n_real) -> tuple[np.ndarray, np.ndarray]:
    """What the sim's objects would give if the detector found them at the photos' rate, per class, from summed
    counts ``(classes, bins)`` (int arrays: the sim's objects in the bins both sides have ``n_sim``, the photos'
    found ``found_real`` and objects ``n_real``): ``(expected, chance_none)``, float arrays ``(classes,)`` of the
    objects expected found, Σ over bins of the sim's objects × the photos' recall in that bin, and the chance of
    finding none, Π (1 − the photos' recall)^(the sim's objects), as if each view were found independently (the
    views of one object in several frames are not, which makes none likelier still). A class the sim found none of
    with ``chance_none`` well above 0.05 is what a world exactly as findable as the photos would give too. A bin
    without photo objects counts none of the sim's. Raises nothing."""
    rate = photo_rate(found_real, n_real)
    n = np.where(n_real > 0, n_sim, 0)
    return (n * rate).sum(-1), np.prod((1.0 - rate) ** n, axis=-1)


def chance_none_views_together(object_bins: list[list[int]], rate: np.ndarray) -> float:
    """The most the chance of finding none of a class's sim objects can be at the photos' rate when the views of one
    object are found together, however closely: ``object_bins`` lists each object's views (their size bins, ints
    indexing ``rate``, the class's photo recall per bin, float ``(bins,)``: :func:`photo_rate`). An object none of
    whose views is found has a chance of at most 1 − the largest of its views' rates (the Fréchet–Hoeffding upper
    bound of the views' joint miss; reached when one draw decides them all), objects independent: Π over objects
    (1 − max rate). Where an object's views are found together more often than apart, :func:`at_photos_rate`'s
    ``chance_none`` (views independent) is the least it can be, and the two bound it. Raises nothing."""
    return float(np.prod([1.0 - max(float(rate[b]) for b in bins) for bins in object_bins if bins]))


def _object_bins(sim: list[list], cls: str) -> list[list[int]] | None:
    """Each sim object of ``cls``: its views' size bins, from :func:`sim_records` rows; None when a row names no
    object (rows of :func:`records`)."""
    views: dict[str, list[int]] = {}
    for rows in sim:
        for row in rows:
            if row[0] == cls:
                if len(row) < 4:
                    return None
                views.setdefault(row[3], []).append(row[1])
    return list(views.values())


def compare(sim: list[list], real: list[list], seed: int = 0, resamples: int = BOOTSTRAP_RESAMPLES) -> dict:
    """Per class and overall: sim and real recall, their ratio (:func:`weighted`), each with a bootstrap interval
    (images resampled, see the module docstring; an exact one where a side found none or all,
    :func:`boundary_intervals`; ``"interval"`` names which), and the objects and objects found on each side (all sizes,
    unweighted). Classes: those with objects on both sides; the others are listed with their counts only. Each
    class's ``at_photos_rate`` holds :func:`at_photos_rate`'s figures and, where ``sim`` rows name their objects
    (:func:`sim_records`), :func:`chance_none_views_together` (``"chance_none_views_together"``, else None)."""
    seen_sim = {row[0] for rows in sim for row in rows}
    seen_real = {row[0] for rows in real for row in rows}
    classes = sorted(seen_sim & seen_real)
    ns, hs = count_table(sim, classes)
    nr, hr = count_table(real, classes)
    point = weighted(ns.sum(0), hs.sum(0), nr.sum(0), hr.sum(0))
    if classes and len(sim) > 1 and len(real) > 1:
        low, high = intervals(ns, hs, nr, hr, seed, resamples)
    else:
        low = high = np.full_like(point, np.nan)
    k = len(classes)

    both = (ns.sum(0) > 0) & (nr.sum(0) > 0)  # (classes, bins) where both sides have objects
    in_both = [np.where(both, a.sum(0), 0) for a in (hs, ns, hr, nr)]  # (classes, bins) counts over those bins

    at_real = at_photos_rate(in_both[1], hr.sum(0), nr.sum(0))
    rate = photo_rate(hr.sum(0), nr.sum(0))

    def together(ci: int, cls: str) -> float | None:
        bins = _object_bins(sim, cls)
        return None if bins is None else chance_none_views_together(bins, rate[ci])

    def entry(rows: tuple[int, int, int], cls: slice | int) -> dict:
        counts = {"objects_sim": int(ns[:, cls].sum()), "found_sim": int(hs[:, cls].sum()),
                  "objects_real": int(nr[:, cls].sum()), "found_real": int(hr[:, cls].sum())}
        ends = [[float(low[r]), float(high[r])] for r in rows]
        if not np.isnan(ends).any():
            methods = boundary_intervals(*(int(a[cls].sum()) for a in in_both), *ends)
        else:
            methods = dict.fromkeys(("sim", "real", "ratio"), "bootstrap")
        return {name: {"value": _num(point[r]), "ci95": [_num(e[0]), _num(e[1])], "interval": methods[name]}
                for name, r, e in zip(("sim", "real", "ratio"), rows, ends)} | counts

    out = {"classes": {c: entry((ci, k + ci, 2 * k + ci), ci) | {"at_photos_rate": {
               "expected_found_sim": float(at_real[0][ci]), "chance_none": float(at_real[1][ci]),
               "chance_none_views_together": together(ci, c)}}
               for ci, c in enumerate(classes)},
           "overall": entry((3 * k, 3 * k + 1, 3 * k + 2), slice(None)),
           "only_sim": _counts(sim, seen_sim - seen_real), "only_real": _counts(real, seen_real - seen_sim),
           "images_sim": len(sim), "images_real": len(real), "size_bins": list(SIZE_LABELS),
           "bootstrap": {"method": "percentile", "confidence": CONFIDENCE, "resamples": resamples,
                         "resampled": "images (sim frames and photos, independently)", "seed": seed}}
    out["goal"] = goal(out)
    return out


def goal(result: dict) -> dict:
    """The realism goal (docs/realism.md, *The goal's verdict*) checked on a :func:`compare` result, for its one
    detector: the overall sim / real ratio against :data:`GOAL_RATIO` (``"overall_met"``: its value at least that;
    None where it is undefined), the classes whose ratio interval lies wholly below 1 (``"below_one"``: {class:
    [low, high]}, both ends numbers, the high end under 1), and the classes with objects on both sides that the
    detector found none of in the sim (``"not_found"``: {class: [objects in the sim, found in the photos, objects
    in the photos, objects expected found at the photos' rate, chance of none at that rate with views independent,
    the most that chance can be with each object's views found together]}, the last three from
    :func:`at_photos_rate` and :func:`chance_none_views_together`, None in a result written before they were), each
    in the table's order. Raises nothing."""
    ratio = result["overall"]["ratio"]["value"]
    rows = _table_order(result)
    below = {c: v["ratio"]["ci95"] for c, v in rows
             if all(isinstance(e, float) for e in v["ratio"]["ci95"]) and v["ratio"]["ci95"][1] < 1.0}
    none = {c: [v["objects_sim"], v["found_real"], v["objects_real"],
                *(_photos_rate(v.get("at_photos_rate", {})))] for c, v in rows if v["found_sim"] == 0}
    met = None if ratio is None else ratio == "inf" or ratio >= GOAL_RATIO
    return {"ratio_at_least": GOAL_RATIO, "overall_ratio": ratio, "overall_met": met, "below_one": below,
            "not_found": none}


def _num(v) -> float | str | None:
    """A strict-JSON value of a figure: ``None`` for NaN (undefined), ``"inf"`` for ∞ (a ratio over a real recall
    of 0)."""
    v = float(v)
    return None if np.isnan(v) else "inf" if np.isinf(v) else v


def _counts(per_image: list[list], classes: set[str]) -> dict:
    """Objects per class of ``classes`` in :func:`records` lists."""
    out: dict[str, int] = {}
    for rows in per_image:
        for c, *_ in rows:
            if c in classes:
                out[c] = out.get(c, 0) + 1
    return dict(sorted(out.items()))


def _cell(v: dict, percent: bool) -> str:
    """``value [low, high]`` of a :func:`compare` figure (percent or a ratio; ``–`` undefined, ``∞`` unbounded;
    ``†`` after an interval not from the bootstrap, :func:`boundary_intervals`)."""
    def fmt(x):
        if x is None:
            return "–"
        if x == "inf":
            return "∞"
        return f"{100 * x:.0f} %" if percent else f"{x:.2f}"
    mark = "" if v.get("interval", "bootstrap") == "bootstrap" else " †"
    return f"{fmt(v['value'])} [{fmt(v['ci95'][0])}, {fmt(v['ci95'][1])}]{mark}"


def _table_order(result: dict) -> list[tuple[str, dict]]:
    """(class, figures) of a :func:`compare` result in the tables' order: most sim objects first, then by name."""
    return sorted(result["classes"].items(), key=lambda kv: (-kv[1]["objects_sim"], kv[0]))


def table(result: dict, title: str) -> str:
    """A Markdown table of :func:`compare`'s result under a ``title`` heading: per class (most sim objects first)
    sim recall, real recall (weighted to the sim's size mix), sim / real, each with its 95 % interval, and the
    objects on each side; then overall; then the classes on one side only."""
    lines = [f"### {title}", "",
             "| class | sim recall | real recall (sim's size mix) | sim / real | found / objects: sim; real |",
             "|---|---|---|---|---|"]
    rows = _table_order(result)
    rows.append(("**all (sim's class × size mix)**", result["overall"]))
    for name, v in rows:
        lines.append(f"| {name} | {_cell(v['sim'], True)} | {_cell(v['real'], True)} | {_cell(v['ratio'], False)} "
                     f"| {v['found_sim']}/{v['objects_sim']}; {v['found_real']}/{v['objects_real']} |")
    for side in ("only_sim", "only_real"):
        if result[side]:
            lines.append(f"\n{side.replace('_', ' ')}: " + ", ".join(f"{c} {n}" for c, n in result[side].items()))
    lines.append("\n" + goal_line(result["goal"]))
    lines.append(f"\n{result['images_sim']} sim frames, {result['images_real']} photos; intervals: 95 % percentile "
                 f"bootstrap, {result['bootstrap']['resamples']} resamples of images; † where a side found none or "
                 "all of its objects (no resample varies it): that side's exact binomial (Clopper–Pearson) 95 % "
                 "interval, and for the ratio the quotients of the sides' opposite ends.")
    return "\n".join(lines) + "\n"


def _photos_rate(entry: dict) -> tuple[float | None, float | None, float | None]:
    """A class's ``at_photos_rate`` entry as ``(expected found, chance of none, its most with an object's views found
    together)``; None for a figure a result was written without."""
    return entry.get("expected_found_sim"), entry.get("chance_none"), entry.get("chance_none_views_together")


def goal_line(g: dict) -> str:
    """One line of :func:`goal`'s verdict for the table: the overall ratio against the bar, the classes wholly below
    1 and those found none of in the sim (with the photos' found / objects beside, and what the photos' rate would
    find of the sim's objects: :func:`at_photos_rate`)."""
    r = g["overall_ratio"]
    overall = "–" if r is None else "∞" if r == "inf" else f"{r:.2f}"
    met = {True: "met", False: "**not met**", None: "undefined"}[g["overall_met"]]
    below = ", ".join(f"{c} [{lo:.2f}, {hi:.2f}]" for c, (lo, hi) in g["below_one"].items()) or "none"
    none = ", ".join(f"{c} 0/{row[0]} (photos {row[1]}/{row[2]}{_at_rate(*row[3:])})"
                     for c, row in g["not_found"].items())
    none = none or "none"
    return (f"goal: sim / real ≥ {g['ratio_at_least']} overall {overall}, {met}; classes wholly below 1: {below}; "
            f"classes of both sides found none of in the sim: {none}")


def _at_rate(expected: float | None = None, chance_none: float | None = None, together: float | None = None) -> str:
    """``; at their rate E expected, P(none) P`` for :func:`goal_line`, then ``, at most Q with an object's views
    found together`` (each part left out for a result without its figures)."""
    if expected is None:
        return ""
    most = "" if together is None else f", at most {together:.2f} with an object's views found together"
    return f"; at their rate {expected:.2f} expected, P(none) {chance_none:.2f}{most}"


def run(realism, args, detector, sections: dict, threshold: float) -> tuple[dict, str]:
    """``realism.py --real-reference``: the photos of ``args.real_photos`` (the first ``args.real_limit``) through
    ``detector`` (``None`` in the smoke run: no detections), compared with the fast frames of ``sections`` at score
    ``threshold``; where frames were also rendered in quality mode (``--quality-frames``), those frames in quality
    mode and, on the same frames, in fast mode, against the same photos (``"quality"`` and ``"fast_same_frames"``
    in the JSON section, two more tables), so that quality mode's ratio is read beside fast mode's on one sample.
    Returns the JSON section and its Markdown tables."""
    import time

    t0 = time.perf_counter()
    photos = load_photos(realism, args.real_photos, args.min_pixels, args.real_limit, args.real_drop_border)
    detections: dict = {}
    real = photo_records(realism, detector, photos, threshold, args.iou, detections)
    sim = sim_records(realism, sections, threshold, args.iou)
    result = compare(sim, real, seed=args.seed, resamples=args.real_resamples)
    result.update({"photos": str(args.real_photos), "photo_detections": detections, "threshold": threshold,
                   "iou": args.iou,
                   "min_pixels": args.min_pixels, "drop_border": args.real_drop_border,
                   "sim_side": "fast frames, COCO's crowd rule"})
    against = (f"against {len(photos)} COCO val2017 photos, recall at score ≥ {threshold}, real weighted to the "
               "sim's size mix" + (", the photos' objects at their border left out" if args.real_drop_border else ""))
    tables = [table(result, f"{args.detector}: sim (fast, crowd rule) {against}")]
    quality = sim_records(realism, sections, threshold, args.iou, "quality", only_with="quality")
    if quality:
        for key, mode, rows in (("quality", "quality", quality),
                                ("fast_same_frames", "fast",
                                 sim_records(realism, sections, threshold, args.iou, "fast", only_with="quality"))):
            result[key] = compare(rows, real, seed=args.seed, resamples=args.real_resamples)
            result[key]["sim_side"] = (f"the {len(quality)} frames rendered in quality mode, {mode} mode, "
                                       "COCO's crowd rule")
            tables.append(table(result[key], f"{args.detector}: sim ({mode}, crowd rule, the {len(quality)} quality "
                                             f"frames) {against}"))
    result["seconds"] = time.perf_counter() - t0
    return result, "\n".join(tables)


def verdict(path: Path) -> str:
    """The goal's verdict (:func:`goal_line`) of a finished ``realism.py --real-reference`` run, read from its
    ``realism.json`` at ``path``, after the path and the run's detector (``realism.py --verdict``).

    Raises:
        ValueError: the file is missing or unreadable, not JSON, or holds no real-photo section.
    """
    try:
        run_json = json.loads(path.read_text())
        line = goal_line(goal(run_json["real_reference"]))
        detector = run_json.get("settings", {}).get("detector", "?")
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
        raise ValueError(f"{path}: not a finished realism.py --real-reference run ({type(e).__name__}: {e})") from e
    return f"{path} ({detector}): {line}"
