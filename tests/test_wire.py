"""The native payload encoding."""

import numpy as np
import pytest

from benchbot.protocol import wire
from benchbot.core.errors import BenchbotError


def test_roundtrip_keeps_dtype_shape_and_values():
    payload = {"rgb": np.arange(24, dtype=np.uint8).reshape(2, 4, 3), "depth": np.ones((2, 4), np.float32) * 1.5,
               "K": np.eye(3), "tuple": (1, 2), "scalar": np.float64(0.25), "none": None}
    back = wire.unpack(wire.pack(payload))
    for key in ("rgb", "depth", "K"):
        assert back[key].dtype == payload[key].dtype and np.array_equal(back[key], payload[key])
    assert back["tuple"] == [1, 2] and back["scalar"] == 0.25 and back["none"] is None


def test_malformed_payload_is_a_clear_error():
    with pytest.raises(BenchbotError, match="malformed payload"):
        wire.unpack(b"\xc1\xff\x00garbage")


def test_object_arrays_refused():
    with pytest.raises(TypeError):
        wire.pack({"x": np.array([object()], dtype=object)})
