"""Continuous actions (`actions="continuous"`): the action is the control itself, clipped to
the actuator's range (`TaskDefinition.control_range`, from the lowest to the highest
discrete control). Over every task and plant: the suite's conformance checks
(tests/test_suite.py's, for this kind of action) and dm_env's own
(`dm_env.test_utils.EnvironmentTestMixin`); the plants' agreement under actions inside and
outside the range, with tests/test_plant_check.py's tolerances; the range moving with the
parameters; the sensor and actuator options acting on the control as they do on a discrete
action's; a batch being its single environments; a learner of discrete actions refused in
one line."""

import math
import unittest

import dm_env
import numpy as np
import pytest
from dm_env import specs, test_utils

from lwrl import tasks
from lwrl.spaces import Discrete
from lwrl.studies.compare.domains import COMPARISONS
from lwrl.studies.robustness.domains import ROBUSTNESS
from lwrl.tasks.batched import LAST, BatchedEnv
from conftest import TASK_PLANTS, off_nominal, one_line_error

CONTINUOUS = {"actions": "continuous"}
SHORT_STEPS = 20
"""A time limit of so many control steps: episodes end and restart within a test."""
MODEL_DOMAINS = [name for name, domain in tasks.DOMAINS.items() if domain.model]
PLANT_TOLERANCES = {"cartpole": 1e-13, "pendulum": 5e-11, "acrobot": 1e-13}
"""tests/test_plant_check.py's bounds on |MuJoCo - analytic| over 50 random-action steps
(`plant_tolerance`)."""
OUTSIDE_TOLERANCE = 1e-6
"""The bound on |MuJoCo - analytic| of a domain of another package that declares no plant
comparison (`plant_tolerance`), in its state's units."""
PAPER_RANGES = {"mountain_car": (-1.0, 1.0), "pendulum": (-5.0, 5.0), "cartpole": (-10.0, 10.0),
                "acrobot": (-1.0, 1.0)}
"""The actuator's range of each of lwrl's own domains at the paper's values."""


def plant_tolerance(domain: str) -> float:
    """The bound on |MuJoCo - analytic| of `PLANT_TOLERANCES`, or for a domain of another
    package (`tasks.ENTRY_POINT_GROUP`) the smallest of its plant comparison's tolerances
    (`studies.compare.domains`) where it declares one, else `OUTSIDE_TOLERANCE`."""
    if domain in PLANT_TOLERANCES:
        return PLANT_TOLERANCES[domain]
    if domain in COMPARISONS:
        return min(COMPARISONS[domain].tolerances.values())
    return OUTSIDE_TOLERANCE


def short(domain: str, task: str) -> dict:
    return {"time_limit": SHORT_STEPS * tasks.definition(domain, task).control_timestep}


def random_controls(rng, control_range, size=None):
    """Uniform over twice the range about its centre: about half of them outside it."""
    low, high = control_range
    middle, half = (low + high) / 2, (high - low) / 2
    return rng.uniform(middle - 2 * half, middle + 2 * half, size=size)


def applied(env, plant) -> float:
    """The control the plant of a dm_env environment was given on its last step."""
    return float(env.physics.named.data.ctrl[env.physics.ACTUATOR] if plant == "mujoco"
                 else env.physics._control[0])


def state_of(time_step) -> np.ndarray:
    return np.array(list(time_step.observation.values()))


# The range -------------------------------------------------------------------------------

@pytest.mark.parametrize("domain, task", tasks.ALL_TASKS)
def test_the_range_is_the_lowest_and_the_highest_control(domain, task):
    """At the paper's values and at values of each row's own: [controls[0], controls[-1]],
    the torque's, the force's or the thrust's limits."""
    definition = tasks.definition(domain, task)
    assert definition.control_range == (definition.controls[0], definition.controls[-1])
    rows = off_nominal(domain, np.random.default_rng(0), 30)
    every = definition.controls_at(rows)
    np.testing.assert_array_equal(definition.control_range_at(rows), every[:, [0, -1]])
    expected = PAPER_RANGES.get(domain, definition.control_range)
    assert definition.control_range == expected
    continuous = tasks.definition(domain, task, **CONTINUOUS)
    assert continuous.continuous and continuous.control_range == expected


# The suite's conformance checks ------------------------------------------------------------

def test_spec_conformance(task_plant):
    """The action spec is a float64 BoundedArray of shape (1,), as dm_control gives its n
    actuators (n,), bounded by the range and named after the control; observations match
    their specs over an episode of actions inside and outside the range."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant, seed=0, **CONTINUOUS)
    definition = env.task.definition
    spec = env.action_spec()
    assert type(spec) is specs.BoundedArray
    assert (spec.shape, spec.dtype, spec.name) == ((1,), np.float64, definition.control_name)
    assert definition.control_name in ("force", "torque", "thrust")
    assert spec.minimum.tolist() == [definition.control_range[0]]
    assert spec.maximum.tolist() == [definition.control_range[1]]
    spec.validate(spec.generate_value())
    observation_spec = env.observation_spec()
    assert tuple(observation_spec) == definition.state_names
    rng = np.random.default_rng(0)
    time_step = env.reset()
    for _ in range(50):
        time_step = env.step(random_controls(rng, definition.control_range, size=1))
        for name, value in time_step.observation.items():
            observation_spec[name].validate(value)
        assert isinstance(time_step.reward, float) and math.isfinite(time_step.reward)
        assert time_step.discount in (0.0, 1.0)
        if time_step.last():
            break


@pytest.mark.parametrize("fraction", [0.0, 1.0, -1.0, 0.37, -0.9, 3.0, -3.0, 1e6])
def test_an_action_is_its_control_clipped_to_the_range(task_plant, fraction):
    """The plant gets the action itself, or the nearer end of the range for one outside it
    (as a number, a float32 or an array of shape (1,) alike)."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant, seed=0, **CONTINUOUS)
    low, high = env.task.definition.control_range
    action = fraction * high
    for given in (action, np.float32(action), np.array([action])):
        env.reset()
        env.step(given)
        assert applied(env, plant) == min(max(float(np.ravel(given)[0]), low), high)


def test_deterministic_for_a_seed(task_plant):
    """The same seed and actions give the same time steps, and the same starts as the
    discrete task's."""
    domain, task, plant = task_plant

    def trajectory(seed):
        env = tasks.load(domain, task, plant=plant, seed=seed, **CONTINUOUS, **short(domain, task))
        rng = np.random.default_rng(1)
        steps = [env.reset()] + [env.step(random_controls(rng, env.task.definition.control_range))
                                 for _ in range(50)]
        return [(int(ts.step_type), ts.reward, ts.discount, tuple(ts.observation.values()))
                for ts in steps]

    assert trajectory(7) == trajectory(7)
    discrete = tasks.load(domain, task, plant=plant, seed=7)
    assert trajectory(7)[0][3] == tuple(discrete.reset().observation.values())


def test_time_limits_truncate(task_plant):
    """A time limit of 5 control steps truncates (discount 1) on the fifth step."""
    domain, task, plant = task_plant
    definition = tasks.definition(domain, task)
    env = tasks.load(domain, task, plant=plant, seed=0, time_limit=5 * definition.control_timestep,
                     **CONTINUOUS)
    env.reset()
    steps = [env.step([0.0]) for _ in range(5)]
    assert [ts.step_type for ts in steps] == [dm_env.StepType.MID] * 4 + [dm_env.StepType.LAST]
    assert steps[-1].discount == 1.0
    assert env.step([0.0]).first()


@pytest.mark.parametrize("action, message", [
    (np.nan, "action must be a finite"), (np.inf, "action must be a finite"),
    ([-np.inf], "action must be a finite"), ("1", "action must be a finite"),
    (None, "action must be a finite"), (True, "action must be a finite"),
    ([1.0, 2.0], r"action must be one \w+, a number or an array of shape \(1,\)"),
    ([[1.0]], r"action must be one \w+, a number or an array of shape \(1,\)"),
    (np.full((2, 2), np.nan),
     r"action must be a finite \w+ .*; got \[\[nan, nan\], \[nan, nan\]\]$"),
])
def test_bad_action_is_refused(task_plant, action, message):
    """NaN, an infinity, a string, a bool or not one number: a one-line ValueError naming the
    control and its range; the episode goes on."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant, seed=0, **CONTINUOUS)
    env.reset()
    low, high = env.task.definition.control_range
    with pytest.raises(ValueError, match=message) as error:
        env.step(action)
    assert "\n" not in str(error.value)
    if "finite" in message:
        assert f"[{low:g}, {high:g}]" in str(error.value)
    env.step([0.0])
    assert env.task.steps == 1  # the refused action took no step


def test_bad_kind_of_action_is_one_line():
    for call in (lambda: tasks.load("pendulum", "swingup", actions="cont"),
                 lambda: tasks.definition("cartpole", "balance", actions=1),
                 lambda: BatchedEnv("acrobot", "swingup", seeds=[0], actions="Continuous")):
        one_line_error(call, "actions must be one of: discrete, continuous; got")
    one_line_error(lambda: tasks.load("pendulum", "swingup", "analytic", frobnicate=1),
                   "allowed: plant, seed, time_limit, params, integrator, equations, actions, ")


# dm_env's own contract ---------------------------------------------------------------------

def _dm_env_contract(domain: str, task: str, plant: str) -> type:
    """`dm_env.test_utils.EnvironmentTestMixin` on the continuous task: its actions drawn
    over twice the range, in episodes of `SHORT_STEPS` steps, so that they end and restart."""

    class Contract(test_utils.EnvironmentTestMixin, unittest.TestCase):
        def make_object_under_test(self):
            return tasks.load(domain, task, plant=plant, seed=0, **CONTINUOUS,
                              **short(domain, task))

        def make_action_sequence(self):
            rng = np.random.default_rng(0)
            control_range = self.environment.task.definition.control_range
            for _ in range(3 * SHORT_STEPS):
                yield random_controls(rng, control_range, size=1)

    Contract.__name__ = Contract.__qualname__ = f"TestDmEnvContract_{domain}_{task}_{plant}"
    return Contract


for _case in TASK_PLANTS:
    _contract = _dm_env_contract(*_case)
    globals()[_contract.__name__] = _contract
del _case, _contract


# The plants agree ----------------------------------------------------------------------------

@pytest.mark.parametrize("domain", MODEL_DOMAINS)
def test_the_plants_agree_under_continuous_actions(domain):
    """20 seeds' starts and 50 random continuous actions each, about half of them outside the
    range, on both plants, as single dm_env environments and as a batch (`mujoco.rollout`):
    the same step types (the cart-poles fail on the same steps), and states within
    tests/test_plant_check.py's bounds. Measured: at most 4.2e-15 (cart-pole, 38 episodes
    failing), 7.0e-12 (pendulum) and 4.2e-15 (acrobot), as under the discrete actions."""
    task = next(iter(tasks.domain(domain).tasks))
    seeds = range(20)
    control_range = tasks.definition(domain, task).control_range
    actions = np.stack([random_controls(np.random.default_rng(seed), control_range, size=50)
                        for seed in seeds], axis=1)  # (T, B)
    assert 0.3 < np.mean((actions < control_range[0]) | (actions > control_range[1])) < 0.7
    runs = {}
    for plant in ("mujoco", "analytic"):
        singles = [tasks.load(domain, task, plant=plant, seed=seed, **CONTINUOUS) for seed in seeds]
        batch = BatchedEnv(domain, task, plant, list(seeds), **CONTINUOUS)
        for env in singles:
            env.reset()
        batch.reset()
        states, step_types = [], []
        for row in actions:
            time_steps = [env.step([a]) for env, a in zip(singles, row)]
            batch_step = batch.step(row[:, None])
            states.append([env.physics.state_vector() for env in singles] + list(batch.state))
            step_types.append([int(ts.step_type) for ts in time_steps] + list(batch_step.step_type))
        runs[plant] = np.array(states), np.array(step_types)
    np.testing.assert_array_equal(runs["mujoco"][1], runs["analytic"][1])
    worst = np.abs(runs["mujoco"][0] - runs["analytic"][0]).max(axis=(0, 1))
    assert np.all(worst < plant_tolerance(domain)), worst


# The sensors, the actuator and the parameters ---------------------------------------------

def every_option(domain: str) -> dict:
    """Noise on the first and last state variables, a delay of two steps, action noise of 0.3
    times the range's top, and a parameter drawn anew for each episode: the robustness
    study's last axis where the domain has one (the torque, the force, Mountain-Car's thrust
    gain), else its last parameter."""
    definition = tasks.definition(domain, next(iter(tasks.domain(domain).tasks)))
    names, parameters = definition.state_names, tasks.domain(domain).parameters
    name = (ROBUSTNESS[domain].axes if domain in ROBUSTNESS else parameters.names)[-1]
    nominal = parameters.items[parameters.position(name)].nominal
    return {"observation_noise": {names[0]: 0.01, names[-1]: 0.2}, "action_delay": 2,
            "action_noise": 0.3 * definition.control_range[1],
            "randomise": {name: (0.5 * nominal, 1.5 * nominal)}}


def test_the_discrete_controls_replay_the_discrete_task(task_plant):
    """Given the control of each discrete action (at the episode's drawn parameter values),
    the continuous task is the discrete task bit for bit, with noisy sensors, a late and
    noisy actuator and the range's parameter drawn per episode: the delay and the noise act
    on a continuous control as on a discrete action's."""
    domain, task, plant = task_plant
    options = {**every_option(domain), **short(domain, task)}
    discrete = tasks.load(domain, task, plant=plant, seed=4, **options)
    continuous = tasks.load(domain, task, plant=plant, seed=4, **options, **CONTINUOUS)
    definition = tasks.definition(domain, task)
    rng = np.random.default_rng(5)
    tops = set()
    for _ in range(3):
        ours, theirs = discrete.reset(), continuous.reset()
        while True:
            assert state_of(ours).tolist() == state_of(theirs).tolist()
            assert (ours.step_type, ours.reward, ours.discount) == (
                theirs.step_type, theirs.reward, theirs.discount)
            if ours.last():
                break
            index = int(rng.integers(definition.num_actions))
            control = definition.controls_at(continuous.task.physical)[index]
            ours, theirs = discrete.step(index), continuous.step([control])
        tops.add(continuous.action_spec().maximum[0])
    assert len(tops) == 3 or domain == "mountain_car"  # the range moved with the torque or force


@pytest.mark.parametrize("domain, plant", [("pendulum", "mujoco"), ("cartpole", "analytic"),
                                           ("acrobot", "analytic")])
def test_the_range_moves_with_the_drawn_parameters(domain, plant):
    """With the torque or the force drawn per episode, each episode's action spec, its clip
    and a batch's ranges are those of its values."""
    task = next(iter(tasks.domain(domain).tasks))
    randomise = every_option(domain)["randomise"]
    env = tasks.load(domain, task, plant=plant, seed=1, randomise=randomise, **CONTINUOUS)
    definition = env.task.definition
    for _ in range(3):
        env.reset()
        low, high = definition.control_range_at(env.task.physical)
        spec = env.action_spec()
        assert (spec.minimum.tolist(), spec.maximum.tolist()) == ([low], [high])
        env.step([1e3])
        assert applied(env, plant) == high
        assert high != definition.control_range[1]
    batch = BatchedEnv(domain, task, plant, [1, 2, 3], randomise=randomise, **CONTINUOUS)
    for _ in range(2):
        batch.reset()
        np.testing.assert_array_equal(batch.control_range,
                                      definition.control_range_at(batch.physical))


# A batch ------------------------------------------------------------------------------------

def test_a_batch_is_its_single_environments(task_plant):
    """B batched environments with every sensor and actuator option and the range's parameter
    drawn per episode are the B single environments of their seeds, step by step, under
    actions inside and outside the range (given `(B,)` and `(B, 1)`)."""
    domain, task, plant = task_plant
    options = {**every_option(domain), **short(domain, task), **CONTINUOUS}
    seeds = [3, 5, 8]
    batch = BatchedEnv(domain, task, plant, seeds, **options)
    singles = [tasks.load(domain, task, plant=plant, seed=seed, **options) for seed in seeds]
    rng = np.random.default_rng(0)
    batch_step, single_steps = batch.reset(), [env.reset() for env in singles]
    ends = 0
    for n in range(3 * SHORT_STEPS):
        actions = random_controls(rng, tasks.definition(domain, task).control_range, len(seeds))
        batch_step = batch.step(actions if n % 2 else actions[:, None])
        single_steps = [env.step(a) for env, a in zip(singles, actions)]
        for b, ts in enumerate(single_steps):
            assert batch_step.step_type[b] == int(ts.step_type)
            np.testing.assert_array_equal(batch_step.observation[b], state_of(ts))
            if not ts.first():
                assert (batch_step.reward[b], batch_step.discount[b]) == (ts.reward, ts.discount)
        ends += int(np.sum(batch_step.step_type == LAST))
    assert ends >= len(seeds)


def test_a_batch_refuses_bad_actions_in_one_line():
    batch = BatchedEnv("cartpole", "balance", "analytic", [0, 1, 2], **CONTINUOUS)
    batch.reset()
    one_line_error(lambda: batch.step([0.0, np.nan, 1.0]), "action must be a finite force",
                   "[-10, 10]")
    one_line_error(lambda: batch.step(np.full((3, 1), np.inf)), "got [inf, inf, inf]")
    wide = BatchedEnv("cartpole", "balance", "analytic", list(range(40)), **CONTINUOUS)
    wide.reset()
    one_line_error(lambda: wide.step(np.full(40, np.nan)), "action must be a finite force")
    one_line_error(lambda: batch.step([0.0, 1.0]), "actions must have shape (3,) or (3, 1)")
    one_line_error(lambda: batch.step(np.zeros((3, 2))), "got shape (3, 2)")
    assert batch.controls is None
    batch.step(np.array([-50.0, 0.5, 50.0]))


# Learners of discrete actions -----------------------------------------------------------------

def test_a_learner_of_discrete_actions_is_refused_in_one_line():
    """Where a discrete learner meets a continuous task (its number of actions, its controls,
    the check of saved agents, the run's configuration, the compiled loop), one line says
    what it can run."""
    from lwrl.runners.config import RunConfig
    from lwrl.runners.run import make_agents, run_compiled
    from lwrl.runners.stepped import run_batched, run_dm_env

    refusal = ("cartpole.balance was made with actions='continuous' (the force itself, in "
               "[-10, 10])", "allowed for such learners: actions='discrete'")
    definition = tasks.definition("cartpole", "balance", **CONTINUOUS)
    for call in (lambda: definition.num_actions, lambda: definition.controls,
                 lambda: definition.controls_at(definition.physical),
                 lambda: definition.nearest_action(1.0),
                 lambda: BatchedEnv("cartpole", "balance", seeds=[0], **CONTINUOUS).num_actions,
                 lambda: RunConfig(task="cartpole.balance", plant="analytic",
                                   task_options=CONTINUOUS)):
        one_line_error(call, *refusal)
    one_line_error(lambda: definition.check_fits(4, Discrete(2), "agents.json"), "agents.json: ", *refusal)
    agent = make_agents(RunConfig(task="cartpole.balance", plant="analytic", agents=2, episodes=1))
    one_line_error(lambda: run_compiled("cartpole", "balance", agent, 1, [0, 1], plant="analytic",
                                        **CONTINUOUS), *refusal)
    env = BatchedEnv("cartpole", "balance", "analytic", seeds=[0, 1], **CONTINUOUS)
    one_line_error(lambda: run_batched(env, agent, 1), "run_batched: ", *refusal)
    single = make_agents(RunConfig(task="cartpole.balance", plant="analytic", agents=1, episodes=1))
    one_line_error(lambda: run_dm_env(tasks.load("cartpole", "balance", "analytic", seed=0,
                                                 **CONTINUOUS), single, 1),
                   "run_dm_env: ", *refusal)
