"""Procedural homes: a seeded generator of furnished homes in BEAR's ground-truth format (rooms and doors
:mod:`.layout`, objects placed by rules, a passive trajectory that sees every object, scene-change and lighting
variants), and the splits ``train``, ``val`` and ``test`` that name them."""
