"""The acrobot (`tasks/acrobot.py`, `models/acrobot.xml`) against the book's equations.

Sources: Sutton and Barto (1998), section 11.3, and Sutton (1996): the dynamics, the torques,
the goal and the start; Gymnasium's `AcrobotEnv` with `book_or_nips = "book"` as an
independent implementation of the same equations; MuJoCo's mass matrix and accelerations of
the MJCF model as an independent derivation of the rigid-body physics.
"""

import json
import math

import dm_env
import gymnasium
import mujoco
import numpy as np
import pytest
from gymnasium.envs.classic_control.acrobot import AcrobotEnv

import lwrl.gym  # noqa: F401  (registers the lwrl/ environments)
from lwrl import models, tasks
from lwrl.cli import main as cli
from lwrl.runners.config import RunConfig
from lwrl.runners.run import run
from lwrl.tasks import acrobot
from conftest import set_state

RNG_STATES = 50
"""Random states per check against MuJoCo and Gymnasium."""
BOOK = np.asarray(acrobot.NOMINAL)
"""The book's parameter values as a vector."""


def _model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(models.read("acrobot"))


def _random_states(seed, count=RNG_STATES):
    """States over the task's whole range: any angles, velocities within the limits."""
    rng = np.random.default_rng(seed)
    low = (-2 * np.pi, -acrobot.MAX_SHOULDER_SPEED, -2 * np.pi, -acrobot.MAX_ELBOW_SPEED)
    return rng.uniform(low, np.negative(low), size=(count, 4)), rng.choice(acrobot.TORQUES, count)


# --- constants and model --------------------------------------------------------------------

def test_book_constants():
    """m1 = m2 = 1 kg, l1 = l2 = 1 m, lc1 = lc2 = 0.5 m, I1 = I2 = 1 kg m^2, g = 9.8 m/s^2,
    tau in {-1, 0, +1} N m, four Euler steps of 0.05 s per action, |theta1_dot| <= 4 pi,
    |theta2_dot| <= 9 pi (Sutton and Barto 1998, section 11.3)."""
    assert (acrobot.NOMINAL.link_mass_1, acrobot.NOMINAL.link_mass_2, acrobot.NOMINAL.link_length_1,
            acrobot.NOMINAL.link_length_2, acrobot.NOMINAL.link_com_1, acrobot.NOMINAL.link_com_2,
            acrobot.NOMINAL.link_inertia_1, acrobot.NOMINAL.link_inertia_2, acrobot.NOMINAL.gravity) == (
        1.0, 1.0, 1.0, 1.0, 0.5, 0.5, 1.0, 1.0, 9.8)
    assert acrobot.TORQUES == (-1.0, 0.0, 1.0)
    assert (acrobot.SUBSTEPS, acrobot.SUBSTEP, acrobot.TIMESTEP) == (4, 0.05, 0.2)
    assert (acrobot.MAX_SHOULDER_SPEED, acrobot.MAX_ELBOW_SPEED) == (4 * np.pi, 9 * np.pi)
    plants = tasks.domain("acrobot").plants
    assert (plants.timestep, plants.substeps, plants.model) == (0.2, 4, "acrobot")
    assert plants.analytic_options == ("integrator",)


def test_model_is_the_books_arm():
    """The MJCF model: MuJoCo's Euler at dt = 0.05 s (eulerdamp and contacts off), g = 9.8;
    two links of 1 kg, 1 m apart joint to joint, their centres of mass 0.5 m down the link
    and inertia 1 kg m^2 about it; both hinges about +y; the motor drives the elbow with
    gear 1 over [-1, 1] N m."""
    model = _model()
    assert model.opt.timestep == acrobot.SUBSTEP
    np.testing.assert_array_equal(model.opt.gravity, [0.0, 0.0, -acrobot.NOMINAL.gravity])
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_ENERGY
    upper, lower = model.body("upper_link"), model.body("lower_link")
    assert upper.mass[0] == acrobot.NOMINAL.link_mass_1 and lower.mass[0] == acrobot.NOMINAL.link_mass_2
    np.testing.assert_array_equal(upper.ipos, [0.0, 0.0, -acrobot.NOMINAL.link_com_1])
    np.testing.assert_array_equal(lower.ipos, [0.0, 0.0, -acrobot.NOMINAL.link_com_2])
    np.testing.assert_array_equal(lower.pos, [0.0, 0.0, -acrobot.NOMINAL.link_length_1])
    assert upper.inertia[1] == acrobot.NOMINAL.link_inertia_1 and lower.inertia[1] == acrobot.NOMINAL.link_inertia_2
    np.testing.assert_array_equal(upper.iquat, [1, 0, 0, 0])
    np.testing.assert_array_equal(lower.iquat, [1, 0, 0, 0])
    for joint in ("shoulder", "elbow"):
        np.testing.assert_array_equal(model.joint(joint).axis, [0.0, 1.0, 0.0])
        assert model.joint(joint).damping[0] == 0.0 and model.joint(joint).frictionloss[0] == 0.0
    assert [model.joint(j).qposadr[0] for j in ("shoulder", "elbow")] == [0, 1]
    torque = model.actuator("torque")
    assert torque.trnid[0] == model.joint("elbow").id and torque.gear[0] == 1.0
    np.testing.assert_array_equal(torque.ctrlrange, [-1.0, 1.0])
    assert model.ncam >= 2 and model.camera(0).name == "fixed"
    tip = model.geom("tip")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.geom_xpos[tip.id][2] - model.body("upper_link").pos[2] == pytest.approx(-2.0)


# --- the equations --------------------------------------------------------------------------

@pytest.mark.parametrize("state, torque, expected", [
    # Hanging at rest, tau = +1: d1 = 0.25 + 2.25 + 2 = 4.5, d2 = 1.75, d22 = 1.25, phi = 0;
    # theta2_dd = 1 / (1.25 - 1.75^2 / 4.5) = 72/41, theta1_dd = -1.75 theta2_dd / 4.5 = -28/41.
    ((0.0, 0.0, 0.0, 0.0), 1.0, (-28 / 41, 72 / 41)),
    # Link 1 horizontal (theta1 = pi/2), straight, at rest, tau = 0: phi2 = 0.5 * 9.8 = 4.9,
    # phi1 = 1.5 * 9.8 + 4.9 = 19.6; theta2_dd = (1.75/4.5 * 19.6 - 4.9) / (41/72) = 196/41,
    # theta1_dd = -(1.75 * 196/41 + 19.6) / 4.5 = -254.8/41.
    ((np.pi / 2, 0.0, 0.0, 0.0), 0.0, (-254.8 / 41, 196 / 41)),
    # Hanging link 1, elbow at pi/2, theta1_dot = 1, theta2_dot = 2, tau = 0: d1 = 3.5,
    # d2 = 1.25, m2 l1 lc2 = 0.5; phi2 = 4.9, phi1 = -0.5*4 - 2*0.5*2*1 + 0 + 4.9 = 0.9;
    # theta2_dd = (1.25/3.5 * 0.9 - 0.5 - 4.9) / (1.25 - 1.25^2/3.5) = -6.32,
    # theta1_dd = -(1.25 * -6.32 + 0.9) / 3.5 = 2.
    ((0.0, 1.0, np.pi / 2, 2.0), 0.0, (2.0, -6.32)),
])
def test_accelerations_by_hand(state, torque, expected):
    """The book's theta1_dd and theta2_dd at states worked out by hand (in the cases)."""
    assert acrobot.accelerations(*state, torque, BOOK) == pytest.approx(expected, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("elbow, expected", [
    (0.0, (4.5, 1.75, 1.25)),          # d1 = 0.25 + (1 + 0.25 + 1) + 2, d2 = 0.25 + 0.5 + 1
    (np.pi / 2, (3.5, 1.25, 1.25)),    # the cos(theta2) terms vanish
    (np.pi, (2.5, 0.75, 1.25)),
])
def test_mass_matrix_by_hand(elbow, expected):
    assert acrobot.mass_matrix(elbow, BOOK) == pytest.approx(expected, rel=1e-15, abs=1e-15)


def test_mass_matrix_is_mujocos():
    """d1, d2 and m2 lc2^2 + I2 are MuJoCo's joint-space inertia matrix (`mj_fullM`) of the
    MJCF arm at random poses, within 1e-12 (measured 2.7e-15)."""
    model = _model()
    data = mujoco.MjData(model)
    states, _ = _random_states(0)
    for state in states:
        data.qpos[:] = state[0::2]
        mujoco.mj_forward(model, data)
        full = np.zeros((2, 2))
        mujoco.mj_fullM(model, data, full)
        d1, d2, d22 = acrobot.mass_matrix(state[2], BOOK)
        np.testing.assert_allclose(full, [[d1, d2], [d2, d22]], rtol=0, atol=1e-12)


def test_accelerations_are_mujocos():
    """MuJoCo's accelerations (`mj_forward`'s qacc) of the MJCF arm, with the motor's torque,
    equal the book's theta1_dd and theta2_dd at random states within 1e-10 (measured 1.7e-13
    at velocities up to the limits): the model's sign conventions are the equations'."""
    model = _model()
    data = mujoco.MjData(model)
    states, torques = _random_states(1)
    for state, torque in zip(states, torques):
        data.qpos[:], data.qvel[:] = state[0::2], state[1::2]
        data.ctrl[model.actuator("torque").id] = torque
        mujoco.mj_forward(model, data)
        np.testing.assert_allclose(data.qacc, acrobot.accelerations(*state, torque, BOOK), rtol=0,
                                   atol=1e-10)


def test_accelerations_are_gymnasiums_book_dynamics():
    """Gymnasium's Acrobot-v1 with `book_or_nips = "book"` (its `_dsdt`, the same equations
    transcribed independently; its state is (theta1, theta2, theta1_dot, theta2_dot)) gives
    the same accelerations at random states, within 1e-12 (measured: identical)."""
    env = AcrobotEnv()
    env.book_or_nips = "book"
    states, torques = _random_states(2)
    for state, torque in zip(states, torques):
        gym_state = np.array([state[0], state[2], state[1], state[3], torque])
        derivatives = env._dsdt(gym_state)
        np.testing.assert_allclose(derivatives[2:4], acrobot.accelerations(*state, torque, BOOK),
                                   rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("semi_implicit", [True, False])
def test_step_is_four_euler_steps_then_the_limit(semi_implicit):
    """One agent step of 0.2 s is four Euler steps of 0.05 s with the torque held, then the
    velocities are clipped (once, not after each Euler step); the angles are not wrapped."""
    states, torques = _random_states(3)
    for state, torque in zip(states, torques):
        expected = tuple(state)
        for _ in range(4):
            th1dd, th2dd = acrobot.accelerations(*expected, torque, BOOK)
            v1, v2 = expected[1] + 0.05 * th1dd, expected[3] + 0.05 * th2dd
            expected = (expected[0] + 0.05 * (v1 if semi_implicit else expected[1]), v1,
                        expected[2] + 0.05 * (v2 if semi_implicit else expected[3]), v2)
        expected = (expected[0], np.clip(expected[1], -4 * np.pi, 4 * np.pi),
                    expected[2], np.clip(expected[3], -9 * np.pi, 9 * np.pi))
        np.testing.assert_allclose(acrobot.step(*state, torque, 0.2, semi_implicit, False, BOOK),
                                   expected, rtol=1e-13, atol=1e-13)
    # element-wise over arrays, and `slips` changes nothing (the domain has no such reading)
    batch = acrobot.step(*states.T, torques, 0.2, semi_implicit, False, BOOK)
    np.testing.assert_array_equal(batch, acrobot.step(*states.T, torques, 0.2, semi_implicit, True, BOOK))
    for column, state, torque in zip(np.array(batch).T, states, torques):
        np.testing.assert_array_equal(column, acrobot.step(*state, torque, 0.2, semi_implicit, False, BOOK))


# --- the velocity limit on both plants ------------------------------------------------------

LIMIT_START = [0.0, 12.0, 0.0, 27.0]
"""Near both speed limits: one step at tau = +1 takes theta1_dot to 47.3 and theta2_dot to
-48.1 rad/s before the limit (and the angles past 2 pi, unwrapped)."""


def test_velocity_limit_applies_on_both_plants():
    """From `LIMIT_START`, one step with tau = +1 ends with theta1_dot = 4 pi and
    theta2_dot = -9 pi exactly, on the batched plants and the dm_env environments of both
    plants; the positions are those of the unlimited Euler steps (MuJoCo's `mj_step` four
    times, which the limit does not touch), and agree between the plants to round-off."""
    raw = np.array(LIMIT_START)
    for _ in range(4):
        raw = np.array(acrobot.euler_step(*raw, 1.0, 0.05, True, BOOK))
    assert raw[1] > 4 * np.pi and raw[3] < -9 * np.pi and raw[0] > 2 * np.pi
    model = _model()
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = LIMIT_START[0::2], LIMIT_START[1::2]
    data.ctrl[:] = 1.0
    mujoco.mj_step(model, data, 4)
    np.testing.assert_allclose(np.column_stack([data.qpos, data.qvel]).ravel(), raw, rtol=0, atol=1e-12)
    plants = tasks.domain("acrobot").plants
    results = [plants.batch(plant, 1).step(np.array([LIMIT_START]), np.array([1.0]))[0]
               for plant in ("mujoco", "analytic")]
    for plant in ("mujoco", "analytic"):
        env = tasks.load("acrobot", "swingup", plant=plant)
        set_state(env, LIMIT_START)
        ts = env.step(2)
        results.append(env.physics.state_vector())
        assert ts.observation["shoulder_angular_velocity"] == 4 * np.pi
        assert ts.observation["elbow_angular_velocity"] == -9 * np.pi
        assert ts.observation["shoulder_angle"] == pytest.approx(acrobot.wrap_angle(raw[0]))
    for state in results:
        assert (state[1], state[3]) == (4 * np.pi, -9 * np.pi)
        np.testing.assert_allclose(state[0::2], raw[0::2], rtol=0, atol=1e-12)


# --- the task --------------------------------------------------------------------------------

@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
@pytest.mark.parametrize("state, goal", [
    ([0.0, 0.0, 0.0, 0.0], False),                    # hanging: tip 2 m below
    ([np.pi, 0.0, 0.0, 0.0], True),                   # straight up: tip 2 m above
    ([2 * np.pi / 3 - 0.01, 0.0, 0.0, 0.0], False),   # straight: tip at -2 cos(theta1) < 1
    ([2 * np.pi / 3 + 0.01, 0.0, 0.0, 0.0], True),
    ([np.pi / 2 + 0.05, 0.0, np.pi / 2, 0.0], True),  # link 1 level, link 2 up: sin + cos 0.05
    ([np.pi / 2 - 0.05, 0.0, np.pi / 2, 0.0], False),
    ([-np.pi / 2 - 0.05, 5.0, -np.pi / 2, -5.0], True),  # the mirror image; speed irrelevant
    ([2 * np.pi + np.pi, 0.0, 0.0, 0.0], True),       # unwrapped angles count modulo 2 pi
])
def test_goal_at_known_states(plant, state, goal):
    """Reward -1, or 0 with discount 0 where the tip is above l1 = 1 m over the shoulder:
    -l1 cos(theta1) - l2 cos(theta1 + theta2) > l1."""
    env = tasks.load("acrobot", "swingup", plant=plant)
    set_state(env, state)
    assert env.task.get_reward(env.physics) == (0.0 if goal else -1.0)
    assert env.task.get_termination(env.physics) == (0.0 if goal else None)
    assert env.physics.tip_height() == pytest.approx(
        -math.cos(state[0]) - math.cos(state[0] + state[2]))


@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
def test_reaching_the_goal_ends_the_episode(plant):
    """From theta1 = 1.9 rad (tip 0.65 m above the shoulder) swinging up at 4 rad/s, one
    step without torque reaches the goal (tip 1.73 m up): reward 0, discount 0, the last
    step; the next step starts a new episode at rest hanging down."""
    env = tasks.load("acrobot", "swingup", plant=plant)
    set_state(env, [1.9, 4.0, 0.0, 0.0])
    ts = env.step(1)
    assert ts.last() and ts.reward == 0.0 and ts.discount == 0.0
    assert env.physics.tip_height() > 1.0
    first = env.step(0)
    assert first.first()
    assert list(first.observation.values()) == [0.0, 0.0, 0.0, 0.0]


@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
def test_start_is_at_rest_hanging_down_and_steps_cost_one(plant):
    """Every episode starts at rest hanging down, whatever the seed; each step that does not
    reach the goal has reward -1 and discount 1; the task has no up-time."""
    for seed in (0, 1):
        env = tasks.load("acrobot", "swingup", plant=plant, seed=seed)
        ts = env.reset()
        assert list(ts.observation.values()) == [0.0] * 4
        for action in (2, 0, 2, 0, 1):
            ts = env.step(action)
            assert ts.reward == -1.0 and ts.discount == 1.0 and ts.mid()
        assert math.isnan(env.task.uptime)


def test_spaces_are_the_books():
    """State (theta_1, theta_1_dot, theta_2, theta_2_dot); elbow torques -1, 0, +1 N m."""
    definition = tasks.definition("acrobot", "swingup")
    assert definition.state_names == ("shoulder_angle", "shoulder_angular_velocity",
                                      "elbow_angle", "elbow_angular_velocity")
    assert definition.controls == (-1.0, 0.0, 1.0)


def test_time_limit_truncates():
    """Default 2000 s = 10 000 steps of 0.2 s; `time_limit=1.0` truncates (discount 1) after
    5 steps, on both plants."""
    assert tasks.definition("acrobot", "swingup").step_limit == 10_000
    for plant in ("mujoco", "analytic"):
        env = tasks.load("acrobot", "swingup", plant=plant, time_limit=1.0)
        env.reset()
        steps = [env.step(1) for _ in range(5)]
        assert [ts.step_type for ts in steps] == [dm_env.StepType.MID] * 4 + [dm_env.StepType.LAST]
        assert steps[-1].discount == 1.0 and steps[-1].reward == -1.0


@pytest.mark.parametrize("plant", ["mujoco", "analytic"])
def test_observation_wraps_both_angles(plant):
    """The observed angles are wrapped to [-pi, pi]; the plant's own are not; the velocities
    pass through. The accessors read the same values."""
    env = tasks.load("acrobot", "swingup", plant=plant)
    state = [3 * np.pi + 0.1, 1.5, -2 * np.pi - 0.2, -3.0]
    set_state(env, state)
    observation = env.task.get_observation(env.physics)
    assert list(observation.values()) == pytest.approx([-np.pi + 0.1, 1.5, -0.2, -3.0])
    assert env.physics.state_vector() == pytest.approx(state)
    physics = env.physics
    assert (physics.shoulder_angle(), physics.shoulder_angular_velocity(), physics.elbow_angle(),
            physics.elbow_angular_velocity()) == pytest.approx((-np.pi + 0.1, 1.5, -0.2, -3.0))


def test_gymnasium_environment():
    """`lwrl/acrobot-swingup-mujoco-v0` (and -analytic-) are registered by `import lwrl.gym`:
    Discrete(3) actions, a Box of the four observations inside the bounds; the start is
    hanging at rest and a step costs -1."""
    for plant in ("mujoco", "analytic"):
        env = gymnasium.make(f"lwrl/acrobot-swingup-{plant}-v0")
        assert env.action_space == gymnasium.spaces.Discrete(3)
        observation, _ = env.reset(seed=0)
        assert observation.tolist() == [0.0] * 4
        np.testing.assert_array_equal(env.observation_space.high,
                                      [np.pi, 4 * np.pi, np.pi, 9 * np.pi])
        for action in (2, 0, 2, 0):
            observation, reward, terminated, truncated, _ = env.step(action)
            assert reward == -1.0 and not terminated and not truncated
            assert observation in env.observation_space


# --- learning --------------------------------------------------------------------------------

def test_agents_learn_to_swing_up():
    """4 agents with the task's defaults (NRBF 6^4, replacing traces, alpha 1, lambda 0.9,
    epsilon 0) on the analytic plant, seeds 0..3, 20 episodes: the mean steps per episode of
    the last 5 episodes are under half those of the first 5, and no episode reaches the time
    limit. Measured: 653.0 in episodes 1-5, 211.0 in episodes 16-20 (seeds 1 and 2 learn
    identically: with a fixed start and epsilon 0, only the tie-breaks between untried
    actions differ between seeds)."""
    _, results = run(RunConfig(task="acrobot.swingup", plant="analytic", agents=4, episodes=20))
    first, last = np.mean(results.steps[:, :5]), np.mean(results.steps[:, -5:])
    assert first > 400
    assert last < 0.5 * first
    assert not results.truncated.any()


def test_train_command_smoke(tmp_path, capsys):
    """`lwrl train acrobot.swingup` on its default (MuJoCo) plant with 2 agents and 3
    episodes writes its configuration and the 6 episodes."""
    out = tmp_path / "run"
    assert cli.main(["train", "acrobot.swingup", "--agents", "2", "--episodes", "3",
                     "--out", str(out)]) == 0
    assert "acrobot.swingup on the mujoco plant" in capsys.readouterr().out
    config = json.loads((out / "config.json").read_text())
    assert config["task"] == "acrobot.swingup" and config["settings"]["n"] == 6
    rows = (out / "episodes.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + 6
