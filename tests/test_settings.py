"""BenchBot's settings (``benchbot.core.settings``): one table of the environment variables, read through one
function, shown by ``benchbot doctor`` with their effective values and sources."""

import json
import re
from pathlib import Path

from typer.testing import CliRunner

from benchbot.core import settings

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
        if path.name in ("settings.py", "limits.py"):
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
                                            "source": "default", "owner": "core (limits)", "meaning": "batch --repeat"}
    assert shown["BENCHBOT_TOKEN"]["value"] == "***" and "s3cret" not in result.stdout
    assert shown["BENCHBOT_SIM_STYLE"] == {**shown["BENCHBOT_SIM_STYLE"], "value": "primitives", "source": "environment"}
    assert shown["BENCHBOT_TAICHI_ARCH"]["source"] in ("default", "environment")
