"""`benchbot plugin new`'s templates (package data in ``benchbot/plugins/scaffold_templates/``): for every kind, each
file of the project is filled in completely and is valid for its type (Python compiles, YAML and TOML parse). The
built project is installed and tested end to end in ``test_plugins_e2e.py``."""

import re
import tomllib

import pytest
import yaml

from benchbot.plugins.scaffold import KINDS, TEMPLATES, project_files


@pytest.mark.parametrize("kind", KINDS)
def test_every_file_of_a_project_is_filled_in_and_valid(kind):
    files = project_files(kind, "lidar_noise")
    assert "pyproject.toml" in files and "tests/test_contract.py" in files
    for rel, text in files.items():
        assert not re.search(r"\$\{[a-z_]+\}", text), f"{rel}: a placeholder was left unfilled"
        if rel.endswith(".py"):
            compile(text, rel, "exec")
        elif rel.endswith((".yaml", ".yml")):
            assert isinstance(yaml.safe_load(text), dict), rel
        elif rel.endswith(".toml"):
            tomllib.loads(text)
    assert tomllib.loads(files["pyproject.toml"])["project"]["name"] == f"benchbot-{kind}-lidar-noise"


def test_every_template_file_is_used():
    import benchbot.plugins.scaffold as scaffold

    source = open(scaffold.__file__, encoding="utf-8").read()
    names = [p.name.removesuffix(".tmpl") for p in TEMPLATES.glob("*.tmpl")]
    assert len(names) >= 18 and all(f'"{n}"' in source for n in names)
