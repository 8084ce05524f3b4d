"""The original API-side connection callbacks (docs/original-benchbot.md, section 5), importable as
``benchbot_api.api_callbacks`` because original clients import the robot config's ``callback_api`` entries from
``benchbot_api.<module>``.

No OpenCV or jsonpickle is needed to import this module.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def convert_to_rgb(data: Any) -> Any:
    """``{'encoding': 'bgr8'|'rgb8'|..., 'data': (H, W, 3) uint8}`` → (H, W, 3) uint8 in RGB order: ``bgr8`` is
    swapped, other encodings pass through unchanged (as in the original). A bare array is returned as it is."""
    if not isinstance(data, dict) or "data" not in data:
        return data
    image = np.asarray(data["data"])
    if data.get("encoding") == "bgr8":
        return np.ascontiguousarray(image[..., ::-1])
    return image


def decode_jsonpickle(data: Any) -> Any:
    """jsonpickle text → object (the original's helper, which forgot its import). Use only on trusted data:
    jsonpickle can build arbitrary objects."""
    import jsonpickle
    import jsonpickle.ext.numpy as jsonpickle_numpy

    jsonpickle_numpy.register_handlers()
    return jsonpickle.decode(data) if isinstance(data, (str, bytes)) else data
