"""Workers on every GPU (benchbot.batch.gpus, the local executor's worker processes, the service's worker pool, Ray's
share of a GPU): the GPUs come from the driver's ``/proc/driver/nvidia/gpus`` files (a stand-in folder here) or else
``nvidia-smi -L`` (a stand-in on PATH here, listing two), narrowed by ``CUDA_VISIBLE_DEVICES``; worker k gets GPU k mod G; the pool balances its workers over the GPUs, reuses free ones
of a profile, replaces idle ones of another when full and waits when all are busy."""

from __future__ import annotations

import json
import multiprocessing
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot.batch import executors, gpus
from benchbot.core.errors import UsageError
from benchbot.service import pool as pool_module
from benchbot.service.pool import PoolWorker, WorkerPool

A = "GPU-0a0a0a0a-0000-0000-0000-000000000000"
B = "GPU-1b1b1b1b-0000-0000-0000-000000000000"
FAKE_SMI = f"""#!/bin/sh
[ "$1" = "-L" ] || exit 9
echo "GPU 0: NVIDIA Fake A (UUID: {A})"
echo "GPU 1: NVIDIA Fake B (UUID: {B})"
"""


@pytest.fixture
def two_gpus(tmp_path, monkeypatch):
    """``nvidia-smi`` on PATH lists two GPUs; no ``CUDA_VISIBLE_DEVICES``."""
    folder = tmp_path / "bin"
    folder.mkdir()
    (folder / "nvidia-smi").write_text(FAKE_SMI)
    (folder / "nvidia-smi").chmod(0o755)
    monkeypatch.setenv("PATH", f"{folder}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.delenv("CUDA_VISIBLE_DEVICES", raising=False)
    monkeypatch.setattr(gpus, "NVIDIA_PROC_GPUS", tmp_path / "no-driver-files")  # a GPU host's own are not read
    return folder


def driver_files(root: Path, dev: Path, gpus_by_bus: dict[str, tuple[str, str, int]], **extra: str) -> None:
    """A stand-in for ``/proc/driver/nvidia/gpus`` in ``root`` (one ``information`` file per PCI bus id, as the
    driver writes it: tab-aligned ``Field: value`` lines) and the device files ``dev/nvidia<minor>``; ``extra``:
    more lines for every GPU (``GPU Excluded="Yes"``)."""
    for bus, (model, uuid, minor) in gpus_by_bus.items():
        (root / bus).mkdir(parents=True)
        lines = [f"Model: \t\t {model}", "IRQ:   \t\t 0", f"GPU UUID: \t {uuid}", "Video BIOS: \t 96.00.74.00.01",
                 "Bus Type: \t PCIe", f"Bus Location: \t {bus}", f"Device Minor: \t {minor}",
                 *(f"{key.replace('_', ' ')}:\t {value}" for key, value in extra.items())]
        (root / bus / "information").write_text("\n".join(lines) + "\n")
        dev.mkdir(exist_ok=True)
        (dev / f"nvidia{minor}").touch()


def test_the_visible_gpus_follow_cuda_visible_devices(two_gpus, monkeypatch):
    assert [(g["index"], g["name"], g["uuid"]) for g in gpus.visible_gpus()] == [(0, "NVIDIA Fake A", A),
                                                                                (1, "NVIDIA Fake B", B)]
    for value, indices in (("1", [1]), ("GPU-1b1b,0", [1, 0]), ("0,7,1", [0]), ("", []), ("0,0", [0])):
        monkeypatch.setenv("CUDA_VISIBLE_DEVICES", value)
        assert [g["index"] for g in gpus.visible_gpus()] == indices, value
    monkeypatch.setenv("PATH", str(two_gpus.parent / "nowhere"))
    monkeypatch.delenv("CUDA_VISIBLE_DEVICES")
    assert gpus.visible_gpus() == []  # no nvidia-smi: no GPUs


def test_the_drivers_files_list_the_gpus_in_bus_order_without_nvidia_smi(tmp_path, monkeypatch):
    root, dev = tmp_path / "gpus", tmp_path / "dev"
    # written out of order: the index is the place in PCI bus id order, as nvidia-smi numbers them
    driver_files(root, dev, {"0000:b8:00.0": ("NVIDIA H200", B, 1), "0000:18:00.0": ("NVIDIA H200", A, 0)})
    assert gpus.proc_gpus(root, dev) == [{"index": 0, "name": "NVIDIA H200", "uuid": A},
                                         {"index": 1, "name": "NVIDIA H200", "uuid": B}]
    monkeypatch.setattr(gpus, "NVIDIA_PROC_GPUS", root)
    monkeypatch.setenv("PATH", str(tmp_path / "no-nvidia-smi"))  # nvidia-smi is not run: there is none
    monkeypatch.setattr(gpus, "DEVICE_DIR", dev)
    monkeypatch.delenv("CUDA_VISIBLE_DEVICES", raising=False)
    assert [g["uuid"] for g in gpus.visible_gpus()] == [A, B]
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "GPU-1b1b")
    assert [(g["index"], g["uuid"]) for g in gpus.visible_gpus()] == [(1, B)]
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "1")  # an index: numbered by nvidia-smi (here none: no GPU)
    assert gpus.visible_gpus() == []


def test_gpus_the_driver_excludes_or_this_process_cannot_open_are_left_out(tmp_path):
    root, dev = tmp_path / "gpus", tmp_path / "dev"
    driver_files(root, dev, {"0000:18:00.0": ("NVIDIA H100", A, 0), "0000:2a:00.0": ("NVIDIA H100", B, 1)})
    (dev / "nvidia0").unlink()  # a container given the host's second GPU only
    assert gpus.proc_gpus(root, dev) == [{"index": 0, "name": "NVIDIA H100", "uuid": B}]
    excluded = tmp_path / "excluded"
    driver_files(excluded, dev, {"0000:18:00.0": ("NVIDIA H100", A, 1)}, GPU_Excluded="Yes")
    assert gpus.proc_gpus(excluded, dev) is None


def test_without_usable_driver_files_nvidia_smi_lists_the_gpus(two_gpus, tmp_path, monkeypatch):
    root, dev = tmp_path / "gpus", tmp_path / "dev"
    assert gpus.proc_gpus(root, dev) is None  # no folder
    root.mkdir()
    assert gpus.proc_gpus(root, dev) is None  # no GPU in it
    driver_files(root, dev, {"0000:18:00.0": ("NVIDIA H100", "GPU-????????-????-????-????-????????????", 0)})
    assert gpus.proc_gpus(root, dev) is None  # a UUID the driver has not read yet
    monkeypatch.setattr(gpus, "NVIDIA_PROC_GPUS", root)
    assert [(g["index"], g["name"], g["uuid"]) for g in gpus.machine_gpus()] == [(0, "NVIDIA Fake A", A),
                                                                                (1, "NVIDIA Fake B", B)]
    driver_files(tmp_path / "good", dev, {"0000:18:00.0": ("NVIDIA H100", A, 0)})
    monkeypatch.setattr(gpus, "NVIDIA_PROC_GPUS", tmp_path / "good")
    monkeypatch.setattr(gpus, "DEVICE_DIR", dev)
    assert [g["name"] for g in gpus.machine_gpus({})] == ["NVIDIA H100"]
    assert [g["name"] for g in gpus.machine_gpus({"CUDA_VISIBLE_DEVICES": "0"})] == ["NVIDIA Fake A", "NVIDIA Fake B"]


def test_worker_k_gets_gpu_k_mod_g_before_its_simulator_starts(two_gpus, monkeypatch):
    found = gpus.visible_gpus()
    assert [gpus.gpu_for_worker(k, found)["index"] for k in range(5)] == [0, 1, 0, 1, 0]
    assert gpus.gpu_for_worker(3, []) is None
    for name in executors.THREAD_VARIABLES:
        monkeypatch.setenv(name, "1")
    counter = multiprocessing.get_context("spawn").Value("i", 0)
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "")  # recorded: put back (unset) after the test
    seen = []
    for _ in range(3):  # what three worker processes' initialisers do, one after another
        monkeypatch.delenv("CUDA_VISIBLE_DEVICES", raising=False)
        executors._init_worker(1, None, found, counter)
        seen.append((os.environ["CUDA_VISIBLE_DEVICES"], executors._gpu["index"]))
    monkeypatch.setattr(executors, "_gpu", None)
    assert seen == [(A, 0), (B, 1), (A, 0)]


def test_a_record_names_its_gpu_unless_its_backend_fell_back_to_the_cpu():
    gpu = {"index": 1, "name": "NVIDIA Fake B", "uuid": B}
    node = {"hostname": "h", **gpus.recorded(gpu)}
    assert node["gpu"] == {"index": 1, "name": "NVIDIA Fake B"}
    assert gpus.on_cpu(node, {"arch": "cuda"}) == node
    assert gpus.on_cpu(node, {"arch": "x64"}) == {"hostname": "h"}
    assert gpus.wants_gpu({"arch": "cuda"}) and gpus.wants_gpu({"arch": "gpu"}) and not gpus.wants_gpu({"arch": "cpu"})


def test_rays_share_of_a_gpu_per_episode_is_a_checked_setting(monkeypatch):
    assert executors.ray_gpus_per_episode() == 0.0625
    for good, value in (("0.25", 0.25), ("1", 1.0), ("2", 2.0)):
        monkeypatch.setenv("BENCHBOT_RAY_GPUS_PER_EPISODE", good)
        assert executors.ray_gpus_per_episode() == value
    for bad in ("0", "-1", "1.5", "half"):
        monkeypatch.setenv("BENCHBOT_RAY_GPUS_PER_EPISODE", bad)
        with pytest.raises(UsageError, match="BENCHBOT_RAY_GPUS_PER_EPISODE"):
            executors.ray_gpus_per_episode()


@pytest.fixture
def sleeper_pool(tmp_path, monkeypatch):
    """A :class:`WorkerPool` of at most 3 whose workers are ``sleep`` processes (the lease logic, not the worker)."""
    made: list[PoolWorker] = []

    def spawn(self, threads, gpu):
        worker = PoolWorker(subprocess.Popen(["sleep", "60"]), tmp_path / f"w{len(made)}.sock", threads, gpu)
        self._workers.append(worker)
        made.append(worker)
        return worker

    monkeypatch.setattr(WorkerPool, "_spawn", spawn)
    pool = WorkerPool(tmp_path, tmp_path / "log", limit=3)
    yield pool, made
    pool.close()


def test_the_pool_spreads_workers_over_the_gpus_reuses_free_ones_and_waits_when_full(sleeper_pool):
    pool, made = sleeper_pool
    two = [{"index": 0, "name": "A", "uuid": A}, {"index": 1, "name": "B", "uuid": B}]
    leased = [pool.lease(8, two) for _ in range(3)]
    assert [w.gpu["index"] for w in leased] == [0, 1, 0] and len(made) == 3
    with pytest.raises(TimeoutError):
        pool.lease(8, two, timeout_s=0.3)  # all three busy, the pool full
    pool.release(leased[1])
    again = pool.lease(8, two)
    assert again is leased[1] and len(made) == 3  # the free worker of that profile, no new process
    pool.release(leased[0])
    cpu = pool.lease(2, [])  # another profile, the pool full: its idle worker is replaced
    assert cpu.gpu is None and cpu.threads == 2 and len(made) == 4 and leased[0].process.poll() is not None
    pool.release(leased[2], broken=True)  # a broken worker is stopped and dropped
    assert leased[2].process.poll() is not None and all(f["pid"] != leased[2].process.pid for f in pool.facts())
    pool.release(again)
    pool.release(cpu)
    assert {f["gpu"]["index"] if f["gpu"] else None for f in pool.facts()} == {1, None}


def test_the_pool_limit_is_bounded():
    assert 4 <= pool_module.POOL_LIMIT <= 64


@pytest.mark.slow
def test_ray_episodes_on_a_gpu_request_their_share_of_one(tmp_path, monkeypatch):
    """A Ray with two (logical) GPUs: each ``--arch cuda`` episode reserves BENCHBOT_RAY_GPUS_PER_EPISODE of one, so
    Ray gives its task one GPU in CUDA_VISIBLE_DEVICES, which its solution (a child of the task) inherits; a CPU
    episode reserves none."""
    ray = pytest.importorskip("ray")
    sys.path.insert(0, str(Path(__file__).parent))
    from cli_in_process import benchbot

    show = tmp_path / "show.py"
    show.write_text("import os\nprint('GPUS=' + repr(os.environ.get('CUDA_VISIBLE_DEVICES')))\n")
    monkeypatch.setenv("BENCHBOT_RAY_GPUS_PER_EPISODE", "1")  # a whole GPU each: the two episodes get one each
    monkeypatch.setenv("RAY_ENABLE_UV_RUN_RUNTIME_ENV", "0")
    monkeypatch.delenv("CUDA_VISIBLE_DEVICES", raising=False)  # Ray's two logical GPUs, not this machine's
    seen = {}
    ray.init(address="local", num_cpus=2, num_gpus=2, include_dashboard=False, log_to_driver=False,
             configure_logging=False)
    try:
        for arch in ("cuda", "cpu"):
            proc = benchbot("batch", "--native", f"{sys.executable} {show}", "--no-sandbox", "--envs", "miniroom:1",
                            "--repeat", "2", "--arch", arch, "--executor", "ray", "--camera-size", "64x48",
                            "--output-dir", str(tmp_path / arch), "--json", "--no-tui", "--no-evaluate")
            episodes = json.loads(proc.stdout)["episodes"]
            run_dir = Path(json.loads(proc.stdout)["run_dir"])
            seen[arch] = sorted((run_dir / e["log"]).read_text().split("GPUS=")[1].split()[0] for e in episodes)
    finally:
        ray.shutdown()
    assert seen["cuda"] == ["'0'", "'1'"], seen
    assert all(value in ("None", "''") for value in seen["cpu"]), seen


def test_the_pool_gives_an_episode_the_free_worker_that_served_its_world_lately(sleeper_pool):
    """Its scene is likely still loaded there (a resident simulator keeps the last three)."""
    pool, made = sleeper_pool
    a, b = pool.lease(4, [], world="house:1"), pool.lease(4, [], world="house:2")
    pool.release(a)
    pool.release(b)
    assert pool.lease(4, [], world="house:2") is b
    assert pool.lease(4, [], world="house:1") is a and len(made) == 2
    pool.release(a)
    pool.release(b)
    for world in ("house:3", "house:4", "house:5"):  # a's three latest worlds: house:1 is no longer among them
        pool.release(pool.lease(4, [], world=world))
    assert a.worlds == ["house:5", "house:4", "house:3"]
    assert pool.lease(4, [], world="house:2") is b
