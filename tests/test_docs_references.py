"""The repository's docs stand alone: every ``docs/NAME.md`` its files cite exists, and nothing cites a reference
document or a shared folder outside the repository that its users do not have."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CITED = re.compile(r"docs/([A-Za-z0-9_-]+\.md)")
SOURCES = ("benchbot", "benchbot_api", "plugins", "docs", "tests", "benchmarks", "schemas", "tools")
#: What users lack, spelled in pieces so that this file does not cite it: the folder beside the checkout, and the
#: reference document kept there.
OUTSIDE_MARKERS = ("../" + "shared", "benchbot-" + "reference", "reference " + "§")
#: A citation of a numbered section of a reference users do not have ("reference 5.6", "reference §4").
SECTION_OF_REFERENCE = re.compile(r"\breference (§ ?)?\d+(\.\d+)*\b")
#: A path of this project's development machines: the checkout's folders, root's home, pytest's temporary folders.
MACHINE_PATH = re.compile(r"(?<![\w.])/(work|root|tmp/pytest-of-\w+)/")
#: A mention of this project's development issues, which users do not have ("issue 20", "the issue's targets");
#: another project's public tracker is cited with its name ("qcr/benchbot issues #81").
DEVELOPMENT_ISSUE = re.compile(r"(?i)(?<!/benchbot\s)\b(issues? #?\d+|the issue's\b|\(issue\b)")


def _texts():
    for top in SOURCES:
        for path in (ROOT / top).rglob("*"):
            if path.suffix in (".py", ".md", ".yaml", ".json", ".toml") and ".venv" not in path.parts:
                yield path, path.read_text(errors="replace")
    yield ROOT / "README.md", (ROOT / "README.md").read_text()


def test_every_cited_doc_exists_and_no_file_cites_what_users_lack():
    missing, outside = [], []
    this = Path(__file__).resolve()
    for path, text in _texts():
        if path.resolve() == this:
            continue
        missing += [f"{path.relative_to(ROOT)}: docs/{name}" for name in CITED.findall(text)
                    if not (ROOT / "docs" / name).is_file()]
        outside += [f"{path.relative_to(ROOT)}" for marker in OUTSIDE_MARKERS
                    if marker in text]
        outside += [f"{path.relative_to(ROOT)}: {m.group(0)}" for m in SECTION_OF_REFERENCE.finditer(text)]
    assert missing == [] and outside == [], (missing, outside)


def test_no_file_names_a_developers_machine_or_this_projects_issues():
    """Absolute paths of a development machine and mentions of the project's development issues mean nothing to
    users: every shipped file, doc and test says what it means instead."""
    found = []
    this = Path(__file__).resolve()
    for path, text in _texts():
        if path.resolve() == this or "results" in path.relative_to(ROOT).parts[:2] or path.suffix == ".json":
            continue  # benchmarks/results/ are recorded outputs of the machines they name; .json files are data
        for pattern in (MACHINE_PATH, DEVELOPMENT_ISSUE):
            found += [f"{path.relative_to(ROOT)}: {m.group(0)}" for m in pattern.finditer(text)]
    assert found == [], found
