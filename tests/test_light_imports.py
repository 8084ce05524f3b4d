"""What a ``benchbot batch`` served by the simulator service imports: no web server (uvicorn, Starlette), no
leaderboard; ``benchbot.server``'s names are still importable from the package, each its module's own object."""

from __future__ import annotations

import importlib
import subprocess
import sys
import textwrap


def test_session_redaction_and_the_cli_app_import_no_web_server_nor_leaderboard():
    # a fresh interpreter: the subject is what gets imported
    code = textwrap.dedent("""
        import sys
        import benchbot.core.session
        from benchbot.server.redaction import ground_truth_strings
        from benchbot.cli.main import get_app
        get_app()
        print(sorted(m for m in ("uvicorn", "starlette", "benchbot.batch.leaderboard", "benchbot.server.routes",
                                  "benchbot.batch.predictivity")
                     if m in sys.modules))
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1] == "[]"


def test_every_name_of_benchbot_server_is_its_modules_own():
    import benchbot.server as server

    assert set(server.__all__) == set(server._DEFINED_IN)
    for name in server.__all__:
        module = importlib.import_module(f"benchbot.server.{server._DEFINED_IN[name]}")
        assert getattr(server, name) is getattr(module, name), name
    assert set(server.__all__) <= set(dir(server))
    try:
        server.no_such_name  # noqa: B018
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:
        raise AssertionError("an unknown name was found")


def test_the_solution_api_reads_no_package_metadata_and_the_version_is_read_on_use():
    code = textwrap.dedent("""
        import sys
        import benchbot_api
        before = "importlib.metadata" in sys.modules
        import benchbot
        from importlib.metadata import version
        print(before, benchbot.__version__ == version("benchbot"))
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ["False", "True"]
