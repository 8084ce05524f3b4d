"""Brief source positions (render/source_positions.py): while a kernel of the package compiles, Taichi records
"File, line, function" without the source excerpt; errors still say where; other kernels keep Taichi's full
messages; the kernels compute what they computed."""

import os

import numpy as np
import pytest
import taichi as ti


@pytest.fixture
def positions():
    from benchbot_sim_taichi.render import source_positions
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    assert ensure_taichi("cpu") == "cpu"
    assert source_positions.use_brief_positions()
    return source_positions


def _compile_error(kernel) -> str:
    with pytest.raises(ti.TaichiCompilationError) as caught:
        kernel(np.zeros(4, np.float32))
    return str(caught.value)


def _kernel_with_an_unknown_name():
    @ti.kernel
    def uses_an_unknown_name(out: ti.types.ndarray(dtype=ti.f32, ndim=1)):
        for i in range(out.shape[0]):
            out[i] = nowhere_defined * 2.0  # noqa: F821 - the error this test wants

    return uses_an_unknown_name


def test_a_kernel_of_the_package_compiles_with_brief_positions_and_its_errors_say_where(positions, monkeypatch):
    monkeypatch.setattr(positions, "PACKAGE_DIR", os.path.dirname(os.path.abspath(__file__)) + os.sep)
    message = _compile_error(_kernel_with_an_unknown_name())
    assert f'File "{os.path.abspath(__file__)}"' in message and "in uses_an_unknown_name" in message
    assert "nowhere_defined" in message
    assert "^" not in message  # no caret line under a source excerpt


def test_a_kernel_defined_elsewhere_keeps_taichis_full_positions(positions, monkeypatch):
    monkeypatch.setattr(positions, "PACKAGE_DIR", "/nowhere" + os.sep)
    message = _compile_error(_kernel_with_an_unknown_name())
    assert "out[i] = nowhere_defined * 2.0" in message and "^^^" in message  # the source line and its carets


def test_brief_positions_change_nothing_a_kernel_computes(positions, monkeypatch):
    def make():
        @ti.kernel
        def polynomial(x: ti.types.ndarray(dtype=ti.f32, ndim=1), out: ti.types.ndarray(dtype=ti.f32, ndim=1)):
            for i in range(x.shape[0]):
                v = ti.Vector([x[i], 1.0 - x[i], 0.5])
                out[i] = v.dot(v) + ti.sqrt(ti.abs(x[i])) * ti.cos(x[i])

        return polynomial

    x = np.linspace(-3, 3, 101).astype(np.float32)
    got = {}
    for where in (os.path.dirname(os.path.abspath(__file__)) + os.sep, "/nowhere" + os.sep):
        monkeypatch.setattr(positions, "PACKAGE_DIR", where)
        out = np.zeros_like(x)
        make()(x, out)
        got[where] = out
    a, b = got.values()
    assert np.array_equal(a, b) and np.abs(a).sum() > 0


def test_full_positions_when_asked(monkeypatch):
    from benchbot_sim_taichi.render import source_positions

    monkeypatch.setattr(source_positions, "_installed", False)
    monkeypatch.setenv("BENCHBOT_TAICHI_FULL_POSITIONS", "1")
    assert source_positions.use_brief_positions() is False
