"""The hook reference: every hookspec documented (Args/Returns/Called/Call policy), docs/hooks.md up to date;
`benchbot plugins` shows hooks and problems; a broken plugin is reported and skipped."""

from __future__ import annotations

import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

from benchbot.core import hookdoc
from benchbot.core.hookspecs import hookimpl
from benchbot.core.registry import Registry

ROOT = Path(__file__).resolve().parents[1]


def test_every_hook_documented():
    assert hookdoc.undocumented() == []
    assert len(hookdoc.hooks()) >= 13


def test_docs_hooks_md_is_up_to_date():
    assert (ROOT / "docs" / "hooks.md").read_text() == hookdoc.render(), (
        "docs/hooks.md is out of date: run `python -m benchbot.core.hookdoc > docs/hooks.md`")


def test_plugin_infos_list_hooks_and_problems(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad_task\nactions: 3\nobservations: []\n")
    mod = types.ModuleType("fake_plugin")
    mod.benchbot_tasks = hookimpl(lambda: [str(bad), {"name": "good_task", "actions": [], "observations": ["poses"]}])
    reg = Registry(extra_plugins={"fake": mod})
    info = next(p for p in reg.plugins if p.name == "fake")
    assert info.hooks == ["benchbot_tasks"] and info.registers == {"tasks": ["good_task"]}
    assert len(info.problems) == 1 and "bad.yaml: $.actions" in info.problems[0]
    sim = next(p for p in reg.plugins if p.name == "sim_taichi")
    assert "benchbot_robot_backends" in sim.hooks


def test_contract_check_reports_bad_plugin(tmp_path):
    import pytest

    from benchbot.plugins import testing

    mod = types.ModuleType("fake_plugin2")
    mod.benchbot_tasks = hookimpl(lambda: [{"name": "x", "actions": "no"}])
    with pytest.raises(AssertionError, match="'observations' is a required property"):
        testing.check_content_plugin(mod)


def test_a_plugin_whose_commands_fail_is_named_and_the_others_still_register(capsys):
    import pluggy
    import typer

    from benchbot.cli.main import add_plugin_commands
    from benchbot.core.hookspecs import HOOK_CLASSES, hookimpl

    class Broken:
        @hookimpl
        def benchbot_commands(self, app):
            raise RuntimeError("missing dependency")

    class Working:
        @hookimpl
        def benchbot_commands(self, app):
            @app.command("hello")
            def hello() -> None:
                """Say hello."""

    manager = pluggy.PluginManager("benchbot")
    for spec in HOOK_CLASSES:
        manager.add_hookspecs(spec)
    manager.register(Broken(), name="broken_plugin")
    manager.register(Working(), name="working_plugin")
    app = typer.Typer()
    warnings = add_plugin_commands(manager, app)
    assert warnings == ["plugin broken_plugin could not add its commands: RuntimeError('missing dependency')"]
    assert "warning: plugin broken_plugin could not add its commands" in capsys.readouterr().err
    assert [c.name for c in app.registered_commands] == ["hello"]


@pytest.mark.slow
def test_a_misspelt_hook_names_the_plugin_and_the_hook_and_the_others_load(tmp_path):
    # a real third-party plugin found through its entry point: a module and a .dist-info on PYTHONPATH
    (tmp_path / "typo_plugin.py").write_text(
        "from benchbot.core.hookspecs import hookimpl\n\n@hookimpl\ndef benchbot_task():\n    return []\n")
    dist = tmp_path / "benchbot_typo-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: benchbot-typo\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[benchbot]\ntypo = typo_plugin\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path),
               BENCHBOT_ONLY_PLUGINS=os.environ["BENCHBOT_ONLY_PLUGINS"] + ",typo")
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "list", "tasks"], capture_output=True, text=True,
                          env=env, timeout=120)
    assert proc.returncode == 0 and "semantic_slam:passive:ground_truth" in proc.stdout  # the others still load
    warning = [line for line in proc.stderr.splitlines() if "typo" in line]
    assert len(warning) == 1 and "implements unknown hook benchbot_task (did you mean benchbot_tasks?)" in warning[0]


def test_a_robot_backends_hook_that_raises_is_reported_and_the_others_load():
    """Every other hook records a problem and goes on; before, this one took the whole registry down."""
    mod = types.ModuleType("broken_backends")

    def benchbot_robot_backends():
        raise RuntimeError("no GPU driver")

    mod.benchbot_robot_backends = hookimpl(benchbot_robot_backends)
    reg = Registry(extra_plugins={"broken": mod})
    info = next(p for p in reg.plugins if p.name == "broken")
    assert info.problems == ["plugin broken: benchbot_robot_backends() raised RuntimeError('no GPU driver')"]
    assert "sim_taichi" in reg.backend_factories and "carter" in reg.names("robots")


def test_every_hook_says_since_when_and_a_retired_one_warns_its_implementers():
    """Each hook's reference says the version that added it; a hook declared with replaced_by makes pluggy warn,
    when a plugin implementing it is registered, with the name of the hook to implement instead."""
    import pluggy

    from benchbot.core.hookspecs import PROJECT_NAME, declared

    assert all("\nSince:\n    BenchBot " in (fn.__doc__ or "") for _, _, fn in hookdoc.hooks())

    class Hooks:
        @declared("0.1", replaced_by="benchbot_new_thing")
        def benchbot_old_thing(self) -> None:
            """A hook on its way out."""

    assert "Deprecated: implement ``benchbot_new_thing`` instead" in Hooks.benchbot_old_thing.__doc__
    pm = pluggy.PluginManager(PROJECT_NAME)
    pm.add_hookspecs(Hooks)
    plugin = types.ModuleType("old_plugin")
    plugin.benchbot_old_thing = hookimpl(lambda: None)
    with pytest.warns(DeprecationWarning, match="benchbot_old_thing is deprecated: implement benchbot_new_thing"):
        pm.register(plugin)


#: The one setting the recording plugin declares (``benchbot_settings``).
RECORDED_SETTING = "BENCHBOT_RECORDER_EVERY_HOOK"


def recording_plugin(calls: list[str]) -> types.ModuleType:
    """A plugin implementing every hookspec: each implementation records its hook's name in ``calls`` and offers
    nothing (an empty list; an empty dict for ``benchbot_robot_backends``; None for the commands and observers),
    but for ``benchbot_settings``, which declares :data:`RECORDED_SETTING`."""
    from benchbot.core.settings import Setting

    plugin = types.ModuleType("recording_plugin")
    offers: dict[str, object] = {"benchbot_robot_backends": {}, "benchbot_commands": None,
                                 "benchbot_episode_started": None, "benchbot_step": None,
                                 "benchbot_episode_finished": None,
                                 "benchbot_settings": [Setting(RECORDED_SETTING, "1", "a setting of the recorder")]}
    for _, name, _ in hookdoc.hooks():
        setattr(plugin, name, hookimpl(_recorder(calls, name, offers.get(name, []))))
    return plugin


def _recorder(calls: list[str], name: str, offer: object):
    def record() -> object:  # names no argument: pluggy passes it none of the hook's
        calls.append(name)
        return type(offer)(offer) if isinstance(offer, (list, dict)) else offer

    return record


def test_every_hookspec_is_called_by_the_core(make_service, registry):
    """datasette's habit: a hook nobody calls is a promise nobody keeps. A plugin implementing every hookspec, in a
    real run: a registry built with it (content, observation, generator and backend hooks), the CLI adding plugins'
    commands, the asset library, the settings as `benchbot doctor` lists them (its setting shown, owned by it), and
    an episode served and closed with it registered (the observer hooks)."""
    import typer

    from benchbot.cli.main import add_plugin_commands
    from benchbot.core import settings
    from benchbot.packs.assets import asset_library

    calls: list[str] = []
    recorder = recording_plugin(calls)
    reg = Registry(extra_plugins={"recorder": recorder})
    add_plugin_commands(reg.plugin_manager, typer.Typer())
    asset_library(reg.plugin_manager)
    shown = {row["name"]: row for row in settings.effective(reg.plugin_manager)}
    assert shown[RECORDED_SETTING]["owner"] == "recorder" and shown[RECORDED_SETTING]["value"] == "1"
    registry.plugin_manager.register(recorder, name="recorder")
    try:
        service = make_service("semantic_slam:passive:ground_truth", "miniroom:1")
        service.call(service.episode.act, "move_next", {})
        service.close()
    finally:
        registry.plugin_manager.unregister(recorder)
    every = [name for _, name, _ in hookdoc.hooks()]
    assert len(every) >= 14 and "benchbot_settings" in every
    assert sorted(set(every) - set(calls)) == [], "hooks never called by the core"


def test_episode_finished_is_called_once_when_the_service_closes(make_service, registry):
    calls = []

    class Spy:
        @hookimpl
        def benchbot_episode_finished(self, info):
            calls.append(info)

    spy = Spy()
    registry.plugin_manager.register(spy)
    try:
        service = make_service("semantic_slam:passive:ground_truth", "miniroom:1")
        service.call(service.episode.act, "move_next", {})
        service.close()
        service.close()  # idempotent for the hook
    finally:
        registry.plugin_manager.unregister(spy)
    assert calls == [{"steps": 1, "collided": False, "finished": False}]


def test_hooks_are_called_through_pluggy_once_per_plugin_with_wrappers_applied():
    """The registry calls each plugin's content hook through pluggy (plugin_manager.call_each_plugin): a hook
    wrapper sees every call, one per implementing plugin, and each plugin's specs stay attributed to it."""
    calls = []

    class Watcher:
        @hookimpl(wrapper=True)
        def benchbot_tasks(self):
            results = yield
            calls.append(list(results))
            return results

    class Mine:
        @hookimpl
        def benchbot_tasks(self):
            return [{"name": "mine_task", "actions": [], "observations": ["poses"]}]

    reg = Registry(extra_plugins={"mine": Mine(), "watcher": Watcher()})
    implementing = [i.plugin_name for i in reg.plugin_manager.hook.benchbot_tasks.get_hookimpls() if not i.wrapper]
    assert len(calls) == len(implementing) and "mine" in implementing and len(implementing) >= 2
    assert [{"name": "mine_task", "actions": [], "observations": ["poses"]}] in [c[0] for c in calls if c]
    assert reg.entry("tasks", "mine_task").plugin == "mine"
    assert next(p for p in reg.plugins if p.name == "mine").registers == {"tasks": ["mine_task"]}
