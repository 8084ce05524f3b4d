"""Helpers shared by the hello examples: where to put pictures, writing PNGs, writing results."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np


def image_folder(results_file: str) -> Path:
    """``<results file without suffix>_images/``, created."""
    folder = Path(results_file).with_suffix("")
    folder = folder.with_name(folder.name + "_images")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def save_png(path: Path, image: np.ndarray) -> None:
    """Save an RGB uint8 (H, W, 3) image, or a depth float32 (H, W) map in metres (scaled to 0–255 over 0–5 m),
    as PNG with OpenCV; prints a note and skips when OpenCV is not installed."""
    try:
        import cv2
    except ImportError:
        print(f"opencv-python-headless is not installed: not saving {path.name}", file=sys.stderr)
        return
    if image.ndim == 2:
        image = np.clip(image / 5.0 * 255.0, 0, 255).astype(np.uint8)
    else:
        image = image[..., ::-1]  # RGB -> OpenCV's BGR
    cv2.imwrite(str(path), image)


def write_results(filename: str, results: dict) -> None:
    """Write the results file as JSON."""
    Path(filename).parent.mkdir(parents=True, exist_ok=True)
    Path(filename).write_text(json.dumps(results, indent=1))
