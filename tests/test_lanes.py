"""The four-lane dot product (`agent.lanes`): vector code with the scalar order's results."""

import numba
import numpy as np
import pytest
from numba.core.errors import TypingError

from lwrl.agent.lanes import lane_dot


def scalar_lanes(x, y) -> float:
    """The order every linear learner's Q is defined in, written out in Python floats: four
    partial sums, lane k the terms `i % 4 == k` in increasing i, the last `n % 4` terms in
    lane 0, combined as `(s0 + s1) + (s2 + s3)`."""
    n = len(x)
    s = [0.0, 0.0, 0.0, 0.0]
    for i in range(n - n % 4):
        s[i % 4] += float(x[i]) * float(y[i])
    for i in range(n - n % 4, n):
        s[0] += float(x[i]) * float(y[i])
    return (s[0] + s[1]) + (s[2] + s[3])


@numba.njit
def compiled_dot(x, y):
    return lane_dot(x, y)


def same_bits(a: float, b: float) -> bool:
    return np.float64(a).tobytes() == np.float64(b).tobytes() or (np.isnan(a) and np.isnan(b))


@pytest.mark.parametrize("n", [0, 1, 2, 3, 4, 5, 7, 8, 13, 64, 81, 405, 1296])
def test_a_lane_dot_is_the_scalar_order_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for scale in (1.0, 1e-160, 1e150):
        x = rng.normal(size=n) * scale * rng.choice([1.0, 1e-8, 1e8], size=n)
        y = rng.random(n)
        assert same_bits(compiled_dot(x, y), scalar_lanes(x, y))


def test_the_order_is_the_lanes_and_not_a_running_sum():
    """Summed as one running sum, these terms give another last bit: the test above can tell
    the orders apart."""
    rng = np.random.default_rng(1)
    x, y = rng.normal(size=64) * 1e3, rng.random(64)
    running = 0.0
    for a, b in zip(x, y):
        running += float(a) * float(b)
    assert not same_bits(running, compiled_dot(x, y))
    assert same_bits(compiled_dot(x, y), scalar_lanes(x, y))


def test_signed_zeros_infinities_and_nans_follow_the_scalar_order():
    cases = [np.array([-0.0, -0.0, -0.0, -0.0, -0.0]), np.array([np.inf, 1.0, -np.inf, 2.0, 0.0]),
             np.array([1e308, 1e308, 0.0, 0.0, 1e308, 1e308, 0.0, 0.0]),
             np.array([np.nan, 0.0, 0.0, 0.0]), np.array([np.inf, 0.0, 0.0, 0.0, 0.0])]
    for x in cases:
        for y in (np.ones_like(x), np.zeros_like(x), -np.ones_like(x)):
            assert same_bits(compiled_dot(x, y), scalar_lanes(x, y)), (x, y)


def test_only_contiguous_float64_vectors_are_taken():
    x = np.arange(8.0)
    with pytest.raises(TypingError):
        compiled_dot(x[::2], x[:4])
    with pytest.raises(TypingError):
        compiled_dot(x.astype(np.float32), x.astype(np.float32))
