"""A Gymnasium vector environment over several devices: ``gym.make_vec("BenchBot-v0", num_envs=N, devices=G)``
spreads N batched sub-environments over G GPUs (docs/gym.md, *Several GPUs*).

Taichi drives one device per process, so the sub-environments are cut into G contiguous slices (``split_envs``):
slice 0 is a :class:`benchbot.gym_vector.BenchBotVectorEnv` in this process, on its device (CUDA device 0 of
``CUDA_VISIBLE_DEVICES``); slice ``g`` > 0 is one in a worker process of its own (a new interpreter, with
``CUDA_VISIBLE_DEVICES`` narrowed to GPU ``g`` before its Taichi starts). Every ``step`` sends each worker its
slice's actions, steps slice 0 here meanwhile, then gathers the workers' answers: the slices run in lockstep and in
parallel. Each sub-environment is the one a single-device vector environment of the same arguments would have at
the same index (same scene, seed, actions, images byte for byte): its robots are independent of the others'.

How observations come back:

* ``on_device=False``: NumPy arrays of all N sub-environments, as with one device. A worker writes its slice into
  shared memory (:mod:`multiprocessing.shared_memory`) that this process made; this process copies the slices into
  the arrays it returns (the caller owns them).
* ``on_device=True`` on CUDA: each image entry (``image_rgb``, ``image_depth``) is a **tuple of G arrays, one per GPU
  in the order of** ``devices``, entry ``g`` holding the images of slice ``g`` (``env.slices[g]``) in that GPU's
  memory, exporting DLPack and the CUDA Array Interface on that device (``torch.from_dlpack(obs["image_rgb"][1])`` is a
  tensor on ``cuda:1``). A worker's frames are shared by CUDA IPC (``DeviceArray.share``: ``cuIpcGetMemHandle``
  in the worker, once per buffer; ``cuIpcOpenMemHandle`` here in that GPU's primary context, once): Taichi 1.7's
  own buffers cannot be exported, so the worker copies each frame device to device into a shareable buffer. The
  worker waits for its kernels and that copy before it answers; before the next ``step``/``reset`` this process waits
  for its own work queued on each worker's GPU (your reads of the frames, on any stream), so no frame is written
  over while read. The laser and pose are NumPy arrays of all N, as with one device (from the second answer on, a
  worker writes them into shared memory too, as every array that came through the pipe).
* ``on_device=True`` on the CPU (``devices=["cpu", "cpu"]``: processes on the CPU, for tests and CPU nodes): the same
  tuples, of NumPy views (slice 0 the renderer's buffer, the others shared memory); overwritten by the next step.
"""

from __future__ import annotations

import importlib
import multiprocessing
import os
import subprocess
import sys
from multiprocessing import shared_memory
from typing import Any, Sequence

import numpy as np

#: What ``devices`` accepts, for the one-line errors.
DEVICES_HELP = ("devices must be 1 (this process's device), 'all' (every visible GPU), a GPU count >= 1, a list of "
                "distinct GPU ordinals starting with 0 (e.g. [0, 1]), or a list of 'cpu' (processes on the CPU)")


def resolve_devices(devices: Any, arch: str | None) -> list[int | str]:
    """``devices`` as a list: GPU ordinals (of this process's visible devices, the first 0: this process's own) or
    ``"cpu"`` entries, one per slice. ``arch`` is the options' ``arch`` (else ``BENCHBOT_TAICHI_ARCH``).

    Raises:
        ValueError: one line: a value not described by :data:`DEVICES_HELP`, GPUs without ``arch`` ``'cuda'``
            (or ``'gpu'``), more GPUs than are visible, or ``'cpu'`` entries with a GPU arch.
        UsageError: no ``arch`` given and ``BENCHBOT_TAICHI_ARCH`` has no valid value (one line naming it).
    """
    arch = (arch or _default_arch()).strip().lower()
    on_gpu = arch in ("cuda", "gpu")
    if devices is None or (isinstance(devices, int) and not isinstance(devices, bool) and devices == 1):
        return ["cpu"] if not on_gpu else [0]
    if isinstance(devices, (list, tuple)) and devices and all(d == "cpu" for d in devices):
        if on_gpu:
            raise ValueError(f"devices={list(devices)!r} runs on the CPU but options arch is {arch!r}: use GPU "
                             "ordinals, or arch 'cpu'")
        return ["cpu"] * len(devices)
    if devices == "all":
        ordinals = list(range(_visible_gpus(arch, devices)))
    elif isinstance(devices, int) and not isinstance(devices, bool) and devices >= 1:
        ordinals = list(range(devices))
    elif (isinstance(devices, (list, tuple)) and devices and all(isinstance(d, int) and not isinstance(d, bool)
                                                                  for d in devices)
          and devices[0] == 0 and len(set(devices)) == len(devices) and min(devices) >= 0):
        ordinals = list(devices)
    else:
        raise ValueError(f"{DEVICES_HELP}; got {devices!r}")
    visible = _visible_gpus(arch, devices)
    if max(ordinals) >= visible:
        raise ValueError(f"devices={devices!r} needs GPU {max(ordinals)}, but this process sees {visible} GPU(s): "
                         "check CUDA_VISIBLE_DEVICES, or ask for fewer")
    return ordinals


def _default_arch() -> str:
    """The simulator's arch setting (``BENCHBOT_TAICHI_ARCH``, declared by the simulator plugin, read by its reader),
    ``"cpu"`` where no enabled plugin declares it.

    Raises:
        UsageError: the variable's value is none its reader takes: one line naming it and the fix."""
    from benchbot.core import settings

    try:
        return settings.value("BENCHBOT_TAICHI_ARCH") or "cpu"
    except KeyError:
        return "cpu"


def _visible_gpus(arch: str, devices: Any) -> int:
    if arch not in ("cuda", "gpu"):
        raise ValueError(f"devices={devices!r} places sub-environments on GPUs, but options arch is {arch!r}: pass "
                         "options={'arch': 'cuda'}, or devices=['cpu', 'cpu'] for processes on the CPU")
    from benchbot.batch.gpus import visible_gpus  # the GPUs nvidia-smi lists, narrowed by CUDA_VISIBLE_DEVICES

    return len(visible_gpus())


def split_envs(num_envs: int, parts: int) -> list[tuple[int, int]]:
    """``parts`` contiguous ``(start, stop)`` slices of ``range(num_envs)``, sizes differing by at most one (the
    first ones larger).

    Raises:
        ValueError: fewer sub-environments than parts.
    """
    if num_envs < parts:
        raise ValueError(f"num_envs={num_envs} cannot be spread over {parts} devices: give at least one "
                         "sub-environment per device")
    base, extra = divmod(num_envs, parts)
    bounds, start = [], 0
    for g in range(parts):
        stop = start + base + (1 if g < extra else 0)
        bounds.append((start, stop))
        start = stop
    return bounds


def _visible_after(ordinal: int) -> str:
    """``CUDA_VISIBLE_DEVICES`` for a worker on this process's GPU ``ordinal`` (the parent's own list applied)."""
    parent = os.environ.get("CUDA_VISIBLE_DEVICES")
    if parent is None or not parent.strip():
        return str(ordinal)
    return [p.strip() for p in parent.split(",")][ordinal]


# ------------------------------------------------------------------------------------------------- the worker side
def serve_fd(fd: int) -> None:
    """A worker process's main function: ``python -c "...serve_fd(FD)"`` started by :class:`_Worker` with
    ``CUDA_VISIBLE_DEVICES`` narrowed to its GPU, ``FD`` the worker's end of a ``multiprocessing.Pipe``. Reads the
    keyword arguments of its slice's one-device vector environment, builds it, then answers ``reset``, ``step``,
    ``blocks`` and ``close`` messages until ``close`` or the pipe closes. Observations named in a ``blocks`` message
    (``{key: shared memory block name}``) are written there from then on; a CUDA image is answered with its IPC
    description (``DeviceArray.share``); the rest travels through the pipe. An exception is sent back, not raised."""
    from multiprocessing.connection import Connection

    conn = Connection(fd)
    blocks: dict[str, shared_memory.SharedMemory] = {}
    env = None
    try:
        from benchbot.gym_vector import BenchBotVectorEnv

        env = BenchBotVectorEnv(**conn.recv())
        conn.send(("ok", None))
    except BaseException as exc:  # noqa: BLE001 - sent to the main process, which raises it
        conn.send(("error", _portable(exc)))
        return
    try:
        while True:
            try:
                command, payload = conn.recv()
            except EOFError:
                return
            if command == "close":
                return
            if command == "blocks":
                blocks.update({key: _attached(name) for key, name in payload.items()})
                conn.send(("ok", None))
                continue
            try:
                conn.send(("ok", _answer(env, command, payload, blocks)))
            except BaseException as exc:  # noqa: BLE001
                conn.send(("error", _portable(exc)))
    finally:
        env.close()
        for block in blocks.values():
            block.close()


def _attached(name: str) -> shared_memory.SharedMemory:
    """The main process's shared memory block ``name``, attached without this process's resource tracker
    unlinking it at exit (Python < 3.13 registers attached blocks too; the main process owns and unlinks them)."""
    from multiprocessing import resource_tracker

    block = shared_memory.SharedMemory(name=name)
    try:
        resource_tracker.unregister(block._name, "shared_memory")  # noqa: SLF001
    except Exception:  # noqa: BLE001 - no tracker running: nothing to undo
        pass
    return block


def _answer(env: Any, command: str, payload: Any, blocks: dict) -> tuple:
    from benchbot.gym_vector import _on_backend_thread

    if command == "reset":
        mask = payload
        if mask.any():
            obs, info = env.reset(options={"reset_mask": mask})
        else:  # nothing of this slice is reset: its current observation, as the one-device env re-renders it
            obs = _on_backend_thread(env._observe)
            info = {"scene_number": np.zeros(len(mask), dtype=np.int64), "_scene_number": mask.copy()}
        return _pack(obs, blocks), info
    if command == "step":
        obs, rewards, terminated, truncated, info = env.step(payload)
        return _pack(obs, blocks), rewards, terminated, truncated, info
    raise ValueError(f"unknown worker command {command!r}")


def _pack(obs: dict, blocks: dict) -> dict:
    """The worker's observations for the pipe: ``("shm",)`` once written into their block, ``("ipc", opener,
    args)`` for a CUDA image, else the value."""
    from benchbot.gym_vector import _on_backend_thread

    out = {}
    for key, value in obs.items():
        if key in blocks:
            value = np.asarray(value)
            np.copyto(np.ndarray(value.shape, value.dtype, buffer=blocks[key].buf), value)
            out[key] = ("shm",)
        elif hasattr(value, "share"):  # described once per buffer by the array itself; on Taichi's thread
            out[key] = ("ipc",) + _on_backend_thread(value.share)
        else:
            out[key] = ("value", value)
    return out


def _portable(exc: BaseException) -> BaseException:
    """``exc`` if it survives pickling, else a ``RuntimeError`` with its one-line message."""
    import pickle

    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:  # noqa: BLE001
        return RuntimeError(f"{type(exc).__name__}: {exc}")


# ------------------------------------------------------------------------------------------------- the main side
class _Worker:
    """One worker process, its slice, its shared memory blocks and the device arrays mapped from it."""

    def __init__(self, device: int | str, bounds: tuple[int, int], kwargs: dict) -> None:
        self.device, self.bounds = device, bounds
        self.count = bounds[1] - bounds[0]
        self.blocks: dict[str, shared_memory.SharedMemory] = {}
        self.shapes: dict[str, tuple] = {}
        self.mapped: dict[str, tuple[tuple, Any]] = {}  # key -> (description, DeviceArray)
        self.pending: dict[str, tuple] = {}  # arrays that came through the pipe: shared memory for them next
        self.conn, child = multiprocessing.Pipe()
        environ = dict(os.environ)
        environ["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)  # imports resolve as they do here
        if device != "cpu":
            environ["CUDA_VISIBLE_DEVICES"] = _visible_after(int(device))
        code = "import sys; from benchbot.gym_devices import serve_fd; serve_fd(int(sys.argv[1]))"
        self.process = subprocess.Popen([sys.executable, "-c", code, str(child.fileno())], env=environ,
                                        pass_fds=[child.fileno()])
        child.close()
        self.conn.send({**kwargs, "num_envs": self.count})

    def attach(self, shapes: dict[str, tuple]) -> None:
        """Give the (started) worker shared memory for the observations ``shapes`` (``{key: (its slice's shape,
        dtype)}``) that have none yet; it writes them there from its next answer on.

        Raises:
            MemoryError: ``/dev/shm`` has less room than the new blocks take (:func:`_check_shared_memory`).
        """
        _check_shared_memory(sum(int(np.prod(shape)) * np.dtype(dtype).itemsize for key, (shape, dtype)
                                 in shapes.items() if key not in self.blocks))
        names = {}
        for key, (shape, dtype) in shapes.items():
            if key not in self.blocks:
                self.shapes[key] = (tuple(shape), np.dtype(dtype))
                size = max(1, int(np.prod(shape)) * np.dtype(dtype).itemsize)
                self.blocks[key] = shared_memory.SharedMemory(create=True, size=size)
                names[key] = self.blocks[key].name
        if names:
            self.send(("blocks", names))
            self.receive()

    def send(self, message: tuple) -> None:
        """Send ``message`` (``(command, payload)``); a one-line ``RuntimeError`` if the worker died."""
        try:
            self.conn.send(message)
        except OSError:  # BrokenPipeError, ConnectionResetError
            raise self._died() from None

    def receive(self) -> Any:
        """The worker's answer; raises what it raised, or a one-line ``RuntimeError`` if it died."""
        try:
            status, value = self.conn.recv()
        except (EOFError, OSError):
            raise self._died() from None
        if status == "error":
            raise value
        return value

    def _died(self) -> RuntimeError:
        try:
            code = self.process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            code = None
        return RuntimeError(f"the vector environment's worker for sub-environments {self.bounds[0]}.."
                            f"{self.bounds[1] - 1} on {self._where()} exited (code {code}): close this environment "
                            "and make a new one")

    def _where(self) -> str:
        return "the CPU" if self.device == "cpu" else f"cuda:{self.device}"

    def unpack(self, packed: dict) -> dict:
        """The worker's observations here: shared-memory views, mapped device arrays, or the values."""
        out = {}
        for key, item in packed.items():
            if item[0] == "shm":
                shape, dtype = self.shapes[key]
                out[key] = np.ndarray(shape, dtype, buffer=self.blocks[key].buf)
            elif item[0] == "ipc":
                out[key] = self._mapped(key, item[1], item[2])
            else:  # through the pipe: an array goes through shared memory from the next step on (_gather)
                out[key] = item[1]
                if isinstance(item[1], np.ndarray) and item[1].dtype != object:
                    self.pending[key] = (item[1].shape, item[1].dtype)
        return out

    def _mapped(self, key: str, opener: str, args: tuple) -> Any:
        old = self.mapped.get(key)
        if old is not None and old[0] == (opener, args):
            return old[1]
        module, name = opener.split(":")
        array = getattr(importlib.import_module(module), name)(*args, device_id=int(self.device))
        if old is not None:
            old[1].release()
        self.mapped[key] = ((opener, args), array)
        return array

    def wait_for_readers(self) -> None:
        """Before the worker writes its next frame: wait for this process's reads of the mapped ones."""
        if self.mapped:
            next(iter(self.mapped.values()))[1].wait_for_readers()

    def close(self) -> None:
        for _, array in self.mapped.values():
            array.release()
        self.mapped = {}
        if self.process.poll() is None:
            try:
                self.conn.send(("close", None))
            except (BrokenPipeError, OSError):
                pass
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=5)
        self.conn.close()
        for block in self.blocks.values():
            block.close()
            block.unlink()
        self.blocks = {}


class _MultiDeviceMethods:
    """The methods of :class:`MultiDeviceVectorEnv` (which adds Gymnasium's ``VectorEnv``:
    :func:`make_multi_device_class`)."""

    def __init__(self, num_envs: int = 1, *, devices: Any = "all", on_device: bool = False,
                 env: str | Sequence[str] | None = None, options: dict | None = None, **kwargs: Any) -> None:
        from gymnasium.vector.utils import batch_space

        from benchbot.gym import DEFAULT_ENV
        from benchbot.gym_vector import BenchBotVectorEnv, _environment_list

        if isinstance(num_envs, bool) or not (isinstance(num_envs, int) and num_envs >= 1):
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        #: one entry per slice: a GPU ordinal of this process, or ``"cpu"``
        self.devices = resolve_devices(devices, (options or {}).get("arch"))
        #: ``(start, stop)`` of the sub-environments of each device, in the order of :attr:`devices`
        self.slices = split_envs(num_envs, len(self.devices))
        self.num_envs, self.on_device = num_envs, bool(on_device)
        names = _environment_list(DEFAULT_ENV if env is None else env, num_envs)
        common = {**kwargs, "options": options, "on_device": on_device}

        def slice_kwargs(bounds: tuple[int, int]) -> dict:
            part = names[bounds[0]:bounds[1]]
            return {**common, "env": part[0] if len(set(part)) == 1 else part}

        self._workers: list[_Worker] = []
        self._local = None
        try:
            for device, bounds in zip(self.devices[1:], self.slices[1:]):  # they build while this process does
                self._workers.append(_Worker(device, bounds, slice_kwargs(bounds)))
            start, stop = self.slices[0]
            self._local = BenchBotVectorEnv(stop - start, **slice_kwargs(self.slices[0]))
            for worker in self._workers:
                worker.receive()
            if not self.on_device:  # the host path; on_device: after the first answer (what is not shared by IPC)
                for worker in self._workers:
                    worker.attach({key: ((worker.count,) + tuple(sub.shape), sub.dtype)
                                   for key, sub in self._local.single_observation_space.spaces.items()})
        except BaseException:
            self.close_extras()
            raise
        local = self._local
        self.render_mode, self.metadata = local.render_mode, local.metadata
        self.single_action_space = local.single_action_space
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.single_observation_space = local.single_observation_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self._last: dict[str, Any] = {}

    def _gather(self, local_answer: Any, message: tuple) -> list:
        """Send ``message`` (``(command, per-worker payloads)``) to every worker, run ``local_answer()`` here
        meanwhile, then collect every answer (all of them, even if one raised: the workers stay in lockstep)."""
        command, payloads = message
        for worker, payload in zip(self._workers, payloads):
            worker.wait_for_readers()
            worker.send((command, payload))
        answers, error = [], None
        try:
            answers.append(local_answer())
        except BaseException as exc:  # noqa: BLE001 - raised once the workers have answered
            error = exc
        for worker in self._workers:
            try:
                answer = worker.receive()
                answers.append((worker.unpack(answer[0]),) + tuple(answer[1:]))
            except BaseException as exc:  # noqa: BLE001
                error = error or exc
        if error is not None:
            raise error
        for worker in self._workers:  # e.g. the laser and poses beside on-device images: shared memory from now on
            if worker.pending:
                worker.attach(worker.pending)
                worker.pending = {}
        return answers

    def _join(self, parts: list[dict]) -> dict:
        """One observation dict of N: per entry the slices concatenated (NumPy), or a tuple of the slices' arrays
        for images handed over on their devices (``on_device``)."""
        out = {}
        for key, first in parts[0].items():
            values = [part[key] for part in parts]
            handed_over = self.on_device and (not isinstance(first, np.ndarray) or first.base is not None)
            out[key] = tuple(values) if handed_over else np.concatenate([np.asarray(v) for v in values])
        self._last = out
        return out

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """As :meth:`benchbot.gym_vector.BenchBotVectorEnv.reset`, over every device's slice (module docstring)."""
        from benchbot.gym import _gym
        from benchbot.gym_vector import _on_backend_thread, reset_mask

        if seed is not None:
            self._np_random, self._np_random_seed = _gym().utils.seeding.np_random(seed)
        mask = reset_mask(options, self.num_envs)
        start, stop = self.slices[0]

        def local() -> tuple:
            part = mask[start:stop]
            if part.any():
                return self._local.reset(options={"reset_mask": part})
            return (_on_backend_thread(self._local._observe),
                    {"scene_number": np.zeros(stop - start, dtype=np.int64), "_scene_number": part.copy()})

        answers = self._gather(local, ("reset", [mask[a:b] for a, b in self.slices[1:]]))
        return self._join([a[0] for a in answers]), _concatenated([a[1] for a in answers])

    def step(self, actions: Any) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray, dict]:
        """As :meth:`benchbot.gym_vector.BenchBotVectorEnv.step`, over every device's slice (module docstring).

        Raises:
            ValueError: ``actions`` is not N actions of the action space.
        """
        from benchbot.gym_vector import checked_actions

        actions = checked_actions(actions, self)
        start, stop = self.slices[0]
        answers = self._gather(lambda: self._local.step(actions[start:stop]),
                               ("step", [actions[a:b] for a, b in self.slices[1:]]))
        obs = self._join([a[0] for a in answers])
        rewards, terminated, truncated = (np.concatenate([a[i] for a in answers]) for i in (1, 2, 3))
        return obs, rewards, terminated, truncated, _concatenated([a[4] for a in answers])

    def render(self) -> tuple | None:
        """The last colour images, one (H, W, 3) uint8 NumPy array per sub-environment (None without
        ``image_rgb``)."""
        from benchbot.gym_vector import _on_backend_thread

        rgb = self._last.get("image_rgb")
        if rgb is None:
            return None
        if isinstance(rgb, tuple):
            parts = [p if isinstance(p, np.ndarray) else (_on_backend_thread(p.numpy) if g == 0 else p.numpy())
                     for g, p in enumerate(rgb)]
            rgb = np.concatenate(parts)
        return tuple(np.array(image) for image in rgb)

    def close_extras(self, **kwargs: Any) -> None:
        """Stop the workers (their scenes and shared memory) and close this process's slice."""
        workers, self._workers = getattr(self, "_workers", []), []
        for worker in workers:
            worker.close()
        local, self._local = getattr(self, "_local", None), None
        if local is not None:
            local.close()


def _check_shared_memory(nbytes: int) -> None:
    """Raise a one-line ``MemoryError`` if ``/dev/shm`` (where shared memory lives on Linux) has less than
    ``nbytes`` free: a block larger than it would kill the worker that writes it (SIGBUS), not raise."""
    import shutil

    try:
        free = shutil.disk_usage("/dev/shm").free
    except OSError:  # not Linux: nothing to check
        return
    if nbytes > free:
        raise MemoryError(f"the vector environment needs {nbytes / 2**20:.0f} MiB of shared memory for a worker's "
                          f"observations but /dev/shm has {free / 2**20:.0f} MiB free: use on_device=True (images "
                          "stay on the GPUs), fewer sub-environments or smaller images, or a larger /dev/shm")


def _concatenated(infos: list[dict]) -> dict:
    """The slices' info dicts as one: each entry's arrays concatenated in slice order."""
    return {key: np.concatenate([info[key] for info in infos]) for key in infos[0]}


def make_multi_device_class() -> type:
    """The :class:`MultiDeviceVectorEnv` class (built lazily: Gymnasium is imported then)."""
    from benchbot.gym import _gym

    _gym()
    from gymnasium.vector import VectorEnv

    class MultiDeviceVectorEnv(_MultiDeviceMethods, VectorEnv):
        """N sub-environments over several devices, stepped in lockstep (the module docstring gives the contract).

        Args:
            num_envs: N (≥ the number of devices); slice ``g`` (``env.slices[g]``) runs on ``env.devices[g]``.
            devices: ``'all'``, a GPU count, a list of GPU ordinals starting with 0, or a list of ``'cpu'``
                (:data:`DEVICES_HELP`).
            on_device: images as tuples of per-device arrays (module docstring); else NumPy arrays of all N.
            env, options, and every other keyword: as :class:`benchbot.gym_vector.BenchBotVectorEnv`.

        Raises:
            ValueError: a bad ``devices`` or ``num_envs``, and whatever ``BenchBotVectorEnv`` raises for a slice.
            UsageError: no ``options['arch']`` and ``BENCHBOT_TAICHI_ARCH`` has no valid value (one line naming it).
            RuntimeError: a worker process died (one line naming its device), here or in ``reset``/``step``.
            MemoryError: (``reset``, ``step``) ``/dev/shm`` has too little room for the workers' shared memory (one
                line; ``on_device=True`` on CUDA needs less of it).
        """

    return MultiDeviceVectorEnv


def make_vector_env(num_envs: int = 1, *, devices: Any = None, **kwargs: Any) -> Any:
    """``gym.make_vec("BenchBot-v0", ...)``'s entry point: a :class:`benchbot.gym_vector.BenchBotVectorEnv` on one
    device (``devices`` None or 1, the default), else a :class:`MultiDeviceVectorEnv`.

    Raises:
        ValueError: a bad ``devices`` (one line, :data:`DEVICES_HELP`).
    """
    resolved = resolve_devices(devices, (kwargs.get("options") or {}).get("arch"))
    if len(resolved) == 1:
        from benchbot.gym_vector import BenchBotVectorEnv

        return BenchBotVectorEnv(num_envs, **kwargs)
    cls = globals().get("MultiDeviceVectorEnv") or _lazy("MultiDeviceVectorEnv")
    return cls(num_envs, devices=resolved, **kwargs)


def _lazy(name: str) -> Any:
    from benchbot.gym import lazy_classes

    return lazy_classes(globals(), {"MultiDeviceVectorEnv": make_multi_device_class})(name)


__getattr__ = _lazy


__all__ = ["DEVICES_HELP", "MultiDeviceVectorEnv", "make_vector_env", "resolve_devices", "split_envs"]
