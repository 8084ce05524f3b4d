"""The resident simulator service: one process per user, machine and installation that keeps the simulator warm
between commands (docs/service.md).

``benchbot batch`` starts it on first use (or ``benchbot service start`` does) and asks it for each episode's backend;
the command itself stays thin: it resolves the run, runs the solution (sandboxed exactly as without the service),
scores and writes the results. The service keeps what every command would otherwise pay again: its plugins loaded,
Taichi initialised on its one backend thread, the kernels compiled, and the scenes it loaded (each simulator shares
loaded scenes by content, as ``benchbot_sim_taichi.loaded_scenes`` does). It stops after
``BENCHBOT_SERVICE_IDLE_S`` seconds without a client; ``BENCHBOT_SERVICE=off`` or ``--no-service`` runs everything in
the command's own process, as before. Results are byte-identical either way.

Its modules:

* :mod:`~benchbot.service.location`: where it lives (a 0700 folder of the user's), which service serves this
  installation (:func:`~benchbot.service.location.installation_key`), its socket, lock and log;
* :mod:`~benchbot.service.protocol`: length-prefixed MessagePack messages on its Unix socket, and the check of the
  peer's credentials (same user, same user namespace: never a sandboxed solution);
* :mod:`~benchbot.service.daemon`: the service process (``python -m benchbot.service.daemon``);
* :mod:`~benchbot.service.pool` and :mod:`~benchbot.service.worker`: its pool of warm simulator worker processes,
  which serve ``batch --workers N`` and GPU batches (each worker with its Taichi threads and its GPU);
* :mod:`~benchbot.service.client`: starting, finding, asking and stopping it;
* :mod:`~benchbot.service.episodes`: an episode's served backend, in this process or in the service, behind one
  interface (what :func:`benchbot.batch.episode_runner.run_episode` uses).
"""

_RESIDENT = False


def set_resident(on: bool = True) -> None:
    """Mark this process as resident: it serves backends one episode after another for other processes (the service
    process calls it as it starts, :func:`benchbot.service.daemon.main`)."""
    global _RESIDENT
    _RESIDENT = bool(on)


def resident() -> bool:
    """Whether this process is resident (:func:`set_resident`): a simulator may then keep what it loaded for an
    episode (a scene and its upload) after the episode, for the next (``benchbot_sim_taichi.loaded_scenes`` keeps a
    few), instead of freeing it at once. False in every other process (a command, a test, a Gym environment)."""
    return _RESIDENT
