"""World generators through the real registry: names (``<generator>_<split>_<index>``, the short form
``procedural:val:42``), generated batches, and one-line errors for an unknown split, a negative or huge index, a
batch over the limit, and a broken generator — with a small in-memory generator registered as a plugin."""

from __future__ import annotations

import pytest

from benchbot.core.errors import SpecError
from benchbot.core.hookspecs import hookimpl
from benchbot.core.registry import Registry
from benchbot.core.world_generators import MAX_BATCH_HOMES, WorldGenerator, short_form

CLASSES = ["chair", "table", "background"]


class Tiny:
    """Homes with one chair at x = index; variant v moves it by v cm."""

    name = "tiny"
    splits = ("train", "val")

    def __init__(self):
        self.calls = []

    def content(self, kind, split, index):
        self.calls.append((kind, split, index))
        name = f"tiny_{split}_{index}"
        envs, gts = [], []
        for v in (1, 2):
            env = {"name": name, "variant": v, "type": "world", "map_path": f"/nowhere/{name}_{v}.json",
                   "start_pose": [1, 0, 0, 0, 0, 0, 0], "trajectory_poses": [], "object_labels": CLASSES[:-1]}
            envs.append(env)
            gts.append({"environment": {"name": name, "variant": v}, "format": {"name": "object_map_ground_truth"},
                        "ground_truth": {"class_list": CLASSES, "objects": [
                            {"class": "chair", "ID_name": "c", "centroid": [index + v / 100, 0, 0.4],
                             "extent": [0.5, 0.5, 0.8], "isgroup": False}]}})
        if split == "val" and index == 13:
            raise SpecError("home 13 is unlucky", "take another")
        return envs if kind == "environments" else gts

    def describe(self, split):
        return f"tiny {split} homes"


class TinyPlugin:
    def __init__(self, *gens):
        self.gens = list(gens)

    @hookimpl
    def benchbot_world_generators(self):
        return self.gens


@pytest.fixture
def tiny():
    gen = Tiny()
    return gen, Registry(extra_plugins={"tinyworlds": TinyPlugin(gen)})


def test_a_generated_home_resolves_by_name_and_short_form_and_is_made_once(tiny):
    gen, reg = tiny
    assert isinstance(gen, WorldGenerator) and reg.generators["tiny"] is gen
    (env,) = reg.scenes("tiny_val_7:2")
    assert env["name"] == "tiny_val_7" and env["variant"] == 2 and env["type"] == "world"
    assert [e["variant"] for e in reg.scenes("tiny:val:7")] == [1]
    assert [e["variant"] for e in reg.scenes("tiny:val:7:1:2")] == [1, 2]
    gt = reg.ground_truth("tiny_val_7:2")
    assert gt["ground_truth"]["objects"][0]["centroid"][0] == pytest.approx(7.02)
    assert gen.calls.count(("environments", "val", 7)) == 1 and gen.calls.count(("ground_truths", "val", 7)) == 1
    assert reg.entry("environments", "tiny_val_7:1").plugin == "tinyworlds"
    assert "tiny" in next(p for p in reg.plugins if p.name == "tinyworlds").registers["world_generators"]


def test_generated_batches_hold_the_first_homes():
    reg = Registry(extra_plugins={"tinyworlds": TinyPlugin(Tiny())})
    batch = reg.get("batches", "tiny_train_3")
    assert batch["environments"] == ["tiny_train_0:1", "tiny_train_1:1", "tiny_train_2:1"]
    with pytest.raises(SpecError, match=rf"batch 'tiny_train_{MAX_BATCH_HOMES + 1}': .* outside 1..{MAX_BATCH_HOMES}"):
        reg.get("batches", f"tiny_train_{MAX_BATCH_HOMES + 1}")
    with pytest.raises(SpecError, match="batch 'tiny_test_5': generator 'tiny' has no split 'test'"):
        reg.get("batches", "tiny_test_5")


@pytest.mark.parametrize("env_string, message", [
    ("tiny:test:1", "generator 'tiny' has no split 'test'"),
    ("tiny:val:-1", "home index -1 is out of range"),
    ("tiny:val:99999999999", "home index 99999999999 is out of range"),
    ("tiny:val", r"not of the form tiny:SPLIT:INDEX\[:VARIANT...\]"),
    ("tiny:val:x", "the index 'x' is not a whole number"),
    ("tiny:val:13", "home 13 is unlucky"),
    ("tiny_val_7:9", "no environment named 'tiny_val_7:9'"),
])
def test_bad_generated_names_are_one_line_errors(tiny, env_string, message):
    _, reg = tiny
    with pytest.raises(SpecError, match=message) as info:
        reg.scenes(env_string)
    assert "\n" not in info.value.message


def test_other_names_pass_through_and_a_taken_or_bad_generator_is_reported():
    gens = {"tiny": Tiny()}
    assert short_form("miniroom:1:2", gens) == "miniroom:1:2" and short_form("tiny:val:3", gens) == "tiny_val_3:1"

    class Nameless:
        name = "Bad Name"
        splits = ("a",)

        def content(self, kind, split, index):
            return []

        def describe(self, split):
            return ""

    reg = Registry(extra_plugins={"one": TinyPlugin(Tiny()), "two": TinyPlugin(Tiny(), Nameless())})
    assert list(reg.generators) == ["procedural", "tiny"]  # the worlds plugin's, then the first tiny
    problem = reg.problems[("world_generators", "two")]
    assert "world generator 'tiny' is offered by plugins 'one' and 'two'" in problem
    assert "is no WorldGenerator with an alphanumeric name" in problem
    assert reg.scenes("miniroom:1")[0]["name"] == "miniroom"  # the listed environments are unaffected


def test_the_short_form_is_made_canonical_where_runs_and_batches_take_it(tiny):
    from benchbot.batch.runner import parse_env_list
    from benchbot.core.session import resolve_run

    _, reg = tiny
    assert reg.canonical("tiny:val:4:1:2") == "tiny_val_4:1:2" and reg.canonical("miniroom:1") == "miniroom:1"
    assert parse_env_list("tiny:val:4, miniroom:1", None, reg) == ["tiny_val_4:1", "miniroom:1"]
    run = resolve_run(reg, "semantic_slam:passive:ground_truth", "carter", "tiny:val:4")
    assert run.env_string == "tiny_val_4:1"  # the name its results carry (name:variant)
    assert reg.has("ground_truths", "tiny_val_5:2") and not reg.has("ground_truths", "miniroom:77")


def test_generated_entries_are_found_but_never_listed(tiny):
    _, reg = tiny
    listed = reg.names("environments")
    reg.scenes("tiny:val:8")
    assert "tiny_val_8:1" in reg.entries["environments"] and reg.names("environments") == listed
    assert ("ground_truths", "tiny_val_8:2") in reg.generated
    assert not any("tiny_val_8:1" in members for members in reg.ground_truth_sets().values())
