"""Which GPUs a batch's workers run on: the NVIDIA GPUs this process may use, and one for each worker.

With a GPU arch (``--arch cuda``/``gpu``, or ``auto`` that picked one), worker ``k`` of a batch gets visible GPU
``k mod G`` (:func:`gpu_for_worker`): its ``CUDA_VISIBLE_DEVICES`` is set to that one GPU before Taichi initialises
(:func:`pin`), so the CUDA driver and Taichi see it as device 0. The GPUs are listed by ``nvidia-smi -L`` (no CUDA
context is made here), narrowed to this process's own ``CUDA_VISIBLE_DEVICES`` where it is set (indices or
``GPU-…`` UUIDs, in its order). Each episode records the GPU it ran on, ``{"index": physical index, "name"}``, in
its record's ``node`` (``gpu``).
"""

from __future__ import annotations

import os
import re
import subprocess

#: The backend options' ``arch`` values that render on a GPU (:func:`benchbot.cli.common.backend_options`).
GPU_ARCHS = ("gpu", "cuda")
#: Seconds ``nvidia-smi -L`` may take.
NVIDIA_SMI_TIMEOUT_S = 10.0

_LINE = re.compile(r"GPU (\d+): (.*?) \(UUID: (GPU-[0-9a-fA-F-]+)\)")


def wants_gpu(options: dict) -> bool:
    """Whether backend ``options`` render on a GPU (their ``arch`` is one of :data:`GPU_ARCHS`)."""
    return str(options.get("arch", "")).lower() in GPU_ARCHS


def _all_gpus() -> list[dict]:
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


def visible_gpus(environ: dict | None = None) -> list[dict]:
    """The GPUs a process with ``environ`` (default this one's) may use, in CUDA's order: ``[{"index": physical
    index, "name", "uuid"}]``; all of the machine's without ``CUDA_VISIBLE_DEVICES``, those it names (indices or
    UUIDs, up to the first it cannot find, as CUDA reads it) with it; ``[]`` without NVIDIA GPUs."""
    found = _all_gpus()
    environ = os.environ if environ is None else environ
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
