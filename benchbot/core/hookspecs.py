"""The hooks through which plugins extend BenchBot (pluggy project name ``benchbot``).

A plugin is a module registered under the entry-point group ``benchbot``; it implements any of these hooks with
the :data:`hookimpl` marker. Content hooks return *specs*: a path to a YAML/JSON file, a dict, or a folder of spec files. The core
validates every spec against ``schemas/<kind>.schema.json`` and indexes it by name (environments by
``name:variant``); a duplicate name is an error naming both plugins.

Plugin modules must import nothing heavy (taichi, rclpy, ray) at import time: do it inside the factories.
"""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Union

import pluggy

if TYPE_CHECKING:  # pragma: no cover
    from benchbot.core.core_settings import Setting
    from benchbot.core.observations import ObservationKind
    from benchbot.core.robot import RobotBackend

PROJECT_NAME = "benchbot"
ENTRY_POINT_GROUP = "benchbot"

hookspec = pluggy.HookspecMarker(PROJECT_NAME)
hookimpl = pluggy.HookimplMarker(PROJECT_NAME)

Spec = Union[str, Path, dict]

SPEC_HOOK_SECTIONS = """Returns:
    A list of specs. Each is a dict; or a path (``str``/``Path``) of a YAML/JSON file (its folder is the spec's
    folder, recorded as ``_file_path``); or a path of a folder, standing for every ``.yaml``, ``.yml`` and ``.json``
    file directly in it, by name (``return [Path(__file__).parent / "tasks"]``).

Called:
    Once per process, when the registry is built (first use of any content).

Call policy:
    every implementation is called; their lists are concatenated. Each spec is validated against its schema; an
    invalid spec or a name clash is skipped and reported (``benchbot plugins``), the rest still load."""


def declared(since: str, *, spec: bool = False, replaced_by: str | None = None) -> Callable[[Callable], Callable]:
    """Declare a hook (a decorator): the hookspec of ``function``, whose docstring gets a ``Since:`` section (the
    BenchBot version that added it) and, for a content hook returning specs (``spec``), the sections every such
    hook shares (:data:`SPEC_HOOK_SECTIONS`).

    A hook being retired keeps working for a release with ``replaced_by`` set: its docstring says so and pluggy
    warns every plugin that implements it, when the plugin is registered (a ``DeprecationWarning`` naming the hook
    and its replacement; pluggy's ``warn_on_impl``).

    Args:
        since: the version, e.g. ``"0.1"``.
        spec: the hook returns specs (a content hook).
        replaced_by: the hook to implement instead, when this one is deprecated.
    """
    def declare(function: Callable) -> Callable:
        doc = inspect.cleandoc(function.__doc__ or "")
        if spec:
            doc += "\n\n" + SPEC_HOOK_SECTIONS
        doc += f"\n\nSince:\n    BenchBot {since}."
        warning = None
        if replaced_by:
            doc += f" Deprecated: implement ``{replaced_by}`` instead; it goes in the next minor release."
            warning = DeprecationWarning(f"the hook {function.__name__} is deprecated: implement {replaced_by} "
                                         "instead")
        function.__doc__ = doc
        return hookspec(warn_on_impl=warning)(function)

    return declare


class ContentHooks:
    """Hooks returning content specs. Call policy: every implementation is called once, when the registry is
    built (asset packs: when the asset library is first used); the results of all plugins are concatenated."""

    @declared("0.1", spec=True)
    def benchbot_tasks(self) -> list[Spec]:
        """Task specs (schema ``task``): ``name``, ``actions``, ``observations``, ``localisation``,
        ``results_format``, ``scene_count``, ``description``."""

    @declared("0.1", spec=True)
    def benchbot_robots(self) -> list[Spec]:
        """Robot specs (schema ``robot``): ``name``, ``type`` (selects the robot backend), ``global_frame``,
        ``robot_frame``, ``poses``, ``connections``."""

    @declared("0.1", spec=True)
    def benchbot_environments(self) -> list[Spec]:
        """Environment specs (schema ``environment``): ``name``, ``variant``, ``type``, ``map_path``,
        ``start_pose`` ``[qw,qx,qy,qz,x,y,z]`` (map frame, metres), ``trajectory_poses``, ``object_labels``.
        Indexed as ``name:variant``."""

    @declared("0.1", spec=True)
    def benchbot_formats(self) -> list[Spec]:
        """Results-format specs (schema ``format``): ``name`` and ``functions`` (``create``,
        ``create_object``, ``validate`` as ``"module:attr"`` import paths)."""

    @declared("0.1", spec=True)
    def benchbot_evaluators(self) -> list[Spec]:
        """Evaluation-method specs (schema ``evaluator``): ``name``, ``valid_result_formats``,
        ``valid_ground_truth_formats``, ``functions`` (``evaluate(results, ground_truths) -> dict``, optional
        ``combine(list) -> dict``), and ``scores``: what ``evaluate`` returns under ``scores`` (each score's
        ``name``, ``direction``, ``range``, ``kind``, ``description``; exactly one ``primary``), which every view
        reads (docs/evaluation.md, "Declaring scores")."""

    @declared("0.1", spec=True)
    def benchbot_examples(self) -> list[Spec]:
        """Example-solution specs (schema ``example``): ``name``, ``native_command`` (run from the spec's
        folder, so give files or folders, not dicts), ``description``, ``reads_ground_truth`` (an example that reads
        the ground truth on purpose: it runs only unsandboxed)."""

    @declared("0.1", spec=True)
    def benchbot_batches(self) -> list[Spec]:
        """Batch specs (schema ``batch``): ``name`` and ``environments`` (a list of environment strings)."""

    @declared("0.1", spec=True)
    def benchbot_ground_truths(self) -> list[Spec]:
        """Ground-truth specs (schema ``ground_truth``): ``{environment, format, ground_truth}`` as in the
        original BenchBot's ground-truth JSON files; found by the environment's ``name:variant``."""

    @declared("0.1")
    def benchbot_asset_packs(self) -> list[Path]:
        """Asset packs: 3D models (GLB) that simulators draw ground-truth objects and furniture with.

        A pack is a folder with ``manifest.json`` (schema ``asset_manifest``), the ``*.glb`` files it lists
        (glTF 2.0: metres, +Y up, front +Z, origin at the centre of the bottom of the bounds) and
        ``ATTRIBUTION.md``. Each asset has an ``id``, a ``class`` (a ground-truth class, or null for furniture that
        is never an object), a ``kind``, a ``role`` (``object``/``distractor``/``structure``), its size, licence
        and creator (see ``benchbot.packs.assets``).

        Returns:
            A list of paths (``str``/``Path``) of ``manifest.json`` files.

        Called:
            Once per process, by ``benchbot.packs.assets.asset_library()``, when a simulator first needs models
            (not when the registry is built).

        Call policy:
            every implementation is called; the packs are merged into one library. An invalid manifest, or a hook
            that raises, leaves that pack out (reported in ``AssetLibrary.problems``); an asset id already used by
            another pack leaves that asset out. The other packs still load.
        """

    @declared("0.1")
    def benchbot_observations(self) -> list[ObservationKind]:
        """Observation kinds of a plugin's own sensors (an IMU, a bumper), beside the core's (docs/observations.md).

        Each is a ``benchbot.core.observations.ObservationKind``, declared once: its name (the key in the
        observations, and in task and robot specs), its structure (shapes, dtypes, units, frame), its structure
        check, its recorder channels (topic, ROS 2 message type, converters to messages and back, and the type's
        definition when it is not a standard one), its Gym space and value, its visualiser views. The recorder,
        the replay, the Gym environment and the contract checks read it from the registry
        (``Registry.observations``); the plugin's robot backend produces the observation, a task asks for it by
        name (docs/plugin-guide.md, "Adding a sensor").

        Returns:
            A list of ``ObservationKind``.

        Called:
            Once per process, when the registry is built.

        Call policy:
            every implementation is called; the kinds join the core's, in plugin order. A kind whose name,
            channel key or topic is taken (by the core's kinds, the recorder's own topics or an earlier plugin's
            kind), that the episode would have to build (``sensor=False``), whose channel type has no definition,
            or that is not an ``ObservationKind`` is left out and reported (``benchbot plugins``); an
            implementation that raises offers nothing and is reported; the other kinds still load.
        """


class BehaviourHooks:
    """Hooks that add behaviour."""

    @declared("0.2")
    def benchbot_world_generators(self) -> list[Any]:
        """Generators of worlds: environments made on demand, too many to list (``benchbot.core.world_generators``).

        Returns:
            A list of ``benchbot.core.world_generators.WorldGenerator``: each has a ``name`` and ``splits``; its
            homes are named ``<name>_<split>_<index>`` (short form ``<name>:<split>:<index>``), its batches
            ``<name>_<split>_<count>``; ``content(kind, split, index)`` gives the environment and ground-truth specs
            of one home's variants, ``describe(split)`` a few words per split for ``benchbot list environments``.

        Called:
            Once per process, when the registry is built; a generator's ``content`` when a name it owns is first
            asked for.

        Call policy:
            every implementation is called; the lists are concatenated. A generator whose name is taken (by an
            earlier generator), or that is no ``WorldGenerator``, is left out and reported (``benchbot plugins``);
            an implementation that raises offers nothing and is reported.
        """

    @declared("0.1")
    def benchbot_robot_backends(self) -> dict[str, Callable[..., "RobotBackend"]]:
        """Robot backends (simulators, real robots) by robot ``type``.

        Returns:
            ``{robot type: factory}``; ``factory(robot_spec: dict, options: dict) -> RobotBackend`` builds a backend
            for robots whose spec has that ``type`` (see ``benchbot.core.robot``). Import heavy modules inside the
            factory, not at module level.

        Called:
            Once per process, when the registry is built.

        Call policy:
            every implementation is called; the dicts are merged. A type offered by two plugins is an error: the
            second is skipped and reported; an implementation that raises offers nothing and is reported
            (``benchbot plugins``), and the other plugins' backends still load.
        """

    @declared("0.2")
    def benchbot_settings(self) -> list[Setting]:
        """The environment variables a plugin reads, declared once (as conda's ``conda_settings``): ``benchbot
        doctor`` shows each with its effective value, where the value came from and the plugin that reads it, and
        ``benchbot.core.settings.get`` finds it by name (docs/plugin-guide.md, "Settings").

        Returns:
            A list of ``benchbot.core.settings.Setting``: ``name`` (``BENCHBOT_<WORDS>``, upper case; another
            program's variable that the plugin reads too, such as ``ROS_DOMAIN_ID``, with ``external=True``),
            ``default`` (text, or ``None``), ``meaning`` (a phrase), optionally ``secret`` (never shown or recorded)
            and ``reader`` (text to value, raising ``ValueError`` with a reason: ``settings.value`` applies it,
            ``benchbot doctor`` marks a value it rejects). The plugin's code reads them through these declarations
            (``settings.get(MY_SETTING)``), so keep them in a module of their own that the plugin's other modules
            import. ``owner`` is set by the core to the plugin's entry-point name.

        Called:
            Once per process, when a setting that is not the core's is first looked up by name, or when all are
            listed (``benchbot doctor``, a batch recording the settings of an episode's backend plugin); through
            the plugin manager alone, without building the registry.

        Call policy:
            every implementation is called; the lists are concatenated after the core's settings, in plugin order.
            A declaration whose name is not ``BENCHBOT_`` and upper-case words (unless ``external``), whose name
            is declared already (by the core, an earlier plugin or the same one), or that is not a ``Setting`` is
            left out; an implementation that raises offers nothing. Each is one line of ``benchbot doctor``'s
            ``settings`` check, naming the plugin; the other declarations still count.
        """

    @declared("0.1")
    def benchbot_commands(self, app: Any) -> None:
        """Add commands to the ``benchbot`` CLI.

        Args:
            ``app``: the ``typer.Typer`` application of the ``benchbot`` command; add commands with
                ``@app.command()`` or sub-apps with ``app.add_typer``.

        Returns:
            Nothing (results are ignored).

        Called:
            Once, when the ``benchbot`` command starts, before it parses its arguments.

        Call policy:
            every implementation is called; results are ignored; one that raises adds no commands and the CLI
            still starts, with a one-line warning naming the plugin.
        """


class ObserverHooks:
    """Hooks that observe episodes (TUI, recorders, progress bars). Nothing in the data path depends on them;
    every implementation is called, results are ignored, and they must return quickly."""

    @declared("0.1")
    def benchbot_episode_started(self, info: dict) -> None:
        """An episode started.

        Args:
            ``info``: ``task`` (name), ``robot`` (name), ``environments`` (list of ``name:variant``).

        Returns:
            Nothing (results are ignored).

        Called:
            On the backend thread, once the robot backend and the episode are built, before the first action.

        Call policy:
            every implementation is called; results are ignored; it must return quickly.
        """

    @declared("0.1")
    def benchbot_step(self, info: dict) -> None:
        """An action was executed.

        Args:
            ``info``: ``step`` (int), ``action`` (str or None), ``args`` (dict), ``result``
                (``SUCCESS``/``FINISHED``/``COLLISION``), ``scene_number`` (int), ``pose`` ((3,) x m, y m, yaw rad,
                map frame).

        Returns:
            Nothing (results are ignored).

        Called:
            On the backend thread after every action of the episode.

        Call policy:
            every implementation is called; results are ignored; it must return quickly.
        """

    @declared("0.1")
    def benchbot_episode_finished(self, info: dict) -> None:
        """An episode ended.

        Args:
            ``info``: ``steps`` (int), ``collided`` (bool), ``finished`` (bool).

        Returns:
            Nothing (results are ignored).

        Called:
            On the backend thread when the episode's service closes: a batch episode's end, ``benchbot run`` or
            ``benchbot replay`` stopping, ``BackendService.close()``; once per service.

        Call policy:
            every implementation is called; results are ignored; it must return quickly.
        """


HOOK_CLASSES = (ContentHooks, BehaviourHooks, ObserverHooks)
