"""Procedural homes against BEAR's data (class histogram, sizes) and built furnished end to end (the benchmark's
smoke mode runs in tests/test_benchmarks_smoke.py)."""

from __future__ import annotations

import collections
import json

import numpy as np
import pytest

from benchbot_worlds.bear import DATA_DIR
from benchbot_worlds.procedural.generator import generate_home
from benchbot_worlds.procedural.objects import (BEAR_CLASS_COUNTS, BEAR_FORMS, BEAR_GROUPS, BEAR_SIZES,
                                                bear_proportions, draw_object, draw_size)


def test_class_counts_and_sizes_are_bears():
    counts = collections.Counter()
    sides = collections.defaultdict(list)
    kinds = collections.defaultdict(list)
    for f in sorted(DATA_DIR.glob("*.json")):
        for o in json.loads(f.read_text())["ground_truth"]["objects"]:
            counts[o["class"]] += 1
            e = np.abs(np.asarray(o["extent"], float))
            sides[o["class"]].append([min(e[:2]), max(e[:2]), e[2]])
            kinds[o["class"], bool(o["isgroup"])].append(sides[o["class"]][-1])
    assert {cls for cls, group in kinds if group} == set(BEAR_GROUPS)  # every class with groups, and only those
    for cls, by_kind in BEAR_GROUPS.items():
        for group, (count, (lo, med, hi)) in by_kind.items():
            v = np.array(kinds[cls, group])
            assert len(v) == count
            np.testing.assert_allclose([v.min(0), np.median(v, 0), v.max(0)], [lo, med, hi], atol=1e-3)
    assert dict(counts) == BEAR_CLASS_COUNTS and sum(counts.values()) == 369
    for cls, (lo, med, hi) in BEAR_SIZES.items():
        v = np.array(sides[cls])
        np.testing.assert_allclose(v.min(0), lo, atol=1e-3)
        np.testing.assert_allclose(np.median(v, 0), med, atol=1e-3)
        np.testing.assert_allclose(v.max(0), hi, atol=1e-3)
    for cls, forms in BEAR_FORMS.items():
        v = np.array(sides[cls])
        below = 0.0
        for top, count, (lo, med, hi) in forms.values():
            w = v[(v[:, 2] > below) & (v[:, 2] <= top)]
            assert len(w) == count
            np.testing.assert_allclose([w.min(0), np.median(w, 0), w.max(0)], [lo, med, hi], atol=1e-3)
            below = top
        assert sum(f[1] for f in forms.values()) == BEAR_CLASS_COUNTS[cls]


def test_laptops_are_drawn_open_and_closed_in_bears_proportion():
    """BEAR has 5 closed and 2 open laptops: 2,100 draws give an open share near 2/7, each size inside its form."""
    rng = np.random.default_rng(0)
    sizes = np.array([draw_size(rng, "laptop") for _ in range(2100)])
    is_open = sizes[:, 2] > 0.1
    assert abs(is_open.mean() - 2 / 7) < 0.03
    for part, form in ((sizes[is_open], "open"), (sizes[~is_open], "closed")):
        lo, _, hi = BEAR_FORMS["laptop"][form][2]
        assert (part >= np.array(lo) - 1e-9).all() and (part <= np.array(hi) + 1e-9).all()


def test_books_are_drawn_single_and_grouped_in_bears_proportion():
    """BEAR has 9 single books and 29 groups (rows and piles): 3,800 draws give a group share near 29/38, each size
    inside its kind's range; other classes are never groups."""
    rng = np.random.default_rng(0)
    draws = [draw_object(rng, "book") for _ in range(3800)]
    group = np.array([g for _, g in draws])
    assert abs(group.mean() - 29 / 38) < 0.03
    sizes = np.array([s for s, _ in draws])
    for part, kind in ((sizes[group], True), (sizes[~group], False)):
        lo, _, hi = BEAR_GROUPS["book"][kind][1]
        assert (part >= np.array(lo) - 1e-9).all() and (part <= np.array(hi) + 1e-9).all()
    assert not any(draw_object(rng, "cup")[1] for _ in range(50))


def test_generated_books_carry_their_group_flag_into_the_ground_truth():
    """The ground truth marks a generated book ``isgroup`` as BEAR's rows and piles are, in about BEAR's share over
    a few homes; no object of another class is a group."""
    books = others = 0
    groups = []
    for seed in range(8):
        for o in generate_home(seed, f"procedural_test_{seed}").variants[0]["ground_truth"]["objects"]:
            if o["class"] == "book":
                books += 1
                groups.append(o["isgroup"])
            else:
                others += o["isgroup"]
    assert books >= 30 and others == 0
    assert 0.55 < np.mean(groups) < 0.95, (books, np.mean(groups))


def test_variant_changes_are_measured_on_bear():
    from benchbot_worlds.procedural.variants import VARIANT_CHANGES, measure_bear_changes

    assert measure_bear_changes() == VARIANT_CHANGES


@pytest.mark.slow
def test_pooled_class_histogram_fits_bears():
    """200 homes' variant-1 objects pooled: chi-square against BEAR's proportions does not reject at 1 %."""
    from scipy.stats import chisquare

    names, p = bear_proportions()
    c = collections.Counter()
    for seed in range(200):
        for o in generate_home(seed, f"procedural_hist_{seed:04d}").variants[0]["ground_truth"]["objects"]:
            c[o["class"]] += 1
    assert set(c) <= set(names)
    obs = np.array([c[k] for k in names])
    assert chisquare(obs, p * obs.sum()).pvalue > 0.01


@pytest.mark.slow
def test_a_generated_home_builds_furnished_and_models_fill_their_cuboids(tmp_path):
    from benchbot.packs.assets import asset_library
    from benchbot.core.seeding import home_seed
    from benchbot_worlds.homes.furnish import PROPORTIONAL_TAG, UNSTRETCHED_CLASSES
    from benchbot_worlds.homes.floorplan import home_files
    from benchbot_worlds.homes.furnish_supports import standing_box
    from benchbot_worlds.homes.furnished import furnish_environment
    from benchbot_worlds.scene.build import build_scene
    from benchbot_worlds.scene.meshes import instance_bounds

    home = generate_home(5, "procedural_test_0005")
    files = []
    for v in home.variants:
        path = tmp_path / f"procedural_test_0005_{v['environment']['variant']}.json"
        path.write_text(json.dumps(v))
        files.append(str(path))
    env = dict(home.variants[0]["environment"], map_path=files[0], home_files=files, style="furnished")
    scene = build_scene(env, seed=0)
    assert scene.style == "furnished"
    objects = home.variants[0]["ground_truth"]["objects"]
    assert scene.n_boxes == len(objects)
    furnished = furnish_environment(objects, home_files(env), [], seed=home_seed(env["name"]))
    assert furnished.furnishing.unsupported == []
    by_object: dict[int, list] = {}
    for inst in furnished.instances:
        if inst.object_index >= 0:
            by_object.setdefault(inst.object_index, []).append(instance_bounds(inst))
    assert len(by_object) >= 0.9 * len(objects)
    library = asset_library()
    proportional = {p.object_index for p in furnished.furnishing.placements
                    if p.mesh is None and PROPORTIONAL_TAG in library.get(p.asset_id).tags}
    checked = 0
    for i, bounds in by_object.items():
        lo = np.min([b[0] for b in bounds], axis=0)
        hi = np.max([b[1] for b in bounds], axis=0)
        c, e = np.asarray(objects[i]["centroid"]), np.asarray(objects[i]["extent"])
        if i in proportional or objects[i]["class"] in UNSTRETCHED_CLASSES:
            # a round clock dial, a bottle: scaled uniformly, inside its cuboid (furnish.proportional_box)
            assert np.all(lo >= c - e / 2 - 1e-4) and np.all(hi <= c + e / 2 + 1e-4), f"object {i}"
            continue
        want_lo, want_hi = standing_box(objects[i], (c - e / 2, c + e / 2))
        np.testing.assert_allclose(lo, want_lo, atol=1e-4, err_msg=f"object {i} {objects[i]['class']}")
        np.testing.assert_allclose(hi, want_hi, atol=1e-4, err_msg=f"object {i} {objects[i]['class']}")
        checked += 1
    assert checked >= 0.8 * len(objects)
