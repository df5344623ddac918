"""The suite as Gymnasium environments (`lwrl.gym`): registration, Gymnasium's
own checker, the observation box, terminated vs truncated, seeding, and step-by-step
agreement with the dm_env environments."""

import math
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from lwrl import tasks  # noqa: E402
from lwrl.gym import (CONTINUOUS_ENV_IDS, DEFAULT_ENV_IDS, ENV_IDS, SuiteEnv,  # noqa: E402
                      SuiteVectorEnv, env_id, register_envs, render_modes)

# Any warning (Gymnasium's checkers warn rather than raise) fails these tests, unless a test
# expects it.
pytestmark = pytest.mark.filterwarnings("error")

TASK_PLANTS = [(domain, task, plant) for domain, task in tasks.ALL_TASKS
               for plant in tasks.ENVIRONMENT_PLANTS[domain]]
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def ids_of(domain):
    return [env_id(d, t, p) for d, t, p in TASK_PLANTS if d == domain]


def rollout(env, policy, episodes, seed, max_steps=None):
    """Run `episodes` episodes; return a list of episodes, each a list of
    `(observation, reward, terminated, truncated, info)`, the first with reward None."""
    result = []
    observation, info = env.reset(seed=seed)
    for _ in range(episodes):
        episode = [(observation, None, False, False, info)]
        while not (episode[-1][2] or episode[-1][3]):
            if max_steps is not None and len(episode) > max_steps:
                break
            episode.append(env.step(policy(episode[-1][0])))
        result.append(episode)
        observation, info = env.reset()
    return result


# Registration ---------------------------------------------------------------------------

def test_every_task_and_plant_is_registered():
    """Every (task, plant) of the suite has the id lwrl/{domain}-{task}-{plant}-v0, made by
    SuiteEnv, its `max_episode_steps` the task's own step limit."""
    expected = {f"lwrl/{d}-{t}-{p}-v0" for d, t, p in TASK_PLANTS}
    assert set(ENV_IDS) == expected and len(ENV_IDS) == len(TASK_PLANTS) == 7
    assert "lwrl/cartpole-balance-mujoco-v0" in ENV_IDS
    assert "lwrl/mountain_car-cost_to_go-analytic-v0" in ENV_IDS
    for (domain, task, plant), id_ in zip(TASK_PLANTS, [env_id(*p) for p in TASK_PLANTS]):
        spec = gymnasium.spec(id_)
        assert spec.entry_point == "lwrl.gym:SuiteEnv"
        assert spec.kwargs == {"domain": domain, "task": task, "plant": plant}
        assert spec.max_episode_steps == tasks.definition(domain, task).step_limit
        assert spec.namespace == "lwrl"


def test_register_envs_is_idempotent():
    """Registering again neither warns (Gymnasium warns when it overrides an id) nor
    replaces the specs."""
    before = {id_: gymnasium.envs.registry[id_] for id_ in ENV_IDS}
    assert register_envs() == ENV_IDS
    assert register_envs() == ENV_IDS
    assert all(gymnasium.envs.registry[id_] is spec for id_, spec in before.items())


def test_registration_from_a_fresh_interpreter():
    """`import tasks` does not import gymnasium; `gymnasium.make("lwrl/...")` needs the ids
    registered (Gymnasium 1.x loads no entry-point plugins), which `module:id` or importing
    `lwrl.gym` does."""
    script = """
import sys
from lwrl import tasks
assert "gymnasium" not in sys.modules, "tasks imported gymnasium"
import gymnasium
try:
    gymnasium.make("lwrl/cartpole-balance-analytic-v0")
except gymnasium.error.Error as error:
    print("unregistered:", type(error).__name__)
env = gymnasium.make("lwrl.gym:lwrl/cartpole-balance-analytic-v0")
print(env.reset(seed=0)[0].tolist())
env = gymnasium.make("lwrl/pendulum-swingup-analytic-v0")
print(type(env.unwrapped).__name__)
"""
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            cwd=ROOT, env={**os.environ, "PYTHONPATH": ROOT}, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["unregistered: NamespaceNotFound", "[0.0, 0.0, 0.0, 0.0]",
                                          "SuiteEnv"]


# Gymnasium's checker and make -----------------------------------------------------------

@pytest.mark.parametrize("id_", ENV_IDS)
def test_check_env(id_):
    """Gymnasium's env checker passes. Its only warnings are that a Box bound is infinite,
    which it is where the task's variable is unbounded (pendulum and cart-pole speeds; the
    acrobot's are limited)."""
    env = gymnasium.make(id_).unwrapped
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    messages = {str(w.message) for w in caught}
    space = env.observation_space
    expected = set()
    if np.any(np.isneginf(space.low)):
        expected.add("A Box observation space minimum value is -infinity. This is probably too low.")
    if np.any(np.isposinf(space.high)):
        expected.add("A Box observation space maximum value is infinity. This is probably too high.")
    assert {m.removeprefix("\x1b[33mWARN: ").removesuffix("\x1b[0m") for m in messages} == expected
    assert (id_.startswith(("lwrl/mountain_car", "lwrl/acrobot"))) == (not expected)


@pytest.mark.parametrize("domain, task, plant", TASK_PLANTS)
def test_make(domain, task, plant):
    """gymnasium.make gives the task on the plant: Discrete actions, a float64 Box of the
    state variables, Gymnasium's two checking wrappers and its TimeLimit at the task's limit."""
    env = gymnasium.make(env_id(domain, task, plant))
    raw = env.unwrapped
    assert isinstance(raw, SuiteEnv)
    assert (raw.domain, raw.task_name, raw.plant) == (domain, task, plant)
    definition = tasks.definition(domain, task)
    assert env.action_space == gymnasium.spaces.Discrete(len(definition.controls))
    assert env.observation_space.dtype == np.float64
    assert env.observation_space.shape == (len(definition.state_names),)
    assert raw.observation_names == definition.state_names
    limits = [w for w in _wrappers(env) if isinstance(w, gymnasium.wrappers.TimeLimit)]
    assert [w._max_episode_steps for w in limits] == [definition.step_limit]
    assert env.render_mode is None and env.metadata["render_modes"] == render_modes(domain)
    observation, info = env.reset(seed=0)
    assert observation.dtype == np.float64 and observation in env.observation_space
    assert info == {"uptime_s": None if domain in ("mountain_car", "acrobot") else 0.0, "steps": 0,
                    "plant": plant}
    observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
    assert info["steps"] == 1 and info["plant"] == plant
    env.close()
    env.close()


def _wrappers(env):
    while isinstance(env, gymnasium.Wrapper):
        yield env
        env = env.env


def test_observation_bounds():
    """The Box's bounds: the task docstrings' ranges, widened to hold terminal states."""
    space = gymnasium.make("lwrl/mountain_car-cost_to_go-analytic-v0").observation_space
    assert space.low.tolist() == [-1.2, -0.07] and space.high.tolist() == [0.5 + 0.07, 0.07]
    space = gymnasium.make("lwrl/pendulum-swingup-mujoco-v0").observation_space
    assert space.low.tolist() == [-np.pi, -np.inf] and space.high.tolist() == [np.pi, np.inf]
    space = gymnasium.make("lwrl/cartpole-balance-mujoco-v0").observation_space
    angle = math.radians(24)
    assert space.high == pytest.approx([4.8, np.inf, angle, np.inf], rel=1e-15)
    assert np.array_equal(space.low, -space.high)
    space = gymnasium.make("lwrl/cartpole-balance-analytic-v0", track_limit=None).observation_space
    assert space.high[0] == np.inf
    space = gymnasium.make("lwrl/cartpole-balance-analytic-v0", track_limit=0.1).observation_space
    assert space.high[0] == pytest.approx(1.1)


# Observations inside the box ------------------------------------------------------------

def _cartpole_policies(rng):
    gains = rng.normal(size=(6, 4)) * [0.3, 0.5, 10.0, 2.0]
    return ([lambda o: int(rng.integers(2)), lambda o: 0, lambda o: 1,
             # accelerate the pole along its motion
             lambda o: int(o[3] < 0)]
            # linear feedback with random gains: some balance, then drift off the track
            + [lambda o, g=g: int(o @ g + 0.05 * rng.normal() > 0) for g in gains])


BOX_CASES = [
    ("lwrl/mountain_car-cost_to_go-analytic-v0", {"time_limit": 400}),
    ("lwrl/pendulum-swingup-mujoco-v0", {"time_limit": 4.0}),
    ("lwrl/pendulum-swingup-analytic-v0", {"time_limit": 4.0, "integrator": "explicit"}),
    # 20 s (1000 steps) keeps the balancing policies' episodes short
    ("lwrl/cartpole-balance-mujoco-v0", {"time_limit": 20.0}),
    ("lwrl/cartpole-balance-analytic-v0", {"time_limit": 20.0}),
    ("lwrl/cartpole-balance-analytic-v0", {"integrator": "explicit", "track_limit": 0.3,
                                           "time_limit": 20.0, "equations": "kfnnet"}),
    ("lwrl/cartpole-balance-analytic-v0", {"track_limit": None, "time_limit": 10.0}),
]


@pytest.mark.parametrize("id_, options", BOX_CASES)
def test_observations_stay_inside_the_box(id_, options):
    """Over random and adversarial policies, every observation, terminal and truncated
    ones included, lies in the observation space, and episodes end both ways where the task
    has both."""
    env = gymnasium.make(id_, **options)
    rng = np.random.default_rng(0)
    if "mountain_car" in id_:
        policies = [lambda o: int(rng.integers(3)), lambda o: 2 if o[1] >= 0 else 0]  # pump
    elif "pendulum" in id_:
        policies = [lambda o: int(rng.integers(2)), lambda o: int(o[1] >= 0)]  # spin up
    else:
        policies = _cartpole_policies(rng)
    ends = {"terminated": 0, "truncated": 0}
    largest = np.zeros(env.observation_space.shape)
    for k, policy in enumerate(policies):
        for episode in rollout(env, policy, episodes=8, seed=k):
            for observation, _, terminated, truncated, _ in episode:
                assert observation in env.observation_space, (observation, env.observation_space)
                largest = np.maximum(largest, np.abs(observation))
            ends["terminated"] += episode[-1][2]
            ends["truncated"] += episode[-1][3]
    assert ends["terminated"] > 0 or "pendulum" in id_
    assert ends["truncated"] > 0 or "time_limit" not in options
    if "mountain_car" in id_:
        assert largest[0] > 0.5  # goal states were observed
    if "cartpole" in id_:
        assert largest[2] > math.radians(12)  # failing states were observed


# Terminated vs truncated ----------------------------------------------------------------

@pytest.mark.parametrize("id_", ids_of("cartpole"))
def test_cartpole_pushed_one_way_terminates(id_):
    """Pushing one way from rest tips the pole: terminated with reward -1, not truncated;
    every step before has reward 0 and the up-time counts them."""
    env = gymnasium.make(id_)
    (episode,) = rollout(env, lambda o: 1, episodes=1, seed=0)
    assert [step[1] for step in episode[1:-1]] == [0.0] * (len(episode) - 2)
    _, reward, terminated, truncated, info = episode[-1]
    assert (reward, terminated, truncated) == (-1.0, True, False)
    assert not any(step[2] or step[3] for step in episode[:-1])
    assert episode[-1][0][2] < -math.radians(12)
    assert info["uptime_s"] == pytest.approx(0.02 * (len(episode) - 2))
    assert 5 < len(episode) < 100


@pytest.mark.parametrize("id_", ids_of("pendulum"))
def test_pendulum_time_limit_truncates(id_):
    """With time_limit=0.1 s the episode is truncated after 5 steps and never terminated."""
    env = gymnasium.make(id_, time_limit=0.1)
    for seed in range(3):
        (episode,) = rollout(env, lambda o: 0, episodes=1, seed=seed)
        assert len(episode) == 6
        assert [step[2] for step in episode] == [False] * 6
        assert [step[3] for step in episode] == [False] * 5 + [True]


def test_mountain_car_goal_terminates_with_reward_zero():
    """From near the goal, pushing forward reaches it: terminated, reward 0, not truncated,
    the position past 0.5 inside the box."""
    env = gymnasium.make("lwrl/mountain_car-cost_to_go-analytic-v0")
    observation, _ = env.reset(seed=0, options={"state": [0.4, 0.05]})
    assert observation.tolist() == [0.4, 0.05]
    rewards = []
    while True:
        observation, reward, terminated, truncated, info = env.step(2)
        rewards.append(reward)
        if terminated or truncated:
            break
    assert (terminated, truncated) == (True, False)
    assert rewards == [-1.0] * (len(rewards) - 1) + [0.0]
    assert observation[0] > 0.5 and observation in env.observation_space
    assert info["uptime_s"] is None and info["steps"] == len(rewards) > 1


def test_terminal_on_the_last_allowed_step_is_not_truncated():
    """A goal reached on the step the time limit allows is terminated only (the dm_env's
    discount 0), never both."""
    env = gymnasium.make("lwrl/mountain_car-cost_to_go-analytic-v0", time_limit=1)
    env.reset(seed=0, options={"state": [0.49, 0.06]})
    _, reward, terminated, truncated, _ = env.step(2)
    assert (reward, terminated, truncated) == (0.0, True, False)
    env.reset(seed=0, options={"state": [-0.5, 0.0]})
    _, reward, terminated, truncated, _ = env.step(2)
    assert (reward, terminated, truncated) == (-1.0, False, True)


def test_stepping_outside_an_episode_raises():
    env = SuiteEnv("cartpole", "balance", "analytic")
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    env.reset(seed=0)
    while not env.step(1)[2]:
        pass
    with pytest.raises(RuntimeError, match="episode has ended"):
        env.step(1)
    env.reset()
    env.step(1)


# Seeding -------------------------------------------------------------------------------

def _trajectory(env, seed, episodes=3, max_steps=60):
    rng = np.random.default_rng(99)
    return [(observation.tolist(), reward, terminated, truncated)
            for episode in rollout(env, lambda o: int(rng.integers(env.action_space.n)), episodes,
                                   seed, max_steps)
            for observation, reward, terminated, truncated, _ in episode]


@pytest.mark.parametrize("id_", ENV_IDS)
def test_same_seed_same_trajectory(id_):
    """The same seed gives the same first observation and the same episodes, in the same
    environment again or a new one; different seeds give different random starts."""
    env = gymnasium.make(id_)
    first = env.reset(seed=5)[0]
    assert np.array_equal(first, env.reset(seed=5)[0])
    assert np.array_equal(first, gymnasium.make(id_).reset(seed=5)[0])
    trajectory = _trajectory(env, seed=5)
    assert trajectory == _trajectory(env, seed=5) == _trajectory(gymnasium.make(id_), seed=5)
    other = env.reset(seed=6)[0]
    if id_.startswith(("lwrl/cartpole", "lwrl/acrobot")):
        assert np.array_equal(first, other) and not first.any()  # the start is fixed at rest
    else:
        assert not np.array_equal(first, other)
        assert _trajectory(env, seed=6) != trajectory
        # seedless resets continue the seeded stream: successive starts differ
        starts = [env.reset()[0].tolist() for _ in range(5)]
        assert len({tuple(s) for s in starts}) == 5


def test_seed_drives_the_tasks_generator():
    """The task draws its starts from Gymnasium's np_random, which for seed s is NumPy's
    default_rng(s): reset(seed=s) then seedless resets give the starts of tasks.load(seed=s)."""
    env = gymnasium.make("lwrl/pendulum-swingup-analytic-v0")
    env.reset(seed=11)
    assert env.unwrapped.suite_task.random is env.unwrapped.np_random
    dm = tasks.load("pendulum", "swingup", plant="analytic", seed=11)
    gym_starts = [env.reset(seed=11)[0]] + [env.reset()[0] for _ in range(4)]
    dm_starts = [np.array(list(dm.reset().observation.values())) for _ in range(5)]
    assert all(np.array_equal(a, b) for a, b in zip(gym_starts, dm_starts))


# Agreement with the dm_env environments ------------------------------------------------

EQUIVALENCE_CASES = [
    ("mountain_car", "cost_to_go", "analytic", {"time_limit": 300}),
    ("pendulum", "swingup", "mujoco", {"time_limit": 1.0}),
    ("pendulum", "swingup", "analytic", {"time_limit": 1.0, "integrator": "explicit"}),
    ("cartpole", "balance", "mujoco", {}),
    ("cartpole", "balance", "analytic", {"track_limit": 0.5}),
]


@pytest.mark.parametrize("domain, task, plant, options", EQUIVALENCE_CASES)
def test_trajectories_equal_the_dm_env(domain, task, plant, options):
    """With the same seed and actions, the Gymnasium environment's episodes are the dm_env
    environment's, step by step and exactly: observations, rewards, terminal (discount 0)
    vs truncated (discount 1) ends, steps and up-time."""
    seed = 21
    gym_env = gymnasium.make(env_id(domain, task, plant), **options)
    dm_env = tasks.load(domain, task, plant=plant, seed=seed, **options)
    rng = np.random.default_rng(3)
    observation, info = gym_env.reset(seed=seed)
    ends = set()
    for _ in range(4):
        time_step = dm_env.reset()
        assert np.array_equal(observation, list(time_step.observation.values()))
        while True:
            action = int(rng.integers(gym_env.action_space.n))
            observation, reward, terminated, truncated, info = gym_env.step(action)
            time_step = dm_env.step(action)
            assert np.array_equal(observation, list(time_step.observation.values()))
            assert reward == time_step.reward
            assert terminated == (time_step.last() and time_step.discount == 0.0)
            assert truncated == (time_step.last() and time_step.discount == 1.0)
            assert info["steps"] == dm_env.task.steps
            if math.isnan(dm_env.task.uptime):
                assert info["uptime_s"] is None
            else:
                assert info["uptime_s"] == dm_env.task.uptime
            if time_step.last():
                ends.add("terminated" if terminated else "truncated")
                break
        observation, info = gym_env.reset()
    assert ends  # episodes ended within the test


# Errors ---------------------------------------------------------------------------------

@pytest.mark.parametrize("id_, error", [
    ("lwrl/cartpole-balance-mujoco-v1", gymnasium.error.VersionNotFound),
    ("lwrl/cartpole-swingup-mujoco-v0", gymnasium.error.NameNotFound),
    ("lwrl/mountain_car-cost_to_go-mujoco-v0", gymnasium.error.NameNotFound),
    ("lwrk/cartpole-balance-mujoco-v0", gymnasium.error.NamespaceNotFound),
])
def test_bad_ids(id_, error):
    with pytest.raises(error):
        gymnasium.make(id_)


@pytest.mark.parametrize("id_, options, message", [
    ("lwrl/cartpole-balance-mujoco-v0", {"integrator": "explicit"},
     "unknown option 'integrator' for cartpole.balance on the mujoco plant; allowed: time_limit, track_limit"),
    ("lwrl/mountain_car-cost_to_go-analytic-v0", {"track_limit": 1.0},
     "unknown option 'track_limit' .*allowed: time_limit, params, observation_noise, "
     "action_delay, action_noise$"),
    ("lwrl/pendulum-swingup-analytic-v0", {"seed": 3}, "seed the environment with reset\\(seed=...\\)"),
    ("lwrl/pendulum-swingup-analytic-v0", {"integrator": "rk4"}, "unknown integrator 'rk4'"),
    ("lwrl/pendulum-swingup-analytic-v0", {"time_limit": -1}, "time_limit must be a positive number"),
    ("lwrl/cartpole-balance-analytic-v0", {"track_limit": 0}, "track_limit must be a positive"),
    ("lwrl/cartpole-balance-mujoco-v0", {"plant": "analytic"},
     "lwrl/cartpole-balance-mujoco-v0 is cartpole.balance on the mujoco plant.*"
     "use lwrl/cartpole-balance-analytic-v0"),
    ("lwrl/cartpole-balance-mujoco-v0", {"plant": "ode"}, "unknown plant 'ode' for cartpole"),
])
def test_bad_make_options(id_, options, message):
    with pytest.raises(ValueError, match=message):
        gymnasium.make(id_, **options)


def test_no_rendering_without_a_render_mode():
    """Frames are drawn only when asked for (`tests/test_gymnasium_render.py`)."""
    env = gymnasium.make("lwrl/cartpole-balance-mujoco-v0")
    env.reset(seed=0)
    assert env.render() is None and env.unwrapped._painter is None


@pytest.mark.parametrize("action", [2, -1, 0.5, "1", None])
def test_bad_actions(action):
    env = SuiteEnv("cartpole", "balance", "analytic")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must be an integer in 0..1"):
        env.step(action)
    env.step(np.int64(1))
    env.step(np.array(0))


@pytest.mark.parametrize("options, message", [
    ({"start": [0.0, 0.0]}, "unknown reset option 'start'; allowed: state"),
    ({"state": [0.0, 0.0, 0.0]}, "state must have 2 entries"),
    ({"state": [[0.0, 0.0]]}, r"reset state must have shape \(2,\)"),
    ({"state": [np.nan, 0.0]}, "state must be finite"),
    ({"state": [0.51, 0.0]}, "is terminal"),
    ({"state": [-1.3, 0.0]}, "outside the observation space"),
    ({"state": [0.0, 0.08]}, "outside the observation space"),
])
def test_bad_reset_options(options, message):
    env = gymnasium.make("lwrl/mountain_car-cost_to_go-analytic-v0")
    env.reset(seed=0)
    env.step(0)
    with pytest.raises(ValueError, match=message):
        env.reset(seed=0, options=options)
    with pytest.raises(RuntimeError, match="episode has ended"):
        env.step(0)  # a failed reset ends the episode before it and starts none


def test_reset_to_a_state():
    """options={"state": s} starts in s (angles as the plant holds them: the observation
    wraps them); the random start is still drawn, so later starts are those of a plain
    reset."""
    env = gymnasium.make("lwrl/pendulum-swingup-mujoco-v0")
    observation, info = env.reset(seed=4, options={"state": [3 * np.pi / 2, 0.5]})
    assert observation == pytest.approx([-np.pi / 2, 0.5], abs=1e-12)
    assert info == {"uptime_s": 0.0, "steps": 0, "plant": "mujoco"}
    after_state = env.reset()[0]
    env.reset(seed=4)
    assert np.array_equal(after_state, env.reset()[0])
    observation, *_ = env.step(1)
    assert observation in env.observation_space


# Continuous actions ---------------------------------------------------------------------

def _expected_warnings(env) -> set:
    """`check_env`'s warnings for an lwrl environment: an infinite bound of the observation
    Box where a variable is unbounded, and for a Box of actions outside [-1, 1] its advice
    to normalise (given for Gymnasium's own Pendulum-v1 too: lwrl's action is the control
    in its units)."""
    expected = set()
    space = env.observation_space
    if np.any(np.isneginf(space.low)):
        expected.add("A Box observation space minimum value is -infinity. This is probably too low.")
    if np.any(np.isposinf(space.high)):
        expected.add("A Box observation space maximum value is infinity. This is probably too high.")
    actions = env.action_space
    if isinstance(actions, gymnasium.spaces.Box) and np.any(np.abs(actions.high) > 1):
        expected.add("For Box action spaces, we recommend using a symmetric and normalized space "
                     "(range=[-1, 1] or [0, 1]). See https://stable-baselines3.readthedocs.io/en/"
                     "master/guide/rl_tips.html for more information.")
    return expected


def test_continuous_ids_are_registered_beside_the_discrete():
    """lwrl/{domain}-{task}-{plant}-continuous-v0 for every id of discrete actions: SuiteEnv
    with actions="continuous", a float64 Box of shape (1,) over the actuator's range."""
    assert CONTINUOUS_ENV_IDS == tuple(id_.replace("-v0", "-continuous-v0") for id_ in ENV_IDS)
    for (domain, task, plant), id_ in zip(TASK_PLANTS, CONTINUOUS_ENV_IDS):
        assert id_ == env_id(domain, task, plant, "continuous")
        spec = gymnasium.spec(id_)
        assert spec.entry_point == "lwrl.gym:SuiteEnv"
        assert spec.max_episode_steps == tasks.definition(domain, task).step_limit
        assert spec.kwargs == {"domain": domain, "task": task, "plant": plant,
                               "actions": "continuous"}
        low, high = tasks.definition(domain, task).control_range
        env = gymnasium.make(id_)
        assert env.action_space == gymnasium.spaces.Box(low, high, (1,), np.float64)
        assert env.unwrapped.actions == "continuous"


def test_each_task_has_an_id_without_a_plant_on_its_default_plant():
    """lwrl/{domain}-{task}-v0 (and -continuous-v0) is the task on the domain's first plant,
    as `tasks.load` takes it; kwargs cannot move it to another plant."""
    assert len(DEFAULT_ENV_IDS) == 2 * len(tasks.ALL_TASKS)
    for domain, task in tasks.ALL_TASKS:
        for actions in ("discrete", "continuous"):
            id_ = env_id(domain, task, None, actions)
            assert id_ in DEFAULT_ENV_IDS and "--" not in id_
            env = gymnasium.make(id_).unwrapped
            assert (env.domain, env.task_name, env.actions) == (domain, task, actions)
            assert env.plant == tasks.ENVIRONMENT_PLANTS[domain][0]
    assert gymnasium.make("lwrl/pendulum-swingup-v0").unwrapped.plant == "mujoco"
    with pytest.raises(ValueError, match="lwrl/pendulum-swingup-v0 is pendulum.swingup on the "
                                         "mujoco plant; make.. kwargs asked for"):
        gymnasium.make("lwrl/pendulum-swingup-v0", plant="analytic")


@pytest.mark.parametrize("id_", ["lwrl/pendulum-swingup-continuous-v0",
                                 "lwrl/cartpole-balance-continuous-v0"])
def test_rescale_action_gives_a_learner_actions_in_minus_one_to_one(id_):
    """Gymnasium's RescaleAction maps [-1, 1] onto the actuator's range: the checker's
    normalisation advice goes, and -1, 0, +1 command the range's ends and its middle."""
    env = gymnasium.wrappers.RescaleAction(gymnasium.make(id_), -1.0, 1.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    assert not [w for w in caught if "normalis" in str(w.message).lower()
                or "symmetric" in str(w.message).lower()], [str(w.message) for w in caught]
    low, high = env.unwrapped.definition.control_range
    assert env.action_space == gymnasium.spaces.Box(-1.0, 1.0, (1,), np.float64)
    for action, control in ((-1.0, low), (0.0, (low + high) / 2), (1.0, high)):
        assert env.action(np.array([action])) == pytest.approx([control])


@pytest.mark.parametrize("id_", CONTINUOUS_ENV_IDS)
def test_check_env_continuous(id_):
    """Gymnasium's env checker passes on every continuous variant, with only the warnings
    `_expected_warnings` names (the normalisation advice for the pendulum's and the
    cart-pole's ranges)."""
    env = gymnasium.make(id_).unwrapped
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    messages = {str(w.message).removeprefix("\x1b[33mWARN: ").removesuffix("\x1b[0m")
                for w in caught}
    assert messages == _expected_warnings(env)


@pytest.mark.parametrize("domain, task, plant, options", [
    ("mountain_car", "cost_to_go", "analytic", {"time_limit": 300, "action_noise": 0.2}),
    ("pendulum", "swingup", "mujoco", {"time_limit": 1.0, "action_delay": 2}),
    ("cartpole", "balance", "analytic", {"track_limit": 0.5, "action_noise": 3.0}),
    ("acrobot", "swingup", "mujoco", {"time_limit": 10.0}),
])
def test_continuous_trajectories_equal_the_dm_env(domain, task, plant, options):
    """With the same seed and continuous actions inside and outside the range (float64 and
    float32), the Gymnasium environment's episodes are the dm_env environment's exactly."""
    seed = 21
    gym_env = gymnasium.make(env_id(domain, task, plant, "continuous"), **options)
    dm_env = tasks.load(domain, task, plant=plant, seed=seed, actions="continuous", **options)
    rng = np.random.default_rng(3)
    high = gym_env.action_space.high
    observation, _ = gym_env.reset(seed=seed)
    outside = 0
    for _ in range(3):
        time_step = dm_env.reset()
        assert np.array_equal(observation, list(time_step.observation.values()))
        while not time_step.last():
            action = rng.uniform(-2 * high, 2 * high).astype(rng.choice([np.float64, np.float32]))
            outside += int(action not in gym_env.action_space)
            observation, reward, terminated, truncated, info = gym_env.step(action)
            time_step = dm_env.step(action)
            assert np.array_equal(observation, list(time_step.observation.values()))
            assert reward == time_step.reward and info["steps"] == dm_env.task.steps
            assert terminated == (time_step.last() and time_step.discount == 0.0)
            assert truncated == (time_step.last() and time_step.discount == 1.0)
        observation, _ = gym_env.reset()
    assert outside > 10


@pytest.mark.parametrize("action, message", [
    (np.array([np.nan]), r"action must be a finite torque \(clipped to the actuator's range, "
                         r"\[-5, 5\]\); got \[nan\]$"),
    (np.array([np.inf]), "action must be a finite torque"),
    (np.array([1.0, 2.0]), r"action must be one torque, a number or an array of shape \(1,\)"),
    ("1", "action must be a finite torque"),
])
def test_bad_continuous_actions(action, message):
    env = gymnasium.make("lwrl/pendulum-swingup-analytic-continuous-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step(action)
    env.step(np.array([7.5]))  # outside: clipped to 5 N m


def test_kwargs_cannot_change_the_kind_of_action():
    with pytest.raises(ValueError, match="with continuous actions; make\\(\\) kwargs asked for "
                                         "pendulum.swingup on the analytic plant: use "
                                         "lwrl/pendulum-swingup-analytic-v0 instead"):
        gymnasium.make("lwrl/pendulum-swingup-analytic-continuous-v0", actions="discrete")
    with pytest.raises(ValueError, match="use lwrl/cartpole-balance-mujoco-continuous-v0"):
        gymnasium.make("lwrl/cartpole-balance-mujoco-v0", actions="continuous")
    with pytest.raises(ValueError, match="actions must be one of: discrete, continuous"):
        SuiteVectorEnv("cartpole", "balance", "analytic", num_envs=2, actions="box")



# Episode length as Gymnasium's ids state it ---------------------------------------------

@pytest.mark.parametrize("env_id", [*DEFAULT_ENV_IDS, *ENV_IDS])
def test_every_id_states_the_task_s_step_limit(env_id):
    """`env.spec.max_episode_steps` is the task's own limit, and `make` wraps `TimeLimit`."""
    spec = gymnasium.spec(env_id)
    definition = tasks.resolve_environment(spec.kwargs["domain"], spec.kwargs["task"],
                                           spec.kwargs["plant"])[0]
    assert spec.max_episode_steps == definition.step_limit
    env = gymnasium.make(env_id)
    assert env.spec.max_episode_steps == definition.step_limit
    assert any(isinstance(wrapper, gymnasium.wrappers.TimeLimit) for wrapper in _wrappers(env))
    env.close()


def test_the_shorter_of_time_limit_and_max_episode_steps_ends_an_episode():
    """A pendulum episode (no terminal state) ends truncated at the earlier limit."""
    for kwargs, steps in (({"max_episode_steps": 7}, 7), ({"time_limit": 0.1}, 5),
                          ({"time_limit": 0.2, "max_episode_steps": 20}, 10)):
        env = gymnasium.make("lwrl/pendulum-swingup-analytic-v0", **kwargs)
        env.reset(seed=0)
        for taken in range(1, steps + 1):
            _, _, terminated, truncated, _ = env.step(0)
            assert not terminated and truncated == (taken == steps), (kwargs, taken)


def test_vector_environment_truncates_at_max_episode_steps():
    """`make_vec` passes the id's `max_episode_steps`; a smaller one truncates the copies
    there, a bad one is refused in one line."""
    envs = gymnasium.make_vec("lwrl/pendulum-swingup-analytic-v0", num_envs=2,
                              vectorization_mode="vector_entry_point", max_episode_steps=4)
    envs.reset(seed=0)
    for taken in range(1, 5):
        _, _, terminated, truncated, _ = envs.step(np.zeros(2, dtype=np.int64))
        assert not terminated.any() and truncated.all() == (taken == 4)
    envs.close()
    with pytest.raises(ValueError, match="max_episode_steps must be a positive integer"):
        SuiteVectorEnv("pendulum", "swingup", "analytic", max_episode_steps=0)
