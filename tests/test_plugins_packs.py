"""Content packs: install by path into a tmp data directory, load through the content_packs plugin, and refuse
unsafe, clashing or code-carrying packs with clear errors."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot.packs import content_packs as cp
from benchbot.core.registry import Registry

TASK = "name: counting:passive:ground_truth\nactions: [move_next]\nobservations: [image_rgb, poses]\ndescription: Count.\n"
EVAL = ("name: countq\nvalid_result_formats: [object_map]\nvalid_ground_truth_formats: [object_map_ground_truth]\n"
        "functions:\n  evaluate: countq.evaluate\n")
EVAL_PY = "def evaluate(results, ground_truths):\n    return {'count': float(len(results['results']['objects']))}\n"


pytestmark = pytest.mark.usefixtures("data_dir")  # tests/conftest.py


def make_pack(root: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    return root


def registry() -> Registry:
    """A fresh registry: the built-in content_packs plugin reads the test's data directory."""
    return Registry()


def test_data_dir_respects_xdg(monkeypatch, tmp_path):
    monkeypatch.delenv("BENCHBOT_DATA_DIR")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert cp.data_dir() == tmp_path / "xdg" / "benchbot"


@pytest.mark.slow
def test_install_pack_with_code_and_original_function_paths(tmp_path, data_dir):
    pack = make_pack(tmp_path / "my-pack", {"tasks/count.yaml": TASK, "evaluation_methods/countq.yaml": EVAL,
                                            "evaluation_methods/countq.py": EVAL_PY,
                                            "batches/b.yaml": "name: my_batch\nenvironments: [miniroom:1]\n"})
    with pytest.raises(cp.PackError, match="contains code") as exc:
        cp.install_pack(pack, registry=registry())
    assert "evaluation_methods/countq.yaml: functions.evaluate" in exc.value.details[0]
    assert not (data_dir / "packs" / "my_pack").exists()
    manifest = cp.install_pack(pack, allow_code=True, registry=registry())
    assert manifest["name"] == "my_pack" and (data_dir / "packs" / "my_pack" / cp.MANIFEST).is_file()
    assert not [p for p in (data_dir / "packs").iterdir() if p.name.startswith(".")]  # no temp dirs left
    reg = registry()
    assert "countq" in reg.names("evaluators") and "my_batch" in reg.names("batches")
    assert reg.entry("tasks", "counting:passive:ground_truth").path == data_dir / "packs" / "my_pack" / "tasks" / "count.yaml"
    assert reg.functions("evaluators", "countq")["evaluate"]({"results": {"objects": [1, 2]}}, []) == {"count": 2.0}
    # installing again clashes with itself unless --force; under another name its task and batch are already
    # provided (identical in meaning) while its evaluator clashes: the same file runs another pack's code
    with pytest.raises(cp.PackError, match="already installed"):
        cp.install_pack(pack, allow_code=True, registry=reg)
    cp.install_pack(pack, allow_code=True, force=True, registry=reg)
    with pytest.raises(cp.PackError, match="clashes") as exc:
        cp.install_pack(pack, name="other", allow_code=True, registry=reg)
    details = "\n".join(exc.value.details)
    assert "tasks/count.yaml: task 'counting:passive:ground_truth' is already provided by pack 'my_pack'" in details
    assert ("evaluation_methods/countq.yaml: evaluator 'countq' is already installed by pack 'my_pack' "
            f"({data_dir / 'packs' / 'my_pack' / 'evaluation_methods' / 'countq.yaml'}) and differs only in functions") in details
    cp.uninstall_pack("my_pack")
    assert "countq" not in registry().names("evaluators")


def test_invalid_files_named_with_json_path(tmp_path):
    pack = make_pack(tmp_path / "bad", {"tasks/t.yaml": "name: t\nactions: 3\nobservations: []\n",
                                        "robots/r.yaml": "name: [unclosed\n", "batches/ok.yaml": "name: b\nenvironments: []\n"})
    with pytest.raises(cp.PackError) as exc:
        cp.install_pack(pack, registry=registry())
    details = "\n".join(exc.value.details)
    assert "tasks/t.yaml: $.actions:" in details and "robots/r.yaml: not valid YAML" in details


def test_clash_with_installed_plugin_names_both_sources(tmp_path):
    pack = make_pack(tmp_path / "clash", {"tasks/t.yaml": TASK.replace("counting:passive:ground_truth",
                                                                       "semantic_slam:passive:ground_truth")})
    with pytest.raises(cp.PackError, match="clashes") as exc:
        cp.install_pack(pack, registry=registry())
    assert "tasks/t.yaml: task 'semantic_slam:passive:ground_truth' is already installed by plugin 'task_semslam'" in exc.value.details[0]


def test_symlink_escape_and_path_traversal_rejected(tmp_path, data_dir):
    outside = tmp_path / "secret.yaml"
    outside.write_text(TASK)
    pack = make_pack(tmp_path / "evil", {"batches/b.yaml": "name: b2\nenvironments: [miniroom:1]\n",
                                         "environments/e.yaml": ("name: evil\nvariant: 1\ntype: sim_taichi\n"
                                                                 "map_path: ../../secret.json\nstart_pose: [1,0,0,0,0,0,0]\n")})
    os.symlink(outside, pack / "batches" / "link.yaml")
    os.symlink(tmp_path, pack / "tasks")
    with pytest.raises(cp.PackError) as exc:
        cp.install_pack(pack, registry=registry())
    details = "\n".join(exc.value.details)
    assert "batches/link.yaml: symlink to" in details and "leaves the pack" in details
    assert "tasks: symlink" in details
    assert "environments/e.yaml: $.map_path: '../../secret.json' leaves the pack" in details
    assert not (data_dir / "packs").exists() or not any((data_dir / "packs").iterdir())
    absolute = make_pack(tmp_path / "abs", {"environments/e.yaml": ("name: evil\nvariant: 1\ntype: sim_taichi\n"
                                                                     "map_path: /etc/passwd\nstart_pose: [1,0,0,0,0,0,0]\n")})
    with pytest.raises(cp.PackError) as exc:
        cp.install_pack(absolute, registry=registry())
    assert "absolute path '/etc/passwd' is not allowed" in exc.value.details[0]


@pytest.mark.slow
def test_examples_need_allow_code(tmp_path):
    pack = make_pack(tmp_path / "ex", {"examples/e.yaml": "name: pack_hello\nnative_command: python hello.py\n",
                                       "examples/hello.py": "print('hi')\n"})
    with pytest.raises(cp.PackError, match="--allow-code|contains code"):
        cp.install_pack(pack, registry=registry())
    cp.install_pack(pack, allow_code=True, registry=registry())
    entry = registry().entry("examples", "pack_hello")
    assert entry.path.parent.name == "examples" and "packs" in entry.path.parts


@pytest.mark.slow
def test_cli_install_reports_each_invalid_file(tmp_path):
    pack = make_pack(tmp_path / "bad_cli", {"tasks/t.yaml": "name: t\nactions: 3\nobservations: []\n"})
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "install", str(pack)], capture_output=True, text=True,
                          env={**os.environ, "BENCHBOT_ONLY_PLUGINS": "content_packs"}, timeout=120)
    assert proc.returncode == 3
    assert "tasks/t.yaml: $.actions:" in proc.stderr and "error:" in proc.stderr


def test_installer_command_uses_uv_or_pip(monkeypatch):
    from benchbot.cli.install_cmd import installer_command

    monkeypatch.setenv("BENCHBOT_INSTALLER", "pip")
    assert installer_command("uninstall", ["x"]) == [sys.executable, "-m", "pip", "uninstall", "-y", "x"]
    monkeypatch.setenv("BENCHBOT_INSTALLER", "uv")
    cmd = installer_command("install", ["x"])
    assert cmd[1:] == ["pip", "install", "--python", sys.executable, "x"] or cmd[:3] == [sys.executable, "-m", "pip"]


GAME_ENV = "name: unreal_room\nvariant: 1\ntype: sim_taichi\nmap_path: {map_path}\nstart_pose: [1,0,0,0,0,0,0]\n"


def test_an_unreal_map_path_is_judged_once_normalised(tmp_path, data_dir):
    """``/Game/...`` (an Unreal asset path of the original's environments) was let through by its prefix alone, so
    ``/Game/../../etc/passwd`` passed the "stays inside the pack" check; it is judged once normalised, at install
    and again when the registry loads a hand-edited pack."""
    evil = "/Game/../../etc/passwd"
    pack = make_pack(tmp_path / "unreal", {"environments/e.yaml": GAME_ENV.format(map_path=evil)})
    with pytest.raises(cp.PackError) as exc:
        cp.install_pack(pack, registry=registry())
    assert exc.value.details == [f"environments/e.yaml: $.map_path: '{evil}' leaves /Game/ (it is '/etc/passwd' "
                                 "once normalised)"]
    (pack / "environments" / "e.yaml").write_text(GAME_ENV.format(map_path="/Game/Maps/../Rooms/kitchen"))
    cp.install_pack(pack, registry=registry())
    assert registry().get("environments", "unreal_room:1")["map_path"] == "/Game/Rooms/kitchen"
    installed = data_dir / "packs" / "unreal" / "environments" / "e.yaml"
    installed.write_text(GAME_ENV.format(map_path=evil))  # edited by hand after the install
    reg = registry()
    assert "unreal_room:1" not in reg.names("environments")
    assert any(f"$.map_path: '{evil}' leaves /Game/" in problem for problem in reg.problems.values()), reg.problems
