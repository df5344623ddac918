"""The robustness study's runs: which agents are trained, and where each is evaluated.

For a task, every learner of the registry that fits it (`agent.LEARNERS`, `Learner.fits`), a
learner of continuous actions on the task made with them (`Learner.actions`, the run's
`actions`), is trained twice, with the settings tuned for it elsewhere where it has them
(`runners.config.tuned_settings`: rl-baselines3-zoo's for DQN and PPO, where `lwrl bench`'s
search starts), else the task's defaults: on the
paper's plant, and with the domain's robustness parameters (`studies.robustness.domains`) drawn
uniformly for every episode between `TRAINING_FACTORS` times their paper values (domain
randomisation). A learner that runs only in the stepped loop trains `STEPPED_AGENTS` agents
at most, under the benchmark's protocol where the command sets no episodes
(`stepped_protocol`: `lwrl bench`'s episodes and episode length, docs/benchmark, instead of
the paper's, which would take DQN and PPO hours per agent on the cart-pole). The JAX
population learners (`Learner.population`: `dqn_jax`, `ppo_jax`, `sac_jax`, `td3_jax`, SB3's
learners in one jitted program, `runners.population`) train under that same protocol with the same tuned
settings as their Stable-Baselines3 counterparts, but with the task's full count of agents
(`agents_for`): in a batch an agent-step costs them tens of microseconds of CPU, against
SB3's milliseconds (docs/guide/jax.md). They run on the JAX plants only (`lwrl.jax`: the
analytic one, and MJX at one set of parameter values, which the randomised training cannot
use), so a study on another plant leaves them out (`learners_for`). Each trained
batch is then evaluated greedily without learning (`RunConfig.trained`, `learn`, `greedy`;
the agents go on as they ended, `Agents.take_over`) in every cell:

- the grid of the robustness parameters, each at `FACTORS` times its paper value (clipped to
  the values the plants accept);
- observation noise on every state variable at once, sigma a fraction `NOISE_LEVELS` of the
  variable's normalisation span (the task's `TaskDefinition.ranges`);
- actuation delays of `DELAYS` control steps.

The evaluation episodes start from seeds of their own (`EVALUATION_SEED` + the agent's
seed), not from the training's starts.
"""

import dataclasses
import math

import numpy as np

from lwrl import agent as learners
from lwrl import tasks
from lwrl.agent import LEARNERS
from lwrl.runners.config import RunConfig, protocol_defaults, task_spec, tuned_settings
from lwrl.studies.robustness.domains import ROBUSTNESS

FACTORS = (0.25, 0.5, 1.0, 2.0, 4.0)
"""Each axis of the parameter grid, times the paper's value."""
TRAINING_FACTORS = (0.5, 2.0)
"""The range of the randomised training, times the paper's value."""
NOISE_LEVELS = (0.0, 0.01, 0.02, 0.05, 0.1)
"""Observation noise: sigma of each state variable as a fraction of its normalisation span."""
DELAYS = (0, 1, 2, 3)
"""Actuation delays, in control steps."""
EVALUATION_SEED = 10_000
"""Added to each agent's seed for its evaluation episodes' starts and sensor streams."""
STEPPED_AGENTS = 5
"""Agents per trained batch, at most, of a learner that runs only in the stepped loop: the
benchmark's count (docs/benchmark), for DQN and PPO take 1 to 3 ms of CPU per learning step
here, 250 to 660 times the paper's agent."""
TRAININGS = ("nominal", "randomised")
QUICK: dict = {"factors": (0.5, 1.0, 2.0), "noise": (0.0, 0.05), "delays": (0, 2), "agents": 2,
               "episodes": 3, "evaluation_episodes": 1, "time_limit_steps": 200}
"""Tiny grids and runs, for a smoke test in seconds."""


@dataclasses.dataclass(frozen=True)
class Cell:
    """Where agents are evaluated: the robustness parameters at `factors` times their
    paper values, observation noise at `noise` of each span, a delay of `delay` steps."""

    factors: tuple
    """One factor per robustness parameter (`Robustness.axes`)."""
    noise: float = 0.0
    delay: int = 0

    @property
    def kind(self) -> str:
        """`parameters`, `noise` or `delay`: which of the study's sets the cell is in (the
        nominal cell, in all three, is `parameters`)."""
        return "noise" if self.noise else "delay" if self.delay else "parameters"


def axes(task: str) -> tuple:
    """The task's robustness parameters (`Parameter`s of its domain), one or two."""
    name = tasks.split_name(task)[0]
    parameters = tasks.domain(name).parameters
    return tuple(parameters.items[parameters.position(axis)]
                 for axis in ROBUSTNESS.of(name).axes)


def cells(task: str, quick: bool = False) -> list:
    """Every cell of the study for `task`: the parameter grid, then the noise levels and
    the delays at the paper's values (each cell once)."""
    factors = QUICK["factors"] if quick else FACTORS
    count = len(axes(task))
    grid = [Cell(tuple(combination)) for combination in
            np.array(np.meshgrid(*[factors] * count, indexing="ij")).reshape(count, -1).T.tolist()]
    nominal = (1.0,) * count
    noise = [Cell(nominal, noise=level) for level in (QUICK["noise"] if quick else NOISE_LEVELS) if level]
    delays = [Cell(nominal, delay=delay) for delay in (QUICK["delays"] if quick else DELAYS) if delay]
    return grid + noise + delays


def values(task: str, cell: Cell) -> dict:
    """`{name: value}` of the robustness parameters away from the paper's in `cell`, each
    its factor times the paper's value, clipped to the accepted range."""
    return {parameter.name: float(np.clip(factor * parameter.nominal, parameter.low, parameter.high))
            for parameter, factor in zip(axes(task), cell.factors) if factor != 1.0}


def learners_for(task: str, plant: str = "analytic") -> list:
    """The learners of the registry installed here that fit `task` on `plant`, each the task
    made with its
    kind of action (`Learner.actions`), in the registry's order: a population learner
    (`Learner.population`) runs on the analytic plant only here (its other JAX plant, MJX,
    takes one set of parameter values per run, not the randomised training's draws)."""
    return [name for name, learner in LEARNERS.items()
            if learner.fits(task_spec(task, actions=learner.actions)) is None
            and learner.unavailable() is None
            and (plant == "analytic" or not learner.population)]


def agents_for(task: str, learner: str, agents=None):
    """Agents per trained batch of `learner` on `task`: `agents` (None: the task's
    protocol), at most `STEPPED_AGENTS` for a learner that runs only in the stepped loop
    (not a population learner, whose batch is one program)."""
    chosen = learners.learner(learner)
    if chosen.compiles or chosen.population:
        return agents
    return min(agents or protocol_defaults(task)["agents"], STEPPED_AGENTS)


def stepped_protocol(task: str, learner: str, episodes, quick: bool, stepped=None) -> tuple:
    """`(episodes, task options)` of the training of `learner` on `task`: `episodes` (None:
    the task's protocol) and `task_options`, or for a learner that does not run in the
    compiled loop (the stepped loop's, and the population learners, which train as their
    stepped counterparts), where neither the command nor `quick` sets them, `stepped[task]`
    where given (`{task: (episodes, task options)}`: `lwrl robustness` passes the
    benchmark's, docs/benchmark, which says what each cuts from the paper's)."""
    stepped = stepped or {}
    if learners.learner(learner).compiles or episodes is not None or quick or task not in stepped:
        return episodes, task_options(task, quick)
    count, options = stepped[task]
    return count, dict(options)


def task_options(task: str, quick: bool) -> dict:
    """The task's options: none, or for a quick run a short time limit."""
    if not quick:
        return {}
    definition = tasks.definition(*tasks.split_name(task))
    steps = min(QUICK["time_limit_steps"], definition.step_limit)
    return {"time_limit": steps * definition.control_timestep if math.isfinite(steps) else steps}


def chosen_learners(task: str, plant: str, names=None) -> list:
    """The learners a study of `task` on `plant` trains: `names` (None: every one that fits,
    `learners_for`), each checked, in the registry's order; a one-line ValueError naming the
    allowed ones otherwise."""
    fitting = learners_for(task, plant)
    if names is None:
        return fitting
    wrong = [name for name in names if name not in fitting]
    if wrong or not names:
        raise ValueError(f"learner {wrong[0] if wrong else ''!r} does not run in a robustness "
                         f"study of {task} on the {plant} plant; allowed: {', '.join(fitting)}")
    return [name for name in fitting if name in names]


def trainings(task: str, plant: str, agents=None, episodes=None, quick: bool = False,
              stepped=None, learners=None) -> dict:
    """`{(learner, training): RunConfig}`: each learner of `learners` (None: every one that
    fits `task` on `plant`, `chosen_learners`), trained on the paper's plant and with randomisation, `agents_for(task,
    learner, agents)` agents (seeds 0..) for `episodes` episodes each (None: the task's
    protocol; `stepped_protocol` with `stepped`), on the task made with the learner's kind
    of action."""
    chosen = chosen_learners(task, plant, learners)  # checked before anything runs
    if quick:
        agents, episodes = agents or QUICK["agents"], episodes or QUICK["episodes"]
    ranges = {parameter.name: tuple(float(np.clip(factor * parameter.nominal, parameter.low,
                                                  parameter.high)) for factor in TRAINING_FACTORS)
              for parameter in axes(task)}
    configs = {}
    for learner in chosen:
        count, options = stepped_protocol(task, learner, episodes, quick, stepped)
        for training in TRAININGS:
            configs[learner, training] = RunConfig(
                task=task, learner=learner, plant=plant, agents=agents_for(task, learner, agents),
                actions=LEARNERS[learner].actions, episodes=count, task_options=options,
                randomise=ranges if training == "randomised" else {},
                **tuned_settings(task, learner))
    return configs


def evaluation(task: str, trained: RunConfig, cell: Cell, episodes: int,
               quick: bool = False) -> RunConfig:
    """The greedy evaluation of the agents of the run `trained` in `cell`, `episodes`
    episodes each, without learning, on the task's own episodes (`task_options`) whatever
    the training's were, so that every learner is measured alike."""
    definition = tasks.definition(*tasks.split_name(task))
    span = np.subtract(definition.ranges[1], definition.ranges[0])
    noise = ({name: float(cell.noise * width) for name, width in zip(definition.state_names, span)}
             if cell.noise else {})
    return dataclasses.replace(trained, randomise={}, params=values(task, cell),
                               observation_noise=noise, action_delay=cell.delay,
                               trained=trained.key, learn=False, greedy=True, episodes=episodes,
                               task_options=task_options(task, quick),
                               seed=trained.seed + EVALUATION_SEED)


def evaluation_episodes(task: str, quick: bool = False) -> int:
    """Greedy episodes per agent and cell: the domain's (`Robustness.evaluation_episodes`,
    fewer where the start is deterministic)."""
    if quick:
        return QUICK["evaluation_episodes"]
    return ROBUSTNESS.of(tasks.split_name(task)[0]).evaluation_episodes
