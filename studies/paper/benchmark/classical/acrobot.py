"""The acrobot's classical controller: Spong (1995)'s energy-based swing-up through the
collocated partial feedback linearisation of the elbow."""

import numpy as np

from lwrl.studies.paper.benchmark.classical.controller import Classical
from lwrl.tasks.acrobot import P, accelerations, mass_matrix
from lwrl.tasks.task_definition import wrap_angle


def energy(state, p) -> float:
    """The arm's energy at one state `(4,)` and the parameter values `p`, the shoulder's
    height the potential's zero: the kinetic [theta1_d, theta2_d] D [theta1_d, theta2_d] / 2
    with D the mass matrix (`mass_matrix`), and the potential -(m1 lc1 + m2 l1) g cos theta1
    - m2 lc2 g cos(theta1 + theta2), whose slopes are the equations' phi1 and phi2."""
    shoulder_angle, shoulder_speed, elbow_angle, elbow_speed = (float(v) for v in state)
    d1, d2, d22 = mass_matrix(elbow_angle, p)
    kinetic = 0.5 * (d1 * shoulder_speed ** 2 + 2.0 * d2 * shoulder_speed * elbow_speed
                     + d22 * elbow_speed ** 2)
    gravity, link_mass_2 = p[P.gravity], p[P.link_mass_2]
    return kinetic - gravity * (
        (p[P.link_mass_1] * p[P.link_com_1] + link_mass_2 * p[P.link_length_1])
        * np.cos(shoulder_angle) + link_mass_2 * p[P.link_com_2]
        * np.cos(shoulder_angle + elbow_angle))


def top_energy(p) -> float:
    """The energy at rest upright, (m1 lc1 + m2 (l1 + lc2)) g (19.6 J at the book's values):
    the swing-up's target, Spong's."""
    return (p[P.link_mass_1] * p[P.link_com_1]
            + p[P.link_mass_2] * (p[P.link_length_1] + p[P.link_com_2])) * p[P.gravity]


ENERGY_GAIN = 40.0
"""k_E (1/s) of the swing-up's outer loop, the elbow's acceleration per relative energy
missing and elbow speed. A scan of 5 to 80 on the book's values found every gain reaching
the goal within 100 steps; 40 was among the fastest (81 steps) and reached it within 260
steps at the other values tried (link 2 half or twice as heavy or twice as long, the
torque half or twice the book's, either inertia a fifth, g 5 or 20 m/s^2)."""
ELBOW_STIFFNESS = 1.0
"""k_P (1/s^2) of the outer loop's pull of the elbow toward straight, which keeps the
energy in the swing rather than in the elbow spinning (chosen with `ENERGY_GAIN`: without
it, up to 330 steps at those values; with it, at most 260)."""


def swingup_control(state, p) -> float:
    """The classical controller's elbow torque at one state `(4,)` (angles wrapped or not).

    Spong's (1995) collocated partial feedback linearisation: the torque that gives the elbow
    the acceleration v, tau = (d22 - d2^2 / d1) (v - theta2_dd(tau = 0)) (the book's elbow
    equation solved for tau), with the energy-based outer loop v = k_E E~ theta2_d - k_P
    theta2, E~ = (E_top - E) / E_top (`energy`, `top_energy`): the torque's power is tau
    theta2_d, so the arm gains energy while it lacks some (all along where g = 0, without a
    top to aim at: E~ = 1). At rest (theta2_d = 0) with energy missing, where that gives no
    push, +tau_max. Within +-tau_max."""
    shoulder_angle, shoulder_speed = float(state[0]), float(state[1])
    elbow_angle, elbow_speed = float(wrap_angle(state[2])), float(state[3])
    limit, target = p[P.torque], top_energy(p)
    missing = (target - energy(state, p)) / target if target > 0.0 else 1.0
    if elbow_speed == 0.0 and missing > 0.0:
        return float(limit)
    d1, d2, d22 = mass_matrix(elbow_angle, p)
    free = accelerations(shoulder_angle, shoulder_speed, elbow_angle, elbow_speed, 0.0, p)[1]
    wanted = ENERGY_GAIN * missing * elbow_speed - ELBOW_STIFFNESS * elbow_angle
    torque = (d22 - d2 * d2 / d1) * (wanted - free)
    return float(min(max(torque, -limit), limit))


CLASSICAL = Classical(
    control=swingup_control,
    source="partial feedback linearisation of the elbow (Spong 1995, \"The swing up control "
           "problem for the acrobot\", IEEE Control Systems Magazine 15(1): 49-55) with an "
           "energy-based outer loop (Spong's energy E_top - E times the elbow's speed)",
    summary="pumps the arm's energy toward the upright's through the linearised elbow")
"""The acrobot's classical controller: from the book's start it reaches the goal in 81
steps (16.2 s) on the discrete task (tests/test_classical.py)."""
