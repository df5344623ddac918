"""The suite's contract, checked over every task and plant (SPEC.md, tasks 1-3)."""

import math

import dm_env
import numba
import numpy as np
import pytest
from dm_env import specs

from lwrl import tasks
from conftest import off_nominal, set_state

STATE_NAMES = {
    "mountain_car": ("position", "velocity"),
    "pendulum": ("angle", "angular_velocity"),
    "cartpole": ("cart_position", "cart_velocity", "pole_angle", "pole_angular_velocity"),
    "acrobot": ("shoulder_angle", "shoulder_angular_velocity", "elbow_angle",
                "elbow_angular_velocity"),
}
CONTROLS = {"mountain_car": (-1.0, 0.0, 1.0), "pendulum": (-5.0, 5.0), "cartpole": (-10.0, 10.0),
            "acrobot": (-1.0, 0.0, 1.0)}
STEP_LIMITS = {"mountain_car": 10_000, "pendulum": 3000, "cartpole": 12_000, "acrobot": 10_000}


def random_episode_steps(env, rng, max_steps):
    """Step with random actions until LAST or `max_steps`; return the time steps."""
    steps = [env.reset()]
    while not steps[-1].last() and len(steps) <= max_steps:
        steps.append(env.step(int(rng.integers(env.action_spec().num_values))))
    return steps


def test_spec_conformance(task_plant):
    """Actions are a DiscreteArray mapping index i to the i-th control in ascending order;
    observations are the state variables, one float64 scalar each, matching their specs."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant, seed=0)
    action_spec = env.action_spec()
    assert isinstance(action_spec, specs.DiscreteArray)
    assert action_spec.num_values == len(CONTROLS[domain])
    assert env.task.definition.controls == CONTROLS[domain]
    assert list(env.task.definition.controls) == sorted(CONTROLS[domain])
    observation_spec = env.observation_spec()
    assert tuple(observation_spec) == STATE_NAMES[domain]
    for ts in random_episode_steps(env, np.random.default_rng(0), 50):
        assert tuple(ts.observation) == STATE_NAMES[domain]
        for name, value in ts.observation.items():
            observation_spec[name].validate(value)
        if not ts.first():
            assert isinstance(ts.reward, float) and math.isfinite(ts.reward)
            assert ts.discount in (0.0, 1.0)


def test_each_action_applies_its_control(task_plant):
    """Action i sets the plant's control to the i-th force or torque."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant, seed=0)
    for index, control in enumerate(CONTROLS[domain]):
        env.reset()
        env.step(index)
        applied = (env.physics.named.data.ctrl[env.physics.ACTUATOR] if plant == "mujoco"
                   else env.physics._control[0])
        assert applied == control


def test_deterministic_for_a_seed(task_plant):
    """The same seed and actions give the same time steps."""
    domain, task, plant = task_plant

    def trajectory(seed):
        env = tasks.load(domain, task, plant=plant, seed=seed)
        rng = np.random.default_rng(1)
        steps = []
        for _ in range(3):
            steps += random_episode_steps(env, rng, 40)
        return [(int(ts.step_type), ts.reward, ts.discount, tuple(ts.observation.values()))
                for ts in steps]

    assert trajectory(7) == trajectory(7)


def test_starts_follow_the_spec(task_plant):
    """Mountain-Car starts uniformly in x in [-1.2, 0.5], v in [-0.07, 0.07]; the pendulum
    at theta ~ U[-pi, pi] at rest; the cart-pole and the acrobot at rest at zero. Random starts differ
    between episodes and seeds and spread over their ranges."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant, seed=3)
    starts = np.array([list(env.reset().observation.values()) for _ in range(200)])
    other_seed = np.array(list(tasks.load(domain, task, plant=plant, seed=4).reset().observation.values()))
    if domain in ("cartpole", "acrobot"):
        assert np.all(starts == 0.0) and np.all(other_seed == 0.0)
        return
    if domain == "mountain_car":
        low, high = np.array([-1.2, -0.07]), np.array([0.5, 0.07])
    else:
        low, high = np.array([-np.pi, 0.0]), np.array([np.pi, 0.0])
    assert np.all(starts >= low) and np.all(starts <= high)
    random_columns = high > low
    spread = starts[:, random_columns].std(axis=0) / (high - low)[random_columns]
    assert np.all(np.abs(spread - 1 / np.sqrt(12)) < 0.05), "starts are not uniform over the range"
    assert len(np.unique(starts[:, 0])) == len(starts)
    assert not np.array_equal(starts[0], other_seed)


@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
@pytest.mark.parametrize("angle, angular_velocity, expected", [
    (0.0, 0.0, 0.3),                                   # upright at rest: cos 0 - 0.7
    (np.pi / 5 - 1e-9, 1.0, np.cos(np.pi / 5 - 1e-9) - 0.7 - 1.0),  # inside pi/5: speed penalised
    (np.pi / 5 + 1e-3, 1.0, np.cos(np.pi / 5 + 1e-3) - 0.7),  # outside: r1 only
    (-np.pi / 2, -3.0, np.cos(-np.pi / 2) - 0.7),
    (np.pi, 0.0, -1.7),                                # hanging
])
def test_pendulum_reward_at_known_states(plant, angle, angular_velocity, expected):
    """r1 = cos(theta) - 0.7; within |theta| <= pi/5, r2 = r1 - |theta_dot| (section 4.2),
    read through the task for a state set in the plant; no state is terminal."""
    env = tasks.load("pendulum", "swingup", plant=plant, seed=0)
    set_state(env, [angle, angular_velocity])
    assert env.task.get_reward(env.physics) == pytest.approx(expected, abs=1e-12)
    assert env.task.get_termination(env.physics) is None


@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
@pytest.mark.parametrize("state, fails", [
    ([0.0, 0.0, 0.0, 0.0], False),
    ([0.0, 0.0, math.radians(11.99), 0.0], False),
    ([0.0, 0.0, math.radians(12.01), 0.0], True),
    ([0.0, 0.0, -math.radians(12.01), 0.0], True),
    ([2.39, 0.0, 0.0, 0.0], False),
    ([-2.41, 0.0, 0.0, 0.0], True),
])
def test_cartpole_failure_at_known_states(plant, state, fails):
    """Failure (reward -1, discount 0) when |theta| > 12 deg or |x| > 2.4 m, else reward 0."""
    env = tasks.load("cartpole", "balance", plant=plant, seed=0)
    set_state(env, state)
    assert env.task.get_reward(env.physics) == (-1.0 if fails else 0.0)
    assert env.task.get_termination(env.physics) == (0.0 if fails else None)


def test_cartpole_track_limit_option():
    """`track_limit=None` removes the track limit; the angle limit stays."""
    env = tasks.load("cartpole", "balance", plant="analytic", track_limit=None)
    set_state(env, [100.0, 0.0, 0.0, 0.0])
    assert env.task.get_termination(env.physics) is None
    set_state(env, [100.0, 0.0, 0.3, 0.0])
    assert env.task.get_termination(env.physics) == 0.0
    env = tasks.load("cartpole", "balance", plant="analytic", track_limit=1.0)
    set_state(env, [1.01, 0.0, 0.0, 0.0])
    assert env.task.get_termination(env.physics) == 0.0


def _one_step(domain, task, state, action, **options):
    env = tasks.load(domain, task, plant="analytic", **options)
    env.reset()
    set_state(env, state)
    env.step(action)
    return env.physics.state_vector()


def test_kfnnet_pendulum_scales_the_acceleration_by_dt_twice():
    """The author's code's suspected slip (SPEC.md, "Known traps"): theta_d' = theta_d +
    dt^2 theta_dd, with theta_dd of m l^2 theta_dd = -mu theta_d + m g l sin(theta) + tau
    (m = l = 1); the paper's equations take dt once."""
    state, dt = [0.5, 1.2], 0.02
    acceleration = -0.01 * 1.2 + 9.81 * math.sin(0.5) + 5.0
    for equations, gain in (("paper", dt), ("kfnnet", dt * dt)):
        velocity = 1.2 + gain * acceleration
        np.testing.assert_allclose(_one_step("pendulum", "swingup", state, 1, equations=equations),
                                   [0.5 + dt * velocity, velocity], rtol=1e-13)


def test_kfnnet_cartpole_takes_the_cart_mass_in_the_spin_term():
    """The author's code's suspected slip: mc l theta_d^2 sin(theta) where the paper has
    m l theta_d^2 sin(theta), in both equations (section 4.3, written out here)."""
    x_dot, theta, theta_dot, force = 0.3, 0.1, -2.0, 10.0
    for equations, spin_mass in (("paper", 0.1), ("kfnnet", 1.0)):
        spin = spin_mass * 0.5 * theta_dot ** 2 * math.sin(theta)
        theta_dd = (9.81 * math.sin(theta) + math.cos(theta) * (-force - spin + 0.0005) / 1.1
                    - 0.000002 * theta_dot / 0.05) / (0.5 * (4 / 3 - 0.1 * math.cos(theta) ** 2 / 1.1))
        x_dd = (force + spin - 0.05 * theta_dd * math.cos(theta) - 0.0005) / 1.1
        expected_velocities = [x_dot + 0.02 * x_dd, theta_dot + 0.02 * theta_dd]
        state = _one_step("cartpole", "balance", [0.0, x_dot, theta, theta_dot], 1,
                          equations=equations)
        np.testing.assert_allclose(state[1::2], expected_velocities, rtol=1e-12)
    at_rest = [_one_step("cartpole", "balance", [0.0, 0.3, 0.1, 0.0], 1, equations=equations)
               for equations in ("paper", "kfnnet")]
    np.testing.assert_array_equal(*at_rest)  # without spin the equations are the same


def test_cartpole_failing_step_ends_the_episode():
    """Pushing one way from rest tips the pole over: the episode ends on the failing step
    with reward -1 and discount 0, and the up-time counts the steps before it."""
    env = tasks.load("cartpole", "balance", plant="mujoco")
    steps = [env.reset()]
    while not steps[-1].last():
        steps.append(env.step(1))
    assert [ts.reward for ts in steps[1:-1]] == [0.0] * (len(steps) - 2)
    assert steps[-1].reward == -1.0 and steps[-1].discount == 0.0
    assert steps[-1].observation["pole_angle"] < -math.radians(12)
    assert env.task.uptime == pytest.approx(0.02 * (len(steps) - 2))


def test_time_limits_truncate(task_plant):
    """Episodes end with discount 1 (a truncation) after the task's time limit: 60 s for the
    pendulum, 240 s for the cart-pole, the 10 000-step safety caps of Mountain-Car and the
    acrobot (2000 s)."""
    domain, task, plant = task_plant
    assert tasks.definition(domain, task).step_limit == STEP_LIMITS[domain]
    time_limit = {"mountain_car": 5, "acrobot": 1.0}.get(domain, 0.1)  # 5 steps
    env = tasks.load(domain, task, plant=plant, seed=0, time_limit=time_limit)
    limit = env.task.definition.step_limit
    assert limit == 5
    start = {"mountain_car": [-0.5, 0.0], "pendulum": [0.4, 0.0], "cartpole": [0.0] * 4,
             "acrobot": [0.0] * 4}[domain]
    set_state(env, start)
    steps = [env.step(i % 2) for i in range(limit)]
    assert [ts.step_type for ts in steps] == [dm_env.StepType.MID] * (limit - 1) + [dm_env.StepType.LAST]
    assert steps[-1].discount == 1.0
    assert env.step(0).first()


def test_terminal_on_the_last_allowed_step_has_discount_zero():
    """A goal reached on the step the time limit allows is terminal, not a truncation."""
    env = tasks.load("mountain_car", "cost_to_go", time_limit=1)
    set_state(env, [0.49, 0.06])
    ts = env.step(2)
    assert ts.last() and ts.reward == 0.0 and ts.discount == 0.0


def test_pendulum_uptime_counts_seconds_up():
    """Up-time adds 0.02 s for each step entering |theta| <= pi/2; none hanging down."""
    env = tasks.load("pendulum", "swingup", plant="analytic")
    set_state(env, [np.pi, 0.0])
    for _ in range(10):
        env.step(0)
    assert env.task.uptime == 0.0
    set_state(env, [0.0, 0.0])
    env.task._uptime = 0.0
    for _ in range(10):
        env.step(0)  # falls, but stays within pi/2 for 10 steps
    assert env.task.uptime == pytest.approx(0.2)


def test_pendulum_observation_wraps_the_angle():
    """The observed angle is wrapped to [-pi, pi]; the plant's own angle is not."""
    env = tasks.load("pendulum", "swingup", plant="mujoco")
    set_state(env, [3 * np.pi + 0.1, 0.0])
    assert env.task.get_observation(env.physics)["angle"] == pytest.approx(-np.pi + 0.1)
    assert env.physics.state_vector()[0] == pytest.approx(3 * np.pi + 0.1)


@pytest.mark.parametrize("call, message", [
    (lambda: tasks.load("cartpol", "balance"), "unknown domain 'cartpol'; available: mountain_car, pendulum, cartpole"),
    (lambda: tasks.load("cartpole", "swingup"), "unknown task 'swingup' of domain 'cartpole'; available: balance"),
    (lambda: tasks.load("mountain_car", "cost_to_go", plant="mujoco"), "unknown plant 'mujoco' for mountain_car; available: analytic"),
    (lambda: tasks.load("pendulum", "swingup", plant="mjx"), "the mjx plant steps batches only (lwrl train, tasks.batched); one environment runs on: mujoco, analytic"),
    (lambda: tasks.load("cartpole", "balance", plant="mujoco", integrator="explicit"), "unknown option 'integrator'"),
    (lambda: tasks.load("cartpole", "balance", plant="analytic", integrator="rk4"), "unknown integrator 'rk4'; allowed: semi_implicit, explicit"),
    (lambda: tasks.load("pendulum", "swingup", plant="mujoco", equations="kfnnet"), "unknown option 'equations'"),
    (lambda: tasks.load("pendulum", "swingup", plant="analytic", equations="R"), "unknown equations 'R'; allowed: paper, kfnnet"),
    (lambda: tasks.load("pendulum", "swingup", frobnicate=1), "allowed: plant, seed, time_limit"),
    (lambda: tasks.load("pendulum", "swingup", time_limit=-1), "time_limit must be a positive number"),
    (lambda: tasks.load("cartpole", "balance", track_limit=0), "track_limit must be a positive number"),
])
def test_bad_names_and_options_say_what_is_allowed(call, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        call()


@pytest.mark.parametrize("action", [-1, "num_actions", 1.5, "1", np.array([0, 1]), None])
def test_bad_action_is_refused(task_plant, action):
    """An action index out of range, or not one integer, raises naming the allowed range."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant)
    env.reset()
    num_actions = env.action_spec().num_values
    if isinstance(action, str) and action == "num_actions":
        action = num_actions
    with pytest.raises(ValueError, match=f"action must be .*integer index in 0..{num_actions - 1}"):
        env.step(action)


def test_nan_state_is_refused(task_plant):
    """A NaN given to a plant raises, naming the state variables."""
    domain, task, plant = task_plant
    env = tasks.load(domain, task, plant=plant)
    env.reset()
    state = np.zeros(len(STATE_NAMES[domain]))
    state[-1] = np.nan
    with pytest.raises(ValueError, match=f"state must be finite.*{STATE_NAMES[domain][-1]}"):
        env.physics.set_state_vector(state)
    with pytest.raises(ValueError, match="2 entries"):
        tasks.load("pendulum", "swingup", plant=plant if domain != "mountain_car" else "analytic"
                   ).physics.set_state_vector([0.0, 0.0, 0.0])


def test_physics_accessors_name_the_quantities():
    """dm_control-style one-line accessors read the state on both plants."""
    for plant in ("mujoco", "analytic"):
        env = tasks.load("cartpole", "balance", plant=plant)
        set_state(env, [0.1, 0.2, 0.03, 0.4])
        physics = env.physics
        assert (physics.cart_position(), physics.cart_velocity(), physics.pole_angle(),
                physics.pole_angular_velocity()) == pytest.approx((0.1, 0.2, 0.03, 0.4))
        env = tasks.load("pendulum", "swingup", plant=plant)
        set_state(env, [2 * np.pi + 0.5, -1.0])
        assert (env.physics.angle(), env.physics.angular_velocity()) == pytest.approx((0.5, -1.0))
    env = tasks.load("mountain_car", "cost_to_go")
    set_state(env, [-0.5, 0.01])
    assert (env.physics.position(), env.physics.velocity(), env.physics.altitude()) == pytest.approx(
        (-0.5, 0.01, np.sin(-1.5)))


@pytest.mark.parametrize("domain, task", tasks.ALL_TASKS)
@pytest.mark.parametrize("integrator", ["semi_implicit", "explicit"])
@pytest.mark.parametrize("equations", ["paper", "kfnnet"])
@pytest.mark.parametrize("physics", ["nominal", "off_nominal"])
def test_transition_is_the_plant_step_and_the_task(domain, task, integrator, equations, physics):
    """The compiled loops' `transition` (run here compiled by numba) gives the analytic
    plant's next state, the task's observation, reward, termination and up-time, exactly:
    at the paper's parameter values, and at values of each state's own (`off_nominal`),
    with each action's control at those values."""
    definition = tasks.definition(domain, task)
    plant = tasks.domain(domain).plants.batch("analytic", 200, **(
        {"integrator": integrator, "equations": equations} if domain != "mountain_car" else {}))
    transition = numba.njit(definition.transition)
    rng = np.random.default_rng(0)
    ranges = {"mountain_car": [1.0, 0.08], "pendulum": [4.0, 8.0], "cartpole": [2.6, 3.0, 0.25, 3.0],
              "acrobot": [7.0, 14.0, 7.0, 30.0]}  # the acrobot's speeds: past their limits
    states = rng.uniform(-1, 1, size=(200, len(definition.state_names))) * ranges[domain]
    rows = (np.tile(definition.physical, (200, 1)) if physics == "nominal"
            else off_nominal(domain, rng, 200))
    controls = definition.controls_at(rows)[np.arange(200),
                                            rng.integers(definition.num_actions, size=200)]
    expected = plant.step(states, controls, None if physics == "nominal" else rows)
    semi_implicit = integrator == "semi_implicit"
    params = np.array(definition.params, dtype=np.float64)
    outcomes = definition.outcomes(expected, rows)
    for i, (state, control, next_expected) in enumerate(zip(states, controls, expected)):
        next_state, observation = np.empty_like(state), np.empty_like(state)
        reward, terminal, up = transition(state, control, next_state, observation,
                                          plant.timestep, semi_implicit,
                                          equations == "kfnnet", (params, rows[i]))
        np.testing.assert_array_equal(next_state, next_expected)
        np.testing.assert_array_equal(observation, definition.observe(next_expected[None])[0])
        assert (reward, terminal) == (outcomes[0][i], outcomes[1][i])
        if definition.has_uptime:
            assert up == outcomes[2][i]