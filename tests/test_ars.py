"""ARS (`agent.ars`, its equations in `agent.random_search`): one update against a
hand-computed case, V2's normaliser, the rollouts' steps counted against the budget, the
update after every 2N episodes, learning on Mountain-Car, and its settings refused in one
line."""

import numpy as np
import pytest

pytest.importorskip("jax", reason="ARS needs the jax extra: pip install 'lwrl[jax]'")

from lwrl import agent as learners  # noqa: E402
from lwrl.agent import random_search, running_stats  # noqa: E402
from lwrl.agent.arithmetic import Count  # noqa: E402
from lwrl.agent.jax_population import jax_modules  # noqa: E402
from lwrl.runners.config import RunConfig  # noqa: E402
from lwrl.runners.run import run  # noqa: E402
from conftest import one_line_error  # noqa: E402

jax, jnp = jax_modules()  # in 64 bits, as the learner runs
DELTAS = jnp.array([[[1.0, 0.0]], [[0.0, 1.0]]])
PLUS, MINUS = jnp.array([3.0, 1.0]), jnp.array([1.0, 2.0])


def test_one_step_by_hand_with_the_top_direction():
    """max(r+, r-) = (3, 2): the top direction is the first; its returns 3 and 1 have
    sigma_R 1, so theta = 0 + 0.5 / (1 * 1) * (3 - 1) delta_1 = (1, 0)."""
    theta = random_search.ars_step(jnp.zeros((1, 2)), DELTAS, PLUS, MINUS, 0.5, 1)
    np.testing.assert_allclose(theta, [[1.0, 0.0]])


def test_one_step_by_hand_with_both_directions():
    """Returns 3, 1, 1, 2: sigma_R = sqrt(2.75 / 4); theta = 0.5 / (2 sigma_R) (2 delta_1 -
    delta_2)."""
    theta = random_search.ars_step(jnp.zeros((1, 2)), DELTAS, PLUS, MINUS, 0.5, 2)
    np.testing.assert_allclose(theta, [[0.5 / (2 * np.sqrt(2.75 / 4)) * 2,
                                        -0.5 / (2 * np.sqrt(2.75 / 4))]], rtol=1e-12)


def test_equal_returns_leave_the_policy():
    theta = jnp.array([[0.3, -0.2]])
    same = jnp.array([-5.0, -5.0])
    np.testing.assert_array_equal(random_search.ars_step(theta, DELTAS, same, same, 0.5, 2), theta)


def test_v2_normalises_by_the_running_mean_and_standard_deviation():
    """The states' mean and sample standard deviation (ARS's `RunningStat`); a variable that
    never changed reads 0; from one sample the variance is mu^2 (`RunningStat.var`)."""
    samples = np.random.default_rng(4).normal(2.0, 3.0, size=(30, 3))
    samples[:, 2] = 1.5
    stats = running_stats.stats_start(3)
    stats = running_stats.stats_add(stats, samples[0])
    _, std = random_search.v2_scale(stats)
    np.testing.assert_allclose(std, np.abs(samples[0]))
    for sample in samples[1:]:
        stats = running_stats.stats_add(stats, sample)
    mean, std = random_search.v2_scale(stats)
    np.testing.assert_allclose(mean[:2], samples[:, :2].mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(std[:2], samples[:, :2].std(axis=0, ddof=1), rtol=1e-12)
    x = np.array([1.0, -1.0, 7.0])
    read = random_search.v2_state(x, mean, std)
    np.testing.assert_allclose(read[:2], (x[:2] - mean[:2]) / (std[:2] + 1e-8))
    assert read[2] == 0.0


def config(**settings) -> RunConfig:
    base = dict(task="mountain_car.cost_to_go", learner="ars", agents=3, episodes=4, seed=1,
                task_options={"time_limit": 200.0}, directions=2, delta_std=0.5, learning_rate=0.1)
    return RunConfig(**{**base, **settings})


def test_every_rollout_s_steps_count_against_the_budget():
    """A budget of 1000 steps: each agent's episodes (its rollouts) sum to it, the last one
    cut, and its clock counts them all."""
    agents, results = run(config(episodes=100, budget=1000))
    np.testing.assert_array_equal(np.nansum(results.steps, axis=1), 1000)
    np.testing.assert_array_equal(agents.clocks, 1000)


def test_the_policy_moves_after_every_2n_episodes():
    """N = 2: after 3 episodes the policy is still 0; after 4 it has moved for the agents
    whose four returns differ."""
    three, _ = run(config(episodes=3))
    assert not np.any(np.asarray(three.state["theta"]))
    four, results = run(config(episodes=4))
    differ = np.ptp(results.returns, axis=1) > 0
    assert differ.any()
    moved = np.any(np.asarray(four.state["theta"]) != 0, axis=(1, 2))
    np.testing.assert_array_equal(moved, differ)


def test_ars_learns_mountain_car():
    """Four agents, 80 episodes of at most 200 steps: the last eight take at most 60 % of the
    first eight's steps (about 160)."""
    _, results = run(config(agents=4, episodes=80, seed=0))
    first, last = results.steps[:, :8].mean(), results.steps[:, -8:].mean()
    assert first > 120 and last < 0.6 * first, (first, last)


@pytest.mark.parametrize("settings, message", [
    (dict(learning_rate=-0.1), "learning_rate must be a finite number > 0"),
    (dict(directions=2, top=3), "top must be at most directions (2)"),
    (dict(directions=0), "directions must be an integer >= 1"),
    (dict(delta_std=-1.0), "delta_std must be a finite number >= 0"),
])
def test_bad_settings_are_refused_in_one_line(settings, message):
    one_line_error(lambda: config(**settings), message)


def test_ars_counts_its_arithmetic_by_hand():
    """Mountain-Car (3 actions x 2 variables), V2, N = b = 8: a decision is 3·2 scores and 2
    for the normalisation; a step adds 3·2 for the perturbed policy and 2·2 for the
    statistics, and 1/16 of the iteration's 8·6 + 4·8 + 2·2 and 2 square roots."""
    counts = learners.learner("ars").arithmetic(config(directions=8).settings, config().task_spec)
    assert counts.decision == Count(8)
    assert counts.update == Count(6 + 4 + 84 / 16, 2 / 16)
    assert counts.step == counts.decision + counts.update
