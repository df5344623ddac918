"""The third benchmark's judging (docs/FINDINGS.md, "The light-weight claim judged a third
time", "The rule"), from the runs a directory holds, at each budget point the verdicts read
(`POINTS`: 1/4, 1 and 4 times the budget):

- a row's **curve** to the point (`curve`): its agents' normalised scores at the clock's
  points up to it, the steps there, and each agent's CPU seconds of training and counted
  multiply-adds there read from the runs' own records (`runners.records`; NaN where a run has
  none), and the host CPUs those records name. At 4 times the budget
  a row still rising at 1 has its continued runs; a row that stopped rising stands at its
  score (and CPU) at 1 from there on, marked as carried;
- the **time to the level** 0.5 (`to_level`): each agent's first evaluation at or above it,
  its steps, its CPU and its multiply-adds read there, censored at the point's budget (and
  its CPU and multiply-adds there) where never (`analysis.curves.time_to_level`);
- per task the **comparisons** of the light-weight row (`protocol.light`) with each of its
  rivals (`rivals`: the deep rows and the rule's new rivals the registry runs): the gate
  (`verdicts.above_random_gate`), the final normalised score's and the area's outcomes
  (`analysis.outcomes.judge`, each in a family of its own of every comparison run at that
  point, over every task), the Kaplan-Meier medians of the steps, CPU and multiply-adds,
  the steps' log-rank p (none where neither row reaches the level: nothing to compare) and
  the ratios of restricted means with their bootstrap intervals (`analysis.curves`),
  "faster/slower" (`curves.pace`). The multiply-adds' ratio, a count that no host's speed
  or load moves, stands beside the CPU's, which the rule reads: rows whose runs were
  computed on different host CPUs (the rows' tables name them) compare seconds of
  different machines;
- the **task verdict** (`analysis.task_verdict.verdict`) from the final score's outcomes
  and the CPU ratios, once every rival's row is run at the point (`NOT_ALL_RUN` until
  then, but for "no", which the rows still to run cannot undo).

The family at a point is the rule's: every comparison its rows make over every task
(`family_size`, 39: five rivals on each discrete task and variant, four on the continuous
pendulum), whatever is run. A comparison whose rows are not both run at the point is "not
run": its hypotheses keep their share of the level and are never shown (p 1), so the levels
of those run do not move as runs are written, and a verdict stands once given. A comparison
that does not pass the gate stays in the family but not in the verdict.
"""

import dataclasses
import math

import numpy as np

from lwrl.analysis import curves, outcomes, statistics, task_verdict, verdicts
from lwrl.analysis.statistics import Estimate
from lwrl.analysis import thresholds
from lwrl.runners import records
from lwrl.runners.store import RunStore
from lwrl.studies.paper.benchmark import evaluation, protocol
from lwrl.studies.paper.benchmark import study as second
from lwrl.studies.paper.benchmark.third import clock, rule

POINTS = dict(zip(("1/4", "1", "4"), clock.VERDICTS))
"""`{name: j}`: the budget points the verdicts read, named by their multiple of the budget."""
NO_ESTIMATE = Estimate(math.nan, math.nan, math.nan)
WHOLE_EPISODE = ("cartpole.balance",)
"""The tasks reached where an episode runs to its end up (the cart-pole balanced for the
whole 240 s); the tasks measured in steps are reached where an episode ends at the goal
before the evaluation's cap (Mountain-Car's and the acrobot's within 1 000 steps)."""


@dataclasses.dataclass(frozen=True)
class Curve:
    """A row's agents to a budget point: the steps at each of the clock's points to it, the
    agents x points normalised scores, CPU seconds of training and multiply-adds (NaN where
    not recorded), the point's evaluation run, whether the row is carried past 1 (not rising
    there), and the host CPUs its records name."""

    steps: np.ndarray
    scores: np.ndarray
    cpu: np.ndarray
    macs: np.ndarray
    final: object
    carried: bool
    hosts: tuple


def trainings(row, point: int) -> dict | None:
    """`{j: RunConfig}` of `row`'s (`study.RowRuns`) runs to `point`, the carried points
    past 1 mapped to its run at 1; None where the row is not run that far."""
    runs = {j: run for j, run in row.trainings.items() if j <= point}
    if point <= clock.POINTS[-1]:
        return runs
    if row.longer is None:
        return None
    longer = clock.longer_trainings(row.trainings[clock.POINTS[-1]]) if row.longer else {}
    return {**runs, **{j: longer.get(j, row.trainings[clock.POINTS[-1]])
                       for j in clock.LONGER if j <= point}}


def recorded_at(out_dir: str, runs: dict) -> tuple:
    """`(cpu, macs, hosts)`: agents x points, each agent's CPU seconds of training and
    counted multiply-adds at the end of each of `runs` (`{j: RunConfig}`, a carried run at
    several points) from the runs' records, NaN where a run has none; and the host CPUs the
    records name, sorted."""
    table = records.read(out_dir, list({run.key: run for run in runs.values()}.values()))
    per_run = [table[table.run == run.key].sort_values("agent") for run in runs.values()]
    cpu, macs = (np.stack([part[column].to_numpy(dtype=float) for part in per_run], axis=1)
                 for column in ("cpu_s", "multiply_adds"))
    return cpu, macs, tuple(sorted(table.host_cpu.dropna().unique()))


def curve(task: str, row, out_dir: str, point: int) -> Curve | None:
    """`row`'s `Curve` on `task` to `point`; None where it is not run that far."""
    runs = trainings(row, point)
    if runs is None:
        return None
    scores = {**row.scores, **(row.longer or {})}
    at_one = scores[clock.POINTS[-1]]
    columns = [scores[j] if j in scores else at_one for j in runs]
    budget = protocol.BUDGETS[rule.split(task)[0]]
    steps = clock.budgets(budget, clock.POINTS + clock.LONGER)
    cpu, macs, hosts = recorded_at(out_dir, runs)
    return Curve(np.array([steps[j] for j in runs], dtype=float),
                 np.stack([np.asarray(c, dtype=float) for c in columns], axis=1),
                 cpu, macs, runs[point], point > clock.POINTS[-1] and not row.longer, hosts)


def to_level(steps, scores, *recorded, level: float = curves.LEVEL) -> tuple:
    """`(steps, *recorded, reached)` per agent: its steps and each clock of `recorded` (CPU,
    multiply-adds: agents x points, from the records) at its first evaluation at or above
    `level`, or at the last point (censored, `reached` False) where it never reaches it."""
    scores = np.asarray(scores, dtype=float)
    first, reached = curves.time_to_level(np.arange(scores.shape[1]), scores, level)
    first, agents = first.astype(int), np.arange(len(scores))
    return (np.asarray(steps, dtype=float)[first],
            *(np.asarray(times, dtype=float)[agents, first] for times in recorded), reached)


@dataclasses.dataclass(frozen=True)
class Pace:
    """A row's times to the level: per agent steps, CPU, multiply-adds and reached; the
    Kaplan-Meier medians of steps, CPU and multiply-adds (NaN where not recorded)."""

    steps: np.ndarray
    cpu: np.ndarray
    macs: np.ndarray
    reached: np.ndarray
    median_steps: Estimate
    median_cpu: Estimate
    median_macs: Estimate


def recorded_median(times, reached) -> Estimate:
    """The Kaplan-Meier median of a recorded clock (CPU, multiply-adds); none where an agent's
    is not recorded."""
    return NO_ESTIMATE if np.isnan(times).any() else curves.median(times, reached)


def pace_of(row_curve: Curve) -> Pace:
    """The times to the level of `row_curve`'s agents."""
    steps, cpu, macs, reached = to_level(row_curve.steps, row_curve.scores, row_curve.cpu,
                                         row_curve.macs)
    return Pace(steps, cpu, macs, reached, curves.median(steps, reached),
                recorded_median(cpu, reached), recorded_median(macs, reached))


def _difference(x, y, axis=-1):
    """mean(x) - mean(y) along `axis` (vectorised for the bootstrap)."""
    return np.mean(x, axis=axis) - np.mean(y, axis=axis)


@dataclasses.dataclass
class Comparison:
    """The light-weight row against one rival on a task at a budget point; `final` and
    `area` are filled in by `judge_families` (None where not run)."""

    task: str
    rival: str
    run: bool
    gate: object = None
    difference: Estimate = NO_ESTIMATE
    final: object = None
    area: object = None
    area_difference: Estimate = NO_ESTIMATE
    logrank: float = math.nan
    steps_ratio: Estimate = NO_ESTIMATE
    cpu_ratio: Estimate = NO_ESTIMATE
    macs_ratio: Estimate = NO_ESTIMATE
    pace: str = ""
    pairs: tuple = ()


def rivals(task: str) -> list:
    """The labels of `task`'s rivals in the rule: its deep rows and the new rivals, in the
    rule's order."""
    base = rule.split(task)[0]
    return [row.label for row in rule.rows(task)
            if row.label in protocol.deep(base) or row.label in rule.RIVALS[
                protocol.variant(base)[1]]]


def compare(task: str, light: tuple, rival: tuple, label: str, random) -> Comparison:
    """The comparison of `light` and `rival`, each `(Curve, Pace)` or None (not run), on
    `task`; `random`: the random row's normalised scores."""
    if light is None or rival is None:
        return Comparison(task, label, False)
    (x_curve, x_pace), (y_curve, y_pace) = light, rival
    x_final, y_final = x_curve.scores[:, -1], y_curve.scores[:, -1]
    budget = x_curve.steps[-1]
    x_area, y_area = (curves.area(c.steps, c.scores, budget) for c in (x_curve, y_curve))
    cpu, macs = (recorded_ratio(x_curve, x_pace, y_curve, y_pace, clock_name)
                 for clock_name in ("cpu", "macs"))
    return Comparison(
        task, label, True,
        gate=verdicts.above_random_gate(x_final, y_final, random,
                                        (protocol.light(rule.split(task)[0]), label)),
        difference=statistics.interval(_difference, x_final, y_final),
        area_difference=statistics.interval(_difference, x_area, y_area),
        logrank=curves.logrank_p_value(x_pace.steps, x_pace.reached, y_pace.steps,
                                       y_pace.reached)
        if x_pace.reached.any() or y_pace.reached.any() else math.nan,
        steps_ratio=curves.restricted_mean_ratio(x_pace.steps, x_pace.reached, y_pace.steps,
                                                 y_pace.reached, budget),
        cpu_ratio=cpu, macs_ratio=macs, pairs=((x_final, y_final), (x_area, y_area)))


def recorded_ratio(x_curve: Curve, x_pace: Pace, y_curve: Curve, y_pace: Pace,
                   clock_name: str) -> Estimate:
    """The ratio of the rows' restricted means of a recorded clock to the level (`"cpu"`,
    `"macs"`), each row restricted to its own clock's end at the budget; none where an
    agent's is not recorded or a row's clock does not run."""
    x_times, y_times = getattr(x_pace, clock_name), getattr(y_pace, clock_name)
    taus = [float(np.max(getattr(c, clock_name)[:, -1])) for c in (x_curve, y_curve)]
    if np.isnan(x_times).any() or np.isnan(y_times).any() or not min(taus) > 0:
        return NO_ESTIMATE
    return curves.restricted_mean_ratio(x_times, x_pace.reached, y_times, y_pace.reached, *taus)


def family_size() -> int:
    """The comparisons the rule's family holds at a budget point: the light-weight row
    against every rival the rule names on every task."""
    return sum(len(rivals(task)) for task in rule.TASKS)


def judge_families(comparisons: list) -> int:
    """Fill in each run comparison's `final` and `area` outcomes, each family (the final
    scores', the areas') judged together (`outcomes.judge`) as the rule's whole family
    (`family_size`), and its `pace`; the number of comparisons run."""
    run = [c for c in comparisons if c.run]
    if run:
        family = max(family_size(), len(run))
        for c, final, area in zip(run, outcomes.judge([c.pairs[0] for c in run], family=family),
                                  outcomes.judge([c.pairs[1] for c in run], family=family)):
            c.final, c.area = final, area
            c.pace = curves.pace(area.rejected, c.steps_ratio)
    return len(run)


NOT_ALL_RUN = "not all run"
"""The verdict of a task at a point where some of its rivals' rows are run that far and
others not yet: what the rows run would give is not the rule's verdict, which is against
every rival, so it waits; only "no" (shown worse than one rival, or dearer to the level)
stands whatever the others give."""


def verdict(comparisons: list) -> tuple:
    """`(verdict, why)` of a task from its comparisons at a point (`task_verdict.verdict`);
    "not run" where none of them is, `NOT_ALL_RUN` where some are not (but "no", which the
    rows not run cannot undo), the rivals not run and what the others give named."""
    against = [task_verdict.Against(c.rival, c.gate.judged, c.final.outcome, c.cpu_ratio)
               for c in comparisons if c.run]
    if not against:
        return "not run", "no comparison has both its rows run this far"
    given, why = task_verdict.verdict(against)
    missing = [c.rival for c in comparisons if not c.run]
    if not missing:
        return given, why
    waiting = f"{', '.join(missing)} not run this far"
    if given == task_verdict.NO:
        return given, f"{why}; {waiting}"
    return NOT_ALL_RUN, f"{waiting}; against the others so far: {given} ({why})"


@dataclasses.dataclass
class TaskJudged:
    """One task at one budget point: its rows' curves and paces (None: not run that far),
    its comparisons and its verdict."""

    task: str
    curves: dict
    paces: dict
    comparisons: list
    verdict: tuple = ("", "")


def task_at(runs, out_dir: str, point: int) -> TaskJudged:
    """`runs` (`study.TaskRuns`) at `point`: the rows' curves and paces and the light-weight
    row's comparisons with each rival, their families not judged yet."""
    base = rule.split(runs.task)[0]
    row_curves = {label: curve(runs.task, row, out_dir, point)
                  for label, row in runs.rows.items()}
    paces = {label: None if c is None else pace_of(c) for label, c in row_curves.items()}
    both = {label: None if row_curves.get(label) is None else (row_curves[label], paces[label])
            for label in row_curves}
    light = both.get(protocol.light(base))
    random = second.normalised(base, runs.references["random"], runs.references)
    comparisons = [compare(runs.task, light, both.get(label), label, random)
                   for label in rivals(runs.task)]
    return TaskJudged(runs.task, row_curves, paces, comparisons)


def judge(task_runs: list, out_dir: str) -> dict:
    """`{point name: ([TaskJudged], family size)}` of every task of `task_runs` at each of
    `POINTS`, every task's comparisons at a point one family, each task's verdict given."""
    judged = {}
    for name, point in POINTS.items():
        tasks = [task_at(runs, out_dir, point) for runs in task_runs]
        size = judge_families([c for t in tasks for c in t.comparisons])
        for t in tasks:
            t.verdict = verdict(t.comparisons)
        judged[name] = (tasks, size)
    return judged


def reached_or_not(task: str) -> bool:
    """Whether `task` is reached or not (the rule's success shares): its goal in steps, or
    `WHOLE_EPISODE`."""
    base = rule.split(task)[0]
    return evaluation.task_measure(base) == evaluation.STEPS or base in WHOLE_EPISODE


def success_share(task: str, out_dir: str, run) -> Estimate:
    """The share of the agents of `run` (a training) that reach `task` in every greedy
    episode of its evaluation, with its Clopper-Pearson interval (`thresholds.success_share`;
    a diverged agent's episodes are not reached)."""
    base = rule.split(task)[0]
    table = RunStore(out_dir).read([clock.evaluation_at(run)])
    if evaluation.task_measure(base) == evaluation.STEPS:
        reached = table.steps < evaluation.STEP_CAP
    else:
        reached = table.uptime_s >= evaluation.episode_seconds(base)
    episodes = table.assign(reached=reached).pivot(index="seed", columns="episode",
                                                   values="reached")
    return thresholds.success_share(thresholds.every_episode(episodes.to_numpy(dtype=float)))
