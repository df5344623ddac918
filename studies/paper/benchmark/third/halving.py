"""The third benchmark's search (docs/FINDINGS.md, the third benchmark's rule, "Searches that
choose reliably"): for every row `CONFIGURATIONS` configurations drawn around the learner's
own centre, chosen by successive halving (Jamieson & Talwalkar 2016, "Non-stochastic best
arm identification and hyperparameter optimization", AISTATS; `compute_plan.SEARCH_RUNGS`):

- all `CONFIGURATIONS` on 2 seeds to 1/8 of the budget, each scored by its agents' mean
  greedy normalised score there;
- the best quarter (8) on 4 seeds to 1/2, scored alike;
- the best quarter of those (2) on 10 seeds to the whole budget, on the clock (`clock`), and
  of those two the one with the better mean final normalised score over its seeds, ties
  going to the larger area under the curve (`choose`).

The search's agents train on seeds `rule.SEARCH_SEED` up and are evaluated from their seed
+ 10 000, none of the rows' (3000 up, 13 000 up). A rung's earlier seeds are the same agents
as the rung before's, run on to the longer budget: a budget cuts a run without changing what
came before it, so their agents continue; their first part is computed again (the runners
keep no agents to go on learning from), about a sixth more than the plan's agent-steps.

The configurations (`configurations`): the row's own settings first (its centre: the task's
settings for the linear learners, the zoo's set for the deep ones, the authors' defaults for
the new rivals), then draws from `ranges`: each step size (`STEP_SIZES`) log-uniform within
x1/4 to x4 of the centre's, the other settings the second benchmark's ranges
(`benchmark.search.RANGES`), and for the learners that take it observation normalisation
(running mean and variance) as a choice (`NORMALISATION`). The draws are a fixed random
stream per task and row (`SEED`): the same on every machine, and resumable.
"""

import dataclasses
import math

import numpy as np

from lwrl.runners import sweep
from lwrl.studies.paper.benchmark import compute_plan, protocol, search
from lwrl.studies.paper.benchmark.search import Choice
from lwrl.studies.paper.benchmark.third import clock, rule

CONFIGURATIONS = compute_plan.SEARCH_RUNGS[0][0]
"""Configurations drawn per row, its centre among them."""
SEED = 20261206
"""The configurations' draws: a stream per task and row, `SEED` then their positions."""
STEP_SIZES = ("alpha", "beta", "learning_rate")
"""The settings that are rates or step sizes, drawn log-uniformly within x1/4 to x4 of the
centre's: Sarsa's and the CMAC's alpha, ASE/ACE's alpha and beta (the actor's and the
critic's), the actor-critic's alpha and beta, the deep learners', ARS's and ObGD's learning
rate."""
AROUND = (0.25, 4.0)
"""A step size's range, in factors of the centre's."""
CAPS = {("actor_critic", "beta"): 1.0}
"""`{(learner, step size): bound}` of the step sizes a learner takes up to a bound only (the
actor-critic's actor step beta, a fraction of the way to the action tried, in (0, 1]): drawn
within `AROUND` of the centre and below the bound."""


@dataclasses.dataclass(frozen=True)
class StepSize:
    """A step size drawn log-uniformly within `AROUND` of the centre's, and at most `cap`."""

    name: str
    cap: float = math.inf

    def draw(self, rng, start: dict):
        centre = start[self.name]
        high = min(AROUND[1], self.cap / centre)
        return float(centre * math.exp(rng.uniform(math.log(AROUND[0]), math.log(high))))
OBSERVATION_NORMALISATION = Choice("normalize_observations", (False, True))
"""Observation normalisation off or on, for the learners that take the setting: the deep
learners' JAX populations (SB3's `VecNormalize`, off by default,
`agent.observation_normalisation`) and the streaming learners (their authors'
`NormalizeObservation`, on by default)."""
NORMALISATION = {"ars": Choice("variant", ("v1", "v2")),
                 "ars_continuous": Choice("variant", ("v1", "v2")),
                 **{learner: OBSERVATION_NORMALISATION for learner in (
                     "dqn_jax", "ppo_jax", "sac_jax", "td3_jax", "stream_q", "stream_ac",
                     "stream_ac_discrete")}}
"""`{learner: the choice of observation normalisation}` of the learners whose settings
have it: ARS's V1 (the state as it is) and V2 (the state normalised by its running mean and
standard deviation, Mania et al. 2018), and `normalize_observations` of the deep learners
and the streaming learners (`OBSERVATION_NORMALISATION`: normalised by the running mean and
variance)."""
NEW_RANGES = {learner: (StepSize("learning_rate"),)
              for learner in ("ars", "ars_continuous", "stream_q", "stream_ac",
                              "stream_ac_discrete")}
"""The ranges of the learners the second benchmark did not search: their step size (the
second benchmark has no ranges of theirs for the rest)."""


def ranges(row: protocol.Row) -> tuple:
    """What is drawn for `row` (see the module)."""
    if row.learner in NEW_RANGES:
        drawn = NEW_RANGES[row.learner]
    else:
        drawn = tuple(StepSize(item.name, CAPS.get((row.learner, item.name), math.inf))
                      if item.name in STEP_SIZES else item for item in search.ranges(row))
    normalisation = NORMALISATION.get(row.learner)
    return drawn + ((normalisation,) if normalisation else ())


def unsearched(task: str) -> list:
    """The labels of `task`'s deep rows and new rivals whose observation normalisation is not
    a searched choice (no setting of their learner's turns it on or off): none of the rule's
    learners today; a learner added to the rule without such a setting is named here."""
    return [row.label for row in rule.rows(task) if not rule.linear(task, row)
            and row.learner not in NORMALISATION]


def configurations(task: str, row: protocol.Row) -> list:
    """The row's `CONFIGURATIONS` settings on `task` (a variant's: its task's): its own, then
    the draws (`ranges`)."""
    base = rule.split(task)[0]
    labels = [r.label for r in rule.rows(base)]
    rng = np.random.default_rng([SEED, rule.TASKS.index(base), labels.index(row.label)])
    centre = search.start(base, row)
    drawn = [dict(row.settings, **{item.name: item.draw(rng, centre) for item in ranges(row)})
             for _ in range(CONFIGURATIONS - 1)]
    return [dict(row.settings)] + drawn


def rung_training(task: str, row: protocol.Row, settings: dict, rung: int,
                  plant: str = "analytic"):
    """The run of one configuration at `rung` (0, 1: its seeds to its fraction; the last
    rung's is the whole budget, cut by the clock, `clock.trainings`)."""
    _, seeds, fraction = compute_plan.SEARCH_RUNGS[rung]
    return rule.training(task, row, settings, rule.SEARCH_SEED, seeds, fraction, plant)


def first_rung(task: str, row: protocol.Row) -> list:
    """The runs of the row's first rung, one per configuration (`configurations`)."""
    return [rung_training(task, row, settings, 0) for settings in configurations(task, row)]


def programs(task: str, row: protocol.Row) -> tuple:
    """`(programs, largest)`: how many batches the sweep makes of the row's first rung
    (`sweep.batches`: runs that differ only in settings each agent may have of its own, one
    compiled program, or one compiled loop, runs as one batch), and the most runs one of them
    holds. A search whose configurations shared their programs trains each as one population
    (`sweep.populations`); where each draws a network's shape, a rollout's length or a
    minibatch of its own, there is little to share."""
    batches = sweep.batches(first_rung(task, row))
    return len(batches), max(map(len, batches))


def evaluation(training):
    """The greedy evaluation that scores a configuration at the end of a rung but the last:
    `clock.VERDICT_EPISODES` episodes per agent, from the clock's starts (`clock.greedy`)."""
    return clock.greedy(training, clock.VERDICT_EPISODES)


def mean_score(values) -> float:
    """The mean of an agent's normalised scores, a diverged agent's (NaN) counting as the
    worst: the configuration's score."""
    return float(np.mean(np.nan_to_num(np.asarray(values, dtype=float), nan=-np.inf)))


def best(scores: dict, count: int) -> list:
    """The `count` configurations of `scores` (`{i: (agents,) normalised scores}`) with the
    best mean score (`mean_score`), in their order; ties to the earlier (the centre first)."""
    ranked = sorted(scores, key=lambda i: (-mean_score(scores[i]), i))
    return sorted(ranked[:count])


def choose(finals: dict) -> int:
    """The configuration of the last rung `{i: ((agents,) final normalised scores, area)}`
    with the better mean final score, ties to the larger area, then to the earlier."""
    return min(finals, key=lambda i: (-mean_score(finals[i][0]), -finals[i][1], i))
