"""Test-wide settings: only the first-party plugins load, whatever else is installed (architecture.md), and content
packs come from an empty, per-session data directory, never from the user's (and built scenes go to a per-session
cache directory). Environments that name no style are
drawn in sim_taichi's ``primitives`` style (fast to build); the tests of the furnished default name it, and
``tests/test_furnished_episode.py`` runs the README's main job on it. The commands the tests run build their
simulator in their own process (``BENCHBOT_SERVICE=off``, as ``--no-service``): no test leaves a resident simulator
service behind, nor depends on one another test started; ``tests/test_service.py`` turns it on where it tests it."""

import os
import signal
import tempfile

pytest_plugins = ["pytester"]  # tests/test_fast_loop.py runs pytest on this conftest

os.environ["BENCHBOT_ONLY_PLUGINS"] = "core_examples,content_packs,worlds,sim_taichi,eval_omq,task_semslam,robot_ros2,assets_sh3d"
os.environ["BENCHBOT_DATA_DIR"] = _TEST_DATA_DIR = tempfile.mkdtemp(prefix="benchbot-test-data-")
os.environ["BENCHBOT_CACHE_DIR"] = _TEST_CACHE_DIR = tempfile.mkdtemp(prefix="benchbot-test-cache-")
os.environ["BENCHBOT_SIM_STYLE"] = "primitives"
os.environ["BENCHBOT_SERVICE"] = "off"

# Ctrl-C reaches the commands the tests start, however pytest was started. A shell without job control starts its
# background commands (`pytest ... &`, nohup) with SIGINT ignored, every child inherits that, and a Python that starts
# with SIGINT ignored never raises KeyboardInterrupt: the tests that press Ctrl-C (SIGINT) would wait out their
# timeouts. Python's own handler here becomes the default disposition in every child that pytest starts.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


# ---------------------------------------------------------------------------------------------------------------------
# The default run is the fast loop: tests marked ``slow`` (more than about 2 s each on a 2-core machine: whole batches,
# real terminals, Ray, ROS 2 end to end) are left out when pytest is run with no path and no ``-m``. `uv run pytest
# -m slow` runs only them, `uv run pytest --run-slow` runs everything, and naming a file or test runs all of it.
# CI (.ci/run) runs the default command and then `uv run pytest -m slow -n 2` (two pytest-xdist workers), so every
# test runs there.
# ---------------------------------------------------------------------------------------------------------------------
def pytest_unconfigure(config):
    """The per-session cache of built scenes (hundreds of MB once furnished homes were built) and data directory
    are removed at the end."""
    import shutil

    for name, made in (("BENCHBOT_CACHE_DIR", _TEST_CACHE_DIR), ("BENCHBOT_DATA_DIR", _TEST_DATA_DIR)):
        if os.environ.get(name) == made:
            shutil.rmtree(made, ignore_errors=True)


def pytest_addoption(parser):
    parser.addoption("--run-slow", action="store_true", default=False,
                     help="also run the tests marked slow (the default run, with no path and no -m, leaves them out)")


def _leaves_out_slow(config) -> bool:
    import pytest

    return (not config.getoption("--run-slow") and not config.option.markexpr
            and config.args_source == pytest.Config.ArgsSource.TESTPATHS)


def pytest_collection_modifyitems(config, items):
    if not _leaves_out_slow(config):
        return
    slow = [item for item in items if item.get_closest_marker("slow")]
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = [item for item in items if not item.get_closest_marker("slow")]
        config._benchbot_slow_left_out = len(slow)


def pytest_report_header(config):
    if _leaves_out_slow(config):
        return ("the fast loop: tests marked slow are left out (`uv run pytest --run-slow` runs all, "
                "`-m slow` only them; CI runs both)")
    return None


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    left_out = getattr(config, "_benchbot_slow_left_out", 0)
    if left_out:
        terminalreporter.write_line(f"{left_out} slow tests left out of this fast run: `uv run pytest -m slow` "
                                    "runs them (CI does)")
