"""Content packs: folders in the original BenchBot add-on layout (tasks, robots, environments, examples, formats,
evaluation methods) and asset packs of 3D models, installed by path or from the original add-ons, with the content
rules every environment is checked against (docs/plugin-guide.md)."""
