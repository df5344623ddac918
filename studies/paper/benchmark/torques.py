"""A task with discrete and with continuous actions side by side (docs/FINDINGS.md, "the
pendulum with continuous torque"): the rows of `DOMAIN.TASK` and of
`DOMAIN.TASK-continuous` on the task's own measure, and the light-weight rows of both (the
paper's agent with its three torques, the actor-critic with any torque in the range)
compared directly.

Doya (2000, "Reinforcement learning in continuous time and space", section 5) reports his
continuous actor-critic swinging the limited-torque pendulum up in several times fewer
trials than a discrete actor-critic. The numbers here speak to it in two units:
- greedy evaluations: the steps until an agent's greedy normalised score first reaches
  `protocol.LEVEL`, at the four fractions of the budget (`judging.steps_to_level`);
- trials: the first training episode (of the whole budget's training) whose up-time,
  normalised by its own task's random and classical rows, reaches `protocol.LEVEL`; an
  agent that never does counts the episodes it had plus one, and is counted apart.

Both tasks share the budget, the episodes and the measure; each task's normalised scores
are against its own reference rows (the classical controller acting with three torques or
with any torque in the range). The direct comparison is one test outside the verdicts'
Holm family, on the final greedy measure itself (seconds up), not the normalised score."""

import matplotlib.pyplot as plt
import numpy as np

from lwrl.analysis import statistics, verdicts
from lwrl.analysis.plots import markdown_images, save_figure
from lwrl.studies.paper.benchmark import evaluation, judging, protocol, study


def pairs(judged: list) -> list:
    """`[(discrete, continuous)]`: the `report.Judged` of each task judged with both kinds of
    action."""
    by_task = {j.runs.task: j for j in judged}
    return [(by_task[task], by_task[task + protocol.CONTINUOUS]) for task in by_task
            if task + protocol.CONTINUOUS in by_task]


def final_measures(runs: study.TaskRuns, label: str) -> np.ndarray:
    """Per agent of row `label`, its task's measure over the greedy episodes that evaluate
    the whole budget's training."""
    key = evaluation.evaluation(runs.trainings[label, protocol.FRACTIONS[-1]]).key
    return evaluation.measure(runs.tables[runs.tables["run"] == key], runs.task)


def training_measures(runs: study.TaskRuns, label: str) -> np.ndarray:
    """Agents x training episodes: the task's measure of each of row `label`'s training
    episodes over the whole budget (NaN after an agent's last)."""
    key = runs.trainings[label, protocol.FRACTIONS[-1]].key
    table = runs.tables[runs.tables["run"] == key]
    column = evaluation.task_measure(runs.task).column
    return table.pivot(index="seed", columns="episode", values=column).sort_index().to_numpy(float)


def trials_to_level(runs: study.TaskRuns, label: str) -> tuple:
    """`(trials, reached)` per agent of row `label`: the first training episode (from 1)
    whose measure, normalised by the task's reference rows, reaches `protocol.LEVEL`; the
    episodes it had plus one where none does."""
    measures = training_measures(runs, label)
    scores = study.normalised(runs.task, measures.ravel(), runs.references).reshape(measures.shape)
    at = np.nan_to_num(scores, nan=-np.inf) >= protocol.LEVEL
    had = np.sum(~np.isnan(measures), axis=1)
    reached = at.any(axis=1)
    return np.where(reached, np.argmax(at, axis=1) + 1, had + 1).astype(float), reached


def section(judged: list, figure_dir: str, out_dir: str) -> list:
    """The report's lines for every task judged with both kinds of action (none where no
    such pair was judged), its figures written to `figure_dir`."""
    lines = []
    for discrete, continuous in pairs(judged):
        task = discrete.runs.task
        measure = evaluation.task_measure(task)
        lines += [f"## {task}: three torques or any torque", "",
                  f"Both tasks' rows on {measure.label} (the final greedy evaluation), their "
                  "normalised scores against their own task's reference rows, the steps until "
                  f"the greedy normalised score reaches {protocol.LEVEL:g} and the training "
                  "episodes (trials) until an episode's does.", "",
                  f"| row | actions | final {measure.label} | final normalised score "
                  "| steps to the level | trials to the level | agents reaching it (trials) |",
                  "|---|---|---|---|---|---|---|"]
        for j, actions in ((discrete, "discrete"), (continuous, "continuous")):
            runs = j.runs
            for row in ("random", "classical"):
                lines.append(f"| {row} | {actions} | "
                             f"{statistics.mean_interval(runs.references[row]).text(1)} | "
                             f"{0 if row == 'random' else 1} | | | |")
            for label, compute in j.computes.items():
                if (label, protocol.FRACTIONS[-1]) not in runs.trainings:
                    continue  # an outside row: no training table
                trials, reached = trials_to_level(runs, label)
                lines.append(
                    f"| {label} | {actions} | "
                    f"{statistics.mean_interval(final_measures(runs, label)).text(1)} | "
                    f"{statistics.mean_interval(runs.scores[label, protocol.FRACTIONS[-1]]).text(2)} | "
                    f"{compute.steps.text(0)} | {statistics.mean_interval(trials).text(1)} | "
                    f"{int(reached.sum())} of {len(reached)} |")
        lines += ["", *_direct(discrete, continuous), ""]
        paths = _curves(discrete, continuous, figure_dir)
        lines += [*markdown_images(paths, out_dir), ""]
    return lines


def _direct(discrete, continuous) -> list:
    """The light-weight rows of the two tasks compared: the final greedy measure (a
    permutation test, P(improvement)) and the steps and trials to the level."""
    light = protocol.light(discrete.runs.task), protocol.light(continuous.runs.task)
    final = protocol.FRACTIONS[-1]
    if (light[0], final) not in discrete.runs.trainings or (light[1], final) not in continuous.runs.trainings:
        return []
    higher = evaluation.task_measure(discrete.runs.task).higher_is_better
    ours, theirs = final_measures(continuous.runs, light[1]), final_measures(discrete.runs, light[0])
    improvement = statistics.improvement_interval(ours, theirs, higher_is_better=higher)
    trials = [trials_to_level(j.runs, label)[0] for j, label in ((discrete, light[0]), (continuous, light[1]))]
    steps = [judging.steps_to_level(j.runs.scores, label, protocol.BUDGETS[j.runs.task])[0]
             for j, label in ((discrete, light[0]), (continuous, light[1]))]
    return [f"- {light[1]} (any torque) against {light[0]} (three torques), final "
            f"{evaluation.task_measure(discrete.runs.task).label}: P({light[1]} better) "
            f"{improvement.text(2)}, permutation p {verdicts.permutation_p_value(ours, theirs):.3g} "
            "(one comparison, outside the verdicts' Holm family).",
            f"- Steps to the level: {light[0]} {statistics.mean_interval(steps[0]).text(0)}, "
            f"{light[1]} {statistics.mean_interval(steps[1]).text(0)} (ratio of the means "
            f"{_ratio(steps[0], steps[1])}); trials: {statistics.mean_interval(trials[0]).text(1)} "
            f"against {statistics.mean_interval(trials[1]).text(1)} (ratio {_ratio(trials[0], trials[1])}). "
            "Doya (2000) reports several times fewer trials for his continuous actor-critic "
            "than for a discrete actor-critic; a ratio above 1 is fewer for the continuous row."]


def _ratio(a, b) -> str:
    """The ratio of the means of `a` and `b` with its bootstrap interval (agents resampled
    within each)."""
    estimate = statistics.interval(lambda x, y, axis=-1: np.mean(x, axis=axis) / np.mean(y, axis=axis),
                                   np.asarray(a, float), np.asarray(b, float))
    return estimate.text(2)


def _curves(discrete, continuous, figure_dir: str) -> list:
    """Every row's mean training measure per episode, both tasks on one figure (solid:
    continuous actions, dashed: discrete); the paths written."""
    figure, axes = plt.subplots(figsize=(7, 4))
    for j, style in ((discrete, "--"), (continuous, "-")):
        for label, fraction in j.runs.trainings:
            if fraction != protocol.FRACTIONS[-1]:
                continue
            measures = training_measures(j.runs, label)
            axes.plot(np.arange(1, measures.shape[1] + 1), np.nanmean(measures, axis=0), style,
                      label=f"{label} ({'continuous' if j is continuous else 'discrete'})")
    axes.set_xlabel("training episode (trial)")
    axes.set_ylabel(evaluation.task_measure(discrete.runs.task).label)
    axes.set_title(f"{discrete.runs.task}: three torques (dashed) or any torque (solid)")
    axes.legend(fontsize="small")
    return save_figure(figure, figure_dir, f"{discrete.runs.task}-torques")
