"""The sensors and the actuator (`tasks.disturbances`): observation noise, actuation delay and
action noise, the same on every plant and path, seeded per environment, and nothing at all
with the options at their defaults."""

import math
import warnings

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lwrl import tasks
from lwrl.tasks import disturbances
from lwrl.tasks.batched import BatchedEnv
from lwrl.tasks.task_definition import wrap_angle
from lwrl.tasks.disturbances import applied_control, noisy_observation, stream_key
from lwrl.tasks.pendulum import transition as pendulum_transition
from conftest import short_time_limit

ALL = [(domain, task, plant) for domain, task in tasks.ALL_TASKS
       for plant in tasks.ENVIRONMENT_PLANTS[domain]]
SHORT = {"mountain_car": 40, "pendulum": 0.5, "cartpole": 240.0, "acrobot": 4.0}
"""Time limits short enough that episodes end and restart within a test (`short_time_limit`:
20 steps for a domain of another package)."""


def first_task(domain: str) -> str:
    return next(iter(tasks.domain(domain).tasks))


def every_option(domain: str) -> dict:
    """Each option on: noise on the first and last state variables, a delay of two steps,
    action noise of 0.3 times the largest control."""
    definition = tasks.definition(domain, first_task(domain))
    names = definition.state_names
    return {"observation_noise": {names[0]: 0.01, names[-1]: 0.2}, "action_delay": 2,
            "action_noise": 0.3 * max(definition.controls)}


def run_single(env, actions) -> list:
    """`(observation, reward, discount, step type)` of a dm_env environment under `actions`
    (a step after the end starts the next episode, as a batch's does)."""
    steps = [env.reset()] + [env.step(int(action)) for action in actions]
    return [(np.array(list(step.observation.values())), 0.0 if step.first() else step.reward,
             1.0 if step.first() else step.discount, int(step.step_type)) for step in steps]


def run_batch(env, actions) -> list:
    """The same of a batched environment under `actions` `(T, B)`."""
    steps = [env.reset()] + [env.step(action) for action in actions]
    return [(step.observation, step.reward, step.discount, step.step_type) for step in steps]


def assert_same(ours: list, theirs: list) -> None:
    for a, b in zip(ours, theirs, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


# --- the defaults -----------------------------------------------------------------------------

def test_at_the_defaults_nothing_is_drawn(monkeypatch):
    """With the options absent or at their defaults no disturbance is computed, and the time
    steps are those of an environment without the options (every path's numbers at the
    defaults are the recorded ones: `test_nominal.py`)."""
    def never(*args):
        raise AssertionError("a disturbance was computed")

    monkeypatch.setattr(disturbances, "OBSERVE_ROWS", never)
    monkeypatch.setattr(disturbances, "ACTUATE_ROWS", never)
    defaults = {"observation_noise": {}, "action_delay": 0, "action_noise": 0.0}
    actions = np.random.default_rng(0).integers(2, size=(60, 2))
    assert_same(run_batch(BatchedEnv("cartpole", "balance", "mujoco", [1, 2], **defaults), actions),
                run_batch(BatchedEnv("cartpole", "balance", "mujoco", [1, 2]), actions))
    assert_same(run_single(tasks.load("pendulum", "swingup", seed=3, **defaults), actions[:, 0]),
                run_single(tasks.load("pendulum", "swingup", seed=3), actions[:, 0]))


# --- every path, one set of numbers ------------------------------------------------------------

@pytest.mark.parametrize("domain, task, plant", ALL)
def test_a_batch_is_its_single_environments_with_every_option(domain, task, plant):
    """With noisy sensors, a late and noisy actuator and episodes that end and restart, B
    batched environments are the B single environments of their seeds, step by step."""
    options = {**every_option(domain), "time_limit": short_time_limit(SHORT, domain)}
    seeds = [3, 5, 8]
    actions = np.random.default_rng(1).integers(tasks.definition(domain, task).num_actions,
                                                size=(100, len(seeds)))
    batch = run_batch(BatchedEnv(domain, task, plant, seeds, **options), actions)
    assert sum(int(np.sum(step[3] == 2)) for step in batch) >= len(seeds)  # episodes ended
    for b, seed in enumerate(seeds):
        single = run_single(tasks.load(domain, task, plant=plant, seed=seed, **options), actions[:, b])
        assert_same([tuple(np.asarray(x)[b] for x in step) for step in batch], single)


def test_a_batch_takes_options_per_environment():
    """Each option as one value per environment: each environment is the single one with
    its own values."""
    sigmas, delays, noises = [0.0, 0.01, 0.05], [0, 1, 3], [0.0, 2.0, 5.0]
    actions = np.random.default_rng(2).integers(2, size=(80, 3))
    batch = run_batch(BatchedEnv("cartpole", "balance", "analytic", [4, 4, 4],
                                 observation_noise={"pole_angle": sigmas}, action_delay=delays,
                                 action_noise=noises), actions)
    for b in range(3):
        single = run_single(tasks.load("cartpole", "balance", plant="analytic", seed=4,
                                       observation_noise={"pole_angle": sigmas[b]},
                                       action_delay=delays[b], action_noise=noises[b]), actions[:, b])
        assert_same([tuple(np.asarray(x)[b] for x in step) for step in batch], single)
    assert not np.array_equal(batch[10][0][0], batch[10][0][1])


@numba.njit
def pendulum_episode(start, actions, controls, p, sigma, delay, sigma_action, key, dt):
    """The disturbances as a compiled loop calls them, on one pendulum episode of
    `actions`: each command through `applied_control`, the domain's `transition`, each
    observation through `noisy_observation`. Returns the observations `(T + 1, 2)`."""
    observations = np.empty((actions.shape[0] + 1, 2))
    state, next_state, observation = start.copy(), np.empty(2), np.empty(2)
    observation[0], observation[1] = wrap_angle(state[0]), state[1]
    noisy_observation(observation, sigma, key, 0, 0)
    observations[0] = observation
    buffer = np.zeros(delay)
    arguments = (np.zeros(0), p)
    for n in range(actions.shape[0]):
        control = applied_control(buffer, n, controls[actions[n]], sigma_action, controls.min(),
                                  controls.max(), key, 0)
        pendulum_transition(state, control, next_state, observation, dt, True, False, arguments)
        noisy_observation(observation, sigma, key, 0, n + 1)
        observations[n + 1] = observation
        state[:] = next_state
    return observations


def test_a_compiled_loop_calling_the_pieces_gives_the_batchs_numbers():
    """The element-wise pieces, called from numba as a compiled loop calls them
    (`pendulum_episode`), give a batched environment's observations, bit for bit."""
    options = {"observation_noise": {"angle": 0.02, "angular_velocity": 0.1}, "action_delay": 2,
               "action_noise": 1.5}
    env = BatchedEnv("pendulum", "swingup", "analytic", [7], params={"mass": 1.4}, **options)
    actions = np.random.default_rng(3).integers(2, size=120)
    batch = np.array([step[0][0] for step in run_batch(env, actions[:, None])])
    start = env.definition.initial_states(np.random.default_rng(7), 1)[0]
    ours = pendulum_episode(start, actions, np.asarray(env.definition.controls),
                            np.asarray(env.definition.physical),
                            env.disturbances.sigma_observation[0], 2, 1.5, stream_key(7),
                            env.definition.control_timestep)
    np.testing.assert_array_equal(ours, batch)


def test_gymnasium_takes_the_options_and_reset_seeds_them():
    """`make(id, observation_noise=..., ...)` is `tasks.load(seed=s, ...)` after
    `reset(seed=s)`, the noisy variables are unbounded in the Box, and Gymnasium's checker
    (its determinism under a seed included) passes."""
    gymnasium = pytest.importorskip("gymnasium")
    from gymnasium.utils.env_checker import check_env

    import lwrl.gym  # noqa: F401
    options = every_option("cartpole")
    env = gymnasium.make("lwrl/cartpole-balance-mujoco-v0", **options)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=True)
    assert all("infinity" in str(warning.message) for warning in caught)  # the unbounded Box
    assert env.observation_space.high[0] == np.inf and env.observation_space.high[2] < np.inf
    actions = np.random.default_rng(4).integers(2, size=40)
    observation, _ = env.reset(seed=11)
    single = run_single(tasks.load("cartpole", "balance", plant="mujoco", seed=11, **options), actions)
    np.testing.assert_array_equal(observation, single[0][0])
    for action, (expected, reward, *_) in zip(actions, single[1:]):
        observation, ours, terminated, truncated, _ = env.step(int(action))
        np.testing.assert_array_equal(observation, expected)
        assert ours == reward
        if terminated or truncated:
            break


# --- what each option does --------------------------------------------------------------------

def test_observation_noise_is_gaussian_in_each_variables_units_and_the_task_is_not_noisy():
    """Over 3000 pendulum steps the observed minus the true angle has mean 0 and the standard
    deviation given (0.05 rad; the speed 0.5 rad/s), within 5 %; rewards, discounts and
    up-time are the noise-free environment's, whose plant goes the same way."""
    actions = np.random.default_rng(5).integers(2, size=2999)
    noisy_env, clean_env = (tasks.load("pendulum", "swingup", plant="analytic", seed=2, **options)
                            for options in ({"observation_noise": {"angle": 0.05,
                                                                   "angular_velocity": 0.5}}, {}))
    noisy, clean = run_single(noisy_env, actions), run_single(clean_env, actions)
    errors = np.array([a[0] - b[0] for a, b in zip(noisy, clean)])
    errors[:, 0] = wrap_angle(errors[:, 0])
    assert np.all(np.abs(errors.mean(axis=0)) < 0.05 * np.array([0.05, 0.5]))
    np.testing.assert_allclose(errors.std(axis=0), [0.05, 0.5], rtol=0.05)
    assert [a[1:] for a in noisy] == [b[1:] for b in clean]
    assert noisy_env.task.uptime == clean_env.task.uptime > 0


def controls_applied(env_options: dict, actions, seed: int = 3) -> np.ndarray:
    """The torques that reach a pendulum's plant under `actions`, read back from its states:
    the plant stepped from each state with torques 0 and 1 (the torque enters linearly)."""
    env = BatchedEnv("pendulum", "swingup", "analytic", [seed], time_limit=60.0, **env_options)
    env.reset()
    states = [env.state[0].copy()]
    for action in actions:
        env.step([action])
        states.append(env.state[0].copy())
    states = np.array(states)
    plant = tasks.domain("pendulum").plants.batch("analytic", 1)
    zero = plant.step(states[:-1], np.zeros(len(actions)))
    unit = plant.step(states[:-1], np.ones(len(actions)))
    return (states[1:, 1] - zero[:, 1]) / (unit[:, 1] - zero[:, 1])


def test_a_late_actuator_applies_each_command_k_steps_later_and_nothing_before():
    """With a delay of 3 steps the torques reaching the plant are 0, 0, 0 (no command has
    arrived), then the commands in their order."""
    actions = np.random.default_rng(6).integers(2, size=50)
    torques = np.asarray(tasks.definition("pendulum", "swingup").controls)[actions]
    applied = controls_applied({"action_delay": 3}, actions)
    np.testing.assert_allclose(applied, np.concatenate([[0.0, 0.0, 0.0], torques[:-3]]), atol=1e-6)
    np.testing.assert_allclose(controls_applied({}, actions), torques, atol=1e-6)


@numba.njit
def noisy_controls(control, sigma, low, high, key, count):
    """`applied_control` of `control` at steps 0..count-1 of episode 0, without delay."""
    out = np.empty(count)
    for n in range(count):
        out[n] = applied_control(np.zeros(0), n, control, sigma, low, high, key, 0)
    return out


def test_action_noise_is_added_to_the_control_and_clipped_to_the_actuators_range():
    """The zero action's control plus noise of sigma 0.1 has mean 0 and standard deviation
    0.1 (5 %); with sigma 5 on a +-1 actuator every applied control stays within [-1, 1],
    and a push at the range's end is only weakened (about half the time not at all); the
    pendulum's applied torques are its commands with noise, clipped at its torque limit."""
    draws = noisy_controls(0.0, 0.1, -1.0, 1.0, stream_key(1), 4000)
    assert abs(draws.mean()) < 0.005 and draws.std() == pytest.approx(0.1, rel=0.05)
    pushes = noisy_controls(1.0, 5.0, -1.0, 1.0, stream_key(1), 1000)
    assert pushes.min() >= -1.0 and pushes.max() == 1.0 and 0.4 < np.mean(pushes == 1.0) < 0.6
    actions = np.random.default_rng(7).integers(2, size=300)
    torques = np.asarray(tasks.definition("pendulum", "swingup").controls)[actions]
    applied = controls_applied({"action_noise": 1.0}, actions)
    assert np.all(np.abs(applied) <= 5.0 + 1e-6)
    assert np.all(np.sign(applied) == np.sign(torques))
    weakened = np.abs(torques) - np.abs(applied)  # min(z, 0) sigma's weakening, z ~ N(0, 1)
    assert np.all(weakened > -1e-6) and 0.4 < np.mean(weakened > 1e-6) < 0.6


def test_each_environment_draws_from_its_own_seed():
    """The same seed, the same noise; another seed, other noise; the starts are the same
    with the disturbances on or off (their stream is apart from the starts')."""
    envs = [tasks.load("mountain_car", "cost_to_go", seed=seed, observation_noise={"position": 0.1})
            for seed in (5, 5, 6)]
    observed = [float(env.reset().observation["position"]) for env in envs]
    assert observed[0] == observed[1] != observed[2]
    clean = tasks.load("mountain_car", "cost_to_go", seed=5)
    clean.reset()
    np.testing.assert_array_equal(envs[0].physics.state_vector(), clean.physics.state_vector())


# --- bad options ------------------------------------------------------------------------------

BAD = st.one_of(
    st.builds(lambda name: {"observation_noise": {name: 0.1}},
              st.text(min_size=1, max_size=10).filter(lambda w: w not in ("angle", "angular_velocity"))),
    st.builds(lambda sigma: {"observation_noise": {"angle": sigma}}, st.one_of(
        st.floats(max_value=0.0, exclude_max=True), st.sampled_from([math.nan, math.inf, "0.1", None]))),
    st.sampled_from([{"observation_noise": 0.1}, {"observation_noise": [0.1, 0.2]}]),
    st.builds(lambda delay: {"action_delay": delay}, st.one_of(
        st.integers(max_value=-1), st.integers(min_value=disturbances.MAX_DELAY + 1),
        st.floats(allow_nan=True).filter(lambda x: not (math.isfinite(x) and x == round(x)
                                                        and 0 <= x <= disturbances.MAX_DELAY)),
        st.sampled_from(["2", True, [1, 2, 3]]))),
    st.builds(lambda sigma: {"action_noise": sigma}, st.one_of(
        st.floats(max_value=0.0, exclude_max=True), st.sampled_from([math.nan, -math.inf, "1", [0.1]]))),
)


@settings(max_examples=200, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(options=BAD, entry=st.sampled_from(["load", "batched"]))
def test_bad_options_are_one_line_naming_what_is_allowed(options, entry):
    with pytest.raises(ValueError) as raised:
        if entry == "load":
            tasks.load("pendulum", "swingup", **options)
        else:
            BatchedEnv("pendulum", "swingup", seeds=[0, 1], **options)
    message = str(raised.value)
    assert "\n" not in message
    name = next(iter(options))
    assert name in message or "unknown state variable" in message
    assert "allowed" in message or "must" in message
