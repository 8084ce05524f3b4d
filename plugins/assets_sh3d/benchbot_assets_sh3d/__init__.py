"""BenchBot asset pack: textured models from the Sweet Home 3D furniture libraries (Debian ``sweethome3d-furniture``),
converted to GLB by ``tools/build_pack.py``."""
