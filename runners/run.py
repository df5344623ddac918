"""A run: B agents, each on its own copy of a task, for K episodes, from a `RunConfig`.

Three ways to run the same thing, giving the same numbers for the same seeds (tested):

- `runners.stepped.run_dm_env`: one agent on one dm_env environment (`tasks.load`), step by
  step (through `run_batched` and `tasks.batched.SteppedEnvs`);
- `runners.stepped.run_batched`: B agents on a `tasks.batched.BatchedEnv` (any plant), one
  array step at a time;
- `runners.compiled.run_compiled`: B agents on the analytic plant, or on MuJoCo, in one
  numba-compiled loop that calls the task's own `transition` (or MuJoCo's `mj_step` and the
  task's `arrive`) and the learner's own step.

`run` picks the compiled loop where it runs the plant (`runners.compiled.compiles`: the
analytic plant and MuJoCo) and the learner (`Learner.compiles`: it has a jitable step),
and the stepped one elsewhere. An agent
stops after K episodes, or when it diverges (its weights are frozen, the episode it diverged
in is cut there and its later episodes are not run: NaN).
"""

import math

import numpy as np

from lwrl import agent as learners
from lwrl import tasks
from lwrl.agent.learner_contract import Agents
from lwrl.runners.compiled import compiles, run_compiled
from lwrl.runners.episodes import EpisodeResults
from lwrl.runners.population import run_population
from lwrl.runners.stepped import run_batched, run_dm_env
from lwrl.tasks.batched import BatchedEnv
from lwrl.tasks.randomisation import check_ranges, draws, kept_deviates

__all__ = ["EpisodeResults", "make_agents", "memory_needed", "run", "run_batched", "run_compiled",
           "run_dm_env"]


def memory_needed(config, recorded_episodes: int = 0) -> int:
    """Bytes a run of `config` needs for its largest arrays, estimated before they are made:
    each agent's arrays (the learner's `memory`), the per-episode results and starts, and
    the tape of `recorded_episodes` episodes."""
    definition = tasks.definition(config.domain, config.task_name, **config.task_options)
    spec = config.task_spec
    per_agent = learners.learner(config.learner).memory(config.settings, spec)
    actions, dim = 1 if spec.continuous else spec.action.n, len(definition.state_names)
    per_episode = 8 * (6 + dim)
    steps = definition.step_limit if recorded_episodes and math.isfinite(definition.step_limit) else 0
    tape = recorded_episodes * (8 * int(steps) * (2 * dim + actions + 3) + per_agent)
    return config.agents * (per_agent + per_episode * config.episodes) + tape


def make_agents(*configs) -> Agents:
    """The agents of one or more `RunConfig`s of one learner, each configuration's `agents`
    in order, untrained (a one-line ValueError where its libraries are not installed).
    Configurations after the first differ from it at most in the learner's per-agent
    settings and the seeds (`sweep.batches` groups them so)."""
    base = configs[0]
    learner = learners.learner(base.learner)
    learner.check_installed()
    settings = [config.settings for config in configs for _ in range(config.agents)]
    return learner.make(settings, base.task_spec,
                        [seed for config in configs for seed in config.seeds])


def environment_options(configs) -> dict:
    """The physical parameters, sensor and actuator options and randomisation of a batch of
    agents joining `configs` (`RunConfig`s, each one's agents in order), as the run loops
    take them: each one's value where the configurations share it, else one value per agent
    (a parameter or a noise that a configuration does not set at its default)."""
    first = configs[0].environment_options()
    if all(config.environment_options() == first for config in configs[1:]):
        return first
    nominal = {parameter.name: parameter.nominal
               for parameter in tasks.domain(configs[0].domain).parameters.items}
    options = {}
    for name, default in (("params", nominal), ("observation_noise", {})):
        names = dict.fromkeys(key for config in configs for key in getattr(config, name))
        if names:
            options[name] = {key: [getattr(config, name).get(key, default.get(key, 0.0))
                                   for config in configs for _ in range(config.agents)]
                             for key in names}
    for name in ("action_delay", "action_noise"):
        options[name] = [getattr(config, name) for config in configs for _ in range(config.agents)]
    if "randomise" in first:
        options["randomise"] = first["randomise"]
    return options


def draw_ahead(config, seeds, batch=None) -> None:
    """Draw the physics of every episode `config` may run (`randomise`), for `seeds` (one per
    agent; `batch` the configurations they come from, as for `run`), into the process's keep
    (`tasks.randomisation.kept_deviates`). A run's loops then find them drawn, so that the
    CPU its clock measures (`runners.records`) does not depend on which run of the process
    drew a seed's episodes first."""
    ranges = check_ranges(tasks.domain(config.domain).parameters,
                          environment_options(batch or [config]).get("randomise"))
    for seed in seeds if ranges else ():
        kept_deviates(seed, config.episodes, len(ranges))


def drawn_values(config, options: dict, seeds, results: EpisodeResults) -> dict:
    """`{name: (B, K)}`: the values each episode drew of the parameters `randomise` names
    (`tasks.randomisation.draws`; NaN where not run), for the results tables."""
    parameters = tasks.domain(config.domain).parameters
    ranges = check_ranges(parameters, options.get("randomise"))
    if not ranges:
        return {}
    physical = draws(parameters, ranges, parameters.values(options.get("params"), len(seeds)),
                     seeds, config.episodes)
    ran = np.isfinite(results.steps)
    return {name: np.where(ran, physical[:, :, parameters.position(name)], np.nan)
            for name in ranges}


def run(config, agents: Agents | None = None, learn: bool = True, greedy: bool = False,
        progress=None, record=(), seeds=None, batch=None, checkpoints=None,
        resume=None) -> tuple[Agents, EpisodeResults]:
    """Run a `RunConfig`: the compiled loop where it runs the plant and the learner, else
    the batched stepper. Returns the agents (new ones unless given) and their results, with
    recordings of the `(agent, episode)` pairs in `record`. `learn=False` runs without
    updates, `greedy=True` with greedy actions (evaluation: both). `seeds` (one per agent of
    given `agents`) replaces the configuration's, and `batch` (the configurations the
    agents come from, `config` first) gives each agent its configuration's physics and
    sensors (`environment_options`), for batches that join several configurations. The
    values drawn per episode (`randomise`) are in `results.physical`. `checkpoints`
    (`{smaller budget: call(agents, results)}`, population learners only) gives on the way
    the runs of `config` with smaller budgets (`runners.population.run_population`), and
    `resume` (a path, population learners only) keeps the run's state there as it goes, for
    a later call to go on from (`runners.resume`)."""
    agents = make_agents(config) if agents is None else agents
    seeds = config.seeds if seeds is None else list(seeds)
    domain, task = config.domain, config.task_name
    options = environment_options(batch or [config])
    if config.actions != "discrete":
        options["actions"] = config.actions
    for name, given in (("checkpoints", checkpoints), ("resume", resume)):
        if given and not agents.learner.population:
            raise ValueError(f"{name} is for population learners only; {config.learner} "
                             "is not one")

    def drawn(results):
        results.physical = drawn_values(config, options, seeds, results)
        return results

    if agents.learner.population:
        results = run_population(domain, task, agents, config.episodes, seeds, learn=learn,
                                 greedy=greedy, progress=progress, record=record,
                                 budget=config.budget,
                                 checkpoints={smaller: _after(call, drawn) for smaller, call
                                              in (checkpoints or {}).items()},
                                 resume=None if resume is None else (resume, config.key),
                                 plant=config.plant_name, **config.plant_options,
                                 **config.task_options, **options)
    elif agents.learner.compiles and compiles(domain, config.plant_name):
        results = run_compiled(domain, task, agents, config.episodes, seeds, learn=learn,
                               greedy=greedy, progress=progress, record=record,
                               budget=config.budget,
                               plant=config.plant_name, **config.plant_options,
                               **config.task_options, **options)
    else:
        env = BatchedEnv(domain, task, config.plant_name, seeds, **config.plant_options,
                         **config.task_options, **options)
        results = run_batched(env, agents, config.episodes, learn=learn, greedy=greedy,
                              budget=config.budget,
                              progress=progress, record=record)
    return agents, drawn(results)


def _after(call, first):
    """`call(agents, first(results))`, as a function of `(agents, results)`."""
    return lambda agents, results: call(agents, first(results))
