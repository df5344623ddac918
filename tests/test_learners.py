"""The learner contract (`agent.learner_contract`), checked for every learner of the registry on every
task of the suite it fits: a new learner is one module and a registry line, and these tests
hold it to the contract without an edit here."""

import dataclasses
import itertools

import numpy as np
import pytest

from lwrl import agent as learners
from lwrl import tasks
from lwrl.agent import io as agent_io
from lwrl.agent.learner_contract import LearnerForm, NoValues
from lwrl.runners.config import RunConfig, task_info
from lwrl.runners.run import make_agent, memory_needed, run, run_batched, run_compiled, run_dm_env
from lwrl.settings import base_type
from lwrl.tasks.batched import BatchedEnv

PAIRS = [(learner, task) for learner, task in itertools.product(learners.LEARNER_NAMES, tasks.TASK_NAMES)
         if learners.learner(learner).fits(task_info(task, actions=learners.learner(learner).actions)) is None]
"""(learner, task) of every learner on every task it fits, made with the learner's kind of
actions (`Learner.actions`)."""
MISFITS = [(learner, task) for learner, task in itertools.product(learners.LEARNER_NAMES, tasks.TASK_NAMES)
           if (learner, task) not in PAIRS]


STEPPED_STEPS = 40
"""Steps per episode of a contract run of a learner without a compiled step (stepped in
Python, as Stable-Baselines3's, whose every step costs what a compiled episode does, or a
JAX program, whose off-policy learners take a gradient step on a minibatch of 256 at every
step once they learn), so that each contract test runs in seconds; three such episodes pass
SAC's `learning_starts` of 100, so its saved agents carry updated networks, optimisers and
replay buffers (TD3's 10 000 and DQN's are held to SB3's updates by
`tests/test_stable_baselines.py`, the JAX learners' first updates to their equations by
`tests/test_population.py` and `tests/test_sac_td3_jax.py`)."""


def steps_per_episode(learner, task) -> int:
    """At most 300 steps, `STEPPED_STEPS` for a learner without a compiled step."""
    definition = tasks.definition(*tasks.split_name(task))
    short = learners.learner(learner).step is None
    return min(STEPPED_STEPS if short else 300, definition.step_limit)


def config_of(learner, task, **settings) -> RunConfig:
    """Three agents, three episodes of at most 300 steps (`steps_per_episode`), on the
    analytic plant."""
    definition = tasks.definition(*tasks.split_name(task))
    limit = steps_per_episode(learner, task) * definition.control_timestep
    return RunConfig(task=task, learner=learner, plant="analytic", agents=3, episodes=3, seed=5,
                     task_options={"time_limit": limit},
                     actions=learners.learner(learner).actions, **settings)


def assert_same_results(a, b):
    for field in ("steps", "returns", "uptime", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


def test_the_registry_names_each_learner_once():
    assert learners.LEARNER_NAMES == tuple(learners.LEARNERS)
    assert learners.DEFAULT_LEARNER == "sarsa"
    for name, learner in learners.LEARNERS.items():
        assert learner.name == name and learner.title and learner.source
        assert dataclasses.is_dataclass(learner.settings)
    with pytest.raises(ValueError, match="unknown learner 'no_such'; available: sarsa, "):
        learners.learner("no_such")


def test_settings_shared_by_name_mean_one_kind_of_value():
    """One flag serves every learner that has a setting of that name: its type is one."""
    seen = {}
    for learner in learners.LEARNERS.values():
        for field in dataclasses.fields(learner.settings):
            kind = base_type(field.type)
            assert seen.setdefault(field.name, kind) == kind, (learner.name, field.name)


@pytest.mark.parametrize("learner, task", PAIRS)
def test_every_run_path_gives_the_same_numbers(learner, task):
    """The compiled loop (where the learner has a compiled step), the batched stepper and
    one agent on a dm_env environment: identical episodes and learned arrays. A population
    learner has one path, the JAX program (`runners.population`): the stepped loop refuses
    it in one line, and the program gives the same numbers again (how it is cut into
    chunks changes none either: `tests/test_population.py`)."""
    config = config_of(learner, task)
    domain, name = tasks.split_name(task)
    options = {**config.task_options, "actions": config.actions}
    batched_agent = make_agent(config)
    if learners.learner(learner).population:
        with pytest.raises(ValueError, match="one JAX program"):
            run_batched(BatchedEnv(domain, name, "analytic", config.seeds, **options),
                        batched_agent, config.episodes)
        first_agent, first = run(config)
        again_agent, again = run(config)
        assert_same_results(again, first)
        np.testing.assert_array_equal(again_agent.arrays.weights, first_agent.arrays.weights)
        return
    batched = run_batched(BatchedEnv(domain, name, "analytic", config.seeds, **options),
                          batched_agent, config.episodes)
    if learners.learner(learner).compiles:
        compiled_agent = make_agent(config)
        compiled = run_compiled(domain, name, compiled_agent, config.episodes, config.seeds,
                                **options)
        assert_same_results(compiled, batched)
        np.testing.assert_array_equal(compiled_agent.arrays.weights, batched_agent.arrays.weights)
    single_config = dataclasses.replace(config, agents=1, seed=config.seed + 1)
    single_agent = make_agent(single_config)
    single = run_dm_env(tasks.load(domain, name, plant="analytic", seed=single_config.seed,
                                   **options), single_agent, config.episodes)
    np.testing.assert_array_equal(single.steps[0], batched.steps[1])
    np.testing.assert_array_equal(single_agent.arrays.weights[0], batched_agent.arrays.weights[1])


@pytest.mark.parametrize("learner, task", PAIRS)
def test_an_agent_is_the_same_alone_and_in_a_batch(learner, task):
    """Agent results depend on its own seed and settings only."""
    config = config_of(learner, task)
    _, batch = run(config)
    _, alone = run(dataclasses.replace(config, agents=1, seed=config.seed + 2))
    np.testing.assert_array_equal(alone.steps[0], batch.steps[2])
    np.testing.assert_array_equal(alone.returns[0], batch.returns[2])


@pytest.mark.parametrize("learner, task", PAIRS)
def test_the_arrays_the_loops_read(learner, task):
    """`q` (B, A), `delta` (B,), `diverged` (B,) and `weights` (B, ...) are there, and the
    memory estimate covers the agents' arrays."""
    config = config_of(learner, task)
    agent, _ = run(config)
    arrays = agent.arrays
    actions = config.task_info.num_actions or 1  # continuous: one output, the action
    assert arrays.q.shape == (3, actions) and arrays.delta.shape == (3,)
    assert arrays.diverged.shape == (3,) and arrays.diverged.dtype == bool
    assert arrays.weights.shape[0] == 3 and np.all(np.isfinite(arrays.weights))
    assert agent.batch_size == 3 and agent.num_actions == actions
    kept = sum(array.nbytes for array in arrays if isinstance(array, np.ndarray))
    assert memory_needed(config) >= kept


@pytest.mark.parametrize("learner, task", PAIRS)
def test_acting_greedily_touches_nothing(learner, task):
    """`learn=False, greedy=True` (evaluation) changes no learned array and no setting, and
    gives the same episodes twice."""
    config = config_of(learner, task)
    agent, _ = run(config)
    weights = agent.arrays.weights.copy()
    settings = agent.settings
    _, first = run(config, agent=agent, learn=False, greedy=True)
    _, second = run(config, agent=agent, learn=False, greedy=True)
    np.testing.assert_array_equal(agent.arrays.weights, weights)
    assert agent.settings == settings
    assert_same_results(first, second)


@pytest.mark.parametrize("learner, task", PAIRS)
def test_saved_agents_load_and_go_on_identically(learner, task, tmp_path):
    config = config_of(learner, task)
    agent, _ = run(config)
    agent_io.save(tmp_path / "agents.npz", agent, {"config": dataclasses.asdict(config)})
    loaded, metadata = agent_io.load(tmp_path / "agents.npz")
    assert type(loaded) is type(agent) and loaded.learner is agent.learner
    assert RunConfig(**metadata["config"]) == config
    np.testing.assert_array_equal(loaded.arrays.weights, agent.arrays.weights)
    _, more = run(config, agent=agent)
    _, more_loaded = run(config, agent=loaded)
    assert_same_results(more, more_loaded)


@pytest.mark.parametrize("learner, task", PAIRS)
def test_values_over_a_grid_are_the_values_at_its_states(learner, task):
    """`action_values_on_grid` and `state_values_on_grid` (a learner may factorise them)
    equal the values at the grid's states, or the learner says it has none."""
    agent = make_agent(config_of(learner, task))
    rng = np.random.default_rng(0)
    weights = rng.normal(size=agent.arrays.weights.shape[1:])
    low, high = map(np.asarray, agent.value_box())
    axes = [np.linspace(lo, hi, 4) for lo, hi in zip(low, high)]
    states = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    try:
        grid = agent.action_values_on_grid(axes, weights)
    except NoValues:
        return
    np.testing.assert_allclose(grid, agent.action_values(states, weights), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(agent.state_values_on_grid(axes, weights),
                               agent.state_values(states, weights), rtol=1e-12, atol=1e-12)
    points = agent.feature_points()
    assert points is None or points.shape[1] == len(low)


@pytest.mark.parametrize("learner, task", MISFITS)
def test_a_learner_says_in_one_line_where_it_does_not_fit(learner, task):
    with pytest.raises(ValueError) as error:
        RunConfig(task=task, learner=learner)
    assert "\n" not in str(error.value) and task in str(error.value)


@pytest.mark.parametrize("learner, task", PAIRS)
def test_a_learner_learns_in_c_or_says_in_one_line_why_not(learner, task):
    """`Agents.learner_form`: a form whose values start from the agent's weights and stream,
    whose RAM parts are counts, and whose check passes in double; or one line."""
    agent = make_agent(config_of(learner, task))
    try:
        form = agent.learner_form(1)
    except ValueError as error:
        assert "\n" not in str(error) and "in C" in str(error)
        return
    assert isinstance(form, LearnerForm)
    values = form.values(np.float64)
    np.testing.assert_array_equal(values["weights"], agent.arrays.weights[1])
    assert values["seed"] == int(agent.arrays.streams[1])
    assert all(isinstance(reals, int) and isinstance(other, int) for reals, other in form.ram.values())
    assert len(form.ranges[0]) == len(form.ranges[1]) == agent.dim
    assert form.check(np.float64) is None and form.summary and form.name and form.smaller


def test_some_learner_learns_in_c():
    assert any(isinstance(make_agent(RunConfig(task=task, learner=learner, agents=1)).learner_form(0),
                          LearnerForm)
               for learner, task in PAIRS if learner == learners.DEFAULT_LEARNER)
