"""Scenes loaded once per process and shared: every :class:`~benchbot_sim_taichi.backend.TaichiSimBackend` of a
process that loads the same world with the same renderer settings renders it through one
:class:`~benchbot_sim_taichi.render.renderer.Renderer` holding one copy of the scene (its BVH, shadow maps, baked
light and textures uploaded once, in GPU memory on CUDA).

This is what lets a batch run the episodes that share a world together in one process (the ``batched`` executor of
``benchbot batch``, :func:`benchbot.batch.executors.run_batched`): one kernel compile, one scene upload, each
episode with its own robot, solution process and API endpoint. Sharing changes no image: every backend of a process
runs on the process's one backend thread (:func:`benchbot.server.service.backend_worker`), so renders never
overlap, and :meth:`~benchbot_sim_taichi.render.renderer.Renderer.render` returns new arrays its caller owns.

A loaded scene lives while a backend uses it (counted); the last backend to let go closes its renderer (frees its
GPU memory), and one whose backends are dropped without closing goes when they are garbage collected. A resident
process (the simulator service, :func:`benchbot.service.resident`) keeps the :data:`KEPT_WHEN_RESIDENT` scenes it
let go of last instead, so that the next command's episode in one of those worlds finds it uploaded. Only scenes with a scene-cache key are shared (:func:`benchbot_sim_taichi.scene_cache.scene_key`: the
world's content, style, seed and the simulator's code); with the scene cache off (``BENCHBOT_SCENE_CACHE_BYTES=0``)
or a file the key cannot read, each backend loads its own.
"""

from __future__ import annotations

import threading
import weakref
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, Callable

#: ``(scene-cache key, arch option, shadow samples, world seed, camera model)``: what makes two loaded scenes the same.
SharingKey = tuple


@dataclass
class LoadedScene:
    """A scene uploaded to a renderer, and how many backends use it.

    Attributes:
        renderer: the :class:`~benchbot_sim_taichi.render.renderer.Renderer` holding the scene.
        scene: the :class:`~benchbot_worlds.scene.model.Scene` (read-only for its users).
        key: its :data:`SharingKey`, or None when it is not shared.
        users: backends holding it.
    """

    renderer: Any
    scene: Any
    key: SharingKey | None
    users: int = 1


#: held weakly: a scene whose backends were dropped without ``close`` goes with them, as their own renderer would
_LOADED: "weakref.WeakValueDictionary[SharingKey, LoadedScene]" = weakref.WeakValueDictionary()
_LOCK = threading.Lock()
#: Scenes a resident process keeps loaded after their last backend let go, at most this many, the oldest closed first.
KEPT_WHEN_RESIDENT = 3
#: those scenes, the one let go of last at the end (held strongly: no backend holds them)
_KEPT: "OrderedDict[SharingKey, LoadedScene]" = OrderedDict()


def acquire(key: SharingKey | None, load: Callable[[], tuple[Any, Any]]) -> LoadedScene:
    """The loaded scene of ``key``, shared with the backends of this process that hold it; else ``load()`` — which
    returns ``(renderer, scene)`` with the scene set on the renderer — is called and its result kept under ``key``
    (not kept when ``key`` is None). Call on the backend thread; pair every call with :func:`release`.

    Raises:
        whatever ``load`` raises (nothing is kept then)."""
    with _LOCK:
        held = _LOADED.get(key) if key is not None else None
        if held is not None:
            held.users += 1
            return held
        kept = _KEPT.pop(key, None) if key is not None else None
        if kept is not None:  # let go of earlier in this resident process: in use again
            kept.users = 1
            _LOADED[key] = kept
            return kept
    renderer, scene = load()
    loaded = LoadedScene(renderer, scene, key)
    if key is not None:
        with _LOCK:
            _LOADED[key] = loaded
    return loaded


def release(loaded: LoadedScene) -> None:
    """One backend lets go of ``loaded``; the last one closes its renderer (on the backend thread, where it renders),
    or, in a resident process (:func:`benchbot.service.resident`), keeps it for a later :func:`acquire` and closes
    the scene kept longest once more than :data:`KEPT_WHEN_RESIDENT` are kept. Never raises for a scene already
    released."""
    from benchbot.service import resident

    with _LOCK:
        if loaded.users <= 0:
            return
        loaded.users -= 1
        if loaded.users > 0:
            return
        if loaded.key is not None and _LOADED.get(loaded.key) is loaded:
            del _LOADED[loaded.key]
        closing = [loaded]
        if loaded.key is not None and resident():
            _KEPT[loaded.key] = loaded
            closing = [_KEPT.popitem(last=False)[1] for _ in range(len(_KEPT) - KEPT_WHEN_RESIDENT)]
    for scene in closing:
        scene.renderer.close()


def loaded_count() -> int:
    """How many shared scenes this process's backends hold now (for tests and diagnostics; kept ones not counted)."""
    with _LOCK:
        return len(_LOADED)


def kept_count() -> int:
    """How many scenes this resident process keeps loaded for later episodes (0 in any other process)."""
    with _LOCK:
        return len(_KEPT)
