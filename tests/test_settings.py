"""BenchBot's settings (``benchbot.core.settings``): one table of the environment variables, the core's and those
plugins declare through ``benchbot_settings``, read through one function, shown by ``benchbot doctor`` with their
effective values and sources."""

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from benchbot.core import settings
from benchbot.core.errors import UsageError

ROOT = Path(__file__).resolve().parents[1]
#: A read of a variable: os.environ.get("X"), os.getenv("X"), os.environ["X"] (but not an assignment to it).
READ = re.compile(r"""os\.(?:environ\.get|getenv)\(\s*["']([A-Z0-9_]+)["']"""
                  r"""|os\.environ\[\s*["']([A-Z0-9_]+)["']\s*\](?!\s*=[^=])""")


#: Shipped code: what users install (the tests and the benchmarks are not).
SHIPPED = [path for folder in ("benchbot", "benchbot_api", "plugins") for path in (ROOT / folder).rglob("*.py")
           if "tests" not in path.parts and "tools" not in path.parts]


def test_every_variable_of_shipped_code_is_in_the_one_table():
    """Every ``BENCHBOT_*`` name written in shipped code is a setting or a limit of the one table that `benchbot
    doctor` shows (before: 35 variables in 5 modules, 15 of them shown)."""
    known = {s.name for s in settings.all_settings()}
    found = {}
    for path in SHIPPED:
        for name in re.findall(r"\bBENCHBOT_[A-Z0-9_]+\b", path.read_text(encoding="utf-8")):
            found.setdefault(name, path.relative_to(ROOT))
    found.pop("BENCHBOT_X", None)  # limits.py's docstrings: "set BENCHBOT_X to raise it"
    assert len(found) > 30
    assert {n: str(p) for n, p in found.items() if n not in known} == {}


def test_no_module_reads_a_setting_but_the_settings_module():
    """Every read of a setting's variable goes through ``settings.get`` (writing one for a child process is fine);
    a limit's only through ``Limit.value`` in limits.py."""
    names = {s.name for s in settings.all_settings()}
    found = []
    for path in SHIPPED:
        if path.name in ("settings.py", "core_settings.py", "limits.py"):
            continue
        for m in READ.finditer(path.read_text(encoding="utf-8")):
            name = m[1] or m[2]
            if name in names:
                found.append(f"{path.relative_to(ROOT)}: {name}")
    assert not found, found


def test_values_defaults_and_sources(monkeypatch):
    monkeypatch.delenv("BENCHBOT_RESULT_LOCATION", raising=False)
    assert settings.get("BENCHBOT_RESULT_LOCATION") == "/tmp/benchbot_result"
    assert settings.source("BENCHBOT_RESULT_LOCATION") == "default"
    monkeypatch.setenv("BENCHBOT_RESULT_LOCATION", "  ")  # blank counts as unset
    assert settings.source("BENCHBOT_RESULT_LOCATION") == "default"
    monkeypatch.setenv("BENCHBOT_RESULT_LOCATION", " /tmp/x.json ")
    assert settings.get("BENCHBOT_RESULT_LOCATION") == "/tmp/x.json"
    assert settings.source("BENCHBOT_RESULT_LOCATION") == "environment"
    monkeypatch.delenv("BENCHBOT_CA_FILE", raising=False)
    assert settings.get("BENCHBOT_CA_FILE") is None and settings.source("BENCHBOT_CA_FILE") == "unset"


def test_doctor_shows_every_setting_with_its_source_and_hides_secrets(monkeypatch):
    from benchbot.cli.main import app

    result = CliRunner().invoke(app, ["doctor", "--no-render", "--json"],
                                env={"BENCHBOT_TOKEN": "s3cret", "BENCHBOT_SIM_STYLE": "primitives"})
    shown = {row["name"]: row for row in json.loads(result.stdout)["settings"]}
    assert set(shown) == {s.name for s in settings.all_settings()}
    assert shown["BENCHBOT_MAX_REPEAT"] == {"name": "BENCHBOT_MAX_REPEAT", "value": "1000 repetitions",
                                            "source": "default", "owner": "core (limits)", "meaning": "batch --repeat",
                                            "problem": None}
    assert shown["BENCHBOT_TOKEN"]["value"] == "***" and "s3cret" not in result.stdout
    assert shown["BENCHBOT_SIM_STYLE"] == {**shown["BENCHBOT_SIM_STYLE"], "value": "primitives", "source": "environment"}
    assert shown["BENCHBOT_TAICHI_ARCH"]["source"] in ("default", "environment")


def _manager(**plugins):
    """A plugin manager with BenchBot's hookspecs and ``plugins`` (name: object) registered, in that order."""
    import pluggy

    from benchbot.core.hookspecs import HOOK_CLASSES, PROJECT_NAME

    pm = pluggy.PluginManager(PROJECT_NAME)
    for hook_class in HOOK_CLASSES:
        pm.add_hookspecs(hook_class)
    for name, plugin in plugins.items():
        pm.register(plugin, name=name)
    return pm


def _declaring(*offered):
    """A plugin whose ``benchbot_settings`` returns ``offered``."""
    from benchbot.core.hookspecs import hookimpl

    class Declaring:
        @hookimpl
        def benchbot_settings(self):
            return list(offered)

    return Declaring()


def test_a_plugin_declares_its_settings_and_the_core_names_it_their_owner(monkeypatch):
    speed = settings.Setting("BENCHBOT_ACME_SPEED", "0.5", "speed of the acme robot", owner="someone else",
                             reader=settings.positive_number)
    home = settings.Setting("ACME_HOME", None, "the acme SDK's own folder", external=True)
    pm = _manager(acme=_declaring(speed, home))
    declared = settings.from_plugins(pm)
    assert declared.problems == ()
    assert [(s.name, s.owner) for s in declared.settings] == [("BENCHBOT_ACME_SPEED", "acme"), ("ACME_HOME", "acme")]
    rows = {row["name"]: row for row in settings.effective(pm)}
    assert rows["BENCHBOT_ACME_SPEED"] == {"name": "BENCHBOT_ACME_SPEED", "value": "0.5", "source": "default",
                                           "owner": "acme", "meaning": "speed of the acme robot", "problem": None}
    monkeypatch.setenv("BENCHBOT_ACME_SPEED", "fast")
    assert settings.effective(pm)[-2]["problem"] == "not a number above 0"
    with pytest.raises(UsageError, match=r"^BENCHBOT_ACME_SPEED='fast' is not a number above 0$"):
        settings.value(speed)
    monkeypatch.setenv("BENCHBOT_ACME_SPEED", " 2.5 ")
    assert settings.value(speed) == 2.5 and settings.source(speed) == "environment"


def test_a_name_declared_twice_or_without_the_prefix_is_left_out_with_one_line_each():
    from benchbot.core.hookspecs import hookimpl

    def setting(name, **kw):
        return settings.Setting(name, None, "a test setting", **kw)

    class Raising:
        @hookimpl
        def benchbot_settings(self):
            raise RuntimeError("no config")

    pm = _manager(first=_declaring(setting("BENCHBOT_SHARED"), setting("BENCHBOT_TOKEN"), setting("ACME_HOME"),
                                   setting("BENCHBOT_SHARED"), setting("benchbot_lower"), "BENCHBOT_TEXT",
                                   setting("BENCHBOT_MAX_REPEAT"), setting("BENCHBOT_FIRST_OWN")),
                  second=_declaring(setting("BENCHBOT_SHARED"), setting("BENCHBOT_SECOND_OWN")),
                  raising=Raising())
    declared = settings.from_plugins(pm)
    assert [(s.name, s.owner) for s in declared.settings] == [
        ("BENCHBOT_SHARED", "first"), ("BENCHBOT_FIRST_OWN", "first"), ("BENCHBOT_SECOND_OWN", "second")]
    assert list(declared.problems) == [
        "plugin first: setting BENCHBOT_TOKEN is declared already, by the core (rename it, or drop the second one)",
        "plugin first: setting ACME_HOME does not start with BENCHBOT_ (name it BENCHBOT_ACME_HOME, or declare "
        "Setting(..., external=True) for another program's variable that the plugin reads)",
        "plugin first: setting BENCHBOT_SHARED is declared already, by the plugin itself (rename it, or drop the "
        "second one)",
        "plugin first: setting name 'benchbot_lower' is not an environment variable name (use BENCHBOT_<WORDS> in "
        "upper case, e.g. BENCHBOT_FIRST_SPEED)",
        "plugin first: benchbot_settings() offered 'BENCHBOT_TEXT', not a benchbot.core.settings.Setting",
        "plugin first: setting BENCHBOT_MAX_REPEAT is declared already, by the core (limits) (rename it, or drop "
        "the second one)",
        "plugin second: setting BENCHBOT_SHARED is declared already, by plugin first (rename it, or drop the second "
        "one)",
        "plugin raising: benchbot_settings() raised RuntimeError('no config')",
    ]
    assert all("\n" not in line for line in declared.problems)


def test_first_party_settings_live_in_their_plugins_and_are_found_by_name():
    """One home per setting: the core's table holds only what the core, the API and the CLI read; the simulator's,
    the worlds' and ROS 2's come from their plugins' ``benchbot_settings`` (before: all in the core's table)."""
    from benchbot.core.core_settings import SETTINGS

    assert {s.owner for s in SETTINGS} == {"core", "api", "cli"}
    owners = {s.name: s.owner for s in settings.all_settings()}
    assert {n: owners[n] for n in ("BENCHBOT_TAICHI_ARCH", "BENCHBOT_TAICHI_THREADS", "BENCHBOT_TAICHI_FULL_POSITIONS",
                                   "BENCHBOT_SIM_STYLE", "BENCHBOT_WORLDS_KEY_FILE", "ROS_DOMAIN_ID",
                                   "BENCHBOT_ROS2_TIME_SCALE")} == {
        "BENCHBOT_TAICHI_ARCH": "sim_taichi", "BENCHBOT_TAICHI_THREADS": "sim_taichi",
        "BENCHBOT_TAICHI_FULL_POSITIONS": "sim_taichi", "BENCHBOT_SIM_STYLE": "worlds",
        "BENCHBOT_WORLDS_KEY_FILE": "worlds", "ROS_DOMAIN_ID": "robot_ros2", "BENCHBOT_ROS2_TIME_SCALE": "robot_ros2"}
    assert settings.problems() == ()
    assert settings.get("BENCHBOT_SIM_STYLE") == "primitives"  # by name, as any code may (conftest.py sets it)
    with pytest.raises(KeyError, match="BENCHBOT_NOBODY_DECLARED is declared neither by the core nor by an enabled"):
        settings.get("BENCHBOT_NOBODY_DECLARED")


def test_a_plugin_reads_its_own_settings_through_its_declarations_even_when_disabled(monkeypatch):
    """sim_taichi builds scenes with the worlds package as a library: with the worlds plugin disabled, its settings
    are nobody's by name, and its code still reads them (through its declarations)."""
    from benchbot_worlds.scene.build import default_style
    from benchbot_worlds.settings import SIM_STYLE

    monkeypatch.setenv("BENCHBOT_DISABLE_PLUGINS", "worlds")
    settings.plugin_settings.cache_clear()
    try:
        assert "BENCHBOT_SIM_STYLE" not in {s.name for s in settings.all_settings()}
        assert settings.get(SIM_STYLE) == "primitives" and default_style() == "primitives"
    finally:
        monkeypatch.delenv("BENCHBOT_DISABLE_PLUGINS")
        settings.plugin_settings.cache_clear()


def test_the_sandbox_passes_on_the_settings_of_its_allow_list():
    """The sandbox's allow-list keeps BENCHBOT_TAICHI_THREADS (a batch worker's share of the cores reaches its
    solution's simulator-side libraries): each BENCHBOT_ name there is a declared setting, now a plugin's."""
    from benchbot.solutions.sandbox import ENV_ALLOWED, sandbox_environment

    declared = {s.name for s in settings.all_settings()}
    allowed = [name for name in ENV_ALLOWED if name.startswith(settings.PREFIX)]
    assert allowed == ["BENCHBOT_TAICHI_THREADS"] and set(allowed) <= declared
    assert sandbox_environment({"BENCHBOT_TAICHI_THREADS": "2", "BENCHBOT_WORLDS_KEY_FILE": "/k"}) == {
        "BENCHBOT_TAICHI_THREADS": "2"}


def test_a_third_party_plugin_s_setting_is_read_by_name_and_shown_by_doctor(tmp_path):
    """A real third-party plugin, found through its entry point (a module and a .dist-info on PYTHONPATH), declares
    a setting: ``settings.get`` finds it by name in another process, and the table ``benchbot doctor`` prints
    (``settings.effective``) shows it with its value, source and owner like the core's, and a bad value with why."""
    import os
    import subprocess
    import sys

    (tmp_path / "acme_plugin.py").write_text(
        "from benchbot.core.hookspecs import hookimpl\nfrom benchbot.core.settings import Setting, positive_number\n\n"
        "SPEED = Setting('BENCHBOT_ACME_SPEED', '0.5', 'speed of the acme robot', reader=positive_number)\n\n"
        "@hookimpl\ndef benchbot_settings():\n    return [SPEED]\n")
    dist = tmp_path / "benchbot_acme-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: benchbot-acme\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[benchbot]\nacme = acme_plugin\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path), BENCHBOT_ONLY_PLUGINS="acme", BENCHBOT_ACME_SPEED="1.5")
    read = subprocess.run([sys.executable, "-c", "from benchbot.core import settings; "
                           "print(settings.get('BENCHBOT_ACME_SPEED'), settings.source('BENCHBOT_ACME_SPEED'), "
                           "settings.value('BENCHBOT_ACME_SPEED'))"], capture_output=True, text=True, env=env,
                          timeout=120)
    assert read.returncode == 0 and read.stdout.split() == ["1.5", "environment", "1.5"], read.stderr
    shown = subprocess.run([sys.executable, "-c", "import json; from benchbot.core import settings; "
                            "print(json.dumps([settings.effective(), settings.problems()]))"],
                           capture_output=True, text=True, env=dict(env, BENCHBOT_ACME_SPEED="fast"), timeout=120)
    assert shown.returncode == 0, shown.stderr
    rows, problems = json.loads(shown.stdout)
    assert {row["name"]: row for row in rows}["BENCHBOT_ACME_SPEED"] == {
        "name": "BENCHBOT_ACME_SPEED", "value": "fast", "source": "environment", "owner": "acme",
        "meaning": "speed of the acme robot", "problem": "not a number above 0"}
    assert problems == ["BENCHBOT_ACME_SPEED='fast' is not a number above 0"]  # what `benchbot doctor` shows


def test_doctor_names_a_value_its_reader_rejects():
    """`benchbot doctor` has a `settings` row: a value a setting's reader rejects is one line naming the variable
    (not required: only what reads it fails), and the table says `environment (invalid: ...)`."""
    from benchbot.cli.main import app

    result = CliRunner().invoke(app, ["doctor", "--no-render", "--json"], env={"BENCHBOT_TAICHI_THREADS": "two"})
    report = json.loads(result.stdout)
    check = next(c for c in report["checks"] if c["name"] == "settings")
    assert check["ok"] is False and check["required"] is False
    assert check["detail"] == "BENCHBOT_TAICHI_THREADS='two' is not a whole number of at least 1"
    row = next(r for r in report["settings"] if r["name"] == "BENCHBOT_TAICHI_THREADS")
    assert row["owner"] == "sim_taichi" and row["problem"] == "not a whole number of at least 1"
