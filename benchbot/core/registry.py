"""The registry: every spec contributed by plugins, validated against ``schemas/`` and indexed by name.

Kinds and their schemas: tasks (``task``), robots (``robot``), environments (``environment``, indexed as
``name:variant``), formats (``format``), evaluators (``evaluator``), examples (``example``), batches (``batch``),
ground_truths (``ground_truth``, indexed by its environment's ``name:variant``).

A spec that fails to load or validate, or whose name clashes with another, is kept out and recorded in
:attr:`Registry.problems`; asking for it raises :class:`~benchbot.core.errors.SpecError` with that problem. A spec
of a name already registered is not a clash when the two are identical in meaning
(:mod:`benchbot.core.spec_meaning`; a plugin's copy is kept over a content pack's), nor when it comes from a
content pack installed with ``--override``; both are recorded in :attr:`Registry.notes`. Nor is a second ground
truth of an environment: it belongs to another *set* of ground truths (:meth:`Registry.ground_truth_sets`: the
original's ``isaac_develop`` and ``bear_develop``, recognised by content, else named after the pack or plugin),
chosen by name when scoring (:meth:`Registry.ground_truth`).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any, Callable

from benchbot.packs.content_packs import (
    LOAD_ERROR_KEY, OVERRIDE_KEY, imported_function_problem, installed_function_problem, is_pack_entry,
)
from benchbot.core import observations
from benchbot.core.errors import SpecError
from benchbot.core.names import did_you_mean
from benchbot.core.plugin_manager import PluginInfo, build_plugin_manager, call_each_plugin, import_object
from benchbot.core.spec_meaning import same_meaning
from benchbot.core.world_generators import WorldGenerator, batch_spec, parse_batch, parse_home, short_form
from benchbot.core.specs import (
    KIND_SCHEMAS, SPEC_SUFFIXES, VALID_STORE_FILE, Entry, entry_name, expand_spec_folders, load_spec_file, singular,
    valid_store, validate,
)


class Registry:
    """All content of all enabled plugins.

    Args:
        extra_plugins: plugins registered in addition to the entry points (see ``build_plugin_manager``).

    Attributes:
        entries: ``{kind: {name: Entry}}`` of every valid spec.
        problems: ``{(kind, name or source): one line}`` of every spec kept out (invalid, or a clash).
        notes: ``{(kind, name): one line}`` of every second source of a name that is no clash (identical in meaning,
            or replaced by a pack's ``--override``).
        overridden: ``{(kind, name): Entry}`` of every spec a pack's ``--override`` replaced.
        alternative_ground_truths: ``{environment: [Entry]}``: ground truths of environments that have one already
            (the default, in :attr:`entries`), which differ from it: other sets (:meth:`ground_truth_sets`).
        generators: ``{name: WorldGenerator}`` of the ``benchbot_world_generators`` hook
            (:mod:`benchbot.core.world_generators`); generated: ``(kind, name)`` of the entries they made on use (in
            :attr:`entries`, not in :meth:`names`).
        observations: ``{name: ObservationKind}``: the core's observation kinds
            (:data:`benchbot.core.observations.BUILT_IN`), then those of plugins (hook ``benchbot_observations``)
            that clash with none before them; the others are in :attr:`problems` under ``("observations", plugin)``.
    """

    def __init__(self, extra_plugins: dict | None = None) -> None:
        from benchbot.packs.pack_layout import cache_dir

        store = valid_store(cache_dir() / VALID_STORE_FILE)  # specs found valid by earlier commands
        self.plugin_manager, self.plugins = build_plugin_manager(extra_plugins)
        self.entries: dict[str, dict[str, Entry]] = {kind: {} for kind in KIND_SCHEMAS}
        self.problems: dict[tuple[str, str], str] = {}  # (kind, name or source) -> one-line problem
        self.notes: dict[tuple[str, str], str] = {}  # (kind, name) -> a second source that is no clash, one line
        self.overridden: dict[tuple[str, str], Entry] = {}  # (kind, name) -> the entry a pack's --override replaced
        self.alternative_ground_truths: dict[str, list[Entry]] = {}  # environment -> ground truths of other sets
        self.backend_factories: dict[str, tuple[str, Callable]] = {}
        infos = self._infos = {p.name: p for p in self.plugins}
        for kind, schema_name in KIND_SCHEMAS.items():
            for plugin, specs, exc in call_each_plugin(self.plugin_manager, f"benchbot_{kind}"):
                if exc is not None:
                    problem = f"plugin {plugin}: benchbot_{kind}() raised {exc!r}"
                    self.problems[(kind, plugin)] = problem
                    if plugin in infos:
                        infos[plugin].problems.append(problem)
                    continue
                for raw in expand_spec_folders(specs or []):
                    self._add(kind, schema_name, raw, plugin, infos.get(plugin))
        store.save()
        for plugin_name, factories, exc in call_each_plugin(self.plugin_manager, "benchbot_robot_backends"):
            if exc is not None or not isinstance(factories or {}, dict):  # the plugin offers nothing; others load
                problem = (f"plugin {plugin_name}: benchbot_robot_backends() raised {exc!r}" if exc is not None else
                           f"plugin {plugin_name}: benchbot_robot_backends() returned {type(factories).__name__}, "
                           "not a dict")
                self.problems[("robot_backends", plugin_name)] = problem
                if plugin_name in infos:
                    infos[plugin_name].problems.append(problem)
                continue
            for type_name, factory in (factories or {}).items():
                if type_name in self.backend_factories:
                    other = self.backend_factories[type_name][0]
                    self.problems[("robot_backends", type_name)] = (
                        f"robot type '{type_name}' is offered by plugins '{other}' and '{plugin_name}'"
                    )
                    if plugin_name in infos:
                        infos[plugin_name].problems.append(self.problems[("robot_backends", type_name)])
                    continue
                self.backend_factories[type_name] = (plugin_name, factory)
                if plugin_name in infos:
                    infos[plugin_name].registers.setdefault("robot_backends", []).append(type_name)
        self.generators: dict[str, WorldGenerator] = {}
        self.generated: set[tuple[str, str]] = set()  # (kind, name) of the entries a generator made on use
        self._generator_plugins: dict[str, str] = {}
        self._add_generators()
        self.observations: dict[str, observations.ObservationKind] = dict(observations.BUILT_IN)
        for plugin_name, kinds, exc in call_each_plugin(self.plugin_manager, "benchbot_observations"):
            if exc is not None:  # the plugin offers no kinds; the others load
                added, found = [], [f"plugin {plugin_name}: benchbot_observations() raised {exc!r}"]
            else:
                added, found = observations.add_offered(self.observations, plugin_name, kinds)
            if found:
                self.problems[("observations", plugin_name)] = "; ".join(found)
            if plugin_name in infos:
                infos[plugin_name].problems.extend(found)
                if added:
                    infos[plugin_name].registers.setdefault("observations", []).extend(added)

    def _add_generators(self) -> None:
        """:attr:`generators` from the ``benchbot_world_generators`` hook (its call policy)."""
        for plugin_name, gens, exc in call_each_plugin(self.plugin_manager, "benchbot_world_generators"):
            found = [f"plugin {plugin_name}: benchbot_world_generators() raised {exc!r}"] if exc is not None else []
            for gen in [] if exc is not None else list(gens or []):
                name = getattr(gen, "name", None)
                if not isinstance(gen, WorldGenerator) or not isinstance(name, str) or not name.isalnum() \
                        or not name.islower() or not name[0].isalpha():
                    found.append(f"plugin {plugin_name}: {gen!r} is no WorldGenerator with an alphanumeric name")
                elif name in self.generators:
                    found.append(f"world generator '{name}' is offered by plugins "
                                 f"'{self._generator_plugins[name]}' and '{plugin_name}'")
                else:
                    self.generators[name] = gen
                    self._generator_plugins[name] = plugin_name
                    if plugin_name in self._infos:
                        self._infos[plugin_name].registers.setdefault("world_generators", []).append(name)
            if found:
                self.problems[("world_generators", plugin_name)] = "; ".join(found)
                if plugin_name in self._infos:
                    self._infos[plugin_name].problems.extend(found)

    def _generated(self, kind: str, name: str) -> bool:
        """Register the specs a world generator makes for ``name`` (an environment or ground truth
        ``<home>:<variant>``, or a batch ``<generator>_<split>_<count>``); False when no generator owns the name.

        Raises:
            SpecError: a generator owns the name's pattern but cannot make it (unknown split, index out of range,
                a held-out split without its key, a spec that fails its schema).
        """
        if not self.generators or kind not in ("environments", "ground_truths", "batches"):
            return False
        if kind == "batches":
            found = parse_batch(name, self.generators)
            if found is None:
                return False
            gen, split, count = found
            self._add_checked(kind, batch_spec(gen, split, count), gen.name)
            return True
        home = parse_home(name.rpartition(":")[0] if ":" in name else name, self.generators)
        if home is None:
            return False
        gen = self.generators[home.generator]
        for k in ("environments", "ground_truths"):
            for spec in gen.content(k, home.split, home.index):
                if entry_name(k, spec) not in self.entries[k]:
                    self._add_checked(k, spec, gen.name)
        return True

    def _add_checked(self, kind: str, spec: dict, generator: str) -> None:
        """:meth:`_add` a generated spec; a spec it keeps out raises its problem (a generated name must resolve)."""
        plugin = self._generator_plugins[generator]
        before = set(self.problems)
        self._add(kind, KIND_SCHEMAS[kind], spec, plugin, None)
        self.generated.add((kind, entry_name(kind, spec)))
        new = [self.problems.pop(k) for k in set(self.problems) - before]
        if new:
            raise SpecError(f"world generator '{generator}': {new[0]}", "report it to the generator's plugin")

    def _add(self, kind: str, schema_name: str, raw: Any, plugin: str, info: PluginInfo | None) -> None:
        path = Path(raw).resolve() if isinstance(raw, (str, Path)) else None
        from_dict = path is None
        if from_dict and isinstance(raw, dict) and raw.get("_file_path"):
            path = Path(raw["_file_path"])  # a dict spec read (and adapted) from a file by its plugin
        source = str(path) if path else f"plugin {plugin} ({kind})"
        try:
            if not from_dict and path.is_dir():
                raise SpecError(f"{path}: a folder with no spec files ({', '.join(SPEC_SUFFIXES)}) in it", "")
            if not from_dict:
                spec = load_spec_file(path)
            else:
                try:
                    spec = dict(raw)
                except (TypeError, ValueError):
                    raise SpecError(f"{source}: expected a mapping or a file path, got {type(raw).__name__}", "") from None
                if spec.get(LOAD_ERROR_KEY):  # the plugin read the file and refuses it (content_packs)
                    raise SpecError(str(spec[LOAD_ERROR_KEY]), "")
            override = bool(spec.pop(OVERRIDE_KEY, False)) and is_pack_entry(plugin, path)
            validate({k: v for k, v in spec.items() if k != "_file_path"}, schema_name, source)
        except SpecError as exc:
            self.problems[(kind, source)] = exc.message
            if info is not None:
                info.problems.append(exc.message)
            return
        if path:
            spec["_file_path"] = str(path)
        name = entry_name(kind, spec)
        entry = Entry(kind, name, spec, plugin, path, override)
        if name in self.entries[kind]:
            first = self.entries[kind][name]
            kept = self._second_source(first, entry)
            if kept is None and kind == "ground_truths" and not first.override:  # another set of ground truths
                default, other = first, entry
                if is_pack_entry(first.plugin, first.path) and not is_pack_entry(plugin, path):
                    default, other = entry, first  # a plugin's stays the default over a pack's
                self.alternative_ground_truths.setdefault(name, []).append(other)
                self.notes[(kind, f"{name} ({other.plugin}: {other.path})")] = (
                    f"ground truth '{name}' of plugin '{other.plugin}' ({other.path or 'dict'}) is another set beside "
                    f"the one of plugin '{default.plugin}' ({default.path or 'dict'}), the default")
                kept = default
            if kept is None:
                self.problems[(kind, name)] = (
                    f"{singular(kind)} '{name}' is defined twice: by plugin '{first.plugin}' ({first.path or 'dict'}) "
                    f"and by plugin '{plugin}' ({path or 'dict'})"
                )
                if info is not None:
                    info.problems.append(self.problems[(kind, name)])
                return
            if kept is first:
                return
            first_info = self._infos.get(first.plugin)  # the second replaces the first: no longer registered by it
            if first_info is not None and name in first_info.registers.get(kind, []):
                first_info.registers[kind].remove(name)
        self.entries[kind][name] = entry
        if info is not None:
            info.registers.setdefault(kind, []).append(name)

    def _second_source(self, first: Entry, second: Entry) -> Entry | None:
        """Which of two entries of one name to keep (noting why in :attr:`notes`), or ``None`` for a clash.

        An override (a pack installed with ``--override``) wins over a spec that is not one; of two specs identical
        in meaning a plugin's is kept over a pack's, else the first.
        """
        key = (first.kind, first.name)
        what = f"{singular(first.kind)} '{first.name}'"

        def source(e: Entry) -> str:
            return f"plugin '{e.plugin}' ({e.path or 'dict'})"

        if first.override != second.override:
            kept, other = (first, second) if first.override else (second, first)
            self.notes[key] = f"{what} of {source(kept)} overrides the one of {source(other)} (--override)"
            self.overridden[key] = other
            return kept
        if not first.override and same_meaning(first.kind, first.spec, second.spec):
            plugin_second = is_pack_entry(first.plugin, first.path) and not is_pack_entry(second.plugin, second.path)
            kept, other = (second, first) if plugin_second else (first, second)
            self.notes[key] = (f"{what} of {source(other)} is identical in meaning to the one of {source(kept)}, "
                               "which is used")
            return kept
        return None

    def has(self, kind: str, name: str) -> bool:
        """Whether ``name`` of ``kind`` is registered, or a world generator makes it (then it is registered now:
        a generated home's environments and ground truths are found by name like listed ones).

        Raises:
            SpecError: a generator owns the name's pattern but cannot make it (e.g. a held-out split without its key).
        """
        if name in self.entries[kind]:
            return True
        return self._generated(kind, name) and name in self.entries[kind]

    def names(self, kind: str) -> list[str]:
        """Sorted names of every valid entry of ``kind`` that a plugin or pack lists (not those a world generator
        made on use: :attr:`generated`)."""
        return sorted(n for n in self.entries[kind] if (kind, n) not in self.generated)

    def entry(self, kind: str, name: str) -> Entry:
        """The entry ``name`` of ``kind``.

        Raises:
            SpecError: it does not exist (with close matches as the hint) or it has a recorded problem.
        """
        if (kind, name) in self.problems:
            raise SpecError(self.problems[(kind, name)], "remove or rename one of the two")
        if name not in self.entries[kind]:
            self._generated(kind, name)
        try:
            return self.entries[kind][name]
        except KeyError:
            raise SpecError(f"no {singular(kind)} named '{name}'", did_you_mean(name, self.names(kind), kind)) from None

    def get(self, kind: str, name: str) -> dict:
        """The spec ``name`` of ``kind`` (see :meth:`entry`)."""
        return self.entry(kind, name).spec

    def make_generated(self, env_strings: list[str], workers: int = 1,
                       on_start: Callable[[int, int], None] | None = None) -> int:
        """Make the generated homes of ``env_strings`` that are not made yet, up to ``workers`` at a time (through
        each generator's optional ``prepare(homes, workers)``; one at a time without it): a batch calls it before
        resolving its plan, so that a sweep over new homes does not make them one by one. ``on_start(homes,
        processes)`` is called before a generator starts. Returns the number of homes asked for (made or not).

        Raises:
            SpecError: as :meth:`scenes` for a malformed or impossible name.
        """
        wanted: dict[str, list[tuple[str, int]]] = {}
        for env in env_strings:
            name = self.canonical(env).partition(":")[0]
            home = parse_home(name, self.generators)
            if home is not None and not any(k.partition(":")[0] == name for k in self.entries["environments"]):
                wanted.setdefault(home.generator, []).append((home.split, home.index))
        for gen_name, homes in wanted.items():
            homes = list(dict.fromkeys(homes))
            prepare = getattr(self.generators[gen_name], "prepare", None)
            if callable(prepare) and len(homes) > 1:
                if on_start is not None:
                    on_start(len(homes), min(workers, len(homes)))
                prepare(homes, workers)
        return sum(len(h) for h in wanted.values())

    def canonical(self, env_string: str) -> str:
        """The environment string as results and run directories name it: a generated home's short form
        ``procedural:val:42[:VARIANT...]`` as ``procedural_val_42:1`` (or its variants); any other string unchanged.

        Raises:
            SpecError: a generator's short form that is malformed (:func:`benchbot.core.world_generators.short_form`).
        """
        return short_form(env_string, self.generators)

    def scenes(self, env_string: str) -> list[dict]:
        """The environment specs of an environment string: ``miniroom:1`` → one, ``miniroom:1:2`` → two
        (the name is everything before the first ':'; every later field is a variant, docs/original-benchbot.md);
        a generated home's short form ``procedural:val:42[:VARIANT...]`` is read as ``procedural_val_42:1`` (or its
        variants: :func:`benchbot.core.world_generators.short_form`).

        Raises:
            SpecError: malformed string or unknown environment.
        """
        name, _, variants = short_form(env_string, self.generators).partition(":")
        if not name or not variants or "" in variants.split(":"):
            raise SpecError(
                f"environment '{env_string}' is not of the form NAME:VARIANT[:VARIANT...]", "e.g. miniroom:1 or house:1:2"
            )
        return [self.get("environments", f"{name}:{v}") for v in variants.split(":")]

    def ground_truth(self, env_name: str, ground_truth_set: str | None = None) -> dict:
        """The ground truth of environment ``name:variant``: the default one, or that of the set
        ``ground_truth_set`` (:meth:`ground_truth_sets`; the original add-on's full name, such as
        ``ground_truths_bear_develop``, works too).

        Raises:
            SpecError: there is none (for that set: naming the sets that have one).
        """
        if ground_truth_set is None:
            return self.get("ground_truths", env_name)
        from benchbot.packs.original_addons import ground_truth_set_name

        sets = self.ground_truth_sets()
        chosen = ground_truth_set_name(ground_truth_set)
        if chosen not in sets:
            raise SpecError(f"no set of ground truths named '{ground_truth_set}'",
                            f"sets: {', '.join(sorted(sets)) or 'none'} (benchbot list ground_truths)")
        if env_name not in sets[chosen]:
            having = sorted(k for k, v in sets.items() if env_name in v)
            raise SpecError(f"ground-truth set '{chosen}' has no ground truth of '{env_name}'",
                            f"sets that have one: {', '.join(having) or 'none'}")
        return sets[chosen][env_name].spec

    def ground_truth_set(self, env_name: str) -> str:
        """The name of the set the default ground truth of ``env_name`` belongs to (:meth:`ground_truth_sets`)."""
        entry = self.entry("ground_truths", env_name)
        return self._set_of(entry)

    def _set_of(self, entry: Entry) -> str:
        from benchbot.packs.pack_layout import packs_dir
        from benchbot.packs.original_addons import ground_truth_set_of

        known = ground_truth_set_of(entry.spec)
        if known is not None:
            return known
        if is_pack_entry(entry.plugin, entry.path) and entry.path is not None:
            try:
                return Path(entry.path).resolve().relative_to(packs_dir().resolve()).parts[0]
            except (ValueError, IndexError, OSError):
                pass
        return entry.plugin

    def ground_truth_sets(self) -> dict[str, dict[str, Entry]]:
        """``{set: {environment: Entry}}`` of every set of ground truths: a ground-truth file that is an unchanged
        copy of one of the original's add-ons belongs to its set (``isaac_develop``, ``bear_develop``:
        :data:`benchbot.packs.original_addons.GROUND_TRUTH_SETS`), any other to the pack (or plugin) that gives it.
        ``bear_develop`` is also made from ``isaac_develop`` where the files are not installed (it moves one sink
        in miniroom:1, 2, 3 and 5: :func:`~benchbot.packs.original_addons.bear_develop_from_isaac_develop`), so the
        BEAR environments have both. Computed once (the files are hashed)."""
        cached = getattr(self, "_ground_truth_sets", None)
        if cached is not None:
            return cached
        from benchbot.packs.original_addons import GROUND_TRUTH_SETS, bear_develop_from_isaac_develop

        sets: dict[str, dict[str, Entry]] = {}
        every = [(name, e) for name, e in self.entries["ground_truths"].items()
                 if ("ground_truths", name) not in self.generated]
        every += [(name, e) for name, entries in self.alternative_ground_truths.items() for e in entries]
        for name, entry in every:
            sets.setdefault(self._set_of(entry), {}).setdefault(name, entry)
        isaac, bear = sets.get("isaac_develop", {}), sets.setdefault("bear_develop", {})
        for name, entry in isaac.items():
            if name in GROUND_TRUTH_SETS["bear_develop"].digests and name not in bear:
                bear[name] = Entry("ground_truths", name, bear_develop_from_isaac_develop(name, entry.spec),
                                   entry.plugin, entry.path)
        if not bear:
            del sets["bear_develop"]
        self._ground_truth_sets = sets
        return sets

    def unavailable_reason(self, kind: str, name: str) -> str:
        """Why the registered spec ``name`` of ``kind`` cannot be used on this machine (a robot whose type no
        installed plugin runs), or ``""``."""
        if kind != "robots" or name not in self.entries[kind]:
            return ""
        robot_type = str(self.entries[kind][name].spec.get("type"))
        if robot_type in self.backend_factories:
            return ""
        types = ", ".join(sorted(self.backend_factories)) or "none"
        return f"type '{robot_type}' needs a robot backend that no installed plugin provides (types here: {types})"

    def backend_factory(self, robot_type: str) -> Callable:
        """The robot-backend factory for robot ``type``.

        Raises:
            SpecError: no enabled plugin offers it.
        """
        if robot_type not in self.backend_factories:
            types = ", ".join(sorted(self.backend_factories)) or "none"
            raise SpecError(
                f"no plugin provides robots of type '{robot_type}' (available: {types})",
                "install the plugin for it (e.g. benchbot-sim-taichi for sim_taichi) or check BENCHBOT_DISABLE_PLUGINS",
            )
        return self.backend_factories[robot_type][1]

    def functions(self, kind: str, name: str) -> dict[str, Callable]:
        """The ``functions`` of a format or evaluator spec, imported: ``{function name: callable}``.

        The functions of a content pack's spec are checked before they are imported (only the pack's own code, when
        installed with ``--allow-code``, or modules of installed plugins' formats/evaluators; see
        :func:`benchbot.packs.content_packs.function_problem`) and after (the object must be defined there).

        Raises:
            SpecError: a function cannot be imported, or a pack may not name it.
        """
        entry = self.entry(kind, name)
        from_pack = is_pack_entry(entry.plugin, entry.path)
        out = {}
        for fn_name, path in entry.spec.get("functions", {}).items():
            where = f"{singular(kind)} '{name}' ({entry.path or entry.plugin}): functions.{fn_name}"
            problem = installed_function_problem(entry.path, path, self) if from_pack else None
            if problem:  # checked again here: the pack's files may have changed since `benchbot install`
                raise SpecError(f"{where}: {problem}; refusing to import it", "a content pack may only name its own "
                                "code (installed with --allow-code) or functions of installed plugins")
            try:
                out[fn_name] = import_object(path)
            except Exception as exc:  # ImportError, AttributeError, or the module failing as it is imported
                raise SpecError(
                    f"{where}: cannot import '{path}': {exc}", "check that the plugin providing it is installed",
                ) from None
            problem = imported_function_problem(path, out[fn_name]) if from_pack else None
            if problem:
                raise SpecError(f"{where}: {problem}; refusing to call it", "name the function where it is defined")
        return out


@functools.lru_cache(maxsize=1)
def get_registry() -> Registry:
    """The process-wide registry of the installed, enabled plugins (built once)."""
    return Registry()
