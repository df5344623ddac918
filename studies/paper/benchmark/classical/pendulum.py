"""The pendulum's classical controller: energy-based swing-up (Åström and Furuta 2000),
then a balance law by pole placement on the model linearised about the top."""

import math

import numpy as np

from lwrl.studies.paper.benchmark.classical.controller import Classical
from lwrl.tasks.pendulum import P
from lwrl.tasks.task_definition import wrap_angle


BALANCE_FREQUENCY = 2.0
"""The balance controller's closed-loop natural frequency in units of the pendulum's own,
sqrt(g / l): twice as fast as gravity topples it (6.3 rad/s at the paper's values, 0.13 rad
per step of 0.02 s)."""


def energy(angle, angular_velocity, p):
    """E = m l^2 theta_d^2 / 2 + m g l (cos theta - 1) at the parameter values `p`: 0 at rest
    upright, -2 m g l at rest hanging (Åström and Furuta 2000's energy, from the top)."""
    mass, length = p[P.mass], p[P.length]
    return (0.5 * mass * length * length * angular_velocity * angular_velocity
            + mass * p[P.gravity] * length * (np.cos(angle) - 1.0))


def balance_gains(p) -> tuple:
    """`(k_p, k_d)` of the balance law tau = -k_p theta - k_d theta_d: with the model
    linearised about the top, m l^2 theta_dd = (m g l - k_p) theta - (mu + k_d) theta_d, its
    poles placed at a double -w, w = `BALANCE_FREQUENCY` sqrt(g / l) (critically damped)."""
    inertia = p[P.mass] * p[P.length] * p[P.length]
    frequency = BALANCE_FREQUENCY * math.sqrt(p[P.gravity] / p[P.length])
    return (p[P.mass] * p[P.gravity] * p[P.length] + inertia * frequency * frequency,
            2.0 * inertia * frequency - p[P.friction])


def catch_angle(p) -> float:
    """The largest |theta| at which tau_max holds the pendulum against gravity, asin(tau_max
    / (m g l)) (0.54 rad, 31 deg, at the paper's values; pi/2 where tau_max >= m g l): where
    the balance law takes over from the swing-up."""
    weight = p[P.mass] * p[P.gravity] * p[P.length]
    return math.asin(p[P.torque] / weight) if weight > p[P.torque] else math.pi / 2


def swingup_control(state, p) -> float:
    """The classical controller's torque at one state `(2,)` (the angle wrapped or not).

    Within `catch_angle` of the top, the balance law (`balance_gains`). Elsewhere the energy
    control of Åström and Furuta (2000) in its bang-bang limit (their large gain), for a
    torque at the hinge, whose power is tau theta_d: tau = tau_max sign(-E theta_d) +
    mu theta_d (the friction's loss made good), which drives E (`energy`) to the top's 0 as
    fast as the torque can. At theta_d = 0, where that gives no push, +tau_max. Within
    +-tau_max; for g > 0 (without gravity there is no top to swing to)."""
    angle, angular_velocity = float(wrap_angle(state[0])), float(state[1])
    limit = p[P.torque]
    if abs(angle) <= catch_angle(p):
        proportional, derivative = balance_gains(p)
        torque = -proportional * angle - derivative * angular_velocity
    elif angular_velocity == 0.0:
        torque = limit
    else:
        pump = -energy(angle, angular_velocity, p) * angular_velocity
        torque = math.copysign(limit, pump) + p[P.friction] * angular_velocity
    return float(min(max(torque, -limit), limit))


CLASSICAL = Classical(
    control=swingup_control,
    source="energy control (Åström and Furuta 2000, \"Swinging up a pendulum by energy "
           "control\", Automatica 36: 287-295), bang-bang, then pole placement on the model "
           "linearised about the top",
    summary="swings up by energy control, then balances by a critically damped PD law")
"""The pendulum's classical controller: from the paper's random starts it swings up within
a few seconds and holds the top (tests/test_classical.py)."""
