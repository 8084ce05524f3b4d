"""BenchBot's settings from the environment: every environment variable that BenchBot and its plugins read, read
through one function (:func:`get`), shown with its effective value and where the value came from by
``benchbot doctor`` (:func:`effective`).

The core declares its own (:data:`SETTINGS`, in :mod:`benchbot.core.core_settings`); each plugin declares the
variables it reads through the hook ``benchbot_settings`` (a list of :class:`Setting`), as conda's
``conda_settings`` does, so a third party's variables are found by :func:`get` and shown by ``benchbot doctor``
like the core's. A plugin's own code reads its settings through the declarations it returns
(``settings.get(MY_SETTING)``), which works whether or not the plugin is loaded; any code may read them by name.

Rules for a plugin's declarations (checked by :func:`from_plugins`; a declaration that breaks one is left out and
reported by ``benchbot doctor``, the plugin's others still count):

- a name is ``BENCHBOT_`` followed by upper-case letters, digits and ``_`` (``BENCHBOT_TAICHI_THREADS``), so that
  BenchBot's variables never clash with another program's; another program's variable that the plugin reads too
  (``ROS_DOMAIN_ID``) is declared with ``external=True`` and may lack the prefix;
- a name belongs to one declaration: the core's (its settings and its limits) or the first plugin's, in plugin
  order; a second declaration of it, by another plugin or the same one, is left out.

Command-line flags and spec fields win over these where both exist (e.g. ``--address`` over
``BENCHBOT_SUPERVISOR_ADDRESS``); a setting only gives the value when nothing more specific does. An empty or blank
value counts as unset.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass, replace
from typing import Any

from benchbot.core.core_settings import (BY_NAME, PREFIX, SETTINGS, Setting, absolute_path, gpu_share, one_of,
                                         positive_number, resolve, whole_number)
from benchbot.core.errors import UsageError

__all__ = ["PREFIX", "SETTINGS", "PluginSettings", "Setting", "absolute_path", "all_settings", "default", "effective",
           "find", "from_plugins", "get", "gpu_share", "one_of", "plugin_settings", "positive_number", "problems",
           "source", "value", "whole_number"]

_NAME = re.compile(r"[A-Z][A-Z0-9_]*")
_HOOK = "benchbot_settings"


@dataclass(frozen=True)
class PluginSettings:
    """What the plugins declared through ``benchbot_settings``.

    Attributes:
        settings: the declarations kept, in plugin order, each with ``owner`` = its plugin's name.
        problems: one line per declaration left out (or per plugin whose hook raised), naming the plugin.
    """

    settings: tuple[Setting, ...] = ()
    problems: tuple[str, ...] = ()


def _core_names() -> dict[str, str]:
    """``{name: 'the core'}`` of the core's settings, ``'the core (limits)'`` of its limits' variables."""
    return {s.name: "the core (limits)" if s.owner == "core (limits)" else "the core" for s in _core_settings()}


def _core_settings() -> tuple[Setting, ...]:
    """:data:`SETTINGS` and, after them, every limit of :mod:`benchbot.core.limits` that a variable changes (its
    default in its unit, owner ``core (limits)``). Limits are read by :meth:`benchbot.core.limits.Limit.value`,
    which checks their values."""
    from benchbot.core import limits

    return SETTINGS + tuple(Setting(limit.env, limit.describe(limit.default), limit.meaning, "core (limits)")
                            for limit in limits.all_limits().values() if limit.env)


def _declaration_problem(plugin: str, declared: Any, taken: dict[str, str]) -> str | None:
    """Why ``declared`` (one item of plugin ``plugin``'s list) cannot join the table whose names and owners are
    ``taken`` (``{name: who declared it}``: ``'the core'``, ``'plugin NAME'``), in one line; ``None`` when it
    can."""
    if not isinstance(declared, Setting):
        return (f"plugin {plugin}: benchbot_settings() offered {declared!r}, not a "
                "benchbot.core.settings.Setting")
    name = declared.name
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        return (f"plugin {plugin}: setting name {name!r} is not an environment variable name "
                f"(use {PREFIX}<WORDS> in upper case, e.g. {PREFIX}{plugin.upper()}_SPEED)")
    if not name.startswith(PREFIX) and not declared.external:
        return (f"plugin {plugin}: setting {name} does not start with {PREFIX} (name it {PREFIX}{name}, or declare "
                "Setting(..., external=True) for another program's variable that the plugin reads)")
    if name in taken:
        by = "the plugin itself" if taken[name] == f"plugin {plugin}" else taken[name]
        return f"plugin {plugin}: setting {name} is declared already, by {by} (rename it, or drop the second one)"
    return None


def from_plugins(plugin_manager) -> PluginSettings:
    """The settings that the plugins of ``plugin_manager`` declare through ``benchbot_settings``, checked against
    the rules of this module's docstring (a valid name, the prefix, one declaration per name).

    Args:
        plugin_manager: a ``pluggy.PluginManager`` (:func:`benchbot.core.plugin_manager.build_plugin_manager`, or a
            registry's ``plugin_manager``).

    Returns:
        :class:`PluginSettings`: the kept declarations (owner: the plugin's entry-point name) and one line per
        problem. Never raises for a plugin's mistake: a hook that raises or returns no list offers nothing.
    """
    from benchbot.core.plugin_manager import call_each_plugin

    taken = _core_names()
    kept: list[Setting] = []
    problems: list[str] = []
    for plugin, offered, exc in call_each_plugin(plugin_manager, _HOOK):
        if exc is not None or not isinstance(offered, (list, tuple)):
            problems.append(f"plugin {plugin}: {_HOOK}() raised {exc!r}" if exc is not None else
                            f"plugin {plugin}: {_HOOK}() returned {type(offered).__name__}, not a list")
            continue
        for declared in offered:
            problem = _declaration_problem(plugin, declared, taken)
            if problem:
                problems.append(problem)
                continue
            taken[declared.name] = f"plugin {plugin}"
            kept.append(replace(declared, owner=plugin))
    return PluginSettings(tuple(kept), tuple(problems))


@functools.lru_cache(maxsize=1)
def plugin_settings() -> PluginSettings:
    """:func:`from_plugins` of the installed, enabled plugins (``BENCHBOT_ONLY_PLUGINS``,
    ``BENCHBOT_DISABLE_PLUGINS``), collected once per process, on the first look-up of a name that is not the
    core's (loading the plugins' modules, not the registry). ``plugin_settings.cache_clear()`` forgets it."""
    from benchbot.core.plugin_manager import build_plugin_manager

    return from_plugins(build_plugin_manager()[0])


def _declared(plugin_manager=None) -> PluginSettings:
    return plugin_settings() if plugin_manager is None else from_plugins(plugin_manager)


def all_settings(plugin_manager=None) -> tuple[Setting, ...]:
    """Every setting: the core's (:data:`SETTINGS`), its limits' variables (owner ``core (limits)``), then the
    plugins' (those of ``plugin_manager``, else of the installed plugins: :func:`plugin_settings`): the one table
    of the variables BenchBot reads, as ``benchbot doctor`` shows it."""
    return _core_settings() + _declared(plugin_manager).settings


def find(setting: str | Setting) -> Setting:
    """The declaration of ``setting``: itself when it is one; else the core's of that name, else an installed
    plugin's.

    Raises:
        KeyError: no declaration has that name (a programming error: declare it first, in the core's table or
            through the plugin's ``benchbot_settings``).
    """
    if isinstance(setting, Setting):
        return setting
    if setting in BY_NAME:
        return BY_NAME[setting]
    for declared in plugin_settings().settings:
        if declared.name == setting:
            return declared
    raise KeyError(f"{setting} is declared neither by the core nor by an enabled plugin (declare it through the "
                   "hook benchbot_settings)")


def get(setting: str | Setting) -> str | None:
    """The value of ``setting`` (a name, or a plugin's declaration): the environment variable, stripped, when set
    and not blank; else its default (``None`` when it has none). Text, as given: :func:`value` applies the reader.

    Raises:
        KeyError: an undeclared name (:func:`find`).
    """
    return resolve(find(setting))[0]


def default(setting: str | Setting) -> str | None:
    """The default of ``setting`` (its value when the variable is unset).

    Raises:
        KeyError: an undeclared name (:func:`find`).
    """
    return find(setting).default


def source(setting: str | Setting) -> str:
    """Where :func:`get`'s value comes from: ``'environment'``, ``'default'`` or ``'unset'`` (no default).

    Raises:
        KeyError: an undeclared name (:func:`find`).
    """
    return resolve(find(setting))[1]


def value(setting: str | Setting) -> Any:
    """The value of ``setting`` as its reader makes it (:attr:`Setting.reader`; the text itself without one);
    ``None`` when unset with no default.

    Raises:
        KeyError: an undeclared name (:func:`find`).
        UsageError: the variable's text is no valid value: one line naming the variable, the text and why, e.g.
            ``BENCHBOT_TAICHI_THREADS='two' is not a whole number of at least 1`` (a reader's reason starting
            with ``not`` is quoted as it is, another after ``is not valid:``).
    """
    declared = find(setting)
    text = resolve(declared)[0]
    if text is None or declared.reader is None:
        return text
    try:
        return declared.reader(text)
    except ValueError as exc:
        unset = f"the default, {declared.default}" if declared.default is not None else "no value"
        reason = str(exc) if str(exc).startswith("not ") else f"not valid: {exc}"
        raise UsageError(f"{declared.name}={text!r} is {reason}",
                         f"set {declared.name} to a valid value, or unset it for {unset}") from None


def _problem(declared: Setting, text: str | None) -> str | None:
    """Why ``text`` is no valid value of ``declared`` (its reader's reason), else ``None``."""
    if text is None or declared.reader is None:
        return None
    try:
        declared.reader(text)
    except ValueError as exc:
        return str(exc)
    return None


def effective(plugin_manager=None) -> list[dict]:
    """Every setting (:func:`all_settings`) as ``{'name', 'value', 'source', 'owner', 'meaning', 'problem'}``: the
    value as the environment gives it, else the default (secret values shown as ``'***'``), where it came from
    (``'environment'``, ``'default'`` or ``'unset'``), and why that value is not valid (its reader's reason) or
    ``None``."""
    rows = []
    for s in all_settings(plugin_manager):
        text, where = resolve(s)
        rows.append({"name": s.name, "value": "***" if (s.secret and text) else text, "source": where,
                     "owner": s.owner, "meaning": s.meaning, "problem": _problem(s, text)})
    return rows


def problems(plugin_manager=None) -> tuple[str, ...]:
    """What is wrong with the settings, one line each: every value a setting's reader rejects
    (``BENCHBOT_TAICHI_THREADS='two' is not a whole number of at least 1``), then every plugin declaration left out
    (:func:`from_plugins`). ``benchbot doctor`` shows them."""
    invalid = [f"{row['name']}={row['value']!r} is " + (row["problem"] if row["problem"].startswith("not ") else
                                                         f"not valid: {row['problem']}")
               for row in effective(plugin_manager) if row["problem"]]
    return tuple(invalid) + _declared(plugin_manager).problems
