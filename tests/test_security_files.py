"""Hostile files: content packs that name functions outside the pack (``os:system``), YAML alias bombs,
invalid UTF-8, deep nesting, huge integers and oversized files in `benchbot install`; zip bombs, oversized and deep
results in `benchbot eval`. Each is refused with a one-line error naming the file and the limit, in bounded time
and memory, by the real command in a subprocess."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
import zipfile
from pathlib import Path
from unittest.mock import ANY

import pytest

from benchbot.packs import content_packs as cp
from benchbot.core.errors import ResultsError, SpecError, UsageError
from benchbot.core.evaluation import load_all
from benchbot.core.limits import MAX_RESULTS_BYTES
from benchbot.core.registry import Registry
from benchbot.core.safe_load import parse_json, parse_yaml

sys.path.insert(0, str(Path(__file__).parent))
from cli_in_process import benchbot  # noqa: E402  (commands whose subject is not the process)
from hostile_files import alias_bomb, zip_bomb as raw_zip  # noqa: E402

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
MEASURE = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:]); "
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(p.returncode)")
"""Runs a command and prints its peak resident memory (KiB) as the last stderr line."""

EVIL_FORMAT = "name: evil_fmt\ndescription: shell\nfunctions:\n  create: \"{function}\"\n"
TASK = ("name: evil:passive:ground_truth\nactions: [move_next]\nobservations: [poses]\nresults_format: evil_fmt\n"
        "description: A task whose results format runs shell commands.\n")
ALLOWED = "benchbot_task_semslam.formats:create_object_map"
TOO_DEEP = "lists/objects are nested more than 64 levels deep (set BENCHBOT_MAX_NESTING_DEPTH to raise it)"


@pytest.fixture(autouse=True)
def data_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("BENCHBOT_DATA_DIR", str(tmp_path / "data"))
    return tmp_path / "data"


def make_pack(root: Path, files: dict[str, str | bytes]) -> Path:
    for rel, content in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            (root / rel).write_bytes(content)
        else:
            (root / rel).write_text(content)
    return root


def cli(*args: str, env: dict | None = None, measure: bool = False, timeout: float = 120) -> tuple:
    """``(process, seconds, peak RSS in MiB or None)`` of ``benchbot ARGS`` run as a user would."""
    cmd = [sys.executable, "-c", MEASURE, *BENCHBOT, *args] if measure else [*BENCHBOT, *args]
    start = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "COLUMNS": "200", **(env or {})})
    seconds = time.monotonic() - start
    rss = None
    if measure:
        *lines, last = proc.stderr.rstrip("\n").splitlines()
        rss = int(last) / 1024
        proc.stderr = "\n".join(lines) + "\n"
    return proc, seconds, rss


def one_line_error(proc: subprocess.CompletedProcess) -> str:
    """The single ``error:`` line of a failed command (asserting there is exactly one and no traceback)."""
    assert "Traceback" not in proc.stderr, proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


# --- 1. functions named by packs -------------------------------------------------------------------------------


@pytest.mark.slow
def test_install_refuses_a_format_that_names_os_system(tmp_path, data_dir):
    marker = tmp_path / "ran"
    pack = make_pack(tmp_path / "evil", {"formats/f.yaml": EVIL_FORMAT.format(function="os:system"),
                                         "tasks/t.yaml": TASK})
    proc, _, _ = cli("install", str(pack))
    assert proc.returncode == 3, proc.stderr
    one_line_error(proc)
    assert "  formats/f.yaml: $.functions.create: 'os:system' is neither code in the pack nor in a module of an " \
           "installed plugin's formats/evaluators (allowed: " in proc.stderr
    assert not (data_dir / "packs" / "evil").exists() and not marker.exists()
    registry = Registry()
    for function in ("subprocess:getoutput", "benchbot.core.atomic:write_json", "benchbot_packs.other.x:y"):
        (pack / "formats" / "f.yaml").write_text(EVIL_FORMAT.format(function=function))
        assert f"formats/f.yaml: $.functions.create: '{function}'" in cp.verify_pack(pack, registry=registry).errors[0]  # --dry-run
        with pytest.raises(cp.PackError) as exc:
            cp.install_pack(pack, allow_code=True, registry=registry)
        assert f"formats/f.yaml: $.functions.create: '{function}'" in exc.value.details[0]


def test_a_pack_may_name_installed_plugin_functions_without_allow_code(tmp_path):
    pack = make_pack(tmp_path / "reuse", {"formats/f.yaml": EVIL_FORMAT.format(function=ALLOWED)})
    manifest = cp.install_pack(pack, registry=Registry())
    assert manifest["allow_code"] is False and manifest["code"] == []
    create = Registry().functions("formats", "evil_fmt")["create"]
    assert create()["objects"] == []


def test_hand_edited_pack_cannot_import_os_system_at_load_time(tmp_path, data_dir):
    """A pack installed cleanly, then its format and manifest edited by hand: the registry refuses to import
    os:system, so the server never offers it through POST /results_functions/create."""
    from benchbot.core.session import resolve_run, start_service

    pack = make_pack(tmp_path / "edited", {"formats/f.yaml": EVIL_FORMAT.format(function=ALLOWED),
                                           "tasks/t.yaml": TASK})
    cp.install_pack(pack, registry=Registry())
    installed = data_dir / "packs" / "edited"
    (installed / "formats" / "f.yaml").write_text(EVIL_FORMAT.format(function="os:system"))
    manifest = json.loads((installed / cp.MANIFEST).read_text())
    (installed / cp.MANIFEST).write_text(json.dumps({**manifest, "allow_code": True, "code": []}))
    registry = Registry()
    with pytest.raises(SpecError, match=r"functions.create: 'os:system' is neither code in the pack .*refusing"):
        registry.functions("formats", "evil_fmt")
    run = resolve_run(registry, "evil:passive:ground_truth", "carter", "miniroom:1")
    with pytest.raises(SpecError, match="os:system"):
        start_service(registry, run)  # the results functions are resolved before any backend is built
    # a name imported into an allowed plugin module from elsewhere is refused by where it is defined
    (installed / "formats" / "f.yaml").write_text(
        EVIL_FORMAT.format(function="benchbot_task_semslam.formats:ResultsError"))
    with pytest.raises(SpecError, match="defined in benchbot.core.errors, not in benchbot_task_semslam"):
        Registry().functions("formats", "evil_fmt")


def test_code_added_to_a_pack_installed_without_allow_code_is_not_loaded(tmp_path, data_dir):
    pack = make_pack(tmp_path / "plain", {"formats/f.yaml": EVIL_FORMAT.format(function=ALLOWED)})
    cp.install_pack(pack, registry=Registry())
    installed = data_dir / "packs" / "plain"
    make_pack(installed, {"formats/f.yaml": EVIL_FORMAT.format(function="mine.create"),
                          "formats/mine.py": "import os\ndef create():\n    os.system('true')\n",
                          "examples/e.yaml": "name: pack_sneaky\nnative_command: python run.py\n"})
    registry = Registry()
    assert "pack_sneaky" not in registry.names("examples") and "evil_fmt" not in registry.names("formats")
    problems = "\n".join(registry.problems.values())
    assert "formats/f.yaml: functions.create runs pack code 'mine.create', but pack 'plain' was installed " \
           "without --allow-code" in problems
    assert "examples/e.yaml: example runs 'python run.py' from the pack, but pack 'plain' was installed " \
           "without --allow-code" in problems


# --- 2. spec files: YAML bombs, encodings, nesting, integers, sizes ---------------------------------------------


@pytest.mark.slow
def test_install_refuses_hostile_spec_files_each_in_one_line(tmp_path):
    depth = 20_000
    pack = make_pack(tmp_path / "hostile", {
        "tasks/bomb.yaml": alias_bomb(),
        "tasks/latin1.yaml": "name: caf\xe9\nactions: [move_next]\n".encode("latin-1"),
        "tasks/deep.yaml": "name: deep\nx: " + "[" * depth + "]" * depth + "\n",
        "batches/deep.json": '{"name": "deep", "x": ' + "[" * depth + "]" * depth + "}",
        "batches/bigint.json": '{"name": "big", "environments": [], "x": ' + "9" * 5000 + "}",
        "batches/bigint.yaml": "name: big2\nenvironments: []\nx: " + "9" * 5000 + "\n",
        "batches/huge.yaml": "name: huge\nenvironments: []\n" + "# padding\n" * 7000,
    })
    proc, seconds, _ = cli("install", str(pack), env={"BENCHBOT_ONLY_PLUGINS": "content_packs",
                                                      "BENCHBOT_MAX_SPEC_BYTES": "64K"})
    assert proc.returncode == 3 and seconds < 30, (seconds, proc.stderr)  # the bomb alone took 49 s before
    assert one_line_error(proc).startswith("error: pack 'hostile'") and "7 problem(s)" in proc.stderr
    expected = [
        "tasks/bomb.yaml: YAML aliases (*name) are not allowed in spec files (line 4)",
        "tasks/latin1.yaml: not UTF-8 text (invalid byte 0xe9 at offset 9)",
        f"tasks/deep.yaml: {TOO_DEEP}",
        f"batches/deep.json: {TOO_DEEP}",
        "batches/bigint.json: a number has more than 4300 digits",
        "batches/bigint.yaml: a number has more than 4300 digits",
        "batches/huge.yaml: the file is 68.4 KiB, more than the limit of 64 KiB (set BENCHBOT_MAX_SPEC_BYTES to "
        "raise it)",
    ]
    details = [line.strip() for line in proc.stderr.splitlines() if line.startswith("  ")]
    for text in expected:
        assert text in details, (text, proc.stderr)


def test_parsers_stay_fast_and_bounded():
    start = time.monotonic()
    with pytest.raises(SpecError, match="aliases"):
        parse_yaml("bomb.yaml", alias_bomb(levels=30), SpecError)
    assert time.monotonic() - start < 30.0  # refused, not expanded: 9**30 strings would take longer than any run
    assert parse_yaml("ok.yaml", "a: &x 1\nb: [2, 3]\n", SpecError) == {"a": 1, "b": [2, 3]}  # an unused anchor
    with pytest.raises(SpecError, match="nested more than 3 levels"):
        os.environ["BENCHBOT_MAX_NESTING_DEPTH"] = "3"
        try:
            parse_json("d.json", b'{"a": [[{"b": 1}]]}', SpecError)
        finally:
            del os.environ["BENCHBOT_MAX_NESTING_DEPTH"]
    with pytest.raises(ResultsError, match=r"d.json: not valid JSON \(line 1 column 7"):
        parse_json("d.json", b'{"a": }', ResultsError)


def test_yaml_and_json_count_nesting_levels_alike():
    # 64 lists around a number is within MAX_NESTING_DEPTH (64) in both formats; YAML counted the number as a level
    within, past = "[" * 64 + "1" + "]" * 64, "[" * 65 + "1" + "]" * 65
    assert parse_yaml("ok.yaml", within, SpecError) == parse_json("ok.json", within, SpecError)
    for parse in (parse_yaml, parse_json):
        with pytest.raises(SpecError, match="nested more than 64 levels"):
            parse("deep", past, SpecError)


def test_bad_limit_variables_are_usage_errors(monkeypatch):
    monkeypatch.setenv("BENCHBOT_MAX_RESULTS_BYTES", "lots")
    with pytest.raises(UsageError, match="BENCHBOT_MAX_RESULTS_BYTES='lots' is not a positive whole number of bytes"):
        MAX_RESULTS_BYTES.value()
    monkeypatch.setenv("BENCHBOT_MAX_RESULTS_BYTES", "2M")
    assert MAX_RESULTS_BYTES.value() == 2 << 20


# --- 3. benchbot eval: zip bombs, large and deep results ---------------------------------------------------------


@pytest.mark.slow
def test_eval_refuses_a_zip_bomb_before_decompressing(tmp_path):
    bomb = raw_zip(tmp_path / "bomb.zip", "r.json", 1 << 30)
    assert bomb.stat().st_size < 1_100_000
    proc, seconds, rss = cli("eval", str(bomb), "-o", str(tmp_path / "s.json"), measure=True)
    assert proc.returncode == 4, proc.stderr
    line = one_line_error(proc)
    assert line == (f"error: {bomb}:r.json: the member (decompressed) is 1 GiB, more than the limit of 64 MiB "
                    "(set BENCHBOT_MAX_RESULTS_BYTES to raise it)")
    assert rss < 300, rss  # 2.1 GB before
    assert not (tmp_path / "s.json").exists()


@pytest.mark.slow
def test_eval_counts_decompressed_bytes_when_the_header_lies(tmp_path, monkeypatch):
    liar = raw_zip(tmp_path / "liar.zip", "r.json", 1 << 30, declared=100)
    proc, _, rss = cli("eval", str(liar), "-o", str(tmp_path / "s.json"), measure=True)
    assert proc.returncode == 4 and f"error: {liar}" in one_line_error(proc)
    assert "does not match its header" in one_line_error(proc)  # says why, not only "Bad CRC-32"
    assert rss < 300, rss  # 2 GB before: zipfile inflated all of it before cutting at the declared size
    # the total of the members is capped too, and the number of members
    many = tmp_path / "many.zip"
    with zipfile.ZipFile(many, "w") as z:
        for i in range(6):
            z.writestr(f"r{i}.json", "{}")
    monkeypatch.setenv("BENCHBOT_MAX_ZIP_MEMBERS", "5")
    assert load_all([many]) == ([], [(str(many), ANY)])
    assert load_all([many])[1][0][1].message == (f"{many}: the zip archive has 6 entries, more than the limit of 5 "
                                                 "members (set BENCHBOT_MAX_ZIP_MEMBERS to raise it)")
    monkeypatch.setenv("BENCHBOT_MAX_ZIP_MEMBERS", "6")
    assert len(load_all([many])[0]) == 6
    monkeypatch.setenv("BENCHBOT_MAX_ZIP_BYTES", "300")  # the archive is ~600 bytes on disk
    assert "(set BENCHBOT_MAX_ZIP_BYTES to raise it)" in load_all([many])[1][0][1].message
    monkeypatch.setenv("BENCHBOT_MAX_ZIP_BYTES", "1K")  # small enough on disk; 6 x 2 bytes decompressed
    assert len(load_all([many])[0]) == 6


@pytest.mark.slow
def test_eval_refuses_a_huge_results_file_without_reading_it(tmp_path):
    huge = tmp_path / "huge.json"
    with open(huge, "wb") as f:
        f.truncate(1 << 30)  # sparse: 1 GiB that costs no disk
    proc, seconds, rss = cli("eval", str(huge), "-o", str(tmp_path / "s.json"), measure=True)
    assert proc.returncode == 4
    assert one_line_error(proc) == (f"error: {huge}: the results file is 1 GiB, more than the limit of 64 MiB "
                                    "(set BENCHBOT_MAX_RESULTS_BYTES to raise it)")
    assert rss < 300, rss  # 1.4 GB before (3.2 GB with the registry of a busier host)


def test_eval_refuses_deep_nesting_and_huge_integers_in_one_line(tmp_path):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    bigint = tmp_path / "bigint.json"
    bigint.write_text('{"task_details": ' + "7" * 5000 + "}")
    archive = tmp_path / "deep.zip"
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("deep.json", '{"a": ' + "[" * 70 + "]" * 70 + "}")
    proc = benchbot("eval", "-V", str(deep), str(bigint), str(archive), env={"COLUMNS": "200"})
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    assert [line for line in proc.stderr.splitlines() if not line.startswith("warning:")] == [
        f"error: {deep}: {TOO_DEEP}",
        f"error: {bigint}: a number has more than 4300 digits",
        f"error: {archive}:deep.json: {TOO_DEEP}",
    ]


def test_a_named_pipe_is_refused_not_waited_on(tmp_path):
    from benchbot.core.limits import MAX_SPEC_BYTES
    from benchbot.core.safe_load import read_capped

    fifo = tmp_path / "task.yaml"
    os.mkfifo(fifo)  # nobody ever writes it: opening it normally would block forever
    result: list = []
    reader = threading.Thread(target=lambda: result.append(_refusal(read_capped, fifo, MAX_SPEC_BYTES)), daemon=True)
    reader.start()
    reader.join(10)
    assert not reader.is_alive() and "not a regular file" in result[0]


def _refusal(fn, *args) -> str:
    try:
        fn(*args, SpecError)
    except SpecError as exc:
        return exc.message
    return "accepted"


# --- 4. one bad results file harms only itself ---------------------------------------------------------------


def _perfect(registry, env: str, **kw) -> dict:
    """A perfect results file of ``env`` (a deep copy: its lists are the registry's ground truth's own)."""
    import copy

    from test_evaluation import perfect_results

    return copy.deepcopy(perfect_results(registry, env, **kw))


def test_eval_refuses_numbers_beyond_a_float_naming_file_and_field_and_scores_the_others(registry, tmp_path):
    """A 400-digit integer is valid JSON under the 4,300-digit cap; in a centroid it crashed scoring with
    OverflowError (a traceback, nothing scored), and so did one in the optional yaw with --oriented."""
    big = _perfect(registry, "miniroom:1")
    big["results"]["objects"][2]["centroid"][1] = 10 ** 400
    yaw = _perfect(registry, "house:1")
    yaw["results"]["objects"][0]["yaw"] = -(10 ** 400)
    paths = {name: tmp_path / f"{name}.json" for name in ("big", "yaw", "good")}
    paths["big"].write_text(json.dumps(big))
    paths["yaw"].write_text(json.dumps(yaw))
    paths["good"].write_text(json.dumps(_perfect(registry, "miniroom:2")))
    out = tmp_path / "s.json"
    proc = benchbot("eval", "--oriented", *map(str, paths.values()), "-o", str(out), env={"COLUMNS": "200"})
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    assert [line for line in proc.stderr.splitlines() if line.startswith("error:")] == [
        f"error: {paths['big']}: results.objects[2].centroid[1]: expected a finite number, got an integer of 401 "
        "digits (beyond a float's range, ±1.8e+308)",
        f"error: {paths['yaw']}: results.objects[0].yaw: expected a finite number (radians about +z), got an integer "
        "of 401 digits (beyond a float's range)",
    ]
    assert json.loads(out.read_text())["scores"]["OMQ"] == 1.0  # the good file, scored and written


BUGGY_FORMAT = ("name: buggy_map\ndescription: a validator with a bug\nfunctions:\n  create: buggy.create\n"
                "  validate: buggy.validate\n")
BUGGY_TASK = ("name: buggy:passive:ground_truth\nactions: [move_next]\nobservations: [poses]\n"
              "results_format: buggy_map\ndescription: A task whose format's validator crashes.\n")


def test_a_format_validator_that_crashes_fails_only_its_file(registry, tmp_path):
    pack = make_pack(tmp_path / "buggy", {"formats/buggy.yaml": BUGGY_FORMAT, "tasks/t.yaml": BUGGY_TASK,
                                          "formats/buggy.py": "def create():\n    return {}\ndef validate(results):\n"
                                                              "    raise RuntimeError('boom\\n' + 'x' * 500)\n"})
    proc, _, _ = cli("install", "--allow-code", str(pack))
    assert proc.returncode == 0, proc.stderr
    bad = _perfect(registry, "miniroom:1")
    bad["task_details"] = {"name": "buggy:passive:ground_truth", "results_format": "buggy_map"}
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    (tmp_path / "good.json").write_text(json.dumps(_perfect(registry, "miniroom:1")))
    proc, _, _ = cli("eval", str(tmp_path / "bad.json"), str(tmp_path / "good.json"), "-o", str(tmp_path / "s.json"))
    assert proc.returncode == 4, proc.stderr
    line = one_line_error(proc)
    assert line.startswith(f"error: {tmp_path / 'bad.json'}: results: format 'buggy_map' could not validate it: "
                           "RuntimeError('boom\\nxxx") and line.endswith("...") and len(line) < 400, line
    assert json.loads((tmp_path / "s.json").read_text())["scores"]["OMQ"] == 1.0


@pytest.mark.slow
def test_eval_says_what_a_results_path_is_in_one_line(registry, tmp_path):
    """A folder, a FIFO and /dev/zero were "no such results file"; a text file named .zip and a truncated zip were
    "not valid JSON". Each is now said for what it is, and the FIFO is never opened (no writer ever comes)."""
    folder = tmp_path / "results"
    folder.mkdir()
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    cases = [(folder, f"error: {folder}: a folder, not a results file"),
             (fifo, f"error: {fifo}: a named pipe (FIFO), not a results file"),
             (Path("/dev/zero"), "error: /dev/zero: a character device, not a results file")]
    for path, expected in cases:
        proc, seconds, _ = cli("eval", str(path), "-o", str(tmp_path / "s.json"), timeout=60)
        assert proc.returncode == 4 and one_line_error(proc) == expected and seconds < 30, (proc.stderr, seconds)
    fake = tmp_path / "x.zip"
    fake.write_text("hello, not a zip")
    good = tmp_path / "good.json"
    good.write_text(json.dumps(_perfect(registry, "miniroom:1")))
    real = tmp_path / "real.zip"
    with zipfile.ZipFile(real, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(good, "r.json")
    truncated = tmp_path / "truncated.zip"
    truncated.write_bytes(real.read_bytes()[: real.stat().st_size // 2])
    proc, _, _ = cli("eval", str(fake), str(truncated), str(good), "-o", str(tmp_path / "s.json"))
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    assert [line for line in proc.stderr.splitlines() if line.startswith("error:")] == [
        f"error: {fake}: not a zip archive, though named .zip (it starts with b'hell')",
        f"error: {truncated}: a damaged zip archive (it starts as one but has no end-of-archive record: truncated?)",
    ]
    assert json.loads((tmp_path / "s.json").read_text())["scores"]["OMQ"] == 1.0


# --- 5. code of installed packs: only what the user allowed at install ----------------------------------------

PLANTED_PY = ("import pathlib\npathlib.Path({marker!r}).write_text('imported')\n"
              "def create():\n    return {{'planted': True}}\n")


def test_allow_code_written_into_an_installed_manifest_by_hand_imports_nothing(tmp_path, data_dir):
    """A pack installed without --allow-code, then its manifest edited to ``allow_code: true`` and a .py dropped
    in (what a program running as the user could plant): before, the registry imported it."""
    marker = tmp_path / "imported"
    pack = make_pack(tmp_path / "plain2", {"formats/f.yaml": EVIL_FORMAT.format(function=ALLOWED)})
    proc, _, _ = cli("install", str(pack))
    assert proc.returncode == 0, proc.stderr
    installed = data_dir / "packs" / "plain2"
    manifest = json.loads((installed / cp.MANIFEST).read_text())
    (installed / cp.MANIFEST).write_text(json.dumps({**manifest, "allow_code": True, "code": []}))
    make_pack(installed, {"formats/f.yaml": EVIL_FORMAT.format(function="mine.create"),
                          "formats/mine.py": PLANTED_PY.format(marker=str(marker))})
    registry = Registry()
    assert "evil_fmt" not in registry.names("formats")
    assert (f"{installed / 'formats' / 'f.yaml'}: functions.create runs pack code 'mine.create', but pack 'plain2' "
            "was installed without --allow-code (to run its code, read it, then install it again: benchbot install "
            f"--force --allow-code {pack})") in registry.problems.values()
    with pytest.raises(SpecError, match="no format named 'evil_fmt'"):
        registry.functions("formats", "evil_fmt")
    assert not marker.exists()


@pytest.mark.slow
def test_code_changed_after_install_with_allow_code_is_not_imported_until_installed_again(tmp_path, data_dir):
    marker = tmp_path / "imported"
    pack = make_pack(tmp_path / "coded", {"formats/f.yaml": EVIL_FORMAT.format(function="mine.create"),
                                          "formats/mine.py": "def create():\n    return {'honest': True}\n"})
    proc, _, _ = cli("install", "--allow-code", str(pack))
    assert proc.returncode == 0, proc.stderr
    approvals = json.loads((data_dir / cp.CODE_APPROVALS).read_text())["packs"]  # the user's record, not the pack's
    assert approvals["coded"]["digest"].startswith("sha256:") and approvals["coded"]["source"] == str(pack)
    assert Registry().functions("formats", "evil_fmt")["create"]() == {"honest": True}
    installed = data_dir / "packs" / "coded"
    refused = (f"{installed / 'formats' / 'f.yaml'}: functions.create runs pack code 'mine.create', but pack "
               "'coded' has changed since it was installed with --allow-code (to run its code, read it, then install "
               f"it again: benchbot install --force --allow-code {pack})")
    for planted in ({"formats/helper.py": PLANTED_PY.format(marker=str(marker))},  # a .py dropped in
                    {"formats/mine.py": PLANTED_PY.format(marker=str(marker))}):  # the allowed .py edited
        make_pack(installed, planted)
        registry = Registry()
        assert "evil_fmt" not in registry.names("formats") and refused in registry.problems.values()
        with pytest.raises(SpecError, match="no format named 'evil_fmt'"):
            registry.functions("formats", "evil_fmt")
    assert not marker.exists()
    proc, _, _ = cli("install", "--force", "--allow-code", str(pack))  # what the message says to do
    assert proc.returncode == 0, proc.stderr
    assert Registry().functions("formats", "evil_fmt")["create"]() == {"honest": True}
    proc, _, _ = cli("uninstall", "coded")
    assert proc.returncode == 0 and "coded" not in json.loads((data_dir / cp.CODE_APPROVALS).read_text())["packs"]
