"""benchbot_sim_taichi.render.dlpack: a Taichi ndarray exported as a DLPack capsule, taken by NumPy without a copy
(host memory, Taichi on the CPU: the same capsule code a CUDA consumer reads), and freed when the consumer is."""

from __future__ import annotations

import gc

import numpy as np
import pytest

ti = pytest.importorskip("taichi")


@pytest.fixture
def taichi_cpu():
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    assert ensure_taichi("cpu") == "cpu"


def test_numpy_takes_the_ndarray_without_a_copy_and_frees_it_with_the_consumer(taichi_cpu):
    from benchbot_sim_taichi.render import dlpack

    live = len(dlpack._LIVE)
    a = ti.ndarray(ti.f32, shape=(2, 3, 4))
    a.from_numpy(np.arange(24, dtype=np.float32).reshape(2, 3, 4))
    exported = dlpack.DeviceArray(a, device_type=dlpack.KDL_CPU)
    assert exported.__dlpack_device__() == (dlpack.KDL_CPU, 0) and exported.shape == (2, 3, 4)
    view = np.from_dlpack(exported)
    assert view.dtype == np.float32 and np.array_equal(view, np.arange(24).reshape(2, 3, 4))
    a.fill(7.0)  # the view is the ndarray's memory
    assert (view == 7.0).all()
    assert len(dlpack._LIVE) == live + 1
    del view
    gc.collect()
    assert len(dlpack._LIVE) == live  # the consumer called the deleter
    capsule = exported.__dlpack__()
    del capsule  # never consumed: the capsule's destructor frees it
    gc.collect()
    assert len(dlpack._LIVE) == live
    b = ti.ndarray(ti.u8, shape=(5,))
    assert np.from_dlpack(dlpack.DeviceArray(b, device_type=dlpack.KDL_CPU)).dtype == np.uint8


def test_what_is_not_offered_is_refused(taichi_cpu):
    from benchbot_sim_taichi.render import dlpack

    exported = dlpack.DeviceArray(ti.ndarray(ti.i32, shape=(3,)), device_type=dlpack.KDL_CPU)
    with pytest.raises(BufferError, match="without copying"):
        exported.__dlpack__(copy=True)
    with pytest.raises(BufferError, match="cannot be exported"):
        exported.__dlpack__(dl_device=(dlpack.KDL_CUDA, 0))
    assert not hasattr(exported, "__cuda_array_interface__")  # host memory
    with pytest.raises(ValueError, match="device_type"):
        dlpack.DeviceArray(ti.ndarray(ti.i32, shape=(3,)), device_type=7)
