"""The task variants the third benchmark adds beside the paper's tasks (docs/FINDINGS.md, "The
light-weight claim judged a third time: the third benchmark's rule"), measured before its
runs so that they can be chosen where the classical level is not reached by everything.

The candidates come from the suite's own axes (docs/guide/tasks.md, "Sensors and actuator"
and "Randomised physics while learning"; the robustness study's, docs/guide/robustness.md):

- `noise`: Gaussian observation noise, sigma `NOISE` of each state variable's normalisation
  span (the task's `TaskDefinition.ranges`), drawn anew each step;
- `delay`: the control applied `DELAY` control steps after it was chosen;
- `physics`: the domain's load and its actuator's strength (`RANDOMISED`, the parameters the
  robustness study spans too) drawn anew for every episode, uniformly between `FACTORS`
  times the paper's values (clipped to the accepted ranges), in training and evaluation
  alike.

Per task and candidate (and the nominal task beside them): the reference rows' means on the
variant (the classical controller reads noisy observations and acts late like any agent, but
knows each episode's physics, `references.ClassicalPolicy`), and the paper's agent with its
task's settings trained for the task's whole budget on the variant by `AGENTS` agents on seeds
`SEED` up (none of the second benchmark's seeds, 0 to 19, 1000 to 1002, and none the third's
evaluation may use), evaluated greedily as the benchmark does (`evaluation.evaluation`): its
final normalised score against the variant's own reference rows and how many of its agents
reach `planning.SATURATED`.

The choice (`choose`), made from the measurement before any of the third benchmark's runs: a
task gets a variant where at least half of the paper's agents reach the classical level on
the nominal task; its variant is the candidate on which the fewest of them do while their
score's interval stays wholly above the random row's 0 (it is still learnt), ties going to
the higher lower end of that interval.

    python -m lwrl.studies.paper.benchmark.variants OUT_DIR

runs them through the sweep runner into `OUT_DIR` (resumable from its tables, as the study's
runs) and writes the table to `OUT_DIR/variants.md`.
"""

import argparse
import dataclasses
import os
import sys

import numpy as np
import pandas as pd

from lwrl import outputs, tasks
from lwrl.analysis import statistics
from lwrl.outside import DomainFacts
from lwrl.studies.paper.benchmark import evaluation, planning, protocol, study

NOISE = 0.05
"""Observation noise: sigma as a fraction of each state variable's normalisation span."""
DELAY = 2
"""Actuation delay, in control steps."""
FACTORS = (0.5, 2.0)
"""The range of the randomised physics, times the paper's values."""
CANDIDATES = ("nominal", "noise", "delay", "physics")
"""The nominal task and the candidate variants, in the table's order."""
TASKS = ("mountain_car.cost_to_go", "pendulum.swingup", "cartpole.balance", "acrobot.swingup")
"""The tasks whose variants are measured: the discrete ones, whose rows the variants share."""
AGENTS = 20
"""Agents of the paper's agent per variant."""
SEED = 5000
"""The first seed of the paper's agents trained on a variant."""
REFERENCES = "variant-references"
RANDOMISED = DomainFacts("lwrl.benchmark_randomised", tuple, "randomised physics", {
    "mountain_car": ("gravity", "thrust"),
    "pendulum": ("mass", "torque"),
    "cartpole": ("pole_mass", "force"),
    "acrobot": ("link_mass_2", "torque"),
})
"""`{domain: parameter names}` the `physics` variant draws per episode: each domain's load (or
what stands for it) and its actuator's strength; a package adds its domain's through the
entry-point group `lwrl.benchmark_randomised` (`lwrl.outside.DomainFacts`)."""


def environment(task: str, candidate: str) -> dict:
    """The environment options (`BatchedEnv`'s, `RunConfig`'s) of `candidate` on `task`."""
    definition = evaluation.task_definition(task)
    if candidate == "nominal":
        return {}
    if candidate == "noise":
        span = np.subtract(definition.ranges[1], definition.ranges[0])
        return {"observation_noise": {name: float(NOISE * width)
                                      for name, width in zip(definition.state_names, span)}}
    if candidate == "delay":
        return {"action_delay": DELAY}
    if candidate == "physics":
        parameters = tasks.domain(definition.domain).parameters
        axes = RANDOMISED.of(definition.domain)
        return {"randomise": {p.name: tuple(float(np.clip(f * p.nominal, p.low, p.high))
                                            for f in FACTORS)
                              for p in parameters.items if p.name in axes}}
    raise ValueError(f"unknown variant {candidate!r}; allowed: {', '.join(CANDIDATES)}")


def references(task: str, candidate: str, out_dir: str) -> dict:
    """`{"random" | "classical": (agents,) measures}` of the reference rows on the variant,
    from `OUT/variant-references/<task>-<candidate>.csv.gz` where written, else run and
    written."""
    path = os.path.join(out_dir, REFERENCES, f"{task}-{candidate}.csv.gz")
    if not os.path.exists(path):
        tables = evaluation.run_references(task, AGENTS, environment=environment(task, candidate))
        table = pd.concat([t.assign(row=row) for row, t in tables.items()], ignore_index=True)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        outputs.write_table(table, path)
    table = outputs.read_table(path)
    return {row: evaluation.measure(part, task) for row, part in table.groupby("row")}


@dataclasses.dataclass(frozen=True)
class Measured:
    """One task's variant: the reference rows' means (the task's measure) and the paper's
    agent's final normalised score with its interval, and how many agents reach the
    classical level."""

    task: str
    candidate: str
    random: float
    classical: float
    paper: statistics.Estimate
    saturated: int
    agents: int


def measure(task: str, candidate: str, out_dir: str, sweep=None) -> Measured:
    """`Measured` of `candidate` on `task` (see the module), resuming what `out_dir` holds."""
    reference = references(task, candidate, out_dir)
    row = protocol.rows(task)[0]
    config = dataclasses.replace(protocol.training(task, row, row.settings, SEED, AGENTS),
                                 **environment(task, candidate))
    evaluated, _ = study.train_and_evaluate({candidate: config}, out_dir, sweep or {},
                                            f"{task} {candidate}")
    scores = study.scored(task, evaluated, reference, diverged_as_worst=True)[candidate]
    return Measured(task, candidate, float(np.mean(reference["random"])),
                    float(np.mean(reference["classical"])), statistics.mean_interval(scores),
                    int(np.sum(scores >= planning.SATURATED)), len(scores))


def choose(measured: list) -> dict:
    """`{task: candidate}`: the variant each task gets (see the module), for the tasks that
    get one."""
    chosen = {}
    for task in dict.fromkeys(m.task for m in measured):
        mine = [m for m in measured if m.task == task]
        nominal = next(m for m in mine if m.candidate == "nominal")
        learnt = [m for m in mine if m.candidate != "nominal" and m.paper.low > 0]
        if 2 * nominal.saturated >= nominal.agents and learnt:
            chosen[task] = min(learnt, key=lambda m: (m.saturated, -m.paper.low)).candidate
    return chosen


def table(measured: list) -> str:
    """The measurements as a Markdown table, the chosen variants marked."""
    chosen = choose(measured)
    lines = ["| task | variant | measure | random | classical | the paper's agent's final "
             "normalised score | its agents at the classical level | chosen |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {m.task} | {m.candidate} | {evaluation.task_measure(m.task).column} | "
              f"{m.random:.1f} | {m.classical:.1f} | {m.paper.text(2)} | "
              f"{m.saturated} of {m.agents} | {'**yes**' if chosen.get(m.task) == m.candidate else ''} |"
              for m in measured]
    return "\n".join(lines)


def main(argv=None) -> None:
    """Measure every task's candidates into `out_dir` and write `out_dir/variants.md`."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out_dir")
    parser.add_argument("--tasks", nargs="+", default=list(TASKS))
    args = parser.parse_args(argv)
    try:
        for task in args.tasks:
            protocol.check_task(task)
        measured = [measure(task, candidate, args.out_dir)
                    for task in args.tasks for candidate in CANDIDATES]
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(2)
    text = table(measured)
    with outputs.atomic_write(os.path.join(args.out_dir, "variants.md")) as file:
        file.write(f"# The third benchmark's candidate variants\n\nWritten by `python -m "
                   f"lwrl.studies.paper.benchmark.variants {args.out_dir}` (the module says what "
                   f"is measured and how the variants are chosen); the normalised scores are "
                   f"against each variant's own reference rows.\n\n{text}\n")
    print(text)


if __name__ == "__main__":
    main()
