"""The simulator's settings (``benchbot_sim_taichi.settings``, declared through ``benchbot_settings``): the renderer
reads the arch and the thread count through their readers, and a bad value is one usage line naming it."""

from __future__ import annotations

import pytest


def test_the_plugin_declares_its_taichi_settings():
    from benchbot_sim_taichi.plugin import benchbot_settings

    assert [s.name for s in benchbot_settings()] == ["BENCHBOT_TAICHI_ARCH", "BENCHBOT_TAICHI_THREADS",
                                                     "BENCHBOT_TAICHI_FULL_POSITIONS", "BENCHBOT_TAICHI_QUICK_COMPILE",
                                                     "BENCHBOT_SIM_CHECK_RENDERS"]


def test_the_render_check_is_off_unless_set_to_1_and_a_bad_value_is_one_line(monkeypatch, tmp_path):
    from benchbot.core.errors import UsageError
    from benchbot_sim_taichi.render_check import FOLDER, render_check

    monkeypatch.setenv("BENCHBOT_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("BENCHBOT_SIM_CHECK_RENDERS", raising=False)
    assert render_check() is None
    monkeypatch.setenv("BENCHBOT_SIM_CHECK_RENDERS", "0")
    assert render_check() is None
    monkeypatch.setenv("BENCHBOT_SIM_CHECK_RENDERS", "1")
    assert render_check().folder == tmp_path / FOLDER
    monkeypatch.setenv("BENCHBOT_SIM_CHECK_RENDERS", "yes")
    with pytest.raises(UsageError, match=r"^BENCHBOT_SIM_CHECK_RENDERS='yes' is not one of 0, 1$"):
        render_check()


def test_threads_and_arch_are_read_through_their_readers(monkeypatch):
    from benchbot_sim_taichi.render.renderer import TaichiSettingError, _cpu_threads, ensure_taichi

    monkeypatch.delenv("BENCHBOT_TAICHI_THREADS", raising=False)
    assert _cpu_threads() == {}
    monkeypatch.setenv("BENCHBOT_TAICHI_THREADS", " 3 ")
    assert _cpu_threads() == {"cpu_max_num_threads": 3}
    for bad in ("0", "two"):
        monkeypatch.setenv("BENCHBOT_TAICHI_THREADS", bad)
        with pytest.raises(TaichiSettingError, match=rf"^BENCHBOT_TAICHI_THREADS='{bad}' is not a whole number of "
                                                     r"at least 1$"):
            _cpu_threads()
    monkeypatch.setenv("BENCHBOT_TAICHI_ARCH", "vulkan")
    with pytest.raises(TaichiSettingError, match="^unknown Taichi arch 'vulkan'$"):
        ensure_taichi()
    with pytest.raises(ValueError, match="^unknown Taichi arch 'metal'$"):
        ensure_taichi("Metal")
