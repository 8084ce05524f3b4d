"""What a run directory's manifest says about how it ran, as ``benchbot report`` and ``benchbot leaderboard`` show it
and compare runs on it: the solution (:func:`solution`, from the recorded command), its isolation and whether its
scores are verifiable (:func:`isolation`, :func:`verifiable`), the standing of its worlds (:func:`worlds`), the
conditions two runs must share to be compared (:data:`CONDITIONS`, :func:`conditions`,
:func:`condition_differences`) and the report's provenance table (:func:`provenance_rows`). What is recorded, and
how, is :mod:`benchbot.batch.provenance`'s.
"""

from __future__ import annotations

import shlex
from typing import TYPE_CHECKING

from benchbot.batch.figures import fmt
from benchbot.solutions.sandbox import VERIFIABLE

if TYPE_CHECKING:
    from benchbot.batch.run_data import RunData


_SOLUTION_FLAGS = ((("--example", "-E"), "example"), (("--native", "-n"), "native"),
                   (("--containerised", "-c"), "container"))
"""The ``benchbot batch`` flags that name a solution, and its kind."""


def solution(manifest: dict) -> tuple[str, str]:
    """``(kind, what)`` of the run's solution from the ``benchbot batch`` command it recorded: ``("example",
    "semslam_geometric")``, ``("native", "python my.py")``, ``("container", "path/to/dir")``; else ``("native",
    <the first episode's command>)`` or ``("unknown", "")``."""
    command = [str(w) for w in manifest.get("command") or []]
    for flags, kind in _SOLUTION_FLAGS:
        for i, word in enumerate(command):
            if word in flags and i + 1 < len(command):
                return kind, command[i + 1]
            for flag in flags:
                if flag.startswith("--") and word.startswith(flag + "="):
                    return kind, word.split("=", 1)[1]
    plan = manifest.get("plan") or [{}]
    argv = plan[0].get("argv") if isinstance(plan[0], dict) else None
    return ("native", " ".join(map(str, argv))) if argv else ("unknown", "")


def isolation(manifest: dict) -> str:
    """How the run's solutions were isolated (its manifest's ``sandbox``: ``bwrap``, ``container`` or ``none``);
    ``none`` for a batch that ran before BenchBot recorded it (it ran unsandboxed)."""
    return str(manifest.get("sandbox") or "none")


def verifiable(manifest: dict) -> bool:
    """Whether the run's scores can be trusted: its solutions could not read the ground truth (they ran sandboxed
    or in a container, docs/security.md)."""
    return isolation(manifest) in VERIFIABLE


def worlds(manifest: dict) -> str:
    """The standing of the run's worlds (:func:`benchbot.batch.signing.worlds_standing`): ``held-out`` when every
    environment is a world of a held-out split (only the scoring host can build it), else ``development — ground
    truth public`` (BEAR, procedural train/val: a solution can carry their ground truth, so no score on them is
    evidence of anything but development)."""
    from benchbot.batch.signing import worlds_standing

    return worlds_standing(manifest.get("environments") or [])


def _distinct(values) -> str:
    """The distinct non-empty values, sorted, joined with " + " ("" when none)."""
    return " + ".join(sorted({str(v) for v in values if v not in (None, "")}))


def camera(run: RunData) -> str:
    """The camera size the run's episodes used, ``WIDTHxHEIGHT``: the plan's options (``--camera-size``), else the
    robots' own (their spec's ``sensors.camera``), else ""."""
    plan = [p for p in run.manifest.get("plan", []) if isinstance(p, dict)]
    sizes = set()
    robots = (run.config.get("robots") or {}) if isinstance(run.config, dict) else {}
    for p in plan:
        options = p.get("options") or {}
        if options.get("width") and options.get("height"):
            sizes.add(f"{options['width']}x{options['height']}")
            continue
        cam = (((robots.get(p.get("robot")) or {}).get("sensors") or {}).get("camera") or {})
        if cam.get("width") and cam.get("height"):
            sizes.add(f"{cam['width']}x{cam['height']}")
    return _distinct(sizes)


def backend(run: RunData) -> dict[str, str]:
    """What the run's episodes' backends were (their records' ``backend``, distinct values joined): ``simulator``
    (plugin distribution and version), ``style``, ``arch``, ``device``; a value is "" when no episode recorded it
    (batches from before BenchBot recorded it)."""
    records = [e.get("backend") or {} for e in run.manifest.get("episodes", []) if isinstance(e, dict)]
    return {"simulator": _distinct(f"{b.get('distribution') or b.get('plugin') or b.get('type')} {b.get('version') or ''}".strip()
                                   for b in records if b),
            "style": _distinct(b.get("style") for b in records),
            "arch": _distinct(b.get("arch") for b in records),
            "device": _distinct(b.get("device") for b in records)}


CONDITIONS = ("task", "robot", "environments", "noise preset", "camera", "simulator", "simulator style", "arch",
              "isolation", "evaluation", "ground truth")
"""What two runs must share for their scores to be comparable (the leaderboard's condition set; a report warns
when runs differ in one the comparison does not name). ``ground truth`` is the set of ground truths the scores
used (``isaac_develop``, ``bear_develop``: the same map scores differently against each)."""

CONTEXT = ("BenchBot", "lock", "device")
"""Provenance a report also compares (a difference is named, as it may change numbers, but is not a condition)."""


def conditions(run: RunData) -> dict[str, str]:
    """The run's :data:`CONDITIONS` and :data:`CONTEXT` as text (distinct values joined; "" where not recorded)."""
    m = run.manifest
    b = backend(run)
    lock = ((m.get("provenance") or {}).get("lock") or {}).get("sha256") or ""
    return {"task": str(m.get("task", "")), "robot": _distinct(r["robot"] for r in run.rows),
            "environments": ", ".join(sorted({r["env"] for r in run.rows})),
            "noise preset": _distinct(r["noise"] for r in run.rows), "camera": camera(run),
            "simulator": b["simulator"], "simulator style": b["style"], "arch": b["arch"],
            "isolation": isolation(m), "evaluation": str(m.get("evaluate_with") or ""),
            "ground truth": _distinct(r.get("ground_truth_set") for r in run.rows),
            "BenchBot": str((m.get("versions") or {}).get("benchbot", "")), "lock": lock[:12], "device": b["device"]}


def condition_differences(runs: list[RunData], mentioned: set[str] | None = None) -> list[dict]:
    """The conditions (and context) in which ``runs`` differ, except those in ``mentioned`` (the factors the
    comparison is about) and ``environments`` (comparisons pair environments both runs have):
    ``[{"what", "values": {label: value}, "condition": bool}]``. A value not recorded in one run is not a
    difference (older batches recorded less)."""
    out = []
    table = [conditions(run) for run in runs]
    for what in CONDITIONS + CONTEXT:
        if what in (mentioned or set()) or what == "environments":
            continue
        values = {run.name: c[what] for run, c in zip(runs, table)}
        if len({v for v in values.values() if v}) > 1:
            out.append({"what": what, "values": values, "condition": what in CONDITIONS})
    return out


def provenance_rows(run: RunData) -> list[tuple[str, str]]:
    """``[(what, value)]``: where a run's numbers came from (solution, command, task, robots, environments,
    episodes, seeds, simulator, style, camera, arch and device, times, versions, lock file, git revisions, machine),
    as its manifest recorded them."""
    m = run.manifest
    kind, what = solution(m)
    plan = [p for p in m.get("plan", []) if isinstance(p, dict)]
    records = [e for e in m.get("episodes", []) if isinstance(e, dict)]
    seeds = sorted({int(p["seed"]) for p in plan if isinstance(p.get("seed"), int)})
    statuses: dict[str, int] = {}
    for e in records:
        statuses[str(e.get("status"))] = statuses.get(str(e.get("status")), 0) + 1
    versions = m.get("versions") or {}
    prov = m.get("provenance") or {}
    machine = prov.get("machine") or {}
    not_recorded = "not recorded (the batch ran before BenchBot recorded it)"
    level = isolation(m)
    b = backend(run)
    lock = prov.get("lock") or {}
    command = prov.get("command") or (shlex.join(["benchbot"] + [str(w) for w in (m.get("command") or [])[1:]])
                                      if m.get("command") else "not recorded")
    rows = [
        ("solution", f"{kind} {what}".strip()),
        ("isolation", f"{level} ({'scores verifiable' if verifiable(m) else 'NOT VERIFIABLE: the solution could read the ground truth'})"
         + ("" if "sandbox" in m else "; not recorded (the batch ran before the sandbox)")),
        ("command", command),
        ("task", str(m.get("task", ""))),
        ("robots", ", ".join(m.get("robots") or [])),
        ("environments", ", ".join(m.get("environments") or [])),
        ("worlds", worlds(m)),
        ("episodes", f"{len(run.rows)} scored of {len(plan) or len(records)} planned ("
                     + ", ".join(f"{n} {s}" for s, n in sorted(statuses.items())) + ")"),
        ("seeds", _ranges(seeds) if seeds else "not recorded"),
        ("noise presets", ", ".join(sorted({str(p.get("noise", "none")) for p in plan})) or "none"),
        ("camera", camera(run) or "not recorded"),
        ("simulator", b["simulator"] or not_recorded),
        ("scene style", b["style"] or not_recorded),
        ("arch, device", f"{b['arch']}, {b['device'] or 'unknown device'}" if b["arch"] else not_recorded),
        ("ground truth", _distinct(r.get("ground_truth_set") for r in run.rows) or not_recorded),
        ("evaluation", str(m.get("evaluate_with") or "none")
         + (f" (primary score {run.primary}, {run.score_set.primary.direction} is better"
            + ("" if run.score_set.declared else "; not declared by the method: assumed") + ")")),
        ("started", str(m.get("started", "not recorded"))),
        ("wall time", f"{fmt(m.get('wall_s'))} s" if isinstance(m.get("wall_s"), (int, float)) else "not recorded"),
        ("BenchBot", str(versions.get("benchbot", "not recorded"))),
        ("BenchBot git revision", str(prov.get("benchbot_git") or (not_recorded if not prov else "not a git checkout"))),
        ("solution git revision", ", ".join(f"{v or 'not a git checkout'} ({k})" for k, v in (prov.get("solution_git") or {}).items())
         or not_recorded),
        ("lock file", f"{lock.get('file')} sha256 {lock.get('sha256')}" if lock else
         ("none (BenchBot installed, not a checkout)" if "lock" in prov else not_recorded)),
        ("machine", (f"{machine.get('cpu') or '?'}, {machine.get('cpus') or '?'} CPUs, {fmt(machine.get('memory_gib'))} GiB; "
                     f"{machine.get('system') or versions.get('platform', '')}") if machine else
         f"{versions.get('platform', '')} (CPU, cores, memory {not_recorded})"),
        ("Python", str(versions.get("python", "not recorded"))),
        ("plugins", ", ".join(f"{k} {v}" for k, v in versions.items() if k not in ("python", "platform", "benchbot"))
         or "not recorded"),
        ("packages", (f"{len(prov['packages'])} installed: " + ", ".join(f"{k} {v}" for k, v in prov["packages"].items()))
         if prov.get("packages") else not_recorded),
    ]
    return rows


def _ranges(values: list[int]) -> str:
    """``[0, 1, 2, 5]`` → ``"0–2, 5"``."""
    out, start = [], None
    for k, v in enumerate(values):
        if start is None:
            start = v
        if k + 1 == len(values) or values[k + 1] != v + 1:
            out.append(str(start) if start == v else f"{start}–{v}")
            start = None
    return ", ".join(out)
