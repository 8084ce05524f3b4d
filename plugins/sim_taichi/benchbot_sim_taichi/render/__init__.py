"""Drawing a scene: the renderer (:mod:`.renderer`: camera, depth, segmentation and laser in one launch, fast and
quality modes, CPU and CUDA), its Taichi kernels (:mod:`.kernels`, :mod:`.sensors`, :mod:`.raster`, :mod:`.pathtrace`
with :mod:`.bsdf`), the acceleration structure (:mod:`.bvh`), baked light (:mod:`.lightmap`), the scene packed for
CUDA (:mod:`.packed_scene`), copies to the host (:mod:`.host_copy`), the camera's colour pipeline
(:mod:`.camera_model`), the denoiser (:mod:`.denoiser`) and a NumPy reference (:mod:`.reference`)."""
