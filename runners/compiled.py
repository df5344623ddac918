"""The agent-environment loop compiled: B agents on a plant of a task, one numba loop that
calls the task's own `transition` (the analytic plant) or MuJoCo's own `mj_step` and the
task's `arrive` (`tasks.engine`), and the learner's own step (`Learner.step`), in parallel
over agents.
Each agent's episode has physical parameter values of its own (`tasks.parameters`: the
agent's row, or drawn per episode, `tasks.randomisation`), so one batch spans a grid: the
analytic plant reads the row, the engine steps the MuJoCo model compiled at it (one model
per distinct row, sharing the first's `mjData`). Between the agent and the plant stand its
sensors and actuator (`tasks.disturbances`: `noisy_observation`, `applied_control`, from
the agent's own stream), as in `tasks.batched.BatchedEnv`.
Its bookkeeping is the stepped loop's (`tasks.task_definition.advance_episode`,
`runners.episodes.finish_episode`, `runners.recording`), and its numbers too (tested).

The names `_loop` calls that a task or a learner gives (`transition`, `arrive`,
`limit_state`, `agent_step`, `command`) are placeholders here: each kernel's module binds
its task's and learner's functions in their place (`lwrl.kernels`). That module, the loop
as numba compiles it, is written to the kernel cache, at `compiled_loop(definition,
learner, plant).path` (its text `.source`), for a reader to step through.

On the analytic plant the loop is compiled without numba's runtime (`lwrl.kernels`,
`runtime=False`): a step allocates nothing and counts no references, and `run_compiled`
passes in the memory it works in (`Scratch`). MuJoCo's needs the runtime to view the
warning counters of its `mjData`."""

import collections
import functools

import numpy as np
from numba.extending import register_jitable

from lwrl import kernels, tasks
from lwrl.kernels import copy_into
from lwrl.agent.learner_contract import Agents
from lwrl.agent.threads import run_in_chunks
from lwrl.runners.episodes import EpisodeResults, episode_starts, finish_episode, step_budget
from lwrl.runners.recording import (make_tape, record_end, record_state, record_transition,
                                    recorded_values, recordings)
from lwrl.settings import check_count
from lwrl.tasks.task_definition import advance_episode
from lwrl.tasks.commands import COMMANDS, check_kinds, episode_controls
from lwrl.tasks.disturbances import Disturbances, applied_control, noisy_observation
from lwrl.tasks.engine import close_workspace, engine_plant, open_workspace, step_model_state
from lwrl.tasks.randomisation import check_ranges, draws
from lwrl.tasks.integrators import check_integrator
from lwrl.tasks.plants import check_equations


Scratch = collections.namedtuple("Scratch", "states buffers")
"""The compiled loop's memory, one row per agent: `states` `(B, 3, d)` its state, next
state and observation, `buffers` its actuator's delay line (`Disturbances.buffers`)."""


def transition(state, control, next_state, observation, dt, semi_implicit, slips, params):
    """The task's `transition` (`TaskDefinition.transition`): each compiled loop's kernel
    binds its task's own in place of this name, and its `arrive` in place of the next."""
    raise NotImplementedError("the compiled loop's kernel binds each task's transition")


def arrive(state, observation, params):
    """The task's `arrive` (`TaskDefinition.arrive`), bound by each kernel."""
    raise NotImplementedError("the compiled loop's kernel binds each task's arrive")


def limit_state(state):
    """The domain's `DomainPlants.limit_state` (or `no_limit`), bound by each kernel."""
    raise NotImplementedError("the compiled loop's kernel binds each domain's limit_state")


def agent_step(b, first, reward, discount, observation, learn, greedy, arrays):
    """The learner's `Learner.step`, bound by each kernel."""
    raise NotImplementedError("the compiled loop's kernel binds each learner's step")


def command(controls, action):
    """The command of the learner's kind of action (`tasks.commands.COMMANDS`), bound by
    each kernel."""
    raise NotImplementedError("the compiled loop's kernel binds each learner's command")


@register_jitable
def analytic_open(plant):
    """The analytic plant needs no workspace."""
    return 0


@register_jitable
def analytic_close(plant, workspace):
    """Nothing to free."""


def _analytic_transition(state, control, next_state, observation, plant, model, workspace,
                         params):
    """The task's `transition`; `plant` = (dt, semi_implicit, slips); no `model`."""
    dt, semi_implicit, slips = plant
    return transition(state, control, next_state, observation, dt, semi_implicit, slips, params)


@register_jitable
def no_limit(state):
    """The `limit_state` of a domain without a limit: the state as it is."""


def _mujoco_transition(state, control, next_state, observation, plant, model, workspace,
                       params):
    """MuJoCo's step in the model at address `model` (`tasks.engine.step_model_state`),
    the domain's `limit_state`, then the task's `arrive`; `plant` an `EnginePlant`."""
    step_model_state(plant, model, workspace, state, control, next_state)
    limit_state(next_state)
    return arrive(next_state, observation, params)


PLANT_STEPS = {
    "analytic": ({"open_plant": analytic_open, "close_plant": analytic_close},
                 {"plant_transition": _analytic_transition}),
    "mujoco": ({"open_plant": open_workspace, "close_plant": close_workspace},
               {"plant_transition": _mujoco_transition}),
}
"""What the loop calls to step each plant, as kernel bindings and helpers
(`lwrl.kernels`): `open_plant(plant)` once per call of the kernel (MuJoCo: an `mjData`
of the call's own, as each thread of `mujoco.rollout` has one), `plant_transition(state,
control, next_state, observation, plant, model, workspace, params)` per step (`model`: the
address of the episode's MuJoCo model, 0 for the analytic plant), and
`close_plant(plant, workspace)` at the end."""

WITHOUT_RUNTIME = ("analytic",)
"""The plants whose loop is compiled without numba's runtime (`lwrl.kernels`)."""


def _loop(start, stop, first, count, starts, start_observations, controls, dt, plant, models,
          task_params, physical, sigma_observation, delays, sigma_action, keys, step_limit,
          budget, spent, learn, greedy, arrays, values, steps, returns, uptime, truncated,
          diverged_episode, done, tape, cancel, scratch):
    """The whole learning loop around the plant's transition: agents `start..stop-1` run
    episodes `first..first+count-1` (their starts given) unless diverged or out of their
    `budget` of steps (`spent[b]` so far; the episode that spends it is cut there, a
    truncation); once `cancel[0]`
    is set (Ctrl-C), each agent stops after the episode it is in (at most tens of ms).
    `dt`: seconds of up-time per step up. Agent b's episode k has the controls
    `controls[b, k]` `(A,)`, the parameter values `physical[b, k]` `(P,)` and the MuJoCo
    model at `models[b, k]` (continuous actions: `controls[b, k]` is the actuator's range,
    `tasks.commands`); its sensors and actuator have the options `sigma_observation[b]`,
    `delays[b]`, `sigma_action[b]` and the stream `keys[b]` (`tasks.disturbances`); it
    works in `scratch` (`Scratch`). `values` `(B, A)`: the agents' action values the tape
    records at each state (`runners.recording.recorded_values`: `A` is 0 for a learner
    without them)."""
    workspace = open_plant(plant)
    for b in range(start, stop):
        state, next_state, observation = (scratch.states[b, 0], scratch.states[b, 1],
                                          scratch.states[b, 2])
        buffer = scratch.buffers[b, :delays[b]]
        for k in range(first, first + count):
            if arrays.diverged[b] or cancel[0] or spent[b] >= budget:
                break
            limit = min(step_limit, budget - spent[b])
            copy_into(state, starts[b, k])
            copy_into(observation, start_observations[b, k])
            noisy_observation(observation, sigma_observation[b], keys[b], k, 0)
            buffer[:] = 0.0
            episode_controls = controls[b, k]
            low, high = np.inf, -np.inf
            for value in episode_controls:
                low, high = min(low, value), max(high, value)
            arguments = (task_params, physical[b, k])
            action = agent_step(b, True, 0.0, 1.0, observation, learn, greedy, arrays)
            r = tape.slot[b, k]
            if r >= 0:
                record_state(tape, r, 0, state, observation, values[b])
            n, total, up, terminal, last = 0, 0.0, 0.0, False, False
            while not last:
                control = applied_control(buffer, n, command(episode_controls, action), sigma_action[b],
                                          low, high, keys[b], k)
                reward, terminal, is_up = plant_transition(state, control, next_state,
                                                           observation, plant, models[b, k],
                                                           workspace, arguments)
                n, up, last = advance_episode(n, up, is_up, terminal, dt, limit)
                noisy_observation(observation, sigma_observation[b], keys[b], k, n)
                total += reward
                copy_into(state, next_state)
                previous = action
                action = agent_step(b, False, reward, 0.0 if terminal else 1.0, observation,
                                    learn, greedy, arrays)
                if r >= 0:
                    record_state(tape, r, n, state, observation, values[b])
                    record_transition(tape, r, n, previous, reward, arrays.delta[b])
                last = last or arrays.diverged[b]
            if r >= 0:
                record_end(tape, r, n, arrays.weights[b])
            spent[b] += n
            finish_episode(b, k, n, total, up, not terminal and n >= limit,
                           arrays.diverged[b], steps, returns, uptime, truncated,
                           diverged_episode, done)
    close_plant(plant, workspace)


def compiled_loop(definition, learner, plant: str = "analytic") -> kernels.Kernel:
    """The compiled loop's kernel for one task (`TaskDefinition`) and learner (`Learner`)
    on `plant`, cached on disk (`lwrl.kernels`): a second process compiles nothing."""
    limit = tasks.domain(definition.domain).plants.limit_state or no_limit
    return _compiled_loop(definition.transition, definition.arrive, limit, learner.step,
                          learner.actions, plant)


@functools.lru_cache(maxsize=None)
def _compiled_loop(task_transition, task_arrive, task_limit, learner_step, actions: str,
                   plant: str) -> kernels.Kernel:
    module = task_transition.__module__.replace(".", "_")
    learner = learner_step.__module__.replace(".", "_")
    bindings, helpers = PLANT_STEPS[plant]
    return kernels.kernel(f"loop_{plant}_{module}_{learner}", _loop,
                          {"transition": task_transition, "arrive": task_arrive,
                           "limit_state": task_limit, "agent_step": learner_step,
                           "command": COMMANDS[actions], **bindings},
                          helpers, runtime=plant not in WITHOUT_RUNTIME)


def compiles(domain: str, plant: str) -> bool:
    """True where `run_compiled` runs `plant` of `domain`: the analytic plant and MuJoCo."""
    return plant in PLANT_STEPS and plant in tasks.domain(domain).plants.names


def plant_of(domain: str, plant: str, integrator: str, equations: str, physical=None):
    """What the loop's `plant_transition` takes: (dt, semi_implicit, slips) for the analytic
    plant, the `tasks.engine.EnginePlant` of the domain's model for MuJoCo."""
    plants = tasks.domain(domain).plants
    if plant == "analytic":
        return (plants.timestep, check_integrator(integrator), check_equations(equations))
    return engine_plant(plants.mujoco_model(physical), plants.mujoco_physics.ACTUATOR, plants.substeps)


def model_addresses(domain: str, plant: str, physical: np.ndarray) -> np.ndarray:
    """`(B, K)`: the address of the MuJoCo model at each episode's parameter values
    `physical` `(B, K, P)`, compiled once per distinct row (`DomainPlants.mujoco_model`,
    which keeps them: compiled code holds their addresses); zeros for the analytic plant."""
    if plant == "analytic":
        return np.zeros(physical.shape[:2], dtype=np.int64)
    rows, inverse = np.unique(physical.reshape(-1, physical.shape[-1]), axis=0, return_inverse=True)
    models = tasks.domain(domain).plants.mujoco_model
    addresses = np.array([models(row)._address for row in rows], dtype=np.int64)
    return addresses[inverse.ravel()].reshape(physical.shape[:2])


def run_compiled(domain: str, task: str, agents: Agents, episodes: int, seeds,
                 learn: bool = True, integrator: str = "semi_implicit", equations: str = "paper",
                 progress=None, record=(), plant: str = "analytic", greedy: bool = False,
                 params=None, randomise=None, budget=None, **options) -> EpisodeResults:
    """B agents of a compiled learner (`Learner.compiles`) on `plant` (analytic or mujoco)
    of `domain.task`, in one compiled loop; environment b is seeded with `seeds[b]` as in
    `BatchedEnv`; `learn` and `greedy` as for `Learner.step`. Episodes run
    in about 20 blocks, after each of which `progress(episodes_done)` is called. The
    `(agent, episode)` pairs in `record` are recorded step by step (`results.recordings`).
    As in `BatchedEnv`, `params` (the physical parameters) and the sensor and actuator
    options (`tasks.disturbances.OPTIONS`) take one value for every agent or one per
    agent; `randomise={name: (low, high)}` draws those parameters anew for each episode
    (`tasks.randomisation`). `budget`: environment steps per agent at most (`RunConfig.budget`;
    None: no budget)."""
    episodes = check_count("episodes", episodes, 1)
    seeds = list(seeds)
    if len(seeds) != agents.batch_size:
        raise ValueError(f"{len(seeds)} seeds for a batch of {agents.batch_size} agents")
    batch = agents.batch_size
    parameters = tasks.domain(domain).parameters
    rows = parameters.values(params, batch)
    ranges = check_ranges(parameters, randomise)
    if params and np.all(rows == rows[0]):
        options["params"] = dict(zip(parameters.names, rows[0]))
    plant_options = {name: value for name, value in (("integrator", integrator), ("equations", equations))
                     if name in tasks.plant_option_names(domain, plant)}
    definition, _, _, sensing = tasks.resolve_environment(domain, task, plant, **options,
                                                          **plant_options)
    check_kinds(agents.learner.name, agents.learner.actions, definition, "run_compiled")
    stepped = plant_of(domain, plant, integrator, equations, definition.physical)
    physical = draws(parameters, ranges, rows, seeds, episodes)
    controls = np.ascontiguousarray(episode_controls(definition, physical))
    sensors = Disturbances(definition.state_names, controls[:, 0], batch, **sensing)
    sensors.seed(seeds)
    results = EpisodeResults.empty(batch, episodes)
    steps = np.zeros((batch, episodes), dtype=np.int64)
    starts = episode_starts(definition, seeds, episodes)
    step_limit = definition.step_limit if np.isfinite(definition.step_limit) else np.iinfo(np.int64).max
    loop = compiled_loop(definition, agents.learner, plant)
    values = recorded_values(agents)
    tape = make_tape(record, batch, episodes, definition.step_limit, starts.shape[2],
                     values.shape[1], agents.arrays.weights.shape[1:], agents.continuous)
    done = np.zeros(batch, dtype=np.int64)  # episodes each agent has finished
    spent = np.zeros(batch, dtype=np.int64)  # steps each agent has taken
    cancel = np.zeros(1, dtype=bool)  # set on Ctrl-C: the loops stop after their episode
    block = max(1, episodes // 20)
    models = model_addresses(domain, plant, physical)
    scratch = Scratch(np.zeros((batch, 3, starts.shape[2])), sensors.buffers)
    try:
        for first in range(0, episodes, block):
            count = min(block, episodes - first)
            run_in_chunks(
                loop, batch, first, count, starts, definition.observe(starts), controls,
                definition.control_timestep, stepped, models,
                definition.loop_arguments()[0], physical, sensors.sigma_observation,
                sensors.delay, sensors.sigma_action, sensors.keys, int(step_limit),
                step_budget(budget), spent, bool(learn), bool(greedy), agents.arrays, values, steps, results.returns,
                results.uptime, results.truncated, results.diverged_episode, done, tape,
                cancel, scratch, min_chunk=1, chunks_per_worker=8, cancel=cancel)
            if progress is not None:
                progress(batch * count)
    except KeyboardInterrupt:
        results.interrupted = True
    ran = np.arange(episodes)[None, :] < done[:, None]
    results.steps = np.where(ran, steps, np.nan)
    results.returns[~ran] = np.nan
    results.uptime[~ran] = np.nan
    if not definition.has_uptime:
        results.uptime[:] = np.nan
    results.recordings = recordings(tape, definition, plant, seeds)
    return results
