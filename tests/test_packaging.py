"""Packaging: the six distributions carry what a PyPI page and an install need, share one version, and the core's
wheel and source distribution hold what they should (docs/releasing.md). The wheels installed with pip outside
the workspace, and the lowest versions the declared ranges allow, are run by `.ci/packaging` in CI."""

from __future__ import annotations

import email
import shutil
import subprocess
import sys
import tarfile
import tomllib
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]
PROJECTS = [ROOT] + sorted(p.parent for p in (ROOT / "plugins").glob("*/pyproject.toml"))


def project(folder: Path) -> dict:
    return tomllib.loads((folder / "pyproject.toml").read_text())["project"]


@pytest.mark.parametrize("folder", PROJECTS, ids=lambda p: p.name)
def test_every_distribution_has_what_a_pypi_page_needs(folder):
    meta = project(folder)
    assert (folder / meta["readme"]).is_file() and (folder / "LICENSE").is_file()
    assert meta["license"] and meta["description"] and meta["authors"] and meta["urls"]
    assert "Programming Language :: Python :: 3.11" in meta["classifiers"]
    assert "version" in meta and "dynamic" not in meta  # one source: the version written here


def test_one_version_and_plugins_accept_the_core_they_ship_with():
    import benchbot

    core = project(ROOT)["version"]
    assert {project(p)["version"] for p in PROJECTS} == {core}
    assert benchbot.__version__ == core  # read from the installed metadata, not written twice
    for folder in PROJECTS[1:]:
        (requirement,) = [Requirement(r) for r in project(folder)["dependencies"] if Requirement(r).name == "benchbot"]
        assert requirement.specifier.contains(core), f"{folder.name} does not accept benchbot {core}"


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("uv") is None, reason="needs uv")
def test_the_cores_wheel_and_sdist_hold_the_core(tmp_path):
    subprocess.run(["uv", "build", "--quiet", "--out-dir", str(tmp_path), str(ROOT)], check=True, timeout=600)
    (wheel,) = tmp_path.glob("benchbot-*.whl")
    (sdist,) = tmp_path.glob("benchbot-*.tar.gz")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        metadata = email.message_from_bytes(archive.read(next(n for n in names if n.endswith(".dist-info/METADATA"))))
    assert "benchbot/schemas/task.schema.json" in names and "benchbot_api/__init__.py" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    assert metadata["License-Expression"] == "MIT" and metadata["Description-Content-Type"] == "text/markdown"
    assert "uv run benchbot batch" in metadata.get_payload()  # the README is the page
    with tarfile.open(sdist) as archive:
        top = {Path(n).parts[1] for n in archive.getnames() if len(Path(n).parts) > 1}
    assert top - {".gitignore"} == {"benchbot", "benchbot_api", "schemas", "README.md", "LICENSE", "pyproject.toml", "PKG-INFO"}
    assert sdist.stat().st_size < 2 << 20  # the core alone: no plugins, benchmarks or pictures
