"""The figures of a report (``benchbot report``): which ones the analysis (:func:`benchbot.batch.analysis.analyse`)
gives, what each draws and its caption, each rendered as PNG, SVG and PDF (:class:`Figure`). The drawing itself,
from plain data, is :mod:`benchbot.batch.figures`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

from benchbot.batch import figures, stats
from benchbot.batch.figures import fmt
from benchbot.batch.object_views import driven_path, map_episode, per_class_columns, trajectory
from benchbot.batch.run_data import RunData
from benchbot.batch.run_stats import present_scores


@dataclass
class Figure:
    """A rendered figure: its file stem, heading, caption and bytes per format."""

    name: str
    title: str
    caption: str
    data: dict[str, bytes]


def make_figures(runs: list[RunData], result: dict, registry=None) -> list[Figure]:
    """Render every figure of the report (PNG, SVG, PDF each), in the page's order: ``summary``, ``environments``,
    ``score_distribution``, ``comparison_K``, ``factor_<factor>``, ``per_class_K``, ``map_<environment>``; runs are
    drawn under short labels when their names are long (:func:`benchbot.batch.figures.short_labels`), the legend
    naming them. ``registry`` gives the planned paths the maps draw (else the results files' own scenes).

    Raises:
        UsageError: matplotlib is missing (:func:`benchbot.batch.figures.pyplot`).
    """
    shorts = figures.short_labels([r["label"] for r in result["runs"]])
    return (_overview_figures(runs, result, shorts) + _comparison_figures(result) + _factor_figures(result, shorts)
            + _per_class_figures(runs, result) + _maps(runs, result, shorts, registry))


def _overview_figures(runs: list[RunData], result: dict, shorts: list[str]) -> list[Figure]:
    """``summary`` (every score over environments), ``environments`` (the primary score per environment) and
    ``score_distribution``."""
    scores = present_scores(runs)
    main = result["main_score"]
    series = [{"label": r["label"], "short": short,
               "values": {s: list(stats.cluster_means([x[s] for x in run.rows if s in x],
                                                      [x["env"] for x in run.rows if s in x]).values())
                          for s in scores},
               "estimates": r["summary"]} for run, r, short in zip(runs, result["runs"], shorts)]
    envs = list(dict.fromkeys(e for r in result["runs"] for e in r["environments"]))
    env_series = [{"label": r["label"], "short": short,
                   "values": {e: v["values"] for e, v in r["environments"].items()}, "estimates": r["environments"]}
                  for r, short in zip(result["runs"], shorts)]
    return [
        Figure("summary", "Scores over environments",
               "Each dot is one environment's mean; the mean over environments is drawn with its 95 % interval "
               f"over them where n allows (n ≥ {stats.MIN_CI_N} environments); every panel's axis is scaled "
               "to its data.",
               figures.render(figures.summary(scores, series, stats.MIN_CI_N))),
        Figure("environments", f"{main} per environment",
               "Each dot is one episode (a repetition); the interval is over the environment's episodes; n under "
               "each environment, one number per run.",
               figures.render(figures.per_group(f"{main} per environment", main, envs, env_series, stats.MIN_CI_N))),
        Figure("score_distribution", f"{main}: score distributions",
               "The fraction of each run's episodes scoring above τ, averaged over its environments (each "
               "counts once), with a 95 % band by the stratified bootstrap (episodes resampled within each "
               "environment: about these environments). A curve above another everywhere is better everywhere.",
               figures.render(figures.score_distribution(main, [
                   {"label": r["label"], "short": short, "distribution": r["robust"]["score_distribution"],
                    "n": r["environments_n"]} for r, short in zip(result["runs"], shorts)]))),
    ]


def _comparison_figures(result: dict) -> list[Figure]:
    """``comparison_K``: the paired differences of the K-th comparison (from 1), when it has episode pairs."""
    main = result["main_score"]
    return [Figure(f"comparison_{k + 1}", f"{c['b']} vs {c['a']}: paired differences",
                   f"Grey dots: episode pairs ({c['pairing']}); large dots: each environment's mean "
                   "difference, the unit of the test; the line is the mean over environments and the band "
                   "its interval.",
                   figures.render(figures.paired_differences(c, main, stats.MIN_TEST_PAIRS)))
            for k, c in enumerate(result["comparisons"]) if c["episodes"]["n"]]


def _factor_figures(result: dict, shorts: list[str]) -> list[Figure]:
    """``factor_<factor>``: the primary score per level of each factor the runs vary that can be shown."""
    main = result["main_score"]
    out = []
    for view in result["factors"]:
        if view["groups"]:
            for s, short in zip(view["series"], shorts):
                s["short"] = short
            out.append(Figure(f"factor_{view['factor']}", f"{main} per {view['factor']}", view["note"],
                              figures.render(figures.per_group(f"{main} per {view['factor']}", main,
                                                               view["groups"], view["series"], stats.MIN_CI_N))))
    return out


def _per_class_figures(runs: list[RunData], result: dict) -> list[Figure]:
    """``per_class_K``: the K-th run's (from 1) per-class counts and scores, when it has them."""
    main = result["main_score"]
    out = []
    for k, (run, r) in enumerate(zip(runs, result["runs"])):
        if r["per_class"]:
            counts, class_scores = per_class_columns(run)
            directions = [(c, run.score_set.get(c).direction) for c in counts]
            out.append(Figure(f"per_class_{k + 1}", f"{r['label']}: per class",
                              "Left: the method's counts per class (those where lower is better to the left of 0). "
                              "Right: its per-class scores.",
                              figures.render(figures.per_class(r["label"], r["per_class"], len(run.objects),
                                                               directions, [s for s in class_scores if s != main]
                                                               or class_scores))))
    return out


def _maps(runs: list[RunData], result: dict, shorts: list[str], registry) -> list[Figure]:
    """``map_<environment>``: a top-down map per environment, one panel per run with per-object matches there."""
    out = []
    for env in dict.fromkeys(e for r in result["runs"] for e in r["environments"]):
        panels = [panel for run, short in zip(runs, shorts)
                  if (panel := _map_panel(run, short, env, registry)) is not None]
        if panels:
            out.append(Figure(f"map_{_slug(env)}", f"{env}: top-down map",
                              f"{len(panels)} panel{'s' if len(panels) > 1 else ''}, one per run; solid: the path the "
                              "robot drove (from the batch's trajectory log or its recording), dashed: the planned "
                              "path.",
                              figures.render(figures.topdown(env, panels))))
    return out


def _map_panel(run: RunData, short: str, env: str, registry) -> dict | None:
    """The panel of ``run`` on the map of ``env`` (:func:`benchbot.batch.figures.topdown`): its median episode
    there (:func:`~benchbot.batch.object_views.map_episode`) with its matches, driven and planned paths; None when
    no episode of it there has matches."""
    chosen = map_episode(run, env)
    if chosen is None:
        return None
    row, evaluation, n = chosen
    s = evaluation.get("scores") or {}
    which = f"median-{run.primary} episode of {n}" if n > 1 else "its only episode"
    path, source = driven_path(run, row)
    counts = ", ".join(f"{c} {s.get(c)}" for c in run.score_set.counts if c in s)
    name = short if short == run.name else f"{short}: {run.name}"
    return {"title": figures._wrap(f"{name}: episode {row['index']} (seed {row['seed']}, {which})", 60)
                     + f"\n{run.primary} {fmt(s.get(run.primary))}" + (f", {counts}" if counts else "")
                     + ("" if path is not None else "\nno driven path recorded: the plan only"),
            "matches": evaluation["matches"], "path": path, "path_source": source,
            "plan": trajectory(env, registry, evaluation.get("environment_details"))}


def _slug(text: str) -> str:
    """``text`` with every character but letters and digits as ``_`` (a file name: ``house:1`` → ``house_1``)."""
    return "".join(c if c.isalnum() else "_" for c in text)
