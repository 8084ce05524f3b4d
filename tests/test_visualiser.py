"""benchbot.api.tools.ObservationVisualiser writes PNGs from real observations; benchbot.api stays light."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("matplotlib")


def test_importing_the_api_does_not_import_matplotlib():
    code = "import sys, benchbot.api, benchbot_api; print('matplotlib' in sys.modules, 'gymnasium' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False"]


def test_visualiser_writes_a_png(make_service, tmp_path, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    from benchbot.api import InProcessBenchBot
    from benchbot.api.tools import ObservationVisualiser

    service = make_service("semantic_slam:passive:ground_truth", "miniroom:1")
    obs, _ = InProcessBenchBot(service).step("move_next")
    obs["image_segment"] = service.call(service.episode.backend.observe, ["image_segment"])["image_segment"]
    vis = ObservationVisualiser(["image_rgb", "image_depth", "laser", "poses", "image_class", "image_instance"])
    assert vis.show is False
    vis.visualise(obs, step_count=1)
    assert vis.fig._suptitle.get_text() == "Agent Observations (step # 1)"
    path = vis.save(tmp_path / "obs.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 5000
    # the grid is filled column by column: entry 1 is below entry 0
    a0, a1 = vis.axs[0].get_position(), vis.axs[1].get_position()
    assert abs(a0.x0 - a1.x0) < 1e-6 and a1.y0 < a0.y0
    vis.close()
    with pytest.raises(ValueError, match="cannot visualise"):
        ObservationVisualiser(["sonar"])
