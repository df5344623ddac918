"""Each row's sensitivity to its settings, from the search every row gets (`search`), drawn
as Jordan et al. (2020, "Evaluating the performance of reinforcement learning algorithms",
ICML) look at it: not the best configuration alone but the distribution of the scores over
the configurations searched.

Per task one figure of two panels:
- left, each row's configurations sorted by their mean final greedy normalised score (the
  search's agents), against their rank as a fraction of the search: a row whose curve stays
  high does well over most of its search, one that rises at the right end only needs its
  settings found;
- right, each configuration's score against the row's step size (lwrl's learners' alpha, the
  deep learners' learning rate), the setting every row's search draws on a log scale; the
  chosen configuration ringed.
"""

import matplotlib.pyplot as plt
import numpy as np

from lwrl.analysis.plots import save_figure
from lwrl.studies.paper.benchmark import protocol, search

STEP_SIZES = ("alpha", "learning_rate")
"""The settings that are a row's step size, the first a row has."""


def step_size(task: str, row: protocol.Row, settings: dict) -> float:
    """The step size of a configuration `settings` of `row` (its own value where the search
    did not draw it: the start's)."""
    values = {**search.start(task, row), **settings}
    name = next(name for name in STEP_SIZES if values.get(name) is not None)
    return float(values[name])


def points(runs) -> dict:
    """`{label: (step sizes, mean scores, chosen position)}` of every row of `runs`
    (`study.TaskRuns`) with search scores, in configuration order (a diverged agent's NaN
    counts as the worst, as `study.choose` counts it)."""
    result = {}
    for row in protocol.rows(runs.task):
        scored = sorted(i for label, i in runs.search_scores if label == row.label)
        if not scored:
            continue
        configurations = search.configurations(runs.task, row)
        means = np.array([np.mean(np.nan_to_num(runs.search_scores[row.label, i], nan=-np.inf))
                          for i in scored])
        sizes = np.array([step_size(runs.task, row, configurations[i]) for i in scored])
        result[row.label] = (sizes, means, scored.index(runs.chosen[row.label]))
    return result


def figure(runs, figure_dir: str) -> list:
    """The task's sensitivity figure (see the module); the paths written."""
    fig, (ranks, sizes) = plt.subplots(1, 2, figsize=(10, 4))
    for label, (steps, means, chosen) in points(runs).items():
        shown = np.maximum(means, -1.0)  # a diverged configuration (-inf) at the axis's foot
        order = np.sort(shown)
        line, = ranks.plot((np.arange(len(order)) + 1) / len(order), order, marker=".", label=label)
        sizes.scatter(steps, shown, s=14, color=line.get_color())
        sizes.scatter(steps[chosen], shown[chosen], s=80, facecolors="none",
                      edgecolors=line.get_color())
    ranks.set_xlabel("configurations at or below (fraction of the search)")
    ranks.set_ylabel("mean final normalised score (diverged: -1)")
    ranks.axhline(protocol.LEVEL, color="grey", linewidth=0.8, linestyle="--")
    ranks.legend(fontsize="small")
    sizes.set_xscale("log")
    sizes.set_xlabel("step size (alpha or learning rate)")
    sizes.set_ylabel("mean final normalised score")
    sizes.set_title("ringed: chosen", fontsize="small")
    fig.suptitle(f"{runs.task}: every row's search")
    fig.tight_layout()
    return save_figure(fig, figure_dir, f"{runs.task}-sensitivity")
