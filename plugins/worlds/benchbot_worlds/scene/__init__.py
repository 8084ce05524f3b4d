"""The scene the renderer draws: its data (:mod:`.model`: :class:`~.model.Scene`, pure NumPy), how an environment
becomes one (:mod:`.build`), mesh models and textures (:mod:`.meshes`), procedural surface textures
(:mod:`.surfaces`) and export to other programs (:mod:`.export`)."""
