"""benchbot.gym_vector: N batched robots behind ``gym.make_vec("BenchBot-v0", num_envs=N)``, checked against N
single ``BenchBot-v0`` environments stepped by hand with the same actions (real simulator, real renders)."""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import benchbot.gym  # noqa: E402,F401  (registers the ids)
from benchbot.core.errors import BackendError, SpecError  # noqa: E402

SMALL = {"width": 32, "height": 24}
ACTIVE = "semantic_slam:active:ground_truth"
PASSIVE = "semantic_slam:passive:ground_truth"


def _single_runs(task: str, envs: list[str], actions: np.ndarray, max_steps: int) -> list[list[tuple]]:
    """What N single environments give for ``actions`` (T, N), each reset on the step after it ended (Gymnasium's
    NEXT_STEP autoreset): per step and environment ``(obs, terminated, truncated, result or None)``."""
    runs = []
    for i, env_name in enumerate(envs):
        env = gymnasium.make("BenchBot-v0", task=task, env=env_name, options=SMALL, max_steps=max_steps)
        obs, _ = env.reset()
        steps, ended = [(obs, False, False, None)], False
        for action in actions[:, i]:
            if ended:
                obs, _ = env.reset()
                steps.append((obs, False, False, None))
                ended = False
                continue
            obs, _, terminated, truncated, info = env.step(int(action))
            steps.append((obs, terminated, truncated, info["result"]))
            ended = terminated or truncated
        env.close()
        runs.append(steps)
    return runs


def _vector_run(task: str, envs: list[str] | str, actions: np.ndarray, max_steps: int, **kwargs) -> list[tuple]:
    n = actions.shape[1]
    vec = gymnasium.make_vec("BenchBot-v0", num_envs=n, task=task, env=envs, options=SMALL, max_steps=max_steps,
                             **kwargs)
    try:
        assert type(vec).__name__ == "BenchBotVectorEnv"  # the vector entry point is make_vec's default here
        obs, info = vec.reset(seed=3)
        assert vec.observation_space.contains({k: np.asarray(v) for k, v in obs.items()})
        steps = [({k: np.array(v) for k, v in obs.items()}, np.zeros(n, bool), np.zeros(n, bool),
                  np.full(n, None))]
        for action in actions:
            obs, reward, terminated, truncated, info = vec.step(action)
            assert reward.shape == (n,) and not reward.any()
            result = np.where(info["_result"], info["result"], None)
            steps.append(({k: np.array(v) for k, v in obs.items()}, terminated, truncated, result))
    finally:
        vec.close()
    return steps


def _assert_same(vector: list[tuple], singles: list[list[tuple]]) -> None:
    for t, (obs, terminated, truncated, result) in enumerate(vector):
        for i, single in enumerate(singles):
            s_obs, s_terminated, s_truncated, s_result = single[t]
            where = f"step {t}, environment {i}"
            assert (bool(terminated[i]), bool(truncated[i]), result[i]) == (s_terminated, s_truncated, s_result), where
            np.testing.assert_allclose(obs["pose"][i], s_obs["pose"], atol=1e-9, err_msg=where)
            np.testing.assert_allclose(obs["laser"][i], s_obs["laser"], atol=1e-5, err_msg=where)
            # one launch for N cameras gives each camera's pixels as a launch of its own does
            assert np.array_equal(obs["image_rgb"][i], s_obs["image_rgb"]), where
            assert np.array_equal(obs["image_depth"][i], s_obs["image_depth"]), where


def test_batched_robots_move_and_see_as_single_environments_do():
    """Three robots in one scene: one drives forward until it collides, one turns, one acts at random; max_steps
    truncates and each is reset on its next step, as three single environments do."""
    rng = np.random.default_rng(7)
    actions = np.stack([np.zeros(14, int), np.full(14, 2), rng.integers(0, 4, 14)], axis=1)
    vector = _vector_run(ACTIVE, "miniroom:1", actions, max_steps=6)
    singles = _single_runs(ACTIVE, ["miniroom:1"] * 3, actions, max_steps=6)
    _assert_same(vector, singles)
    results = {r for _, _, _, step in vector for r in step if r is not None}
    assert "COLLISION" in results, results  # the test saw a collision and a truncation
    assert any(truncated.any() for _, _, truncated, _ in vector)


def test_passive_robots_follow_the_trajectory_in_two_scenes():
    """Passive robots in two scenes of one vector environment follow each scene's trajectory to FINISHED."""
    envs = ["miniroom:4", "miniroom:1", "miniroom:4"]
    actions = np.zeros((36, 3), int)
    vector = _vector_run(PASSIVE, envs, actions, max_steps=1000)
    singles = _single_runs(PASSIVE, envs, actions, max_steps=1000)
    _assert_same(vector, singles)
    assert any(r == "FINISHED" for _, _, _, step in vector for r in step)


def test_on_device_images_are_the_renderers_buffers_without_a_copy():
    """On the CPU, ``on_device`` images are NumPy views of the renderer's buffers (DLPack through NumPy), equal to
    the host copies, and the next step writes over them."""
    vec = gymnasium.make_vec("BenchBot-v0", num_envs=2, task=ACTIVE, env="miniroom:1", options=SMALL, on_device=True)
    host = gymnasium.make_vec("BenchBot-v0", num_envs=2, task=ACTIVE, env="miniroom:1", options=SMALL)
    try:
        obs, _ = vec.reset()
        expected, _ = host.reset()
        rgb = np.from_dlpack(obs["image_rgb"])
        assert np.array_equal(rgb, expected["image_rgb"]) and not rgb.flags.owndata
        before = rgb.copy()
        vec.step(np.array([2, 2]))  # both turn: the view now shows the new frame
        assert not np.array_equal(rgb, before)
        assert np.array_equal(rgb, host.step(np.array([2, 2]))[0]["image_rgb"])
    finally:
        vec.close()
        host.close()


def test_what_the_vector_environment_refuses_is_one_line():
    make = gymnasium.make_vec
    with pytest.raises(SpecError, match="has 2 scenes"):
        make("BenchBot-v0", num_envs=2, task="scd:active:ground_truth", env="miniroom:1:2", options=SMALL)
    with pytest.raises(SpecError, match="noisy localisation"):
        make("BenchBot-v0", num_envs=2, task="semantic_slam:active:dead_reckoning", options=SMALL)
    with pytest.raises(BackendError, match="fast mode without sensor noise"):
        make("BenchBot-v0", num_envs=2, task=ACTIVE, options={**SMALL, "noise": "realistic"})
    with pytest.raises(ValueError, match="one scene per vector environment"):
        make("BenchBot-v0", num_envs=2, task=ACTIVE, env=["miniroom:1", "miniroom:2"], on_device=True)
    with pytest.raises(ValueError, match="a list of 3"):
        make("BenchBot-v0", num_envs=3, task=ACTIVE, env=["miniroom:1", "miniroom:2"])
    with pytest.raises(SpecError, match="nosuchhome"):
        make("BenchBot-v0", num_envs=2, task=ACTIVE, env="nosuchhome:1")
    vec = make("BenchBot-v0", num_envs=2, task=ACTIVE, options=SMALL)
    try:
        vec.reset()
        for bad in (np.array([0]), np.array([0, 4]), np.array([0.5, 1.0])):
            with pytest.raises(ValueError, match="2 integers of Discrete"):
                vec.step(bad)
    finally:
        vec.close()


def test_sync_mode_still_steps_separate_simulators():
    vec = gymnasium.make_vec("BenchBot-v0", num_envs=2, vectorization_mode="sync", task=ACTIVE, options=SMALL)
    try:
        assert type(vec).__name__ == "SyncVectorEnv"
        obs, _ = vec.reset(seed=0)
        assert obs["image_rgb"].shape == (2, 24, 32, 3)
    finally:
        vec.close()


def _cuda_and_torch() -> bool:
    try:
        import torch
    except ImportError:
        return False
    return torch.cuda.is_available()


@pytest.mark.skipif(not _cuda_and_torch(), reason="needs an NVIDIA GPU and PyTorch (runs on the GPU machine)")
def test_on_device_images_reach_torch_on_the_gpu_without_a_copy():
    """On CUDA, ``torch.from_dlpack`` of an on-device image is a CUDA tensor over the renderer's buffer (same
    address), equal to the host copy of the same step; so is ``torch.as_tensor`` through the CUDA Array Interface."""
    import torch

    options = {**SMALL, "arch": "cuda"}
    vec = gymnasium.make_vec("BenchBot-v0", num_envs=3, task=ACTIVE, env="miniroom:1", options=options,
                             on_device=True)
    host = gymnasium.make_vec("BenchBot-v0", num_envs=3, task=ACTIVE, env="miniroom:1", options=options)
    try:
        for actions in (None, np.array([0, 2, 3])):
            obs = vec.reset()[0] if actions is None else vec.step(actions)[0]
            expected = host.reset()[0] if actions is None else host.step(actions)[0]
            rgb, depth = torch.from_dlpack(obs["image_rgb"]), torch.from_dlpack(obs["image_depth"])
            assert rgb.is_cuda and rgb.data_ptr() == obs["image_rgb"].pointer and rgb.dtype == torch.uint8
            assert torch.equal(rgb.cpu(), torch.from_numpy(expected["image_rgb"]))
            assert torch.equal(depth.cpu(), torch.from_numpy(expected["image_depth"]))
            via_interface = torch.as_tensor(obs["image_depth"], device="cuda")
            assert via_interface.data_ptr() == depth.data_ptr()
            np.testing.assert_allclose(obs["pose"], expected["pose"], atol=1e-12)
    finally:
        vec.close()
        host.close()


@pytest.mark.skipif(not _cuda_and_torch(), reason="needs an NVIDIA GPU and PyTorch (runs on the GPU machine)")
def test_a_step_waits_for_reads_still_queued_on_a_stream_of_the_consumers_own():
    """A read of an on-device frame that PyTorch has queued (behind a long kernel) on a stream of its own, not
    Taichi's, still sees that frame when the next step comes before the read has run: the step waits for it
    instead of rendering over the buffer. The frames differ from step to step, so an overwrite would show."""
    import torch

    vec = gymnasium.make_vec("BenchBot-v0", num_envs=2, task=ACTIVE, env="miniroom:1",
                             options={"width": 64, "height": 48, "arch": "cuda"}, on_device=True)
    try:
        obs = vec.reset(seed=0)[0]
        stream = torch.cuda.Stream()  # PyTorch's streams do not order against the legacy default stream
        for t in range(4):
            rgb = torch.from_dlpack(obs["image_rgb"])
            with torch.cuda.stream(stream):
                given = rgb.clone()
                torch.cuda.synchronize()
                torch.cuda._sleep(200_000_000)  # clock cycles: about 0.1 s of GPU time on this stream
                late = rgb.clone()  # queued behind the sleep: runs after the step below has launched
            obs = vec.step(np.array([t % 4, (t + 1) % 4]))[0]
            torch.cuda.synchronize()
            assert not torch.equal(torch.from_dlpack(obs["image_rgb"]), given)  # the step changed the frame
            assert torch.equal(late, given)
    finally:
        vec.close()


def test_infos_and_reset_mask_match_sync_vector_env():
    """The info keys and masks of reset and of NEXT_STEP autoreset are those SyncVectorEnv gives over BenchBot-v0;
    ``options['reset_mask']`` resets only the masked robots; a bad action array is refused in one line."""
    actions = np.array([[0, 2], [0, 2], [3, 2], [1, 2], [2, 0]])
    kwargs = {"num_envs": 2, "task": ACTIVE, "env": "miniroom:1", "options": SMALL, "max_steps": 2}
    infos = {}
    for mode in ("vector_entry_point", "sync"):
        vec = gymnasium.make_vec("BenchBot-v0", vectorization_mode=mode, **kwargs)
        try:
            obs, info = vec.reset(seed=0)
            start, run = obs["pose"].copy(), [info]
            for a in actions:
                obs, _, terminated, truncated, info = vec.step(a)
                run.append({**info, "terminated": terminated, "truncated": truncated})
            moved = obs["pose"].copy()
            assert not np.allclose(moved, start)
            obs, info = vec.reset(options={"reset_mask": np.array([False, True])})
            run.append(info)
            np.testing.assert_allclose(obs["pose"], [moved[0], start[1]], atol=1e-9)  # only robot 1 is reset
            if mode == "vector_entry_point":
                with pytest.raises(ValueError, match="reset_mask"):
                    vec.reset(options={"reset_mask": np.array([0, 1])})
                with pytest.raises(ValueError) as bad:
                    vec.step(np.arange(200).reshape(100, 2))
                assert "\n" not in str(bad.value) and "(100, 2)" in str(bad.value)
        finally:
            vec.close()
        infos[mode] = run
    for t, (a, b) in enumerate(zip(infos["vector_entry_point"], infos["sync"], strict=True)):
        # SyncVectorEnv leaves 'result' out when every robot was reset; here it is there, masked off
        assert b.keys() <= a.keys() and not any(a[f"_{key}"].any() for key in a.keys() - b.keys() if key[0] != "_"), t
        for key in b:
            assert np.array_equal(a[key], b[key]), (t, key, a[key], b[key])


def test_bad_keywords_are_one_line_value_errors():
    for kwargs, match in (({"env": 5}, "a list of 2"), ({"env": "miniroom:1", "num_envs": True}, "num_envs"),
                          ({"max_steps": 0}, "max_steps"), ({"step_m": -1.0}, "step_m")):
        with pytest.raises(ValueError, match=match):
            gymnasium.make_vec("BenchBot-v0", **{"num_envs": 2, "task": ACTIVE, **kwargs})


# --------------------------------------------------------------------------------------- several devices (processes)
def test_devices_are_checked_before_anything_starts():
    """``devices`` is refused in one line for bad values, GPUs on a CPU arch, 'cpu' processes on a GPU arch, and
    more devices than sub-environments; the slices are contiguous and as even as possible."""
    from benchbot.gym_devices import resolve_devices, split_envs

    assert resolve_devices(None, "cpu") == ["cpu"] and resolve_devices(1, "cuda") == [0]
    assert resolve_devices(["cpu", "cpu", "cpu"], None) == ["cpu"] * 3
    assert split_envs(7, 3) == [(0, 3), (3, 5), (5, 7)] and split_envs(1024, 2) == [(0, 512), (512, 1024)]
    make = gymnasium.make_vec
    for devices, arch, match in ((0, "cpu", "devices must be"), ("many", "cpu", "devices must be"),
                                 ([1, 0], "cuda", "devices must be"), ([0, 0], "cuda", "devices must be"),
                                 (True, "cpu", "devices must be"), (2, "cpu", "options arch is 'cpu'"),
                                 ("all", "cpu", "options arch is 'cpu'"), (["cpu", "cpu"], "cuda", "runs on the CPU")):
        with pytest.raises(ValueError, match=match) as error:
            make("BenchBot-v0", num_envs=4, task=ACTIVE, options={**SMALL, "arch": arch}, devices=devices)
        assert "\n" not in str(error.value), devices
    with pytest.raises(ValueError, match="at least one sub-environment per device"):
        make("BenchBot-v0", num_envs=2, task=ACTIVE, options=SMALL, devices=["cpu"] * 3)
    with pytest.raises(ValueError, match=r"needs GPU 99, but this process sees \d+ GPU"):
        make("BenchBot-v0", num_envs=2, task=ACTIVE, options={**SMALL, "arch": "cuda"}, devices=[0, 99])


def test_a_worker_sees_only_its_gpu_of_this_processs_visible_ones(monkeypatch):
    from benchbot.gym_devices import _visible_after

    monkeypatch.delenv("CUDA_VISIBLE_DEVICES", raising=False)
    assert _visible_after(1) == "1"
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "2, 3")
    assert (_visible_after(0), _visible_after(1)) == ("2", "3")


def test_too_little_shared_memory_is_one_line_before_a_worker_writes(monkeypatch):
    """A worker's observations that would not fit in /dev/shm are refused in one line (writing them would kill it)."""
    import collections
    import shutil

    from benchbot.gym_devices import _check_shared_memory

    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage(64 * 2**20, 0, 64 * 2**20))
    _check_shared_memory(32 * 2**20)
    with pytest.raises(MemoryError, match="needs 1051 MiB of shared memory .* has 64 MiB free: use on_device=True"):
        _check_shared_memory(512 * 480 * 640 * 7 + 512 * 360 * 8)


@pytest.mark.slow
def test_two_processes_give_one_process_results_byte_for_byte():
    """devices=['cpu', 'cpu']: sub-environments 0-1 here, 2 in a worker process; observations (images, laser, pose),
    terminated, truncated and infos equal a one-process vector environment's exactly, through collisions,
    truncation, autoreset and reset masks that leave a whole slice out; ``on_device`` gives a tuple of the slices'
    arrays; a worker's error comes back as its own exception."""
    rng = np.random.default_rng(7)
    actions = np.stack([np.zeros(14, int), np.full(14, 2), rng.integers(0, 4, 14)], axis=1)
    kwargs = {"num_envs": 3, "task": ACTIVE, "env": "miniroom:1", "options": SMALL, "max_steps": 6}
    runs = {}
    for devices in (None, ["cpu", "cpu"]):
        vec = gymnasium.make_vec("BenchBot-v0", devices=devices, **kwargs)
        try:
            run = [vec.reset(seed=0)]
            run += [vec.step(a) for a in actions]
            run += [vec.reset(options={"reset_mask": m}) for m in (np.array([False, False, True]),
                                                                   np.array([True, False, False]))]
            if devices:
                assert type(vec).__name__ == "MultiDeviceVectorEnv" and vec.slices == [(0, 2), (2, 3)]
                assert len(vec.render()) == 3
        finally:
            vec.close()
        runs[str(devices)] = run
    for t, (one, two) in enumerate(zip(runs["None"], runs["['cpu', 'cpu']"], strict=True)):
        for a, b in zip(one, two, strict=True):
            items = a.items() if isinstance(a, dict) else [("", a)]
            for key, value in items:
                other = b[key] if key else b
                assert np.asarray(value).dtype == np.asarray(other).dtype, (t, key)
                assert np.array_equal(value, other), (t, key)
    assert {"COLLISION", "SUCCESS"} <= {r for step in runs["None"][1:15] for r in step[4]["result"]}

    vec = gymnasium.make_vec("BenchBot-v0", num_envs=3, task=ACTIVE, env="miniroom:1", options=SMALL,
                             devices=["cpu", "cpu"], on_device=True)
    try:
        obs, _ = vec.reset()
        assert [np.from_dlpack(part).shape for part in obs["image_rgb"]] == [(2, 24, 32, 3), (1, 24, 32, 3)]
        assert obs["laser"].shape == (3, 360)
        first = np.concatenate(obs["image_rgb"])
        obs = vec.step(np.array([2, 2, 2]))[0]
        assert not np.array_equal(np.concatenate(obs["image_rgb"]), first)
        vec._workers[0].process.kill()  # a worker that dies is one line naming its sub-environments
        with pytest.raises(RuntimeError, match=r"sub-environments 2\.\.2 on the CPU exited") as died:
            vec.step(np.array([2, 2, 2]))
        assert "\n" not in str(died.value)
    finally:
        vec.close()
    with pytest.raises(SpecError, match="nosuchhome"):
        gymnasium.make_vec("BenchBot-v0", num_envs=2, task=ACTIVE, env=["miniroom:1", "nosuchhome:1"], options=SMALL,
                           devices=["cpu", "cpu"])


def _gpus_and_torch() -> int:
    try:
        import torch
    except ImportError:
        return 0
    return torch.cuda.device_count() if torch.cuda.is_available() else 0


@pytest.mark.skipif(_gpus_and_torch() < 2, reason="needs two NVIDIA GPUs and PyTorch (runs on the GPU machine)")
def test_two_gpus_hand_each_slice_over_on_its_own_gpu():
    """devices=2 on CUDA: ``obs['image_rgb']`` is a tuple of one array per GPU, ``torch.from_dlpack`` of entry g a
    tensor on cuda:g, equal byte for byte to one GPU's images of those sub-environments; the host path gives the same
    NumPy arrays as one GPU; a read queued on GPU 1 behind a long kernel still sees its frame after the next step."""
    import torch

    options = {**SMALL, "arch": "cuda"}
    kwargs = {"num_envs": 4, "task": ACTIVE, "env": "miniroom:1", "options": options}
    one = gymnasium.make_vec("BenchBot-v0", **kwargs)
    host = gymnasium.make_vec("BenchBot-v0", devices=2, **kwargs)
    vec = gymnasium.make_vec("BenchBot-v0", devices=2, on_device=True, **kwargs)
    try:
        steps = [None, np.array([0, 2, 3, 1]), np.array([2, 2, 0, 3])]
        for actions in steps:
            expected = one.reset()[0] if actions is None else one.step(actions)[0]
            got = vec.reset()[0] if actions is None else vec.step(actions)[0]
            on_host = host.reset()[0] if actions is None else host.step(actions)[0]
            for key in expected:
                assert np.array_equal(on_host[key], expected[key]), key
            for key in ("image_rgb", "image_depth"):
                parts = [torch.from_dlpack(part) for part in got[key]]
                assert [p.device.index for p in parts] == [0, 1], key
                joined = torch.cat([p.cpu() for p in parts])
                assert torch.equal(joined, torch.from_numpy(expected[key])), key
            assert np.array_equal(got["pose"], expected["pose"]) and np.array_equal(got["laser"], expected["laser"])
        assert vec.render()[3].shape == (24, 32, 3)
        stream = torch.cuda.Stream(device=1)
        rgb = torch.from_dlpack(got["image_rgb"][1])
        with torch.cuda.device(1), torch.cuda.stream(stream):
            given = rgb.clone()
            torch.cuda.synchronize(1)
            torch.cuda._sleep(200_000_000)
            late = rgb.clone()  # queued behind the sleep, on GPU 1
        obs = vec.step(np.array([3, 3, 3, 3]))[0]
        torch.cuda.synchronize(1)
        assert not torch.equal(torch.from_dlpack(obs["image_rgb"][1]), given) and torch.equal(late, given)
    finally:
        vec.close()
        host.close()
        one.close()
