"""The contract checks, for the authors of learners and domains: as Gymnasium's `check_env`
holds an environment to Gymnasium's API, `check_learner` holds a learner to the learner
contract (`lwrl.agent.learner_contract`) on every task of the suite, and `check_domain` holds
a domain to the task contract (`lwrl.tasks.domain_contract`, SPEC.md tasks 1-3) on every task
and plant of a single environment.

    from lwrl.testing import check_domain, check_learner
    from my_package.learner import LEARNER
    check_learner(LEARNER)                       # every task of the suite, or tasks=[...]

Each check is also a small public function of its own (`check_learner_run_paths(learner,
task)`, `check_task_deterministic(domain, task, plant)`, ...), so that a test suite can run
them one by one, as lwrl's own tests do (tests/test_learners.py, tests/test_suite.py). A check
that fails raises `ContractError` (an AssertionError) whose one line names the learner or
domain, the task, the check and what was wrong; the failure it caught is its cause.

The checks run through lwrl's registries, as `lwrl train` does: a learner or domain is
checked once its package is installed with its entry point (`lwrl.learners`, `lwrl.tasks`;
`pip install -e .` while it is being written). Each runs in seconds: three agents, three
episodes of at most 300 steps (`STEPPED_STEPS` for a learner stepped in Python).
"""

import contextlib
import dataclasses
import functools
import json
import math
import tempfile
from pathlib import Path

import dm_env
import numpy as np
from dm_env import specs

from lwrl import agent as learners
from lwrl import tasks as suite
from lwrl.agent import io as agent_io
from lwrl.agent.jax_population import PopulationAgents
from lwrl.agent.learner_contract import CONTINUOUS_ACTIONS, Learner, LearnerForm, NoValues
from lwrl.runners.config import RunConfig, task_spec
from lwrl.runners.run import make_agents, memory_needed, run, run_batched, run_compiled, run_dm_env
from lwrl.spaces import Box
from lwrl.tasks.batched import LAST, BatchedEnv
from lwrl.tasks.domain_contract import Domain

STEPPED_STEPS = 40
"""Steps per episode of a contract run of a learner without a compiled step (stepped in
Python, as Stable-Baselines3's, whose every step costs what a compiled episode does, or a
JAX program), so that each check runs in seconds; a learner whose defaults would not update
within them says what it runs with instead (`Learner.checked`), so that its saved agents
carry updated networks, optimisers and replay buffers."""
COMPILED_STEPS = 300
"""Steps per episode of a contract run of a learner with a compiled step."""
BATCH_STEPS = 40
"""The time limit, in control steps, of the batch check's episodes: episodes end and restart
within it."""
BAD_ACTIONS = (-1, "num_actions", 1.5, "1", np.array([0, 1]), None)
"""Actions an environment refuses: out of range (`num_actions` stands for the first index
past the last), or not one integer."""


class ContractError(AssertionError):
    """A learner or a domain breaks its contract: one line naming it, the task, the check and
    what was wrong."""


def _one_line(error: BaseException) -> str:
    """`error`'s message in one line (NumPy's assertions span several)."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    return "; ".join(lines) or type(error).__name__


@contextlib.contextmanager
def _held(subject: str, check: str):
    """Turn a failure inside into a `ContractError` naming `subject` and `check`."""
    try:
        yield
    except ContractError:
        raise
    except AssertionError as error:
        raise ContractError(f"{subject}: {check}: {_one_line(error)}") from error
    except Exception as error:
        raise ContractError(f"{subject}: {check}: raised {type(error).__name__}: "
                            f"{_one_line(error)}") from error


def _expect(condition, what: str) -> None:
    """Fail with `what` unless `condition` (an `assert` that `python -O` keeps)."""
    if not condition:
        raise AssertionError(what)


def _same_results(a, b, what: str) -> None:
    """Two runs' episode records are identical."""
    for field in ("steps", "returns", "uptime", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field),
                                      err_msg=f"{what}: {field} differ")


def _registered(kind: str, held, registry: dict, group: str) -> str:
    """The name of `held` (an object of the registry, or its name), which must be the one
    `registry` holds (through the entry-point group `group`)."""
    name = held if isinstance(held, str) else held.name
    if registry.get(name) is None or (not isinstance(held, str) and registry[name] is not held):
        raise ContractError(f"{kind} {name!r}: not in lwrl's registry; declare its "
                            f"{kind.upper()} under the entry-point group '{group}' and install "
                            f"its package (pip install -e .)")
    return name


# Learners ------------------------------------------------------------------------------------

def learner_name(learner: Learner | str) -> str:
    """The registry name of `learner` (a `Learner` or its name), which must be the one the
    registry holds (`agent.LEARNERS`, through the entry-point group `lwrl.learners`)."""
    return _registered("learner", learner, learners.LEARNERS, learners.ENTRY_POINT_GROUP)


def fits(learner: Learner | str, task: str) -> bool:
    """Whether `learner` fits `task` (DOMAIN.TASK) with its kind of actions (`Learner.fits`),
    whatever is installed (`Learner.unavailable`)."""
    chosen = learners.learner(learner_name(learner))
    return chosen.fits(task_spec(task, actions=chosen.actions)) is None


def steps_per_episode(learner: Learner | str, task: str) -> int:
    """At most `COMPILED_STEPS` steps, `STEPPED_STEPS` for a learner without a compiled step,
    and at most the task's own limit."""
    definition = suite.definition(*suite.split_name(task))
    short = learners.learner(learner_name(learner)).step is None
    return min(STEPPED_STEPS if short else COMPILED_STEPS, definition.step_limit)


def contract_config(learner: Learner | str, task: str) -> RunConfig:
    """The checks' run: three agents, three episodes of `steps_per_episode` steps, seed 5, on
    the analytic plant, with the learner's kind of actions and the settings it is checked
    with (`Learner.checked`)."""
    name = learner_name(learner)
    chosen = learners.learner(name)
    definition = suite.definition(*suite.split_name(task))
    limit = steps_per_episode(name, task) * definition.control_timestep
    return RunConfig(task=task, learner=name, plant="analytic", agents=3, episodes=3, seed=5,
                     task_options={"time_limit": limit}, actions=chosen.actions,
                     **chosen.checked)


def _learner_check(function):
    """A check of a learner on a task: it takes a `Learner` or its name, and a failure names
    both and the check."""
    @functools.wraps(function)
    def check(learner: Learner | str, task: str) -> None:
        name = learner_name(learner)
        with _held(f"learner {name!r} on task {task!r}", function.__name__):
            function(name, task)
    return check


def check_learner_declaration(learner: Learner | str) -> None:
    """The learner's registry entry: its name, a title, a source, settings as a dataclass,
    settings to be checked with (`Learner.checked`) that are its own, and what shapes its
    program (`Learner.shared`) of its default settings as a tuple of JSON values (a run's
    batch is named by them, `runners.sweep.batch_key`)."""
    name = learner_name(learner)
    with _held(f"learner {name!r}", "check_learner_declaration"):
        declared = learners.learner(name)
        _expect(declared.name == name,
                f"the registry holds it as {name!r}, it is {declared.name!r}")
        _expect(declared.title and declared.source, "its title or its source is empty")
        _expect(dataclasses.is_dataclass(declared.settings), "its settings are not a dataclass")
        names = {field.name for field in dataclasses.fields(declared.settings)}
        unknown = sorted(set(declared.checked) - names)
        _expect(not unknown, f"it is checked with {', '.join(unknown)}, which are not its "
                             f"settings")
        shared = declared.shared([declared.settings()])
        _expect(isinstance(shared, tuple), f"shared gives {shared!r}, not a tuple")
        try:
            json.dumps(shared)
        except (TypeError, ValueError) as error:
            raise AssertionError(f"shared gives {shared!r}, not JSON values: {error}") from None


@_learner_check
def check_learner_run_paths(learner: str, task: str) -> None:
    """The compiled loop (where the learner has a compiled step), the batched stepper and one
    agent on a dm_env environment give identical episodes and learned arrays. A population
    learner has one path, the JAX program (`runners.population`): the stepped loop refuses it
    in one line, and the program gives the same numbers again."""
    config = contract_config(learner, task)
    domain, name = suite.split_name(task)
    options = {**config.task_options, "actions": config.actions}
    batched_agent = make_agents(config)
    if learners.learner(learner).population:
        try:
            run_batched(BatchedEnv(domain, name, "analytic", config.seeds, **options),
                        batched_agent, config.episodes)
        except ValueError as error:
            _expect("one JAX program" in str(error),
                    f"the stepped loop refuses it without naming the JAX program: {error}")
        else:
            raise AssertionError("the stepped loop runs a population learner")
        first_agent, first = run(config)
        again_agent, again = run(config)
        _same_results(again, first, "two runs of the program")
        np.testing.assert_array_equal(again_agent.arrays.weights, first_agent.arrays.weights,
                                      err_msg="two runs of the program: weights differ")
        return
    batched = run_batched(BatchedEnv(domain, name, "analytic", config.seeds, **options),
                          batched_agent, config.episodes)
    if learners.learner(learner).compiles:
        compiled_agent = make_agents(config)
        compiled = run_compiled(domain, name, compiled_agent, config.episodes, config.seeds,
                                **options)
        _same_results(compiled, batched, "the compiled loop and the batched stepper")
        np.testing.assert_array_equal(
            compiled_agent.arrays.weights, batched_agent.arrays.weights,
            err_msg="the compiled loop and the batched stepper: weights differ")
    single_config = dataclasses.replace(config, agents=1, seed=config.seed + 1)
    single_agent = make_agents(single_config)
    single = run_dm_env(suite.load(domain, name, plant="analytic", seed=single_config.seed,
                                   **options), single_agent, config.episodes)
    np.testing.assert_array_equal(single.steps[0], batched.steps[1],
                                  err_msg="one agent on dm_env and in the batch: steps differ")
    np.testing.assert_array_equal(single_agent.arrays.weights[0], batched_agent.arrays.weights[1],
                                  err_msg="one agent on dm_env and in the batch: weights differ")


@_learner_check
def check_learner_alone_as_in_a_batch(learner: str, task: str) -> None:
    """An agent's results depend on its own seed and settings only."""
    config = contract_config(learner, task)
    _, batch = run(config)
    _, alone = run(dataclasses.replace(config, agents=1, seed=config.seed + 2))
    np.testing.assert_array_equal(alone.steps[0], batch.steps[2],
                                  err_msg="alone and in a batch: steps differ")
    np.testing.assert_array_equal(alone.returns[0], batch.returns[2],
                                  err_msg="alone and in a batch: returns differ")


@_learner_check
def check_learner_arrays(learner: str, task: str) -> None:
    """`delta` (B,), `diverged` (B,) and `weights` (B, ...) are there; the agents act in
    the task's `Discrete` space or in `CONTINUOUS_ACTIONS` as their learner says; action
    values are a capability: `q` (B, A) where a learner of discrete actions has them, and
    otherwise no `q` nor `num_actions` at all, `latest_values` saying so in one line; and
    the memory estimate covers the agents' arrays."""
    config = contract_config(learner, task)
    agent, _ = run(config)
    arrays = agent.arrays
    spec = config.task_spec
    expected = CONTINUOUS_ACTIONS if agent.learner.takes is Box else spec.action
    _expect(agent.action_space == expected,
            f"action_space is {agent.action_space}, not {expected}")
    if "q" in arrays._fields:
        _expect(not spec.continuous, "q is there, but a learner of continuous actions has no "
                                     "action values over its actions")
        shape = (3, spec.action.n)
        _expect(arrays.q.shape == shape, f"q has shape {arrays.q.shape}, not {shape}")
        _expect(agent.latest_values() is arrays.q, "latest_values is not arrays.q")
    else:
        _expect(not hasattr(agent, "num_actions"),
                "num_actions is there, but the agents keep no action values")
        try:
            agent.latest_values()
        except NoValues as error:
            _expect("\n" not in str(error), "latest_values' refusal is not one line")
        else:
            raise AssertionError("latest_values gave values, but arrays have no q")
    _expect(arrays.delta.shape == (3,), f"delta has shape {arrays.delta.shape}, not (3,)")
    _expect(arrays.diverged.shape == (3,) and arrays.diverged.dtype == bool,
            f"diverged is {arrays.diverged.dtype} {arrays.diverged.shape}, not bool (3,)")
    _expect(arrays.weights.shape[0] == 3,
            f"weights have shape {arrays.weights.shape}, not (3, ...)")
    _expect(np.all(np.isfinite(arrays.weights)), "weights are not all finite")
    _expect(agent.batch_size == 3, f"batch_size is {agent.batch_size}, not 3")
    kept = sum(array.nbytes for array in arrays if isinstance(array, np.ndarray))
    needed = memory_needed(config)
    _expect(needed >= kept, f"the memory estimate, {needed} bytes, is below the arrays' {kept}")


@_learner_check
def check_learner_greedy_touches_nothing(learner: str, task: str) -> None:
    """`learn=False, greedy=True` (evaluation) changes no learned array and no setting, and
    gives the same episodes twice."""
    config = contract_config(learner, task)
    agent, _ = run(config)
    weights = agent.arrays.weights.copy()
    settings = agent.settings
    _, first = run(config, agents=agent, learn=False, greedy=True)
    _, second = run(config, agents=agent, learn=False, greedy=True)
    np.testing.assert_array_equal(agent.arrays.weights, weights,
                                  err_msg="acting greedily changed the weights")
    _expect(agent.settings == settings, "acting greedily changed the settings")
    _same_results(first, second, "two greedy evaluations")


@_learner_check
def check_learner_save_and_load(learner: str, task: str) -> None:
    """Saved agents load as the same kind, with the same run configuration and weights, and
    go on learning identically."""
    config = contract_config(learner, task)
    agent, _ = run(config)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "agents.npz"
        agent_io.save(path, agent, {"config": dataclasses.asdict(config)})
        loaded, metadata = agent_io.load(path)
    _expect(type(loaded) is type(agent), f"loaded as {type(loaded).__name__}, "
                                          f"saved as {type(agent).__name__}")
    _expect(loaded.learner is agent.learner, "the loaded agents' learner is another")
    _expect(RunConfig(**metadata["config"]) == config, "the loaded run configuration differs")
    np.testing.assert_array_equal(loaded.arrays.weights, agent.arrays.weights,
                                  err_msg="the loaded weights differ")
    _, more = run(config, agents=agent)
    _, more_loaded = run(config, agents=loaded)
    _same_results(more, more_loaded, "going on with the saved and the loaded agents")


def _values(function, *arguments):
    """`function(*arguments)`, or None where the learner has no such values (`NoValues`)."""
    try:
        return function(*arguments)
    except NoValues:
        return None


@_learner_check
def check_learner_values_on_a_grid(learner: str, task: str) -> None:
    """`action_values_on_grid` and `state_values_on_grid` (a learner may factorise them)
    equal the values at the grid's states, or the learner says it has none (`NoValues`);
    action values are of a learner of discrete actions only, and one of continuous actions
    gives its greedy actions in [-1, 1] (`greedy_actions`), agent b's those of its weights."""
    agent = make_agents(contract_config(learner, task))
    rng = np.random.default_rng(0)
    weights = rng.normal(size=agent.arrays.weights.shape[1:])
    low, high = map(np.asarray, agent.value_box())
    axes = [np.linspace(lo, hi, 4) for lo, hi in zip(low, high)]
    states = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    for on_grid, at_states, what in (
            (agent.action_values_on_grid, agent.action_values, "action values"),
            (agent.state_values_on_grid, agent.state_values, "state values")):
        grid, at = _values(on_grid, axes, weights), _values(at_states, states, weights)
        _expect((grid is None) == (at is None), f"{what} are there on a grid or at states, "
                                                f"not both")
        if grid is not None:
            np.testing.assert_allclose(grid, at, rtol=1e-12, atol=1e-12,
                                       err_msg=f"{what} on the grid and at its states")
    _expect(not agent.continuous or _values(agent.action_values, states) is None,
            "a learner of continuous actions gives action values")
    greedy = _values(agent.greedy_actions, states)
    _expect((greedy is not None) == agent.continuous,
            "a learner of continuous actions gives no greedy actions" if agent.continuous
            else "a learner of discrete actions gives greedy actions in [-1, 1]")
    if greedy is not None:
        _expect(greedy.shape == (3, *states.shape[:-1]),
                f"greedy actions have shape {greedy.shape}, not {(3, *states.shape[:-1])}")
        _expect(np.all(np.abs(greedy) <= 1.0), "greedy actions outside [-1, 1]")
        np.testing.assert_allclose(agent.greedy_actions(states, agent.arrays.weights[1]),
                                   greedy[1], rtol=1e-6, atol=1e-7,
                                   err_msg="agent 1's greedy actions from its weights and in "
                                           "the batch")
    points = agent.feature_points()
    _expect(points is None or points.shape[1] == len(low),
            f"feature points have {points.shape[1] if points is not None else 0} coordinates, "
            f"the state {len(low)}")


@_learner_check
def check_learner_refuses_misfit(learner: str, task: str) -> None:
    """A run of the learner on a task it does not fit is refused in one line naming the task."""
    try:
        RunConfig(task=task, learner=learner)
    except ValueError as error:
        message = str(error)
        _expect("\n" not in message and task in message,
                f"the refusal is not one line naming the task: {message!r}")
    else:
        raise AssertionError("a run on a task it does not fit is not refused")


@_learner_check
def check_learner_in_c(learner: str, task: str) -> None:
    """`Agents.learner_form`: a form whose values start from the agent's weights and stream
    (its stream's state, `arrays.streams`, or a JAX population's seed),
    whose RAM parts are counts, and whose check passes in double, and agents that take the
    weights a device sends back (`take_weights`); or one line saying why the learner does
    not learn in C."""
    agent = make_agents(contract_config(learner, task))
    try:
        form = agent.learner_form(1)
    except ValueError as error:
        _expect("\n" not in str(error) and "in C" in str(error),
                f"the refusal is not one line saying why not in C: {str(error)!r}")
        return
    _expect(isinstance(form, LearnerForm), f"learner_form gives a {type(form).__name__}")
    values = form.values(np.float64)
    np.testing.assert_array_equal(np.ravel(values["weights"]), np.ravel(agent.arrays.weights[1]),
                                  err_msg="the form's weights are not the agent's")
    stream = (agent.seeds[1] if isinstance(agent, PopulationAgents)  # JAX's keys: the seed's
              else agent.arrays.streams[1])
    _expect(values["seed"] == int(stream), "the form's seed is not the agent's stream")
    _expect(all(isinstance(reals, int) and isinstance(other, int)
                for reals, other in form.ram.values()), "the form's RAM parts are not counts")
    _expect(len(form.ranges[0]) == len(form.ranges[1]) == agent.dim,
            f"the form's ranges are not {agent.dim} long")
    checked = form.check(np.float64)
    _expect(checked is None, f"the form's check in double fails: {checked}")
    _expect(form.summary and form.name and form.smaller,
            "the form's summary, name or smaller is empty")
    learned = agent.arrays.weights + np.arange(agent.arrays.weights.size).reshape(
        agent.arrays.weights.shape) % 7 / 8.0
    agent.take_weights(learned)  # what a device sends back
    np.testing.assert_allclose(agent.arrays.weights, learned, rtol=1e-6,
                               err_msg="take_weights does not make the agents' weights these")


LEARNER_CHECKS = (check_learner_run_paths, check_learner_alone_as_in_a_batch, check_learner_arrays,
                  check_learner_greedy_touches_nothing, check_learner_save_and_load,
                  check_learner_values_on_a_grid, check_learner_in_c)
"""The checks of a learner on each task it fits."""


def check_learner(learner: Learner | str, tasks: list | tuple | None = None) -> None:
    """Hold `learner` (a `Learner` of the registry, or its name) to the learner contract:
    its declaration, then on each task (DOMAIN.TASK; every task of the suite when None) that
    it fits every check of `LEARNER_CHECKS`, and on each it does not fit
    `check_learner_refuses_misfit`. Raises `ContractError` at the first failure, the first
    where the libraries it needs are not installed (`Learner.unavailable`)."""
    check_learner_declaration(learner)
    name = learner_name(learner)
    with _held(f"learner {name!r}", "check_learner"):
        reason = learners.learner(name).unavailable()
        _expect(reason is None, str(reason))
    for task in suite.TASK_NAMES if tasks is None else tasks:
        if fits(name, task):
            for check in LEARNER_CHECKS:
                check(name, task)
        else:
            check_learner_refuses_misfit(name, task)


# Domains -------------------------------------------------------------------------------------

def domain_name(domain: Domain | str) -> str:
    """The registry name of `domain` (a `Domain` or its name), which must be the one the
    registry holds (`tasks.DOMAINS`, through the entry-point group `lwrl.tasks`)."""
    return _registered("domain", domain, suite.DOMAINS, suite.ENTRY_POINT_GROUP)


def _task_check(function):
    """A check of a task on a plant of a single environment: it takes a `Domain` or its name,
    and a failure names the domain, the task, the plant and the check."""
    @functools.wraps(function)
    def check(domain: Domain | str, task: str, plant: str) -> None:
        name = domain_name(domain)
        with _held(f"domain {name!r}, task {task!r} on the {plant} plant", function.__name__):
            function(name, task, plant)
    return check


def random_episode_steps(env, rng: np.random.Generator, max_steps: int) -> list:
    """The time steps of `env` under random actions until LAST or `max_steps`."""
    steps = [env.reset()]
    while not steps[-1].last() and len(steps) <= max_steps:
        steps.append(env.step(int(rng.integers(env.action_spec().num_values))))
    return steps


def check_domain_declaration(domain: Domain | str) -> None:
    """The domain gives its physics: tasks with bounds, normalisation ranges and angles over its state
    variables."""
    name = domain_name(domain)
    with _held(f"domain {name!r}", "check_domain_declaration"):
        declared = suite.domain(name)
        _expect(declared.name == name and declared.tasks,
                f"the registry holds it as {name!r}, it is {declared.name!r} with tasks "
                f"{list(declared.tasks)}")
        for task in declared.tasks:
            definition = suite.definition(name, task)
            state_names = definition.state_names
            _expect(set(definition.angles) <= set(state_names),
                    f"task {task!r}: angles {definition.angles} not all state variables")
            low, high = definition.bounds
            _expect(len(low) == len(high) == len(state_names) and np.all(np.less(low, high)),
                    f"task {task!r}: bounds are not below-above pairs over the state variables")
            low, high = definition.ranges
            _expect(len(low) == len(high) == len(state_names)
                    and np.all(np.isfinite(low) & np.isfinite(high) & np.less(low, high)),
                    f"task {task!r}: the normalisation ranges are not finite below-above "
                    f"pairs over the state variables")


@_task_check
def check_task_spec(domain: str, task: str, plant: str) -> None:
    """Actions are a DiscreteArray mapping index i to the i-th control in ascending order;
    observations are the state variables, one float64 scalar each, matching their specs;
    rewards are finite floats, discounts 0 or 1."""
    env = suite.load(domain, task, plant=plant, seed=0)
    action_spec = env.action_spec()
    definition = suite.definition(domain, task)
    _expect(isinstance(action_spec, specs.DiscreteArray),
            f"the action spec is a {type(action_spec).__name__}, not a DiscreteArray")
    _expect(env.task.definition.controls == definition.controls,
            "the environment's controls are not the task's")
    _expect(action_spec.num_values == len(definition.controls),
            f"{action_spec.num_values} actions for {len(definition.controls)} controls")
    _expect(list(definition.controls) == sorted(definition.controls),
            f"the controls {definition.controls} are not in ascending order")
    observation_spec = env.observation_spec()
    _expect(tuple(observation_spec) == definition.state_names,
            f"the observation spec's names {tuple(observation_spec)} are not the state "
            f"variables {definition.state_names}")
    for ts in random_episode_steps(env, np.random.default_rng(0), 50):
        _expect(tuple(ts.observation) == definition.state_names,
                f"an observation's names {tuple(ts.observation)} are not the state variables")
        for name, value in ts.observation.items():
            observation_spec[name].validate(value)
        if not ts.first():
            _expect(isinstance(ts.reward, float) and math.isfinite(ts.reward),
                    f"the reward {ts.reward!r} is not a finite float")
            _expect(ts.discount in (0.0, 1.0), f"the discount {ts.discount!r} is not 0 or 1")


@_task_check
def check_task_actions_apply_controls(domain: str, task: str, plant: str) -> None:
    """Action i sets the plant's control to the i-th force or torque."""
    env = suite.load(domain, task, plant=plant, seed=0)
    for index, control in enumerate(suite.definition(domain, task).controls):
        env.reset()
        env.step(index)
        applied = (env.physics.named.data.ctrl[env.physics.ACTUATOR] if plant == "mujoco"
                   else env.physics._control[0])
        _expect(applied == control, f"action {index} applies {applied}, not its control {control}")


@_task_check
def check_task_deterministic(domain: str, task: str, plant: str) -> None:
    """The same seed and actions give the same time steps."""
    def trajectory(seed):
        env = suite.load(domain, task, plant=plant, seed=seed)
        rng = np.random.default_rng(1)
        steps = []
        for _ in range(3):
            steps += random_episode_steps(env, rng, 40)
        return [(int(ts.step_type), ts.reward, ts.discount, tuple(ts.observation.values()))
                for ts in steps]

    _expect(trajectory(7) == trajectory(7), "two runs with seed 7 and the same actions differ")


@_task_check
def check_task_starts(domain: str, task: str, plant: str) -> None:
    """Every start is one of the task's own (`initial_states`, within its bounds), the same
    for the same seed; random starts differ between episodes and between seeds."""
    definition = suite.definition(domain, task)
    starts = [np.array(list(suite.load(domain, task, plant=plant, seed=seed).reset()
                            .observation.values())) for seed in (3, 3, 4)]
    env = suite.load(domain, task, plant=plant, seed=3)
    episodes = np.array([list(env.reset().observation.values()) for _ in range(20)])
    low, high = definition.bounds
    _expect(np.all(episodes >= low) and np.all(episodes <= high),
            "a start lies outside the task's bounds")
    np.testing.assert_array_equal(starts[0], starts[1], err_msg="seed 3 starts twice differently")
    if len(np.unique(episodes, axis=0)) > 1:  # the task's starts are random
        _expect(not np.array_equal(starts[0], starts[2]), "seeds 3 and 4 start alike")
        _expect(len(np.unique(episodes, axis=0)) == len(episodes),
                "random starts repeat over 20 episodes")


@_task_check
def check_task_time_limit(domain: str, task: str, plant: str) -> None:
    """A time limit of 5 control steps ends an episode that reaches no terminal state in them
    with discount 1 (a truncation) on the fifth step, and the next step starts another."""
    definition = suite.definition(domain, task)
    env = suite.load(domain, task, plant=plant, seed=0, time_limit=5 * definition.control_timestep)
    _expect(env.task.definition.step_limit == 5,
            f"a limit of 5 control steps gives a step limit of {env.task.definition.step_limit}")
    env.reset()
    steps = [env.step(i % 2) for i in range(5)]
    _expect([ts.step_type for ts in steps] == [dm_env.StepType.MID] * 4 + [dm_env.StepType.LAST],
            f"the step types are {[ts.step_type.name for ts in steps]}, not 4 MID then LAST")
    _expect(steps[-1].discount == 1.0, f"the truncation's discount is {steps[-1].discount}, not 1")
    _expect(env.step(0).first(), "the step after the truncation starts no episode")


@_task_check
def check_task_refuses_bad_actions(domain: str, task: str, plant: str) -> None:
    """An action index out of range, or not one integer (`BAD_ACTIONS`), raises naming the
    allowed range."""
    env = suite.load(domain, task, plant=plant)
    env.reset()
    num_actions = env.action_spec().num_values
    allowed = f"integer index in 0..{num_actions - 1}"
    for action in BAD_ACTIONS:
        if isinstance(action, str) and action == "num_actions":
            action = num_actions
        try:
            env.step(action)
        except ValueError as error:
            _expect("action must be" in str(error) and allowed in str(error),
                    f"action {action!r} is refused without naming the {allowed}: {error}")
        else:
            raise AssertionError(f"action {action!r} is taken")


@_task_check
def check_task_refuses_nan_state(domain: str, task: str, plant: str) -> None:
    """A NaN given to a plant raises, naming the state variables."""
    env = suite.load(domain, task, plant=plant)
    env.reset()
    names = suite.definition(domain, task).state_names
    state = np.zeros(len(names))
    state[-1] = np.nan
    try:
        env.physics.set_state_vector(state)
    except ValueError as error:
        _expect("state must be finite" in str(error) and names[-1] in str(error),
                f"a NaN state is refused without naming {names[-1]!r}: {error}")
    else:
        raise AssertionError("a NaN state is taken")


@_task_check
def check_task_batched(domain: str, task: str, plant: str) -> None:
    """A batch of B environments (`tasks.batched.BatchedEnv`), given the seeds and actions of
    B single dm_env environments, returns identical step types, rewards, discounts,
    observations and up-times over several episodes (terminal and truncated ends and the
    resets after them, with a time limit of `BATCH_STEPS` control steps)."""
    seeds = [3, 5, 8, 13, 21]
    options = {"time_limit": BATCH_STEPS * suite.definition(domain, task).control_timestep}
    batched = BatchedEnv(domain, task, plant, seeds, **options)
    singles = [suite.load(domain, task, plant=plant, seed=seed, **options) for seed in seeds]
    rng = np.random.default_rng(0)
    batched.reset()
    for env in singles:
        env.reset()
    ends = 0
    for step in range(3 * BATCH_STEPS):
        actions = rng.integers(batched.num_actions, size=len(seeds))
        batched_ts = batched.step(actions)
        for i, ts in enumerate(env.step(int(a)) for env, a in zip(singles, actions)):
            where = f"environment {i} at step {step}"
            _expect(batched_ts.step_type[i] == int(ts.step_type), f"{where}: the step types differ")
            np.testing.assert_array_equal(batched_ts.observation[i], list(ts.observation.values()),
                                          err_msg=f"{where}: the observations differ")
            if not ts.first():
                _expect(batched_ts.reward[i] == ts.reward, f"{where}: the rewards differ")
                _expect(batched_ts.discount[i] == ts.discount, f"{where}: the discounts differ")
            np.testing.assert_array_equal(batched.uptime[i], singles[i].task.uptime,
                                          err_msg=f"{where}: the up-times differ")
            _expect(batched.steps[i] == singles[i].task.steps, f"{where}: the step counts differ")
        ends += int(np.sum(batched_ts.step_type == LAST))
    _expect(ends >= len(seeds), f"{ends} episodes ended in {3 * BATCH_STEPS} steps of "
                                f"{len(seeds)} environments: too few to check their ends")


@_task_check
def check_task_batched_observations_are_their_own(domain: str, task: str, plant: str) -> None:
    """The observations a batch returns share no memory with its state: the next steps leave
    them as they were (as dm_env's suite requires of its environments)."""
    env = BatchedEnv(domain, task, plant, seeds=[0, 1])
    steps = [env.reset()] + [env.step([1, 0]) for _ in range(3)]
    kept = [step.observation.copy() for step in steps]
    env.step([0, 1])
    for step, observation in zip(steps, kept):
        np.testing.assert_array_equal(step.observation, observation,
                                      err_msg="a later step changed an earlier observation")
        _expect(not np.shares_memory(step.observation, env.state),
                "an observation shares memory with the batch's state")


TASK_CHECKS = (check_task_spec, check_task_actions_apply_controls, check_task_deterministic,
               check_task_starts, check_task_time_limit, check_task_refuses_bad_actions,
               check_task_refuses_nan_state, check_task_batched,
               check_task_batched_observations_are_their_own)
"""The checks of each task of a domain on each plant of a single environment."""


def check_domain(domain: Domain | str) -> None:
    """Hold `domain` (a `Domain` of the registry, or its name) to the task contract: its
    declaration, then every check of `TASK_CHECKS` on each of its tasks and each plant of a
    single environment (`tasks.ENVIRONMENT_PLANTS`). Raises `ContractError` at the first
    failure."""
    check_domain_declaration(domain)
    name = domain_name(domain)
    for task in suite.domain(name).tasks:
        for plant in suite.ENVIRONMENT_PLANTS[name]:
            for check in TASK_CHECKS:
                check(name, task, plant)
