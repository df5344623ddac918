"""The cart-pole's classical controller: LQR on the paper's equations linearised about the
upright."""

import functools

import numpy as np

from lwrl.studies.paper.benchmark.classical.controller import Classical
from lwrl.tasks.cartpole import FAIL_ANGLE, P, RANGES, TIMESTEP, TRACK_LIMIT


def linearised(p) -> tuple:
    """`(A (4, 4), B (4,))`: the paper's equations about the upright at rest, d state / dt =
    A state + B F, at the parameter values `p`. With sin theta = theta, cos theta = 1 and
    theta_d^2 = 0, and without the cart's Coulomb friction (no linear part; 0.0005 N):
    theta_dd = (g theta - F / (mc + m) - mu_p theta_d / (m l)) / (l (4/3 - m / (mc + m))),
    x_dd = (F - m l theta_dd) / (mc + m)."""
    total_mass = p[P.cart_mass] + p[P.pole_mass]
    pole_mass_length = p[P.pole_mass] * p[P.half_length]
    lever = p[P.half_length] * (4.0 / 3.0 - p[P.pole_mass] / total_mass)
    pole = np.array([0.0, 0.0, p[P.gravity], -p[P.pole_friction] / pole_mass_length]) / lever
    pole_force = -1.0 / (total_mass * lever)
    a = np.zeros((4, 4))
    a[0, 1] = a[2, 3] = 1.0
    a[1], a[3] = -pole_mass_length * pole / total_mass, pole
    b = np.array([0.0, (1.0 - pole_mass_length * pole_force) / total_mass, 0.0, pole_force])
    return a, b


LQR_LIMITS = (TRACK_LIMIT, RANGES[1][1], FAIL_ANGLE, RANGES[1][3])
"""Bryson's rule's largest acceptable value of each state variable, for the LQR's weights
1 / limit^2: the track limit (2.4 m), the failure angle (12 deg), and the author's ranges
of the speeds (1.5 m/s, 150 deg/s); the force's weight is 1 / F^2."""


@functools.lru_cache(maxsize=64)
def _lqr_gain(values: tuple) -> np.ndarray:
    """`lqr_gain` of parameter values as a tuple (a key of the cache), read-only."""
    try:  # here, not at import: scipy is the paper extra's, not lwrl's core's
        import scipy.linalg
    except ImportError as error:
        raise ImportError("the cart-pole's LQR solves its Riccati equation with scipy: "
                          "pip install 'lwrl[paper]'") from error

    a, b = linearised(np.asarray(values))
    a, b = np.eye(4) + TIMESTEP * a, TIMESTEP * b[:, None]  # Euler's method at dt = 0.02 s
    q = np.diag(1.0 / np.square(LQR_LIMITS))
    r = np.array([[1.0 / values[P.force] ** 2]])
    s = scipy.linalg.solve_discrete_are(a, b, q, r)
    gain = np.linalg.solve(r + b.T @ s @ b, b.T @ s @ a)[0]
    gain.flags.writeable = False
    return gain


def lqr_gain(p) -> np.ndarray:
    """K `(4,)` of the discrete-time LQR, F = -K state, at the parameter values `p`: the
    Riccati equation of `linearised` stepped by Euler's method at dt = 0.02 s, with Bryson's
    weights (`LQR_LIMITS`); about (-3.5, -8.9, -77.6, -17.5) at the paper's values. Solved
    once per values (scipy, of the `paper` extra)."""
    return _lqr_gain(tuple(np.asarray(p, dtype=np.float64).tolist()))


def lqr_control(state, p) -> float:
    """The classical controller's force at one state `(4,)`: -K state, within +-F."""
    force = -float(lqr_gain(p) @ np.asarray(state, dtype=np.float64))
    return min(max(force, -p[P.force]), p[P.force])


CLASSICAL = Classical(
    control=lqr_control,
    source="linear-quadratic regulator on the paper's equations linearised about the upright "
           "(Anderson and Moore, \"Optimal Control: Linear Quadratic Methods\", 1990), "
           "Bryson's weights",
    summary="LQR balance, F = -K state within +-F, K from the parameters' linearised model")
"""The cart-pole's classical controller: through the discrete task's +-F (bang-bang) it
balances for the 240 s from the paper's start and from +-5 deg (tests/test_classical.py)."""
