"""Which GPUs a batch's workers run on: the NVIDIA GPUs this process may use, and one for each worker.

With a GPU arch (``--arch cuda``/``gpu``, or ``auto`` that picked one), worker ``k`` of a batch gets visible GPU
``k mod G`` (:func:`gpu_for_worker`): its ``CUDA_VISIBLE_DEVICES`` is set to that one GPU before Taichi initialises
(:func:`pin`), so the CUDA driver and Taichi see it as device 0. The GPUs are listed from the NVIDIA driver's
``/proc/driver/nvidia/gpus/<PCI bus id>/information`` files (:func:`proc_gpus`: reading them opens no GPU, where
``nvidia-smi -L`` took 0.2–1 s on a host with many GPUs), else by ``nvidia-smi -L`` (:func:`smi_gpus`; no CUDA
context is made either way), narrowed to this process's own ``CUDA_VISIBLE_DEVICES`` where it is set (indices or
``GPU-…`` UUIDs, in its order). Each episode records the GPU it ran on, ``{"index": physical index, "name"}``, in
its record's ``node`` (``gpu``).
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

#: The backend options' ``arch`` values that render on a GPU (:func:`benchbot.cli.common.backend_options`).
GPU_ARCHS = ("gpu", "cuda")
#: Seconds ``nvidia-smi -L`` may take.
NVIDIA_SMI_TIMEOUT_S = 10.0

_LINE = re.compile(r"GPU (\d+): (.*?) \(UUID: (GPU-[0-9a-fA-F-]+)\)")
#: The NVIDIA driver's folder of one sub-folder per GPU, named by its PCI bus id (``0000:18:00.0``).
NVIDIA_PROC_GPUS = Path("/proc/driver/nvidia/gpus")
#: The folder of the GPUs' device files (``nvidia0``, ``nvidia1``, …) this process can see.
DEVICE_DIR = Path("/dev")
_UUID = re.compile(r"GPU-[0-9a-fA-F]{8}(-[0-9a-fA-F]{4}){3}-[0-9a-fA-F]{12}")


def wants_gpu(options: dict) -> bool:
    """Whether backend ``options`` render on a GPU (their ``arch`` is one of :data:`GPU_ARCHS`)."""
    return str(options.get("arch", "")).lower() in GPU_ARCHS


def smi_gpus() -> list[dict]:
    """Every NVIDIA GPU of the machine as ``nvidia-smi -L`` lists them: ``[{"index", "name", "uuid"}]``; ``[]``
    where there is no ``nvidia-smi`` or it fails."""
    try:
        proc = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True, timeout=NVIDIA_SMI_TIMEOUT_S,
                              check=False, env={k: v for k, v in os.environ.items() if k != "CUDA_VISIBLE_DEVICES"})
    except (OSError, subprocess.TimeoutExpired):
        return []
    if proc.returncode != 0:
        return []
    return [{"index": int(m[1]), "name": m[2].strip(), "uuid": m[3]}
            for m in (_LINE.search(line) for line in proc.stdout.splitlines()) if m]


def _proc_fields(text: str) -> dict[str, str]:
    """The ``Field: value`` lines of a driver ``information`` file as a dict (values stripped)."""
    return {key.strip(): value.strip() for key, sep, value in (line.partition(":") for line in text.splitlines())
            if sep}


def proc_gpus(root: Path | str | None = None, dev: Path | str | None = None) -> list[dict] | None:
    """Every NVIDIA GPU of the machine as the driver lists them in ``root`` (default :data:`NVIDIA_PROC_GPUS`): one
    folder per GPU named by its PCI bus id, holding an ``information`` file with ``Model:``, ``GPU UUID:``,
    ``Device Minor:`` and ``GPU Excluded:`` lines. ``[{"index", "name", "uuid"}]`` in PCI bus id order, the order
    and numbering of ``nvidia-smi`` (``index`` counts the GPUs listed); a GPU the driver excludes
    (``GPU Excluded: Yes``) or whose device file ``<dev>/nvidia<minor>`` (``dev`` default :data:`DEVICE_DIR`) this
    process cannot see (a container given some of the host's GPUs) is left out, as ``nvidia-smi`` leaves it out.

    None where the listing cannot stand for ``nvidia-smi -L``'s: no such folder, no GPU in it, a file that cannot be
    read, or a GPU without its model or a full UUID (a driver that shows ``GPU-????????-…`` before the GPU is first
    initialised); the caller then asks ``nvidia-smi``."""
    root = NVIDIA_PROC_GPUS if root is None else Path(root)
    dev = DEVICE_DIR if dev is None else Path(dev)
    try:
        folders = sorted(p for p in root.iterdir() if (p / "information").is_file())
        infos = [_proc_fields((p / "information").read_text(errors="replace")) for p in folders]
    except OSError:
        return None
    found = []
    for info in infos:
        name, uuid, minor = info.get("Model", ""), info.get("GPU UUID", ""), info.get("Device Minor", "")
        if not name or not _UUID.fullmatch(uuid):
            return None
        if info.get("GPU Excluded", "No").lower().startswith("yes"):
            continue
        if minor.isdigit() and not (dev / f"nvidia{minor}").exists():
            continue
        found.append({"index": len(found), "name": name, "uuid": uuid})
    return found or None


def machine_gpus(environ: dict | None = None) -> list[dict]:
    """Every NVIDIA GPU of the machine, ``[{"index", "name", "uuid"}]`` in ``nvidia-smi``'s order and numbering:
    from the driver's files (:func:`proc_gpus`) unless ``CUDA_VISIBLE_DEVICES`` in ``environ`` (default this
    process's) names a GPU by index, else from ``nvidia-smi -L`` (:func:`smi_gpus`). Indices follow ``nvidia-smi``,
    which on a host that confines a job to some GPUs by its device cgroup (Slurm) counts only those the job may
    open, as its ``CUDA_VISIBLE_DEVICES`` does; the driver's files list them all, so indices are read only against
    ``nvidia-smi``'s list; UUIDs are the same in both."""
    environ = os.environ if environ is None else environ
    wanted = environ.get("CUDA_VISIBLE_DEVICES") or ""
    if not any(entry.strip().isdigit() for entry in wanted.split(",")):
        listed = proc_gpus()
        if listed is not None:
            return listed
    return smi_gpus()


def visible_gpus(environ: dict | None = None) -> list[dict]:
    """The GPUs a process with ``environ`` (default this one's) may use, in CUDA's order: ``[{"index": physical
    index, "name", "uuid"}]``; all of the machine's without ``CUDA_VISIBLE_DEVICES``, those it names (indices or
    UUIDs, up to the first it cannot find, as CUDA reads it) with it; ``[]`` without NVIDIA GPUs."""
    environ = os.environ if environ is None else environ
    found = machine_gpus(environ)
    wanted = environ.get("CUDA_VISIBLE_DEVICES")
    if wanted is None:
        return found
    out = []
    for entry in (e.strip() for e in wanted.split(",")):
        match = [g for g in found if (entry.isdigit() and g["index"] == int(entry))
                 or (entry.startswith("GPU-") and g["uuid"].startswith(entry))]
        if not match or match[0] in out:
            break
        out.append(match[0])
    return out


def gpu_for_worker(k: int, gpus: list[dict]) -> dict | None:
    """Worker ``k``'s GPU: ``gpus[k mod len(gpus)]``; None without GPUs."""
    return gpus[k % len(gpus)] if gpus else None


def pin(gpu: dict | None, environ: dict | None = None) -> None:
    """Make ``gpu`` (from :func:`visible_gpus`) the only GPU of a process with ``environ`` (default this one's):
    ``CUDA_VISIBLE_DEVICES`` set to its UUID, before anything initialises CUDA (Taichi reads it at ``ti.init``).
    Nothing for None."""
    if gpu is not None:
        (os.environ if environ is None else environ)["CUDA_VISIBLE_DEVICES"] = gpu["uuid"]


#: Taichi's CPU arches (:func:`benchbot.batch.provenance.taichi_device`): a backend that fell back to one of them ran
#: on no GPU, whatever its process was given.
CPU_ARCHS = ("x64", "arm64", "cpu")


def on_cpu(node: dict, backend: dict) -> dict:
    """A record's ``node`` without its ``gpu`` when its ``backend`` facts say it rendered on the CPU (Taichi fell
    back from CUDA: no usable GPU), else ``node`` as it is."""
    if str(backend.get("arch", "")) in CPU_ARCHS and "gpu" in node:
        return {k: v for k, v in node.items() if k != "gpu"}
    return node


def recorded(gpu: dict | None) -> dict:
    """What an episode's record keeps of ``gpu``: ``{"gpu": {"index", "name"}}`` (``{}`` for None)."""
    return {"gpu": {"index": gpu["index"], "name": gpu["name"]}} if gpu else {}
