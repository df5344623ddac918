"""The study as one call: every task's runs, figures and the report (`lwrl robustness`)."""

import os
import time

from lwrl import outputs
from lwrl.studies.robustness import plan, report
from lwrl.studies.robustness.study import study_task

REPORT = "report.md"
FIGURES = "figures"


def robustness(task_names, out_dir: str, command: str, plant: str = "analytic",
               quick: bool = False, agents=None, episodes=None, evaluation_episodes=None,
               sweep=None, stepped=None, learners=None) -> str:
    """Run the study of each task (resuming what an earlier call into `out_dir` finished;
    `sweep`: where its batches run, `runners.sweep.run_sweep`'s `backend`, `workers` and
    `address`; `stepped`: `plan.stepped_protocol`'s; `learners`: the learners trained, None
    for every one that fits), then write one map figure per task in
    `out_dir/figures` and `out_dir/report.md`, which names `command` and the wall time;
    return the report's path."""
    if agents is not None and agents < 2:
        raise ValueError(f"agents must be at least 2 (an interval needs two agents); got {agents}")
    for task in task_names:  # every task's learners checked before anything runs
        plan.chosen_learners(task, plant, learners)
    started = time.perf_counter()
    results = [study_task(task, out_dir, plant, quick, agents, episodes, evaluation_episodes,
                          sweep, stepped, learners) for task in task_names]
    figure_dir = os.path.join(out_dir, FIGURES)
    paths = {}
    for result in results:
        written = report.figure(result, figure_dir)
        paths[result.task] = os.path.relpath(written[0], out_dir)
    path = os.path.join(out_dir, REPORT)
    with outputs.atomic_write(path) as file:
        file.write(report.document(results, command, time.perf_counter() - started, paths))
    return path
