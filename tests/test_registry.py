"""The registry: schemas, validation errors with file and JSON path, duplicates, disabling plugins."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import jsonschema
import pytest

from benchbot.core.errors import SpecError
from benchbot.core.hookspecs import hookimpl
from benchbot.core.registry import Registry
from benchbot.core.specs import schema_dir

EXPECTED = {
    "tasks": 6, "formats": 3, "evaluators": 1, "robots": 3, "environments": 10, "ground_truths": 10, "batches": 7,
}


def test_every_schema_is_valid_draft_2020_12():
    schemas = sorted(schema_dir().glob("*.schema.json"))
    assert len(schemas) >= 9
    for path in schemas:
        schema = json.loads(path.read_text())
        assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
        jsonschema.Draft202012Validator.check_schema(schema)


def test_first_party_content_loads_without_problems(registry):
    assert registry.problems == {}
    for kind, count in EXPECTED.items():
        assert len(registry.names(kind)) == count, kind
    assert {"hello_passive", "hello_active", "hello_eval_semantic_slam", "semslam_geometric"} <= set(registry.names("examples"))
    assert "sim_taichi" in registry.backend_factories


def test_environment_strings(registry):
    assert [e["variant"] for e in registry.scenes("miniroom:1:2")] == [1, 2]
    with pytest.raises(SpecError, match="not of the form"):
        registry.scenes("miniroom")
    with pytest.raises(SpecError) as info:
        registry.scenes("minirom:1")
    assert "miniroom:1" in info.value.hint


def _plugin(**hooks):
    module = types.ModuleType("test_plugin")  # a plugin as entry points give them: a module (hashable)
    for name, value in hooks.items():
        setattr(module, name, hookimpl(lambda value=value: value))
    return module


def test_invalid_spec_is_skipped_with_file_and_json_path(tmp_path):
    bad = tmp_path / "bad_task.yaml"
    bad.write_text("name: my_task\nactions: [move_next]\nobservations: [image_rgb, 3]\n")
    broken = tmp_path / "broken.yaml"
    broken.write_text("name: [unclosed\n")
    reg = Registry(extra_plugins={"mine": _plugin(benchbot_tasks=[bad, broken])})
    problems = list(reg.problems.values())
    assert any(str(bad) in p and "$.observations[1]" in p for p in problems), problems
    assert any(str(broken) in p and "not valid YAML" in p for p in problems), problems
    assert "my_task" not in reg.names("tasks")
    assert len(reg.names("tasks")) == 6  # the rest keep working


def test_a_folder_stands_for_the_spec_files_in_it(tmp_path):
    tasks, empty = tmp_path / "tasks", tmp_path / "empty"
    tasks.mkdir(), empty.mkdir()
    (tasks / "b_task.yml").write_text("name: b_task\nactions: [move_next]\nobservations: [poses]\n")
    (tasks / "a_task.json").write_text('{"name": "a_task", "actions": [], "observations": ["poses"]}')
    (tasks / "notes.txt").write_text("not a spec")
    (tasks / "nested").mkdir()
    (tasks / "nested" / "c_task.yaml").write_text("name: c_task\nactions: []\nobservations: [poses]\n")
    reg = Registry(extra_plugins={"mine": _plugin(benchbot_tasks=[tasks, str(empty)])})
    mine = next(p for p in reg.plugins if p.name == "mine")
    assert mine.registers["tasks"] == ["a_task", "b_task"]  # by file name; not recursive; other suffixes ignored
    assert reg.entry("tasks", "b_task").path == (tasks / "b_task.yml").resolve()
    assert mine.problems == [f"{empty}: a folder with no spec files (.yaml, .yml, .json) in it"]


def test_duplicate_name_names_both_plugins():
    dup = {"name": "semantic_slam:passive:ground_truth", "actions": ["move_next"], "observations": ["poses"]}
    reg = Registry(extra_plugins={"copycat": _plugin(benchbot_tasks=[dup])})
    with pytest.raises(SpecError) as info:
        reg.get("tasks", "semantic_slam:passive:ground_truth")
    assert "task_semslam" in info.value.message and "copycat" in info.value.message


def test_disable_plugins(monkeypatch):
    monkeypatch.setenv("BENCHBOT_DISABLE_PLUGINS", "eval_omq")
    reg = Registry()
    assert reg.names("evaluators") == []
    assert [p.status for p in reg.plugins if p.name == "eval_omq"] == ["disabled"]


def test_spec_files_get_their_path(registry):
    entry = registry.entry("tasks", "semantic_slam:passive:ground_truth")
    assert entry.path is not None and Path(entry.spec["_file_path"]) == entry.path


def test_list_tells_every_task_apart(registry):
    """`benchbot list tasks` shows each description's first sentence: no two tasks may share it (the six
    semantic_slam/scd tasks once all began with the same sentence)."""
    from benchbot.cli.list_cmd import first_sentence

    shown = [first_sentence(registry.get("tasks", name).get("description", "")) for name in registry.names("tasks")]
    assert len(shown) >= 6 and len(set(shown)) == len(shown), shown


def test_a_spec_found_valid_is_not_validated_again_and_any_change_is(monkeypatch):
    """``specs.validate`` remembers the specs it found valid (a registry is built again for every command and test):
    the same spec again is not validated again; a changed value, a value of another type (``True`` for ``1``) or
    another schema is, and an invalid spec is refused every time."""
    from benchbot.core import specs

    checked = []
    real = specs.first_error
    monkeypatch.setattr(specs, "first_error", lambda instance, schema: checked.append(schema) or real(instance, schema))
    monkeypatch.setattr(specs, "_SCHEMA_VALID", {})
    monkeypatch.setattr(specs, "_store", None)  # this process's memory only (the store across processes: below)
    batch = {"name": "b", "environments": ["miniroom:1", "house:2"]}
    for _ in range(3):
        specs.validate(json.loads(json.dumps(batch)), "batch", "b.yaml")
    assert checked == ["batch"]
    specs.validate({**batch, "environments": ["miniroom:1", "house:3"]}, "batch", "b.yaml")
    specs.validate({**batch, "description": "x"}, "batch", "b.yaml")
    assert len(checked) == 3
    for bad in ({**batch, "name": True}, {**batch, "environments": []}):
        for _ in range(2):
            with pytest.raises(SpecError, match=r"b\.yaml: \$\."):
                specs.validate(bad, "batch", "b.yaml")
    assert len(checked) == 7
    exact = specs._exact_bytes
    assert exact({"a": 1}) != exact({"a": True}) != exact({"a": 1.0}) != exact({"a": -0.0}) != exact({"a": 0.0})
    assert exact({"a": 1, "b": 2}) != exact({"b": 2, "a": 1}) and exact({1: "x"}) != exact({"1": "x"})
    assert exact([1, [2]]) != exact([1, (2,)]) and exact({"a": "é"}) == exact(json.loads('{"a": "\\u00e9"}'))
    assert exact(sys.intern("name")) == exact("".join(["na", "me"]))  # an interned string as any other

    class Named(str):
        pass

    with pytest.raises(ValueError):  # a subclass of str is not remembered: validated every time
        exact({"a": Named("x")})
    monkeypatch.setattr(specs, "SCHEMA_VALID_MEMO", 2)
    for k in range(5):
        specs.validate({**batch, "name": f"b{k}"}, "batch", "b.yaml")
    assert len(specs._SCHEMA_VALID) <= 2


def test_specs_found_valid_are_remembered_across_processes_by_content(tmp_path, monkeypatch):
    """The registry stores the digests of the specs it found valid in the cache directory (``specs.ValidStore``): a
    later process (a fresh memory and store) validates none of them again, but a changed spec, a changed schema file
    and an invalid spec (never stored) are validated; an unreadable store counts as empty."""
    from benchbot.core import specs

    checked = []
    real = specs.first_error
    monkeypatch.setattr(specs, "first_error", lambda instance, schema: checked.append(schema) or real(instance, schema))
    monkeypatch.setenv("BENCHBOT_CACHE_DIR", str(tmp_path / "cache"))
    store_file = tmp_path / "cache" / specs.VALID_STORE_FILE

    def new_process() -> None:
        monkeypatch.setattr(specs, "_SCHEMA_VALID", {})
        monkeypatch.setattr(specs, "_store", None)
        checked.clear()

    new_process()
    first = Registry()
    assert checked and not first.problems and store_file.is_file()
    stored = json.loads(store_file.read_text())["digests"]
    assert len(stored) == len(checked)
    new_process()
    second = Registry()
    assert checked == [] and not second.problems
    assert {k: set(v) for k, v in second.entries.items()} == {k: set(v) for k, v in first.entries.items()}

    new_process()
    store = specs.valid_store(store_file)
    batch = {"name": "b", "environments": ["miniroom:1"]}
    specs.validate(batch, "batch", "b.yaml")
    store.save()
    new_process()
    store = specs.valid_store(store_file)
    specs.validate(dict(batch), "batch", "b.yaml")
    specs.validate({**batch, "environments": ["miniroom:2"]}, "batch", "b.yaml")
    assert checked == ["batch"]
    for _ in range(2):
        with pytest.raises(SpecError):
            specs.validate({**batch, "environments": []}, "batch", "b.yaml")
    assert len(checked) == 3
    store.save()

    schema = tmp_path / "thing.schema.json"
    schema.write_text(json.dumps({"type": "object", "properties": {"n": {"type": "integer"}}}))
    specs.validate({"n": 1}, schema, "t.yaml")
    store.save()
    schema.write_text(json.dumps({"type": "object", "properties": {"n": {"type": "string"}}}))
    new_process()
    specs._schema_identity.cache_clear()
    specs.validator.cache_clear()
    specs.valid_store(store_file)
    with pytest.raises(SpecError, match=r"t\.yaml: \$\.n"):  # the schema changed: validated again, now invalid
        specs.validate({"n": 1}, schema, "t.yaml")

    store_file.write_text("{not json")
    new_process()
    specs.valid_store(store_file)
    specs.validate(dict(batch), "batch", "b.yaml")
    assert checked == ["batch"]
    monkeypatch.setattr(specs, "_store", None)
