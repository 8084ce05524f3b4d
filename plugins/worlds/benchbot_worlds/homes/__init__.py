"""Furnished homes: a floor plan derived from a layout's cuboids (:mod:`.floorplan`, drawn by
:mod:`.floorplan_plot`), furniture models fitted to the cuboids (:mod:`.fitting`), supports, wall furniture and free
space (:mod:`.furnish`, :mod:`.furnish_supports`, :mod:`.furnish_walls`, :mod:`.furnish_space`) and the whole home as
meshes (:mod:`.furnished`)."""
