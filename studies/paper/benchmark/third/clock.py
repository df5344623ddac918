"""The third benchmark's clock (docs/FINDINGS.md, the third benchmark's rule, "A fine clock"):
each run is evaluated greedily at `len(POINTS)` points log-spaced over its budget, 2^(j/3 - 6)
of it for j = -1 ... 18 (1.2 % to 100 %, 1/4 and 1/2 among them), `VERDICT_EPISODES` greedy
episodes at the points the verdicts read (`VERDICTS`: 1/4, 1 and 4 times the budget), one at
the others. A row still rising at the budget (`rising`) is continued to 4 times it, at the
points j = 19 ... 24 (`longer_trainings`).

A point's agents are those of the run given that fraction of the budget: a budget cuts a run
without changing what came before it (tests/test_budget.py), so the runs of one row at the
20 budgets are one run's agents at 20 moments. For a population learner `runners.sweep`
computes them as one run with checkpoints (`runners.sweep.families`); a linear learner's
cost a few seconds each.

Greedy episodes are the second benchmark's (`evaluation.evaluation`: each agent's seed +
10 000 for its starts, the task's own episodes, the cap of the tasks measured in steps),
and on the acrobot they start from states that differ (`START_SPREAD`), the same draws for
every row (they come from the agent's seed alone).
"""

import dataclasses

import numpy as np

from lwrl.analysis.statistics import mean_interval
from lwrl.runners.config import RunConfig
from lwrl.studies.paper.benchmark import evaluation, protocol

POINTS = tuple(range(-1, 19))
"""The points j of the clock: the fraction 2^(j/3 - 6) of the budget each."""
LONGER = tuple(range(19, 25))
"""The points past the budget, to 4 times it, of a row still rising at 1 (`rising`)."""
VERDICTS = (12, 18, 24)
"""The points the verdicts read: 1/4, 1 and 4 times the budget."""
HALF = 15
"""The point at 1/2 of the budget, against which a row's rise at 1 is measured."""
VERDICT_EPISODES = evaluation.EPISODES
"""Greedy episodes per agent at a point the verdicts read."""
FINE_EPISODES = 1
"""Greedy episodes per agent at the other points (the area averages over the points)."""
START_SPREAD = {"acrobot.swingup": 0.1}
"""`{task: s}`: the tasks whose greedy episodes start from states drawn uniformly in [-s, s]
around their rest, in each variable (the acrobot's task option `start_spread`: Gymnasium's
Acrobot-v1 start), where the task itself starts from one state."""


def fraction(point: int) -> float:
    """The fraction of the budget at `point` j: 2^(j/3 - 6)."""
    return 2.0 ** (point / 3 - 6)


def budgets(budget: int, points=POINTS) -> dict:
    """`{j: steps}`: the budget of the run cut at each of `points` of the clock."""
    return {point: round(fraction(point) * budget) for point in points}


def trainings(full: RunConfig) -> dict:
    """`{j: RunConfig}`: the run `full` (its whole budget) cut at each point of the clock."""
    return {point: dataclasses.replace(full, budget=steps)
            for point, steps in budgets(full.budget).items()}


def longer_trainings(full: RunConfig) -> dict:
    """`{j: RunConfig}`: the run `full` (its whole budget) continued to each point past it
    (`LONGER`), the same run (its settings, the learner's horizon among them) given more
    steps and as many more episodes: its cut at the budget is `full`'s run (the budget, not
    the episodes, ends it, `protocol.most_episodes`)."""
    longer = dataclasses.replace(full, episodes=round(fraction(LONGER[-1])) * full.episodes)
    return {point: dataclasses.replace(longer, budget=steps)
            for point, steps in budgets(full.budget, LONGER).items()}


def rising(scores: dict) -> bool:
    """Whether a row's agents, `{j: (agents,) normalised scores}`, are still rising at the
    budget: the interval of their mean rise from 1/2 to 1 of it wholly above 0."""
    return bool(mean_interval(np.asarray(scores[POINTS[-1]]) - np.asarray(scores[HALF])).low > 0)


def point_of(training: RunConfig, budget: int) -> int:
    """The point j of the clock at which `training` ends, of a task of `budget` steps; a
    ValueError where it ends at none."""
    for point, steps in budgets(budget, POINTS + LONGER).items():
        if steps == training.budget:
            return point
    raise ValueError(f"a run of {training.budget} steps ends at no point of the clock of a "
                     f"budget of {budget} steps")


def greedy(training: RunConfig, episodes: int) -> RunConfig:
    """The greedy evaluation of the agents of `training` as they ended it
    (`evaluation.evaluation`), `episodes` episodes each, from starts that differ where the
    task starts from one state (`START_SPREAD`)."""
    run = evaluation.evaluation(training)
    spread = START_SPREAD.get(training.task)
    options = dict(run.task_options, start_spread=spread) if spread else run.task_options
    return dataclasses.replace(run, episodes=episodes, task_options=options)


def episodes_at(training: RunConfig) -> int:
    """The greedy episodes per agent at the point `training` ends: `VERDICT_EPISODES` at the
    points the verdicts read, else `FINE_EPISODES`."""
    budget = protocol.BUDGETS[benchmark_task(training)]
    return VERDICT_EPISODES if point_of(training, budget) in VERDICTS else FINE_EPISODES


def evaluation_at(training: RunConfig) -> RunConfig:
    """The clock's greedy evaluation of `training`, one of a row's runs (`trainings`)."""
    return greedy(training, episodes_at(training))


def benchmark_task(config: RunConfig) -> str:
    """The benchmark task (`protocol.BUDGETS`'s name) a run trains on."""
    return config.task + (protocol.CONTINUOUS if config.actions == "continuous" else "")


def area(fractions, scores) -> float:
    """The area under the normalised-score curve over the budget: the trapezoid over the
    evaluations at `fractions` of the budget (in steps, divided by the budget), of the
    `scores` there (the rule's "faster", judged on curves)."""
    return float(np.trapezoid(np.asarray(scores, dtype=float), np.asarray(fractions, dtype=float)))
