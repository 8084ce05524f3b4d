"""Loading plugins: every module registered under the entry-point group ``benchbot`` is a plugin.

Environment variables:
    ``BENCHBOT_DISABLE_PLUGINS``: comma-separated entry-point names to skip (e.g. ``sim_taichi,eval_omq``).
    ``BENCHBOT_ONLY_PLUGINS``: comma-separated entry-point names; when set, every other plugin is skipped (the test
    suite uses it so installed third-party plugins never load into tests).
"""

from __future__ import annotations

import importlib
import importlib.metadata as md
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any, Iterator

import pluggy

from benchbot.core import hookspecs


@dataclass
class PluginInfo:
    """One plugin as found through its entry point.

    Attributes:
        name: the entry-point name (e.g. ``sim_taichi``).
        module: the module path (e.g. ``benchbot_sim_taichi.plugin``).
        distribution: the distribution that declares it (e.g. ``benchbot-sim-taichi``), or ``""``.
        version: that distribution's version, or ``""``.
        status: ``loaded``, ``disabled`` or ``failed``.
        error: why it failed to load (one line), or ``""``.
        registers: filled by the registry: kind → names this plugin contributed.
        hooks: names of the hooks it implements (e.g. ``["benchbot_robots", "benchbot_tasks"]``).
        problems: filled by the registry: one line per spec of this plugin that was skipped (invalid, clashing,
            or a hook that raised).
    """

    name: str
    module: str
    distribution: str = ""
    version: str = ""
    status: str = "loaded"
    error: str = ""
    registers: dict[str, list[str]] = field(default_factory=dict)
    hooks: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


def _names_from_env(var: str) -> set[str]:
    """The comma list of the core's setting ``var`` (read through :mod:`benchbot.core.core_settings`, which knows
    no plugin: :mod:`benchbot.core.settings` loads plugins through this module)."""
    from benchbot.core.core_settings import core_get

    return {n.strip() for n in (core_get(var) or "").split(",") if n.strip()}


def build_plugin_manager(extra_plugins: dict[str, ModuleType | object] | None = None) -> tuple[
    pluggy.PluginManager, list[PluginInfo]
]:
    """A plugin manager with every enabled ``benchbot`` entry point registered.

    Args:
        extra_plugins: ``{name: module or object}`` registered in addition (tests, embedding applications).

    Returns:
        ``(plugin_manager, infos)``; a plugin that fails to import is not registered and appears in ``infos`` with
        ``status='failed'`` and the reason. Never raises for a broken plugin.
    """
    pm = pluggy.PluginManager(hookspecs.PROJECT_NAME)
    for hook_class in hookspecs.HOOK_CLASSES:
        pm.add_hookspecs(hook_class)
    disabled = _names_from_env("BENCHBOT_DISABLE_PLUGINS")
    only = _names_from_env("BENCHBOT_ONLY_PLUGINS")
    infos: list[PluginInfo] = []
    seen: set[str] = set()
    for ep in sorted(md.entry_points(group=hookspecs.ENTRY_POINT_GROUP), key=lambda e: e.name):
        if ep.name in seen:  # the same distribution visible twice on sys.path
            continue
        seen.add(ep.name)
        dist = getattr(ep, "dist", None)
        info = PluginInfo(
            name=ep.name,
            module=ep.value,
            distribution=dist.metadata["Name"] if dist is not None else "",
            version=dist.version if dist is not None else "",
        )
        infos.append(info)
        if ep.name in disabled or (only and ep.name not in only):
            info.status = "disabled"
            continue
        try:
            plugin = ep.load()
            pm.register(plugin, name=ep.name)
            unknown_hooks_check(pm, plugin, ep.name)
            info.hooks = _hook_names(pm, plugin)
        except Exception as exc:  # a broken third-party plugin must not break the others
            info.status, info.error = "failed", f"{type(exc).__name__}: {exc}".splitlines()[0]
    for name, plugin in (extra_plugins or {}).items():
        pm.register(plugin, name=name)
        unknown_hooks_check(pm, plugin, name)
        infos.append(PluginInfo(name=name, module=getattr(plugin, "__name__", repr(plugin)), hooks=_hook_names(pm, plugin)))
    pm.check_pending()  # every implementation now has its hookspec (pluggy's own check, as a last guard)
    return pm, infos


class UnknownHookError(Exception):
    """A plugin implements a hook that no hookspec declares (usually a misspelt name)."""


def unknown_hooks_check(pm: pluggy.PluginManager, plugin: object, name: str) -> None:
    """Unregister ``plugin`` and raise when it implements a hook that BenchBot does not declare: a misspelt hook
    (``benchbot_task`` for ``benchbot_tasks``) would otherwise never be called, silently. Hooks marked
    ``optionalhook=True`` are allowed (they are meant for hookspecs another plugin may add).

    Raises:
        UnknownHookError: ``"plugin NAME implements unknown hook benchbot_task (did you mean benchbot_tasks?)"``.
    """
    from benchbot.core.names import close_names

    known = [h for h in dir(pm.hook) if h.startswith(hookspecs.PROJECT_NAME + "_") and getattr(pm.hook, h).has_spec()]
    unknown = sorted(caller.name for caller in (pm.get_hookcallers(plugin) or [])
                     if not caller.has_spec() and not all(i.optionalhook for i in caller.get_hookimpls()
                                                          if i.plugin is plugin))
    if unknown:
        pm.unregister(plugin)
        hook = unknown[0]
        close = close_names(hook, known)
        suggestion = f" (did you mean {', '.join(close)}?)" if close else " (the hooks are listed in docs/hooks.md)"
        raise UnknownHookError(f"plugin {name} implements unknown hook {hook}{suggestion}")


def _hook_names(pm: pluggy.PluginManager, plugin: object) -> list[str]:
    """Sorted names of the hooks ``plugin`` implements."""
    return sorted(caller.name for caller in (pm.get_hookcallers(plugin) or []))


def import_object(path: str) -> object:
    """The object named by an import path ``"package.module:attr"``.

    Raises:
        ImportError, AttributeError: the module or attribute does not exist.
    """
    module_name, _, attr = path.partition(":")
    module = importlib.import_module(module_name)
    return getattr(module, attr) if attr else module


def call_each_plugin(pm: pluggy.PluginManager, hook_name: str, **kwargs: Any) -> Iterator[
    tuple[str, Any, Exception | None]
]:
    """Call the hook ``hook_name`` once per plugin implementing it, through pluggy, so that each plugin's result, or
    its failure, is known to be that plugin's: the registry attributes specs and problems to plugins, and a broken
    plugin must not stop the others. Each call goes through ``pm.subset_hook_caller`` (the hook with every other
    implementing plugin removed), so pluggy's hook-call monitoring, tracing and hook wrappers apply as to ``pm.hook``.

    Args:
        pm: the plugin manager (:func:`build_plugin_manager`).
        hook_name: e.g. ``"benchbot_tasks"``.
        **kwargs: the hook's arguments, by name.

    Yields:
        ``(plugin_name, result, exception)`` in registration order (the order the registry keeps the first of two
        specs of one name by): ``result`` is what the plugin returned (``None`` when it raised, or returned
        ``None``), ``exception`` what it raised, else ``None``.

    Raises:
        TypeError: a registered plugin object is unhashable (``subset_hook_caller`` keeps a set of plugins; modules,
            as entry points give them, and instances of ordinary classes are hashable).
    """
    caller = getattr(pm.hook, hook_name)
    impls = [i for i in caller.get_hookimpls() if not (i.hookwrapper or i.wrapper)]
    for impl in impls:
        single = pm.subset_hook_caller(hook_name, remove_plugins=[i.plugin for i in impls if i is not impl])
        try:
            results = single(**kwargs)
        except Exception as exc:  # noqa: BLE001 - reported against this plugin by the caller
            yield impl.plugin_name, None, exc
            continue
        yield impl.plugin_name, (results[0] if results else None), None

