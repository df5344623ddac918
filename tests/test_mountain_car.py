"""Mountain-Car's dynamics, reward and termination, step by step, against independent sources:
Gymnasium's MountainCar-v0, a table computed by hand from the paper's equations
(Främling 2008, section 4.1; SPEC.md "Task 1"), and the dm_env built by `tasks.load`.
"""

import dm_env
import gymnasium
import numpy as np
import pytest

from lwrl import tasks
from lwrl.tasks import mountain_car
from conftest import set_state


@pytest.fixture(scope="module")
def gymnasium_car():
    """Gymnasium's MountainCar-v0 without its wrappers (its state is set directly)."""
    env = gymnasium.make("MountainCar-v0").unwrapped
    yield env
    env.close()


def _gymnasium_steps(env, positions, velocities, action):
    """Gymnasium's next state (float64, its internal `state`) and termination flag from each
    state; its action index i applies the force (i - 1) * 0.001, like our index i."""
    results = []
    for position, velocity in zip(positions, velocities):
        env.state = np.array([position, velocity])
        _, _, terminated, _, _ = env.step(action)
        results.append((*env.state, terminated))
    next_positions, next_velocities, terminated = np.array(results).T
    return next_positions, next_velocities, terminated.astype(bool)


def _ours(positions, velocities, action):
    return mountain_car.step(positions, velocities, mountain_car.THRUSTS[action],
                             np.asarray(mountain_car.NOMINAL))


@pytest.mark.parametrize("action", [0, 1, 2])
def test_step_matches_gymnasium_inside_the_domain(gymnasium_car, action):
    """Random states with x in [-1.1, 0.4] and v in [-0.07, 0.07]: our step equals
    Gymnasium's MountainCar-v0 step to 1e-12, for each action (SPEC "Task 1": same equations).

    Gymnasium differs (SPEC "Known traps") by capping x at 0.6 and terminating at x >= 0.5
    with v >= 0, where ours terminates at x > 0.5. From these states |v'| <= 0.07 gives
    x' in [-1.17, 0.47]: neither the left wall, the cap nor either goal rule applies, and both
    report "not terminal". The velocity range is the whole domain, so the clip of v' at
    +-0.07, the same in both, is exercised (asserted below).
    """
    rng = np.random.default_rng(0)
    positions = rng.uniform(-1.1, 0.4, 1000)
    velocities = rng.uniform(-mountain_car.MAX_SPEED, mountain_car.MAX_SPEED, 1000)
    gym_positions, gym_velocities, gym_terminated = _gymnasium_steps(
        gymnasium_car, positions, velocities, action)
    next_positions, next_velocities = _ours(positions, velocities, action)
    np.testing.assert_allclose(next_positions, gym_positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(next_velocities, gym_velocities, rtol=0, atol=1e-12)
    assert not gym_terminated.any()
    assert not mountain_car.reached_goal(next_positions).any()
    assert np.any(np.abs(next_velocities) == mountain_car.MAX_SPEED)


@pytest.mark.parametrize("action", [0, 1, 2])
def test_left_wall_matches_gymnasium(gymnasium_car, action):
    """Near the left wall moving left (x in [-1.2, -1.17], v in [-0.07, -0.04], so that
    x + v' <= -1.17 - 0.04 + 0.001 + 0.0025 < -1.2), both Gymnasium and ours stop the car at
    the wall: x' = -1.2, v' = 0 (section 4.1; SPEC "Task 1")."""
    rng = np.random.default_rng(1)
    positions = rng.uniform(mountain_car.MIN_POSITION, -1.17, 50)
    velocities = rng.uniform(-mountain_car.MAX_SPEED, -0.04, 50)
    gym_positions, gym_velocities, _ = _gymnasium_steps(
        gymnasium_car, positions, velocities, action)
    next_positions, next_velocities = _ours(positions, velocities, action)
    for position, velocity in ((gym_positions, gym_velocities), (next_positions, next_velocities)):
        np.testing.assert_array_equal(position, np.full(50, -1.2))
        np.testing.assert_array_equal(velocity, np.zeros(50))


# By hand from section 4.1: v' = clip(v + 0.001 a - 0.0025 cos(3x), -0.07, 0.07);
# x' = max(x + v', -1.2), v' = 0 if x' was clipped; reward 0 and terminal iff x' > 0.5.
# Cosines to 16 digits.
HAND_TABLE = [
    # x, v, a -> x', v', reward, terminal
    # interior: cos(0) = 1; v' = 0.01 + 0.001 - 0.0025 = 0.0085; x' = 0 + 0.0085
    (0.0, 0.01, 1.0, 0.0085, 0.0085, -1.0, False),
    # interior, no thrust: v' = 0.02 - 0.0025 = 0.0175; x' = 0.0175
    (0.0, 0.02, 0.0, 0.0175, 0.0175, -1.0, False),
    # interior, reverse: cos(-1.5) = 0.0707372016677029, 0.0025 cos = 0.000176843004169257;
    # v' = -0.001 - 0.000176843004169257 = -0.001176843004169257; x' = -0.501176843004169257
    (-0.5, 0.0, -1.0, -0.501176843004169257, -0.001176843004169257, -1.0, False),
    # left wall: cos(-3.57) = -0.9096285273579445, 0.0025 cos = -0.002274071318394861;
    # v' = -0.02 - 0.001 + 0.002274071318394861 = -0.018725928681605139;
    # x + v' = -1.208725928681605139 < -1.2, so x' = -1.2 and v' = 0
    (-1.19, -0.02, -1.0, -1.2, 0.0, -1.0, False),
    # velocity clip at +0.07: cos(-3) = -0.9899924966004454, 0.0025 cos = -0.002474981241501114;
    # v + 0.001 + 0.002474981241501114 = 0.073474981241501114 > 0.07, so v' = 0.07;
    # x' = -1.0 + 0.07 = -0.93
    (-1.0, 0.07, 1.0, -0.93, 0.07, -1.0, False),
    # velocity clip at -0.07: v' = -0.07 - 0.001 - 0.0025 = -0.0735 -> -0.07; x' = -0.07
    (0.0, -0.07, -1.0, -0.07, -0.07, -1.0, False),
    # goal: cos(1.35) = 0.2190066870930415, 0.0025 cos = 0.000547516717732604;
    # v' = 0.06 - 0.000547516717732604 = 0.059452483282267396;
    # x' = 0.509452483282267396 > 0.5: reward 0, terminal
    (0.45, 0.06, 0.0, 0.509452483282267396, 0.059452483282267396, 0.0, True),
    # goal after a velocity clip: cos(1.32) = 0.2481754516523729, 0.0025 cos = 0.000620438629130932;
    # v' = 0.071 - 0.000620438629130932 = 0.070379561370869068 -> 0.07; x' = 0.51 > 0.5
    (0.44, 0.07, 1.0, 0.51, 0.07, 0.0, True),
    # exactly at the goal: cos(1.29) = 0.2771208750565576, 0.0025 cos = 0.000692802187641394;
    # v' = 0.071 - 0.000692802187641394 = 0.070307197812358606 -> 0.07; x' = 0.43 + 0.07 = 0.5
    # (also exactly 0.5 in binary64), not > 0.5: reward -1, not terminal
    (0.43, 0.07, 1.0, 0.5, 0.07, -1.0, False),
    # just below: v' = 0.069 + 0.001 - 0.000692802187641394 = 0.069307197812358606;
    # x' = 0.499307197812358606
    (0.43, 0.069, 1.0, 0.499307197812358606, 0.069307197812358606, -1.0, False),
]


@pytest.mark.parametrize(
    "position, velocity, thrust, next_position, next_velocity, reward, terminal", HAND_TABLE)
def test_step_matches_hand_computed_table(position, velocity, thrust, next_position,
                                          next_velocity, reward, terminal):
    """One step, its reward and its termination equal the values computed by hand from the
    paper's equations (section 4.1; SPEC "Task 1"), to 1e-12: interior steps, the left wall
    (v' reset to 0), the velocity clip at +-0.07, reaching the goal (x' > 0.5: reward 0,
    terminal) and landing exactly at or just below 0.5 (reward -1, not terminal)."""
    position_next, velocity_next = mountain_car.step(position, velocity, thrust,
                                                     np.asarray(mountain_car.NOMINAL))
    assert position_next == pytest.approx(next_position, rel=0, abs=1e-12)
    assert velocity_next == pytest.approx(next_velocity, rel=0, abs=1e-12)
    assert mountain_car.reward(position_next) == reward
    assert mountain_car.reached_goal(position_next) == terminal


@pytest.mark.parametrize("state, next_position, step_type, reward, discount", [
    ((0.44, 0.07), 0.51, dm_env.StepType.LAST, 0.0, 0.0),
    ((0.43, 0.07), 0.5, dm_env.StepType.MID, -1.0, 1.0),
    ((0.0, 0.01), 0.0085, dm_env.StepType.MID, -1.0, 1.0),
])
def test_dm_env_step_reward_and_discount(state, next_position, step_type, reward, discount):
    """Through the dm_env of `tasks.load("mountain_car", "cost_to_go")`, forward thrust
    (action 2) from a state set after reset (rows of the hand table): reaching the goal ends
    the episode with reward 0 and discount 0 (terminal); landing at x' = 0.5 or below
    continues (MID) with reward -1 and discount 1 (section 4.1; SPEC "Task 1")."""
    env = tasks.load("mountain_car", "cost_to_go", seed=0)
    env.reset()
    with env.physics.reset_context():
        env.physics.set_state_vector(list(state))
    time_step = env.step(2)
    assert time_step.step_type == step_type
    assert time_step.reward == reward
    assert time_step.discount == discount
    assert time_step.observation["position"] == pytest.approx(next_position, rel=0, abs=1e-12)


def test_the_task_is_the_papers():
    """State (x, v), thrusts -1, 0, +1, a 10 000-step safety cap (SPEC.md: the protocol has
    none), starts x ~ U[-1.2, 0.5], v ~ U[-0.07, 0.07], other for another seed."""
    definition = tasks.definition("mountain_car", "cost_to_go")
    assert definition.state_names == ("position", "velocity")
    assert definition.controls == (-1.0, 0.0, 1.0) and definition.step_limit == 10_000
    env = tasks.load("mountain_car", "cost_to_go", seed=3)
    starts = np.array([list(env.reset().observation.values()) for _ in range(200)])
    other = list(tasks.load("mountain_car", "cost_to_go", seed=4).reset().observation.values())
    low, high = np.array([-1.2, -0.07]), np.array([0.5, 0.07])
    assert np.all(starts >= low) and np.all(starts <= high)
    assert np.all(np.abs(starts.std(axis=0) / (high - low) - 1 / np.sqrt(12)) < 0.05)
    assert len(np.unique(starts[:, 0])) == len(starts) and not np.array_equal(other, starts[0])


def test_physics_accessors_name_the_quantities():
    env = tasks.load("mountain_car", "cost_to_go")
    set_state(env, [-0.5, 0.01])
    assert (env.physics.position(), env.physics.velocity(), env.physics.altitude()) == pytest.approx(
        (-0.5, 0.01, np.sin(-1.5)))


def test_terminal_on_the_last_allowed_step_has_discount_zero():
    """A goal reached on the step the time limit allows is terminal, not a truncation."""
    env = tasks.load("mountain_car", "cost_to_go", time_limit=1)
    set_state(env, [0.49, 0.06])
    ts = env.step(2)
    assert ts.last() and ts.reward == 0.0 and ts.discount == 0.0
