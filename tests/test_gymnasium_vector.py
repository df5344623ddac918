"""The suite's vector environments (`gymnasium.make_vec`, backed by `tasks.batched`): the
spaces and metadata Gymnasium expects, its default autoreset, and step by step the
transitions, infos and autoresets of Gymnasium's own `SyncVectorEnv` over the single
environments, to the bit."""

import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import data_equivalence  # noqa: E402
from gymnasium.utils.passive_env_checker import check_action_space, check_observation_space  # noqa: E402
from gymnasium.vector import AutoresetMode, SyncVectorEnv  # noqa: E402

from lwrl.gym import CONTINUOUS_ENV_IDS, ENV_IDS, SuiteVectorEnv  # noqa: E402
from conftest import short_time_limit  # noqa: E402

pytestmark = pytest.mark.filterwarnings("error")

SHORT = {"mountain_car": 60, "pendulum": 0.4, "cartpole": 240.0, "acrobot": 6.0}
"""A time limit per domain short enough that random episodes end often (the cart-pole's
fail on their own; `short_time_limit`: 20 steps for a domain of another package)."""


def random_actions(env, rng):
    """One random action per copy: an index, or a continuous control drawn over twice the
    Box's range, about half of them outside it (clipped, in both environments alike)."""
    space = env.single_action_space
    if isinstance(space, gymnasium.spaces.Discrete):
        return rng.integers(0, space.n, env.num_envs)
    return rng.uniform(-2 * space.high, 2 * space.high, (env.num_envs, 1))


def make_both(id_, num_envs=4, **kwargs):
    domain = id_.split("/")[1].split("-")[0]
    kwargs.setdefault("time_limit", short_time_limit(SHORT, domain))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # make_vec warns of missing or wrong autoreset metadata
        ours = gymnasium.make_vec(id_, num_envs=num_envs, **kwargs)
    reference = gymnasium.make_vec(id_, num_envs=num_envs, vectorization_mode="sync", **kwargs)
    return ours, reference


@pytest.mark.parametrize("id_", ENV_IDS + CONTINUOUS_ENV_IDS)
def test_make_vec_gives_the_batched_vector_environment(id_):
    ours, reference = make_both(id_)
    assert isinstance(ours, SuiteVectorEnv) and isinstance(reference, SyncVectorEnv)
    assert ours.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    assert ours.metadata["autoreset_mode"] == reference.metadata["autoreset_mode"]
    check_action_space(ours.single_action_space)
    check_observation_space(ours.single_observation_space)
    for space in ("single_action_space", "action_space", "single_observation_space",
                  "observation_space"):
        assert getattr(ours, space) == getattr(reference, space), space
    assert ours.num_envs == 4 and ours.spec.id == id_


@pytest.mark.parametrize("id_", ENV_IDS + CONTINUOUS_ENV_IDS)
def test_the_same_transitions_as_the_single_environments(id_):
    """Random actions for 400 steps: every observation, reward, termination, truncation and
    info equals `SyncVectorEnv`'s over `SuiteEnv`, autoresets included (several episodes
    end in each copy), after a seeded reset and after a reset that continues the streams;
    continuous actions inside and outside the range alike."""
    ours, reference = make_both(id_)
    actions = np.random.default_rng(0)
    ended = 0
    for seed in (3, None):
        first = ours.reset(seed=seed), reference.reset(seed=seed)
        assert data_equivalence(*first, exact=True), first
        assert first[0][0] in ours.observation_space
        for _ in range(400):
            action = random_actions(ours, actions)
            ours_step, reference_step = ours.step(action), reference.step(action)
            assert data_equivalence(ours_step, reference_step, exact=True), (ours_step, reference_step)
            assert ours_step[0] in ours.observation_space
            ended += int(np.sum(ours_step[2] | ours_step[3]))
    assert ended >= 8


def test_the_autoreset_step_returns_the_first_observation_and_ignores_the_action():
    env = gymnasium.make_vec("lwrl/pendulum-swingup-analytic-v0", num_envs=2, time_limit=0.04)
    env.reset(seed=0)
    env.step([0, 1])
    observation, reward, terminated, truncated, info = env.step([1, 1])
    assert truncated.tolist() == [True, True] and not terminated.any()
    restarted = env.step([0, 1])
    again = gymnasium.make_vec("lwrl/pendulum-swingup-analytic-v0", num_envs=2, time_limit=0.04)
    again.reset(seed=0)
    for _ in range(2):
        again.step([1, 0])
    assert data_equivalence(restarted, again.step([1, 0]), exact=True)
    assert restarted[1].tolist() == [0.0, 0.0] and restarted[4]["steps"].tolist() == [0, 0]


def test_a_vector_wrapper_of_gymnasium_counts_the_same_episodes():
    """`RecordEpisodeStatistics` (a vector wrapper of Gymnasium's) over both."""
    ours, reference = (gymnasium.wrappers.vector.RecordEpisodeStatistics(env)
                       for env in make_both("lwrl/cartpole-balance-analytic-v0", num_envs=3))
    for env in (ours, reference):
        env.reset(seed=1)
        env.action_space.seed(1)
        for _ in range(300):
            env.step(env.action_space.sample())
    assert len(ours.return_queue) >= 10
    assert list(ours.return_queue) == list(reference.return_queue)
    assert list(ours.length_queue) == list(reference.length_queue)


@pytest.mark.parametrize("kwargs, message", [
    ({"num_envs": 0}, "num_envs must be a positive integer; got 0"),
    ({"autoreset_mode": AutoresetMode.SAME_STEP}, "autoreset_mode must be"),
    ({"render_mode": "rgb_array"}, "the vector environment does not render"),
    ({"time_limit": 0.03}, "time_limit must be a whole number of control steps of 0.02"),
    ({"gravity": 1.0}, "unknown option 'gravity'"),
])
def test_bad_vector_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        SuiteVectorEnv("pendulum", "swingup", "analytic", **{"num_envs": 2, **kwargs})


def test_bad_vector_steps():
    env = SuiteVectorEnv("cartpole", "balance", "analytic", num_envs=2)
    with pytest.raises(RuntimeError, match="call reset"):
        env.step([0, 1])
    env.reset(seed=0)
    for actions in ([0], [0, 2], [0.5, 1], [[0, 1]]):
        with pytest.raises(ValueError, match=r"^actions? must (be an integer index in 0..1|have "
                                             r"shape \(2,\), one per environment)"):
            env.step(actions)
    with pytest.raises(ValueError, match="seed must be an integer or 2 seeds"):
        env.reset(seed=[1, 2, 3])


def test_continuous_actions_are_a_box_of_one_control_per_copy():
    """`(B, 1)` float64 over the actuator's range; `(B,)` is taken too, and a NaN refused."""
    env = gymnasium.make_vec("lwrl/cartpole-balance-analytic-continuous-v0", num_envs=3)
    assert env.single_action_space == gymnasium.spaces.Box(-10.0, 10.0, (1,), np.float64)
    assert env.action_space == gymnasium.spaces.Box(-10.0, 10.0, (3, 1), np.float64)
    env.reset(seed=0)
    flat = env.step(np.array([-20.0, 0.5, 20.0]))
    again = gymnasium.make_vec("lwrl/cartpole-balance-analytic-continuous-v0", num_envs=3)
    again.reset(seed=0)
    assert data_equivalence(flat, again.step(np.array([[-10.0], [0.5], [10.0]])), exact=True)
    with pytest.raises(ValueError, match=r"^action must be a finite force"):
        env.step(np.array([[0.0], [np.nan], [0.0]]))

