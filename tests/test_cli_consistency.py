"""The CLI is consistent (docs/cli.md). Every command, plugins' commands included, is walked through the real Typer
app. A short flag has one meaning, the one in docs/cli.md's table. Every option has a help text, and `-h` shows no
`<bool>`. `--arch` defaults to auto. Spec text is printed verbatim. Unknown names get a "did you mean". Score tables
show integer counts and tell repeats apart."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

sys.path.insert(0, str(Path(__file__).parent))
from test_evaluation import perfect_results  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def cli(*args: str, cwd: Path | None = None, env: dict | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, COLUMNS="200", **(env or {})))


@pytest.fixture(scope="module")
def app():
    """The `benchbot` app with every plugin's commands, as `benchbot` builds it."""
    from benchbot.cli.common import registry
    from benchbot.cli.main import add_plugin_commands, app

    if not any(getattr(g, "name", None) == "sim" for g in app.registered_groups):
        add_plugin_commands(registry().plugin_manager, app)
    return app


def invoke(app, *args: str):
    """Run ``benchbot ARGS`` in this process (the same app, cheaper than a new interpreter); ``.stdout``,
    ``.stderr``, ``.exit_code``."""
    return CliRunner().invoke(app, list(args), env={"COLUMNS": "200"})


def commands(app) -> list[tuple[str, object]]:
    """``[(path, click command)]`` of every command and group, the root first."""
    found = []

    def walk(cmd, path):
        found.append((path, cmd))
        for name, sub in sorted(getattr(cmd, "commands", {}).items()):
            walk(sub, f"{path} {name}")

    walk(typer.main.get_command(app), "benchbot")
    return found


def options(cmd) -> list:
    """The command's options, its help option included."""
    ctx = cmd.make_context(cmd.name or "benchbot", [], resilient_parsing=True)
    return [p for p in cmd.params if p.param_type_name == "option"] + [cmd.get_help_option(ctx)]


def documented_short_flags() -> dict[str, str]:
    """``{short: long}`` from docs/cli.md's table."""
    table = {}
    for line in (ROOT / "docs" / "cli.md").read_text().splitlines():
        match = re.match(r"\|\s*`(-[A-Za-z])`\s*\|\s*`(--[a-z-]+)`\s*\|", line)
        if match:
            assert match[1] not in table, f"docs/cli.md lists {match[1]} twice"
            table[match[1]] = match[2]
    return table


def test_a_short_flag_means_one_thing_in_every_command(app):
    uses: dict[str, list[tuple[str, set[str]]]] = {}
    for path, cmd in commands(app):
        for opt in options(cmd):
            longs = {o for o in [*opt.opts, *opt.secondary_opts] if o.startswith("--")}
            for short in (o for o in [*opt.opts, *opt.secondary_opts] if re.fullmatch(r"-[A-Za-z]", o)):
                uses.setdefault(short, []).append((path, longs))
    assert {"-e", "-t", "-r", "-n", "-E", "-o", "-h", "-v"} <= set(uses)  # the walk reached the commands
    table = documented_short_flags()
    problems = []
    for short, where in sorted(uses.items()):
        if short not in table:
            problems.append(f"{short} ({', '.join(p for p, _ in where)}) is not in docs/cli.md's table")
            continue
        for path, longs in where:
            if table[short] not in longs:
                problems.append(f"{path}: {short} is {'/'.join(sorted(longs))}, docs/cli.md says {table[short]}")
    problems += [f"docs/cli.md lists {s}, which no command has" for s in table if s not in uses]
    assert not problems, "\n".join(problems)


def test_arch_defaults_to_auto_and_native_takes_a_command_everywhere(app):
    arch = {path: opt.default for path, cmd in commands(app) for opt in options(cmd) if "--arch" in opt.opts}
    assert {"benchbot run", "benchbot batch"} <= set(arch)
    assert set(arch.values()) == {"auto"}, arch
    native = {path: opt.is_flag for path, cmd in commands(app) for opt in options(cmd) if "--native" in opt.opts}
    assert native == {"benchbot submit": False, "benchbot batch": False, "benchbot challenge evaluate": False}


def test_every_option_has_help_and_help_shows_no_bool(app):
    runner = CliRunner()
    missing, bools = [], []
    for path, cmd in commands(app):
        missing += [f"{path} {'/'.join(opt.opts)}" for opt in options(cmd) if not (opt.help or "").strip()]
        shown = runner.invoke(app, [*path.split()[1:], "-h"], env={"COLUMNS": "200"}, catch_exceptions=False)
        assert shown.exit_code == 0, (path, shown.output)
        if "<bool>" in shown.output:
            bools.append(path)
    assert not missing, f"options without help: {missing}"
    assert not bools, f"'<bool>' in the help of: {bools}"
    assert any(path == "benchbot sim render" for path, _ in commands(app))  # plugin commands were walked


@pytest.mark.slow
def test_submit_runs_the_words_after_native_as_the_command(served, tmp_path):
    _, server = served("semantic_slam:passive:ground_truth", "miniroom:1")
    script = tmp_path / "echo_args.py"
    script.write_text("import json, os, sys\n"
                      "json.dump({'argv': sys.argv[1:]}, open(os.environ['BENCHBOT_RESULT_LOCATION'], 'w'))\n")
    copy = tmp_path / "copied.json"
    proc = cli("submit", "--native", sys.executable, str(script), "one", "two words", "--address", server.address,
               "--results-location", str(copy), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(copy.read_text()) == {"argv": ["one", "two words"]}
    proc = cli("submit", "-n", f"{sys.executable} {script} quoted", "--address", server.address,
               "--results-location", str(copy), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(copy.read_text()) == {"argv": ["quoted"]}


def test_submit_refuses_the_originals_e_and_r_naming_their_long_flags(app):
    for flag, long in (("-e", "--evaluate-with"), ("-r", "--results-location")):
        result = invoke(app, "submit", "--native", "python", "my.py", flag, "x")
        assert result.exit_code == 2 and long in result.stderr, result.stderr


def table_rows(text: str, column: int) -> list[str]:
    """The cells of ``column`` of a Rich table, the wrapped lines of one row joined by spaces."""
    rows: list[str] = []
    for line in text.splitlines():
        cells = line.split("│")
        if len(cells) < column + 2:
            continue
        if cells[1].strip() or not rows:
            rows.append(cells[column + 1].strip())
        else:
            rows[-1] += " " + cells[column + 1].strip()
    return [" ".join(r.split()) for r in rows]


def test_list_and_show_print_spec_text_as_written(app):
    formats = table_rows(invoke(app, "list", "formats").stdout, 2)
    assert any("(centroid [x, y, z] and extent [dx, dy, dz]," in r for r in formats), formats
    assert any("state_list (default [added, removed, unchanged])" in r for r in formats), formats
    assert any("(a box that stands for a group of objects, e.g. a shelf of books)" in r for r in formats), formats
    evaluators = table_rows(invoke(app, "list", "evaluators").stdout, 2)
    assert any(r.startswith("Object Map Quality (OMQ; Hall et al. 2020, arXiv:2009.05246): optimally") for r in evaluators)
    shown = invoke(app, "show", "format", "object_map")  # a singular kind is accepted
    assert shown.exit_code == 0, shown.stderr
    assert "centroid [x, y, z] and extent [dx," in shown.stdout


@pytest.mark.slow
def test_an_unknown_name_gets_a_suggestion_in_every_command(app, tmp_path):
    proc = cli("sim", "render", "kitchen:1", "-o", "x.png", cwd=tmp_path)  # a plugin's command, as a user runs it
    assert proc.returncode == 3 and "Traceback" not in proc.stderr, proc.stderr
    assert "hint: known environments: house (variants 1, 2, 3, 4, 5), miniroom (variants 1, 2, 3, 4, 5)" in proc.stderr
    for args, hint in [
        (("run", "-e", "miniroom:9"), "hint: miniroom has variants 1, 2, 3, 4, 5, e.g. miniroom:1"),
        (("run", "-e", "minirom:1"), "hint: did you mean miniroom:1?"),
        (("run", "-e", "miniroom:1", "-t", "semslam"), "hint: did you mean semantic_slam:"),
        (("batch", "-E", "hello_pasive", "-e", "miniroom:1", "--output-dir", str(tmp_path)),
         "hint: did you mean hello_passive?"),
        (("gt", "house:9"), "hint: house has variants 1, 2, 3, 4, 5"),
        (("show", "tsks", "x"), "did you mean tasks?"),
    ]:
        result = invoke(app, *args)
        assert result.exit_code in (2, 3) and hint in result.stderr, (args, result.stderr)
    assert list(tmp_path.iterdir()) == []  # nothing was rendered, and the failed batch made no run directory


def test_close_names_for_every_kind(registry):
    from benchbot.core.errors import SpecError

    for kind, typo, expected in [("robots", "cartr", "carter"), ("formats", "objmap", "object_map"),
                                 ("evaluators", "omqq", "omq"), ("examples", "hello_activ", "hello_active"),
                                 ("batches", "develop1", "develop_1"), ("ground_truths", "house:9", "house:1"),
                                 ("tasks", "scd", "scd:passive:ground_truth")]:
        with pytest.raises(SpecError) as exc:
            registry.entry(kind, typo)
        assert expected in exc.value.hint, (kind, exc.value.hint)


@pytest.mark.slow
def test_unknown_action_in_a_content_pack_is_refused_at_install(tmp_path):
    pack = tmp_path / "typo_pack"
    (pack / "tasks").mkdir(parents=True)
    (pack / "tasks" / "t.yaml").write_text("name: typo:passive:ground_truth\nactions: [move_next, move_nxt]\n"
                                           "observations: [poses]\n")
    proc = cli("install", str(pack), env={"BENCHBOT_DATA_DIR": str(tmp_path / "data")})
    assert proc.returncode == 3, proc.stderr
    assert "tasks/t.yaml: $.actions[1]: unknown action 'move_nxt'" in proc.stderr
    assert "did you mean move_next?" in proc.stderr
    assert not (tmp_path / "data" / "packs" / "typo_pack").exists()
    (pack / "tasks" / "t.yaml").write_text("name: typo:passive:ground_truth\nactions: [turn]\nobservations: [poses]\n")
    proc = cli("install", str(pack), env={"BENCHBOT_DATA_DIR": str(tmp_path / "data")})
    assert "unknown action 'turn' (the actions are move_next, move_distance, move_angle)" in proc.stderr  # none close


def test_score_tables_show_integer_counts_and_label_repeats(app, registry, tmp_path):
    files = []
    for name, env in (("a", "miniroom:1"), ("b", "miniroom:1"), ("c", "house:1")):
        files.append(tmp_path / f"{name}.json")
        files[-1].write_text(json.dumps(perfect_results(registry, env)))
    proc = invoke(app, "eval", *map(str, files), "-o", str(tmp_path / "s.json"))
    assert proc.exit_code == 0, proc.stderr
    rows = {r.split("│")[1].strip(): [c.strip() for c in r.split("│")[2:-1]] for r in proc.stdout.splitlines()
            if r.startswith("│")}
    assert {"miniroom:1 (a)", "miniroom:1 (b)", "house:1", "combined (mean of 3 results)"} == set(rows), rows
    tp = [r[-3:] for r in rows.values()]
    assert ["18", "0", "0"] in tp and ["56", "0", "0"] in tp
    assert rows["combined (mean of 3 results)"][-3:] == ["30.67", "0", "0"]  # (18 + 18 + 56) / 3
    proc = invoke(app, "eval", str(files[0]), "--required-envs", "miniroom:1,house:1", "-o", str(tmp_path / "s.json"))
    assert "combined (mean of 1 result + 1 missing)" in proc.stdout and "│ 9  " in proc.stdout, proc.stdout


def test_a_batch_s_repeats_are_labelled_by_episode_and_never_cut_at_80_columns(monkeypatch):
    from rich.console import Console

    from benchbot.cli import eval_cmd
    from benchbot.cli.tables import row_labels
    from benchbot.core.evaluation import Evaluation

    sources = [f"runs/b/results/{i:03d}_miniroom_{1 + i // 2}.json" for i in range(4)]
    assert row_labels([(s, f"miniroom:{1 + i // 2}") for i, s in enumerate(sources)]) == \
        ["miniroom:1 #0", "miniroom:1 #1", "miniroom:2 #2", "miniroom:2 #3"]
    scores = {"OMQ": 0.1601, "avg_pairwise": 0.2374, "avg_label": 0.1876, "avg_spatial": 0.495,
              "avg_fp_quality": 0.4686, "TP": 15, "FP": 8, "FN": 3}
    from benchbot.core.evaluation import method_scores
    from benchbot.core.registry import get_registry

    evaluation = Evaluation(method="omq", score_set=method_scores(get_registry(), "omq"))  # as evaluate() makes it
    evaluation.per_result = [(s, {"environment_details": [{"name": "miniroom", "variant": 1 + i // 2}],
                                  "scores": dict(scores)}) for i, s in enumerate(sources)]
    evaluation.combined = {"scores": dict(scores)}
    console = Console(width=80, record=True, force_terminal=False)
    monkeypatch.setattr(eval_cmd, "out", console)
    eval_cmd.print_scores(evaluation)
    text = console.export_text()
    assert max(map(len, text.splitlines())) <= 80 and "…" not in text, text
    rows = [line.split() for line in text.splitlines() if line.startswith(("miniroom", "combined"))]
    assert [r[:2] for r in rows[:4]] == [["miniroom:1", "#0"], ["miniroom:1", "#1"], ["miniroom:2", "#2"],
                                         ["miniroom:2", "#3"]], text
    assert all(r[-8:] == ["0.1601", "0.2374", "0.1876", "0.4950", "0.4686", "15", "8", "3"] for r in rows), text


#: The arguments each command that takes a count flag needs besides it (every other one is refused first).
COUNT_FLAG_COMMANDS = {
    "benchbot batch": ["--example", "hello_passive", "--envs", "miniroom:1"],
    "benchbot run": ["--env", "miniroom:1"],
    "benchbot sim render": ["miniroom:1", "-o", "never.png"],
    "benchbot sim prepare": ["miniroom:1", "--arch", "cpu"],
    "benchbot ros2 serve-sim": ["--env", "miniroom:1"],
    "benchbot worlds generate": ["-o", "never_pack"],
    "benchbot challenge init": ["never_challenge"],
    "benchbot challenge evaluate": ["never_submission", "--challenge", "never_challenge"],
}


def test_every_count_flag_has_a_documented_maximum_checked_first(app, tmp_path, monkeypatch):
    """Every integer flag of every command, plugins' included, is bounded: by Click's own range (``--port``) or by a
    maximum from benchbot.core.limits said in its help, and a value past it is one usage line (exit 2) naming the
    flag and the bound, before anything runs (``batch --repeat 99999999999999999999`` planned until killed)."""
    monkeypatch.chdir(tmp_path)
    bounded = {}
    for path, cmd in commands(app):
        for param in options(cmd):
            if getattr(getattr(param, "type_descriptor", None), "annotation", None) is not int:
                continue
            if getattr(param, "max", None) is not None:
                continue  # Typer's own range: --port 0..65535, --domain-id 0..232
            bounded.setdefault(path, []).append(param)
    assert set(bounded) == set(COUNT_FLAG_COMMANDS), "a count flag without a maximum, or a stale entry"
    for path, params in bounded.items():
        for param in params:
            flag = max(param.opts, key=len)
            documented = re.search(r"(\d+) to (\d+)", param.help or "")
            assert documented, f"{path} {flag}: its help does not give its range ({param.help!r})"
            low, high = int(documented[1]), int(documented[2])
            for value, says in ((high + 1, f"is more than the maximum of {high}"), (low - 1, f"is less than {low}"),
                                (10 ** 20, f"is more than the maximum of {high}")):
                result = invoke(app, *path.split()[1:], *COUNT_FLAG_COMMANDS[path], flag, str(value))
                errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
                assert result.exit_code == 2 and len(errors) == 1, (path, flag, value, result.stderr)
                assert errors[0].startswith(f"error: {flag} {value} {says}"), (path, flag, errors)
    sized = [path for path, cmd in commands(app) if any("--camera-size" in p.opts for p in options(cmd))]
    assert sized == ["benchbot batch", "benchbot ros2 serve-sim", "benchbot run"]
    for path in sized:  # a camera's sides count pixels: bounded in every command that takes one
        result = invoke(app, *path.split()[1:], *COUNT_FLAG_COMMANDS[path], "--camera-size", "100000x10")
        assert result.exit_code == 2, (path, result.stderr)
        assert result.stderr.startswith("error: --camera-size '100000x10': each side must be at most 8192 pixels")
    assert list(tmp_path.iterdir()) == []  # nothing was planned, rendered or written
