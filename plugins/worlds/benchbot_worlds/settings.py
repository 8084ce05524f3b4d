"""The environment variables the worlds package reads, declared once (hook ``benchbot_settings`` in
:mod:`benchbot_worlds.plugin`): ``benchbot doctor`` shows them, and the package reads them through these
declarations (``settings.get(SIM_STYLE)``), whether or not the plugin is loaded (a simulator builds scenes with
it as a library). Imports nothing heavy."""

from __future__ import annotations

from benchbot.core.settings import Setting

#: The scene style of environments whose spec names none (:func:`benchbot_worlds.scene.build.default_style`
#: checks it against the styles).
SIM_STYLE = Setting("BENCHBOT_SIM_STYLE", "furnished", "scene style of environments naming none: furnished or "
                    "primitives")
#: Where the host's key of the held-out test split is (:func:`benchbot_worlds.procedural.splits.key_path`).
WORLDS_KEY_FILE = Setting("BENCHBOT_WORLDS_KEY_FILE", None, "the host's key of the held-out test split of "
                          "procedural homes (only a host holding it can build them); else <data dir>/worlds/"
                          "test_split.key, made by `benchbot worlds key`")

#: Every setting of the worlds package, in the order ``benchbot doctor`` shows them.
SETTINGS = (SIM_STYLE, WORLDS_KEY_FILE)
