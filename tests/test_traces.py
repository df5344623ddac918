"""Eligibility traces (eq. 2, 5 and 6) and the flush of tiny traces."""

import numba
import numpy as np
import pytest

from lwrl.agent.traces import ACCUMULATING, FLUSH_THRESHOLD, REPLACING, REPLACING_RESET, update_

RULES = [ACCUMULATING, REPLACING, REPLACING_RESET]
accumulating_, replacing_, replacing_reset_unused_ = RULES


def updated(rule, e, phi, action, gamma_lambda):
    """The traces `(N, A)` after one update (with no weight change), leaving `e` as it was;
    `update_` stores them action-major, `(A, N)`."""
    e = np.array(e, dtype=np.float64).T.copy()
    update_(rule, e, np.zeros_like(e), np.array(phi, dtype=np.float64), action, gamma_lambda, 0.0)
    return e.T


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
    accumulating, replacing = np.zeros((2, 8)), np.zeros((2, 8))
    weights = np.zeros((2, 8))
    most_accumulated = 0.0
    for _ in range(1000):
        phi = rng.dirichlet(np.full(8, 0.3))  # >= 0, sums to 1, like NRBF features
        action = rng.integers(2)
        update_(ACCUMULATING, accumulating, weights, phi, action, 0.9, 0.0)
        update_(REPLACING, replacing, weights, phi, action, 0.9, 0.0)
        assert replacing.max() <= 1.0
        most_accumulated = max(most_accumulated, accumulating.max())
    assert most_accumulated > 1.0


def test_weights_move_by_step_times_the_new_traces():
    """Eq. 1: w <- w + alpha delta e, with e the traces after this step's rule; here
    e = [[0.45, 0.25], [0.09, 0.75]] (the replacing case above) and alpha delta = -2."""
    e = np.array(E).T.copy()
    w = np.array([[1.0, 2.0], [3.0, 4.0]]).T.copy()
    update_(REPLACING, e, w, np.array(PHI), 1, 0.9, -2.0)
    np.testing.assert_allclose(w.T, [[1.0 - 0.9, 2.0 - 0.5], [3.0 - 0.18, 4.0 - 1.5]], rtol=0, atol=1e-15)


def test_tiny_traces_are_flushed():
    """Traces that decay below 1e-100 become 0 (subnormals slow every later pass); 1e-100
    itself and larger ones stay."""
    e = np.array([[1e-101, 2e-100, 5e-324, FLUSH_THRESHOLD / 0.5]])
    update_(REPLACING, e, np.zeros((1, 4)), np.zeros(4), 0, 0.5, 0.0)
    np.testing.assert_array_equal(e, [[0.0, 1e-100, 0.0, FLUSH_THRESHOLD]])


@pytest.mark.parametrize("rule", RULES)
def test_bad_input_raises_one_clear_line(rule):
    e = np.zeros((3, 2))
    with pytest.raises(ValueError, match=r"traces e and weights w must have shape \(A, N\)"):
        update_(rule, e, e, np.zeros(3), 0, 0.9, 0.0)
    with pytest.raises(ValueError, match=r"traces e and weights w must have shape \(A, N\)"):
        update_(rule, e, np.zeros((3, 3)), np.zeros(2), 0, 0.9, 0.0)
    for action in (-1, 3):
        with pytest.raises(ValueError, match=r"action must be an index in \[0, A\)"):
            update_(rule, e, e.copy(), np.zeros(2), action, 0.9, 0.0)


@numba.njit
def _batch_update(e, w, phi, actions, gamma_lambda, step):
    """One update of each agent of a batch under each rule, compiled."""
    for b in range(e.shape[0]):
        for r in range(3):
            update_(r, e[b, r], w[b, r], phi[b], actions[b], gamma_lambda, step)


def test_rules_compiled_in_numba_equal_python():
    rng = np.random.default_rng(3)
    e = rng.uniform(0.0, 1.0, size=(4, 3, 2, 5))  # (agents, rule, A, N)
    e[0, :, :, 0] = 1e-120
    w = rng.normal(size=e.shape)
    phi = rng.dirichlet(np.ones(5), size=4)
    actions = rng.integers(2, size=4)
    expected_e, expected_w = e.copy(), w.copy()
    for b in range(4):
        for r in range(3):
            update_(r, expected_e[b, r], expected_w[b, r], phi[b], actions[b], 0.7, 0.3)
    _batch_update(e, w, phi, actions, 0.7, 0.3)
    np.testing.assert_array_equal(e, expected_e)
    np.testing.assert_array_equal(w, expected_w)
    assert np.all(e[0, :, 1 - actions[0], 0] == 0.0)  # 0.7 * 1e-120 flushed or reset
