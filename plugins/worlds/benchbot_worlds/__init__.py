"""BenchBot's worlds, free of any simulator: the scene model (:mod:`.scene`), furnished homes and their floor plans
(:mod:`.homes`), the ten BEAR homes (:mod:`.bear`) and the procedural homes of the train, validation and test
splits. A simulator plugin draws a world through :func:`benchbot_worlds.scene.build.build_scene`."""
