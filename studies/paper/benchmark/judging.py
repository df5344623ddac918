"""The second benchmark's verdicts, by docs/FINDINGS.md's rule ("The light-weight claim judged
again: the second benchmark's rule"), from the rows' normalised scores (`study.TaskRuns`) and
what a learning step costs:

- per task and rival (DQN, PPO; SAC and TD3 on a task made with continuous actions, against
  the actor-critic over the paper's features in the paper's agent's place, `protocol.light`):
  the gate (`analysis.verdicts.above_random_gate`: not judged
  unless both sides' intervals lie above the random row's), the permutation test of the
  final normalised scores with Holm's correction across the whole task x rival family, the
  probability of improvement;
- per row, the compute until an agent's greedy normalised score first reaches
  `protocol.LEVEL` at one of the evaluations (`protocol.FRACTIONS`): the steps taken to it
  times the CPU seconds (and the multiply-adds, where counted) of a learning step; an agent
  that never reaches it counts the whole budget and is counted as not reaching it;
- per task the verdict: yes where the light-weight row is not worse than any judged rival and
  reaches the level with at most `COMPUTE_FRACTION` of that rival's CPU seconds; no where
  it is worse than a judged rival or needs more than its compute; partly otherwise; not
  judged where no comparison is judged.
"""

import dataclasses
import math

import numpy as np

from lwrl.analysis import statistics, verdicts
from lwrl.studies.paper.benchmark import protocol

COMPUTE_FRACTION = 1 / 100
"""The paper's agent's compute to the level, at most this fraction of a rival's."""


@dataclasses.dataclass(frozen=True)
class Compute:
    """The compute of a row's agents until their greedy normalised score first reaches the
    level: the mean over agents with its interval, and how many reached it."""

    steps: statistics.Estimate
    cpu_s: statistics.Estimate | None
    """None where the row's CPU per learning step was not measured."""
    reached: int
    agents: int
    macs: statistics.Estimate | None = None
    """The counted multiply-adds until then (`Learner.arithmetic`); None where the row's
    learner does not count them."""


def steps_to_level(scores: dict, label: str, budget: int, level: float = protocol.LEVEL):
    """Per agent of `label`, the steps of the first fraction of the budget at which its
    greedy normalised score (`scores[label, fraction]`) reaches `level`, else the budget;
    and which agents reached it."""
    agents = len(scores[label, protocol.FRACTIONS[-1]])
    steps, reached = np.full(agents, float(budget)), np.zeros(agents, dtype=bool)
    for fraction in reversed(protocol.FRACTIONS):  # the earliest one that reaches it wins
        at = np.asarray(scores[label, fraction]) >= level
        steps[at], reached[at] = round(fraction * budget), True
    return steps, reached


def compute(scores: dict, label: str, budget: int, cpu_s_per_step=None,
            macs_per_step=None) -> Compute:
    """`Compute` of `label` (see `steps_to_level`), in CPU seconds where `cpu_s_per_step`,
    and in multiply-adds where `macs_per_step(steps)` gives the row's counted multiply-adds
    per agent-step of a run of that many steps of learning (its updates amortised over
    them, `Learner.arithmetic`)."""
    steps, reached = steps_to_level(scores, label, budget)
    seconds = (statistics.mean_interval(steps * cpu_s_per_step)
               if cpu_s_per_step is not None else None)
    macs = (statistics.mean_interval(np.array([macs_per_step(int(n)) * n for n in steps]))
            if macs_per_step is not None else None)
    return Compute(statistics.mean_interval(steps), seconds, int(reached.sum()), len(steps), macs)


@dataclasses.dataclass(frozen=True)
class Comparison:
    """The task's light-weight row (`protocol.light`: the paper's agent) against one rival on
    one task."""

    task: str
    rival: str
    gate: verdicts.GateVerdict
    p_value: float
    improvement: statistics.Estimate
    """P(an agent of the light-weight row does better than one of the rival), with its
    interval."""
    adjusted: float = math.nan
    """Holm's adjusted p-value across the family (`holm_family`)."""
    significant: bool = False


def compare(task: str, scores: dict, random_scores, rival: str) -> Comparison:
    """The task's light-weight row (`protocol.light`) against `rival` on `task` by their
    final normalised scores."""
    final, light = protocol.FRACTIONS[-1], protocol.light(task)
    paper, other = np.asarray(scores[light, final]), np.asarray(scores[rival, final])
    gate = verdicts.above_random_gate(paper, other, random_scores, names=(light, rival))
    return Comparison(task, rival, gate, verdicts.permutation_p_value(paper, other),
                      statistics.improvement_interval(paper, other, higher_is_better=True))


def holm_family(comparisons: list) -> list:
    """The comparisons with Holm's adjusted p-values across all of them (the task x rival
    family), whether judged or not: the correction does not depend on the gate."""
    corrected = verdicts.holm([c.p_value for c in comparisons])
    return [dataclasses.replace(c, adjusted=float(p), significant=bool(r))
            for c, p, r in zip(comparisons, corrected.adjusted, corrected.rejected)]


def side(comparison: Comparison, scores: dict) -> int:
    """+1 where the light-weight row is better than the rival (Holm-significant, its mean
    higher), -1 where worse, 0 a tie."""
    if not comparison.significant:
        return 0
    final, light = protocol.FRACTIONS[-1], protocol.light(comparison.task)
    difference = np.nanmean(scores[light, final]) - np.nanmean(scores[comparison.rival, final])
    return 1 if difference > 0 else -1


def verdict(comparisons: list, scores: dict, computes: dict) -> str:
    """The task's verdict (see the module) from its comparisons (Holm-corrected) and each
    row's `Compute`."""
    judged = [c for c in comparisons if c.gate.judged]
    if not judged:
        return "not judged"
    paper = computes[protocol.light(judged[0].task)].cpu_s
    outcomes = []
    for comparison in judged:
        rival = computes[comparison.rival].cpu_s
        measured = paper is not None and rival is not None
        outcomes.append((side(comparison, scores),
                         measured and paper.value <= COMPUTE_FRACTION * rival.value,
                         measured and paper.value > rival.value))
    if any(s < 0 or dearer for s, _, dearer in outcomes):
        return "no"
    if all(s >= 0 and cheap for s, cheap, _ in outcomes):
        return "yes"
    return "partly"
