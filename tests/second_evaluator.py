"""A second evaluation method, defined in the tests, that knows nothing of OMQ: ``reach`` scores an object map by how
far each ground-truth object is from the nearest proposed object. Its primary score is lower-is-better, so every
view that reads the declaration (and not OMQ's names) ranks, compares and prints it the right way round.

Register it with ``Registry(extra_plugins={"reach": ReachPlugin()})`` (this folder on ``sys.path``); the spec's
functions are imported as ``second_evaluator:evaluate`` and ``second_evaluator:combine``."""

from __future__ import annotations

import numpy as np

from benchbot.core.hookspecs import hookimpl

REACH_M = 0.5
"""A ground-truth object with a proposal's centroid within this many metres counts as reached."""

SPEC = {
    "name": "reach",
    "description": "distance from each ground-truth object to the nearest proposal (a test method)",
    "valid_result_formats": ["object_map"],
    "valid_ground_truth_formats": ["object_map_ground_truth"],
    "functions": {"evaluate": "second_evaluator:evaluate", "combine": "second_evaluator:combine"},
    "scores": [
        {"name": "miss_m", "primary": True, "direction": "lower", "range": [0, None], "short": "miss",
         "description": "mean distance (m) from a ground-truth object's centroid to the nearest proposal's"},
        {"name": "reached", "direction": "higher", "range": [0, 1],
         "description": f"share of ground-truth objects with a proposal within {REACH_M} m"},
        {"name": "proposals", "kind": "count", "direction": "higher", "range": [0, None],
         "description": "objects proposed"},
    ],
}


def evaluate(results: dict, ground_truths: list[dict]) -> dict:
    """``{"scores": {"miss_m", "reached", "proposals"}}`` of a results file against its one ground truth."""
    gt = np.array([o["centroid"] for o in ground_truths[0]["ground_truth"]["objects"]], float).reshape(-1, 3)
    proposed = np.array([o["centroid"] for o in results["results"]["objects"]], float).reshape(-1, 3)
    if len(proposed) == 0:
        nearest = np.full(len(gt), 10.0)
    else:
        nearest = np.linalg.norm(gt[:, None, :] - proposed[None, :, :], axis=2).min(axis=1)
    return {"task_details": results["task_details"], "environment_details": results["environment_details"],
            "scores": {"miss_m": float(nearest.mean()), "reached": float((nearest <= REACH_M).mean()),
                       "proposals": int(len(proposed))}}


def combine(scores: list[dict]) -> dict:
    """Each score averaged over the results (a missing result counts as nothing proposed)."""
    keys = ("miss_m", "reached", "proposals")
    values = {k: [s["scores"][k] for s in scores if "scores" in s] for k in keys}
    return {"scores": {k: float(np.mean(v)) if v else 0.0 for k, v in values.items()}}


class ReachPlugin:
    """The plugin offering ``reach``."""

    @hookimpl
    def benchbot_evaluators(self) -> list[dict]:
        return [dict(SPEC)]


class UndeclaredPlugin:
    """``reach_undeclared``: the same method with no ``scores`` declaration (an older third-party evaluator)."""

    @hookimpl
    def benchbot_evaluators(self) -> list[dict]:
        return [{k: v for k, v in SPEC.items() if k != "scores"} | {"name": "reach_undeclared"}]


class TwoPrimariesPlugin:
    """``reach_two``: a declaration with two primary scores (refused by the schema)."""

    @hookimpl
    def benchbot_evaluators(self) -> list[dict]:
        scores = [dict(s, primary=True) for s in SPEC["scores"][:2]] + SPEC["scores"][2:]
        return [dict(SPEC, name="reach_two", scores=scores)]
