"""Eligibility traces (eq. 2, 5 and 6) and the flush of tiny traces."""

import numba
import numpy as np
import pytest

from agent.traces import (FLUSH_THRESHOLD, accumulating_, flush_tiny_, replacing_,
                          replacing_reset_unused_)

RULES = [accumulating_, replacing_, replacing_reset_unused_]


def updated(rule, e, phi, action, gamma_lambda):
    """The traces after one update, leaving `e` as it was."""
    e = np.array(e, dtype=np.float64)
    rule(e, np.array(phi, dtype=np.float64), action, gamma_lambda)
    return e


def gradient(phi, action, num_actions):
    """dQ(s, a)/dw: phi in the taken action's column, 0 elsewhere."""
    grad = np.zeros((len(phi), num_actions))
    grad[:, action] = phi
    return grad


E = [[0.5, 0.2], [0.1, 0.0]]
PHI = [0.25, 0.75]


def test_accumulating_by_hand():
    # gamma lambda e = [[0.45, 0.18], [0.09, 0.0]]; action 1 adds phi to column 1:
    # [[0.45, 0.18 + 0.25], [0.09, 0.0 + 0.75]]
    np.testing.assert_allclose(updated(accumulating_, E, PHI, 1, 0.9),
                               [[0.45, 0.43], [0.09, 0.75]], rtol=0, atol=1e-15)


def test_replacing_by_hand():
    # gamma lambda e = [[0.45, 0.18], [0.09, 0.0]]; column 1 becomes max(decayed, phi):
    # [[0.45, max(0.18, 0.25)], [0.09, max(0.0, 0.75)]]
    np.testing.assert_allclose(updated(replacing_, E, PHI, 1, 0.9),
                               [[0.45, 0.25], [0.09, 0.75]], rtol=0, atol=1e-15)
    # the decayed trace wins where it is larger: max(0.9 * 0.4, 0.25) = 0.36
    np.testing.assert_allclose(updated(replacing_, [[0.5, 0.4], [0.1, 0.0]], PHI, 1, 0.9),
                               [[0.45, 0.36], [0.09, 0.75]], rtol=0, atol=1e-15)


def test_replacing_reset_unused_by_hand():
    # binary features: neurons 0 and 2 active, action 0. Active rows become [1, 0];
    # the inactive row decays: 0.9 * [0.1, 0.4] = [0.09, 0.36]
    e = [[0.5, 0.2], [0.1, 0.4], [0.3, 0.6]]
    np.testing.assert_allclose(updated(replacing_reset_unused_, e, [1.0, 0.0, 1.0], 0, 0.9),
                               [[1.0, 0.0], [0.09, 0.36], [1.0, 0.0]], rtol=0, atol=1e-15)


def test_replacing_does_not_reset_other_actions():
    """Eq. 6 only decays the other actions' traces; eq. 5 zeroes them on active features."""
    rng = np.random.default_rng(0)
    e = rng.uniform(0.0, 1.0, size=(6, 3))
    phi = np.array([0.0, 0.3, 0.0, 0.7, 0.0, 0.0])
    plain = updated(replacing_, e, phi, 2, 0.8)
    np.testing.assert_array_equal(plain[:, :2], 0.8 * e[:, :2])
    reset = updated(replacing_reset_unused_, e, phi, 2, 0.8)
    np.testing.assert_array_equal(reset[[1, 3], :2], 0.0)
    np.testing.assert_array_equal(reset[[0, 2, 4, 5], :2], 0.8 * e[[0, 2, 4, 5], :2])


@pytest.mark.parametrize("rule", RULES)
def test_lambda_zero_gives_the_gradient(rule):
    """With gamma lambda = 0 every trace is one-step Sarsa's gradient."""
    rng = np.random.default_rng(1)
    e = rng.uniform(0.0, 2.0, size=(5, 3))
    phi = np.array([0.0, 0.1, 0.6, 0.0, 0.3])
    np.testing.assert_array_equal(updated(rule, e, phi, 1, 0.0), gradient(phi, 1, 3))


def test_replacing_stays_at_most_one_accumulating_exceeds_it():
    rng = np.random.default_rng(2)
    accumulating, replacing = np.zeros((8, 2)), np.zeros((8, 2))
    most_accumulated = 0.0
    for _ in range(1000):
        phi = rng.dirichlet(np.full(8, 0.3))  # >= 0, sums to 1, like NRBF features
        action = rng.integers(2)
        accumulating_(accumulating, phi, action, 0.9)
        replacing_(replacing, phi, action, 0.9)
        assert replacing.max() <= 1.0
        most_accumulated = max(most_accumulated, accumulating.max())
    assert most_accumulated > 1.0


def test_flush_zeroes_only_tiny_entries():
    values = [1e-101, -1e-101, 5e-324, 0.0, FLUSH_THRESHOLD, 1e-99, -0.5, 0.5]
    e = np.array(values).reshape(2, 2, 2)  # any shape, e.g. a batch of agents
    flush_tiny_(e)
    np.testing.assert_array_equal(e.ravel(), [0.0, 0.0, 0.0, 0.0] + values[4:])
    batch = np.full((3, 4, 2), 1e-200)
    flush_tiny_(batch[:, 1:, 0])  # a non-contiguous view is flushed in place too
    assert np.all(batch[:, 1:, 0] == 0.0) and np.all(batch[:, 0, :] == 1e-200)


@pytest.mark.parametrize("rule", RULES)
def test_bad_input_raises_one_clear_line(rule):
    e = np.zeros((2, 3))
    with pytest.raises(ValueError, match=r"e must have shape \(N, A\) and features phi shape \(N,\)"):
        rule(e, np.zeros(3), 0, 0.9)
    with pytest.raises(ValueError, match=r"traces e must have shape \(N, A\)"):
        rule(np.zeros(2), np.zeros(2), 0, 0.9)
    for action in (-1, 3):
        with pytest.raises(ValueError, match=r"action must be an index in \[0, A\)"):
            rule(e, np.zeros(2), action, 0.9)


@numba.njit
def _batch_step(e, phi, actions, gamma_lambda):
    """One update of each agent of a batch: the three rules and the flush, compiled."""
    for b in range(e.shape[0]):
        accumulating_(e[b, 0], phi[b], actions[b], gamma_lambda)
        replacing_(e[b, 1], phi[b], actions[b], gamma_lambda)
        replacing_reset_unused_(e[b, 2], phi[b], actions[b], gamma_lambda)
    flush_tiny_(e)


def test_rules_compiled_in_numba_equal_python():
    rng = np.random.default_rng(3)
    e = rng.uniform(0.0, 1.0, size=(4, 3, 5, 2))  # (agents, rule, N, A)
    e[0, :, 0, :] = 1e-120
    phi = rng.dirichlet(np.ones(5), size=4)
    actions = rng.integers(2, size=4)
    expected = e.copy()
    for b in range(4):
        for r, rule in enumerate(RULES):
            rule(expected[b, r], phi[b], actions[b], 0.7)
    flush_tiny_(expected)
    _batch_step(e, phi, actions, 0.7)
    np.testing.assert_array_equal(e, expected)
    assert np.all(e[0, :, 0, 1 - actions[0]] == 0.0)  # 0.7 * 1e-120 flushed or reset
