"""`lwrl compare`: the analytic and physics-engine plants of one task, side by side.

    from lwrl.studies.compare.comparison import compare
    comparison = compare("pendulum.swingup", seeds=10, out_dir="compare/pendulum")
    comparison.open_loop.trials         # tidy tables (pandas)

1. Open loop (`lwrl.studies.compare.open_loop`): the same starts and random actions on MuJoCo, the
   analytic semi-implicit and explicit Euler plants and an RK4 reference; per-step
   divergence, time within tolerance, energy drift.
2. Closed loop (`lwrl.studies.compare.closed_loop`): the task's default agent learning on
   each plant, held on each to a claim when given one (`judge`; `lwrl compare` passes the
   paper's item for the task, `lwrl.studies.paper.items.judge`).
3. Transfer: each trained batch run greedily on every plant.
4. With `rrd_path`, a Rerun recording: the greedy episode of agent 0 trained on MuJoCo,
   its actions replayed open loop on every plant from its start, ghosts in one scene.

Writes `report.md`, the tables as CSV (`open_loop_steps.csv.gz`, `open_loop_trials.csv`,
`energy.csv`, `episodes.csv.gz`, `transfer.csv`) and `figures/*.png|svg` under `out_dir`.
"""

import dataclasses
import os
import time

import numpy as np

from lwrl import outputs, tasks
from lwrl.studies.compare import closed_loop as cl
from lwrl.studies.compare import report as compare_report
from lwrl.studies.compare import open_loop as ol

QUICK = dict(steps=50, episodes=3, eval_episodes=1)
"""`quick=True`: open-loop horizon (steps), training and evaluation episodes."""


def comparable_tasks() -> list:
    """The tasks with a MuJoCo plant, as DOMAIN.TASK."""
    return [f"{domain}.{task}" for domain, task in tasks.ALL_TASKS
            if tasks.domain(domain).model is not None]


def check_task(task: str) -> str:
    """Return the domain of `task`, or raise naming the tasks that can be compared."""
    if task not in comparable_tasks():
        reason = ("has only the analytic plant" if task in tasks.TASK_NAMES
                  else "is not a task of the suite")
        raise ValueError(f"{task} {reason}; compare one of: {', '.join(comparable_tasks())}")
    return task.split(".")[0]


@dataclasses.dataclass
class Comparison:
    """A comparison's results and where they were written."""

    task: str
    quick: bool
    open_loop: ol.OpenLoop
    closed_loop: cl.ClosedLoop
    timings: dict
    """Wall seconds per part."""
    report_path: str
    rrd_path: str | None = None


def replay(task: str, recording, substeps: int = ol.REFERENCE_SUBSTEPS) -> dict:
    """`{plant: (T + 1, d) states}`: the actions of an `EpisodeRecording` replayed open loop
    from its start on the reference and every compared plant."""
    domain = task.split(".")[0]
    start = recording.states[:1]
    controls = np.asarray(recording.controls)[recording.actions][None]
    return {plant: ol.trajectories(ol.plant(domain, plant, 1, substeps), start, controls)[0]
            for plant in (ol.REFERENCE, *ol.COMPARED)}


def record(task: str, recording, rrd_path: str) -> dict:
    """Write the Rerun recording of `replay(task, recording)`; return its entity paths per plant."""
    from lwrl.viz import comparison as viz_comparison
    from lwrl.viz import rerun as viz

    domain = task.split(".")[0]
    definition = tasks.definition(*tasks.split_name(task))
    states = replay(task, recording)
    reference = states[ol.REFERENCE]
    errors = {plant: {variable: values[0] for variable, values in ol.errors(
        definition, trajectory[None], reference[None]).items()}
        for plant, trajectory in states.items() if plant != ol.REFERENCE}
    rec = viz.open_recording(viz.APPLICATION_ID, rrd_path=rrd_path)
    rec.send_blueprint(viz_comparison.blueprint(task, recording.state_names, list(ol.tolerances(domain))),
                       make_active=True, make_default=True)
    paths = viz_comparison.log_plants(
        rec, task, states, recording.timestep, ol.REFERENCE, ol.LABELS, recording.state_names,
        {plant: ol.energy(domain, trajectory) for plant, trajectory in states.items()}, errors)
    viz.close_recording(rec)
    return paths


def compare(task: str, seeds: int = 10, episodes: int | None = None, out_dir: str = "compare",
            rrd_path: str | None = None, quick: bool = False, progress=None,
            judge=None, learner: str | None = None) -> Comparison:
    """Run the whole comparison of `task` with `seeds` trials and agents (seeds 0..seeds-1)
    and write its results under `out_dir`. `episodes` overrides the task's training
    episodes, `learner` the paper's Sarsa(lambda) (`agent.LEARNERS`); `quick` shortens
    everything to a smoke test; `progress(episodes_done)` follows
    the closed-loop part (`closed_loop.total_episodes` in all). `judge(table, figure_dir)
    -> (name, section)`, if given, holds each plant's training results to a claim (a
    section with `rows`, `verdict` and `rule`) and the report shows it per plant."""
    domain = check_task(task)
    figure_dir = os.path.join(out_dir, "figures")
    os.makedirs(figure_dir, exist_ok=True)
    timings = {}
    start = time.perf_counter()
    open_result = ol.open_loop(task, range(seeds), steps=QUICK["steps"] if quick else None)
    timings["open loop"] = time.perf_counter() - start
    start = time.perf_counter()
    closed_result = cl.closed_loop(task, seeds, QUICK["episodes"] if quick else episodes,
                                   eval_episodes=QUICK["eval_episodes"] if quick else None,
                                   progress=progress, learner=learner)
    timings["closed loop and transfer"] = time.perf_counter() - start
    write_tables(open_result, closed_result, out_dir)
    transfer = compare_report.transfer_statistics(closed_result)
    figures = compare_report.write_figures(open_result, closed_result, transfer, domain, task, figure_dir)
    paper_sections = {}
    for plant, table in closed_result.episodes.groupby("compared", sort=False) if judge else ():
        plant_dir = os.path.join(figure_dir, f"paper_{plant}")  # the claim's own figure
        os.makedirs(plant_dir, exist_ok=True)
        paper_sections[plant] = judge(table, plant_dir)
    comparison = Comparison(task, quick, open_result, closed_result, timings,
                            os.path.join(out_dir, "report.md"), rrd_path)
    with outputs.atomic_write(comparison.report_path) as file:
        file.write(compare_report.report(comparison, figures, paper_sections, out_dir))
    if rrd_path:  # last, so that a recording that cannot be written loses nothing else
        start = time.perf_counter()
        with outputs.atomic_path(rrd_path) as temporary:
            record(task, closed_result.replay, temporary)
        timings["recording"] = time.perf_counter() - start
    return comparison


def write_tables(open_result: ol.OpenLoop, closed_result: cl.ClosedLoop, out_dir: str) -> None:
    """The tidy tables as CSV under `out_dir` (the per-step ones compressed), each whole or
    not at all."""
    for name, table in (("open_loop_steps.csv.gz", open_result.steps),
                        ("open_loop_trials.csv", open_result.trials),
                        ("energy.csv", open_result.energy),
                        ("episodes.csv.gz", closed_result.episodes),
                        ("transfer.csv", closed_result.transfer)):
        outputs.write_table(table, os.path.join(out_dir, name))
