"""NRBF features (eq. 8 and 9): normalised, factorised exactly, guarded against underflow."""

import itertools

import numba
import numpy as np
import pytest

from lwrl.agent.nrbf import DEFAULT_R2, NRBF, nrbf_features_into

LOWS = (-1.2, -0.07, -np.pi, -2.0)
HIGHS = (0.5, 0.07, np.pi, 3.0)
"""Ranges of up to four state variables (Mountain-Car's, then made up)."""


def network(d, n, r2=DEFAULT_R2):
    return NRBF(low=LOWS[:d], high=HIGHS[:d], n=n, r2=r2)


def to_task_units(net, normalised):
    """States in task units from states in normalised units."""
    low, high = np.array(net.low), np.array(net.high)
    return low + np.asarray(normalised) * (high - low)


def direct_nrbf(normalised_state, n, r2):
    """Eq. 8 and 9 evaluated over all n^d centroids, written independently of agent.nrbf."""
    d = len(normalised_state)
    phi = []
    for index in itertools.product(range(n), repeat=d):  # the last index varies fastest
        c = (np.array(index) + 0.5) / n
        phi.append(np.exp(-np.sum((normalised_state - c) ** 2) / r2))
    phi = np.array(phi)
    return phi / phi.sum()


@pytest.mark.parametrize("d", [1, 2, 3, 4])
def test_features_are_nonnegative_and_sum_to_one(d):
    net = network(d, n=5)
    rng = np.random.default_rng(d)
    states = to_task_units(net, rng.uniform(-3.0, 4.0, size=(7, 3, d)))  # in and out of range
    phibar = net.features(states)
    assert phibar.shape == (7, 3, 5 ** d)
    assert np.all(phibar >= 0)
    np.testing.assert_allclose(phibar.sum(axis=-1), 1.0, rtol=0, atol=1e-12)
    assert net.features(states[0, 0]).shape == (5 ** d,)


@pytest.mark.parametrize("d,n", [(1, 7), (2, 5), (3, 4), (4, 6)])
@pytest.mark.parametrize("r2", [DEFAULT_R2, 0.05])
def test_factorised_equals_direct_evaluation(d, n, r2):
    net = network(d, n, r2)
    rng = np.random.default_rng(10 * d + n)
    normalised = rng.uniform(-0.3, 1.3, size=(20, d))
    phibar = net.features(to_task_units(net, normalised))
    for row, s in zip(phibar, normalised):
        np.testing.assert_allclose(row, direct_nrbf(s, n, r2), rtol=0, atol=1e-12)


def test_centroids_are_cell_midpoints_in_c_order():
    net = network(d=3, n=4)
    expected = [(np.array(i) + 0.5) / 4 for i in itertools.product(range(4), repeat=3)]
    np.testing.assert_array_equal(net.centroids, expected)
    # neuron ravel_multi_index((i0, i1, i2)) sits at ((i0 + .5)/4, (i1 + .5)/4, (i2 + .5)/4)
    i = np.ravel_multi_index((2, 0, 3), (4, 4, 4))
    np.testing.assert_array_equal(net.centroids[i], [2.5 / 4, 0.5 / 4, 3.5 / 4])
    np.testing.assert_array_equal(net.centroids[1], [0.125, 0.125, 0.375])  # last varies fastest


@pytest.mark.parametrize("d,n", [(1, 6), (2, 4), (3, 3)])
def test_state_on_a_centroid_puts_its_largest_feature_there(d, n):
    net = network(d, n)
    phibar = net.features(to_task_units(net, net.centroids))
    np.testing.assert_array_equal(np.argmax(phibar, axis=-1), np.arange(net.num_features))


@pytest.mark.parametrize("d,n", [(1, 5), (2, 4), (2, 5), (4, 3)])
def test_state_in_the_middle_gives_symmetric_features(d, n):
    net = network(d, n)
    grid = net.features(to_task_units(net, np.full(d, 0.5))).reshape((n,) * d)
    for axis in range(d):
        np.testing.assert_allclose(grid, np.flip(grid, axis=axis), rtol=0, atol=1e-15)
    if d > 1:
        np.testing.assert_allclose(grid, grid.T, rtol=0, atol=1e-15)


@pytest.mark.parametrize("far", [20.0, 50.0, -1e3, 1e200, -1e300])
def test_underflow_guard_far_outside_the_range(far):
    """Far outside the range every unguarded RBF underflows; the features stay finite, sum
    to 1 and sit on the edge centroid. Beyond the clamp margin (M = 400 n r^2 = 24 here)
    the value is limited, which changes nothing (and keeps values too large for float64
    to tell the centroids apart, like 1e200, on the edge)."""
    net = network(d=2, n=6)
    centroid_grid = (np.arange(6) + 0.5) / 6
    with np.errstate(over="ignore"):
        assert np.all(np.exp(-(far - centroid_grid) ** 2 / DEFAULT_R2) == 0.0)  # unguarded: 0/0
    grid = net.features(to_task_units(net, [far, 0.37])).reshape(6, 6)
    assert np.all(np.isfinite(grid))
    assert grid.sum() == pytest.approx(1.0, abs=1e-12)
    edge = 5 if far > 0 else 0
    assert grid[edge].sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(grid[edge], direct_nrbf(np.array([0.37]), 6, DEFAULT_R2),
                               rtol=0, atol=1e-12)


def test_bad_input_raises_one_clear_line():
    with pytest.raises(ValueError, match=r"n \(centroids per dimension\) must be .* >= 2; got 1"):
        NRBF(low=(0.0,), high=(1.0,), n=1)
    with pytest.raises(ValueError, match=r"n .* must be an integer >= 2; got 2.5"):
        NRBF(low=(0.0,), high=(1.0,), n=2.5)
    for r2 in (0.0, -0.01, np.nan):
        with pytest.raises(ValueError, match=r"r2 \(the spread r\^2\) must be finite and > 0"):
            NRBF(low=(0.0,), high=(1.0,), n=3, r2=r2)
    with pytest.raises(ValueError, match=r"low must be finite and below a finite high .* got "
                                         r"low=\[0.0, 1.0\], high=\[1.0, 1.0\]"):
        NRBF(low=(0.0, 1.0), high=(1.0, 1.0), n=3)
    with pytest.raises(ValueError, match=r"same length d >= 1; got shapes \(2,\) and \(3,\)"):
        NRBF(low=(0.0, 0.0), high=(1.0, 1.0, 1.0), n=3)
    with pytest.raises(ValueError, match=r"same length d >= 1; got shapes \(0,\) and \(0,\)"):
        NRBF(low=(), high=(), n=3)
    net = network(d=2, n=3)
    with pytest.raises(ValueError, match=r"states must have shape \(\.\.\., 2\); got \(4, 3\)"):
        net.features(np.zeros((4, 3)))
    with pytest.raises(ValueError, match=r"states must have shape \(\.\.\., 2\); got \(\)"):
        net.features(0.0)
    with pytest.raises(ValueError, match="states must be finite"):
        net.features([np.nan, 0.0])
    with pytest.raises(ValueError, match=r"out must have shape \(n\^d,\)"):
        nrbf_features_into(np.zeros(2), np.zeros(2), np.ones(2), 3, 0.01, np.empty(8),
                           np.empty((2, 3)))
    with pytest.raises(ValueError, match=r"scratch must have shape \(d, n\)"):
        nrbf_features_into(np.zeros(2), np.zeros(2), np.ones(2), 3, 0.01, np.empty(9),
                           np.empty((3, 2)))


@numba.njit
def _features_one_by_one(states, low, high, n, r2):
    out = np.empty((states.shape[0], n ** states.shape[1]))
    scratch = np.empty((states.shape[1], n))
    for b in range(states.shape[0]):
        nrbf_features_into(states[b], low, high, n, r2, out[b], scratch)
    return out


@pytest.mark.parametrize("d", [1, 2, 4])
def test_single_state_function_equals_the_batch_method(d):
    """The jitable function, compiled in other numba code and run as plain Python, gives
    what `NRBF.features` gives."""
    net = network(d, n=6)
    low, high = np.array(net.low), np.array(net.high)
    states = to_task_units(net, np.random.default_rng(d).uniform(-1.0, 2.0, size=(9, d)))
    batch = net.features(states)
    np.testing.assert_allclose(_features_one_by_one(states, low, high, net.n, net.r2), batch,
                               rtol=0, atol=1e-15)
    out, scratch = np.full(net.num_features, np.nan), np.full((d, net.n), np.nan)
    for state, expected in zip(states, batch):
        nrbf_features_into(state, low, high, net.n, net.r2, out, scratch)
        np.testing.assert_allclose(out, expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize("d, n", [(1, 5), (2, 8), (3, 4), (4, 6)])
def test_the_features_are_the_factors_outer_product_multiplied_from_the_last(d, n):
    """Bit for bit `g_0 (g_1 (... g_{d-1}))` of the per-dimension factors (`scratch`), the
    order every result was computed in, whatever loops compute it."""
    net = network(d, n)
    low, high = np.array(net.low), np.array(net.high)
    out, factors = np.empty(net.num_features), np.empty((d, n))
    for state in to_task_units(net, np.random.default_rng(n).uniform(-0.5, 1.5, size=(20, d))):
        nrbf_features_into(state, low, high, n, net.r2, out, factors)
        expected = factors[d - 1]
        for j in range(d - 2, -1, -1):
            expected = np.multiply.outer(factors[j], expected)
        assert out.tobytes() == expected.ravel().tobytes()
