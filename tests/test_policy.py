"""Per-agent random streams and epsilon-greedy action choice."""

import numba
import numpy as np
import pytest

from lwrl.agent.policy import epsilon_greedy
from lwrl.agent.streams import seed_streams, uniform


@numba.njit
def _draws(streams, i, count):
    out = np.empty(count)
    for k in range(count):
        out[k] = uniform(streams, i)
    return out


@numba.njit
def _choices(q, epsilon, streams, count):
    out = np.empty(count, dtype=np.int64)
    for k in range(count):
        out[k] = epsilon_greedy(q, epsilon, streams, 0)
    return out


def test_splitmix64_reference_value():
    """SplitMix64 from state 0 first outputs 0xE220A8397B1DCDAF (the reference
    implementation); its top 53 bits over 2^53 are the float."""
    assert _draws(seed_streams([0]), 0, 1)[0] == (0xE220A8397B1DCDAF >> 11) * 2.0 ** -53


def test_streams_are_independent_of_the_batch():
    """Agent i's draws depend on its seed only, not on its neighbours or their draws."""
    alone = _draws(seed_streams([7]), 0, 50)
    batch = seed_streams([3, 7, 9])
    _draws(batch, 0, 13)
    np.testing.assert_array_equal(_draws(batch, 1, 50), alone)


def test_uniform_draws_cover_the_unit_interval():
    draws = _draws(seed_streams([11]), 0, 100_000)
    assert draws.min() >= 0.0 and draws.max() < 1.0
    assert abs(draws.mean() - 0.5) < 0.005 and abs(draws.var() - 1 / 12) < 0.002


def test_bad_seeds():
    with pytest.raises(ValueError, match="non-negative integers"):
        seed_streams([-1])
    with pytest.raises(ValueError, match="non-negative integers"):
        seed_streams([0.5])


def test_greedy_picks_the_best_action():
    assert set(_choices(np.array([0.0, 2.0, -1.0]), 0.0, seed_streams([1]), 200)) == {1}


def test_ties_are_broken_uniformly():
    """All-zero values (the first episode): each action is picked a third of the time."""
    counts = np.bincount(_choices(np.zeros(3), 0.0, seed_streams([2]), 30_000), minlength=3)
    np.testing.assert_allclose(counts / 30_000, 1 / 3, atol=0.015)
    counts = np.bincount(_choices(np.array([1.0, 0.0, 1.0]), 0.0, seed_streams([2]), 30_000), minlength=3)
    assert counts[1] == 0 and abs(counts[0] - counts[2]) < 800


def test_epsilon_explores_uniformly():
    """With epsilon = 0.3 and one best action of three, the others get 0.1 each."""
    counts = np.bincount(_choices(np.array([5.0, 0.0, 0.0]), 0.3, seed_streams([4]), 50_000), minlength=3)
    np.testing.assert_allclose(counts / 50_000, [0.8, 0.1, 0.1], atol=0.01)
