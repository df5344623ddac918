"""Euler's method, the paper's integrator, in its two readings.

The paper integrates every plant "using Euler's method" with a time step of 0.02 s without
saying which Euler. `explicit` is the literal reading (position from the old velocity);
`semi_implicit` is MuJoCo's `Euler` integrator (velocity first, then position with the new
velocity). See SPEC.md, "Integration".
"""

from numba.extending import register_jitable

INTEGRATORS = ("semi_implicit", "explicit")
"""The two readings of Euler's method (see the module), MuJoCo's first."""


def check_integrator(integrator: str) -> bool:
    """Return True for `semi_implicit`, False for `explicit`; reject anything else."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"unknown integrator {integrator!r}; allowed: {', '.join(INTEGRATORS)}")
    return integrator == "semi_implicit"


@register_jitable
def euler(q, q_dot, q_ddot, dt, semi_implicit):
    """One Euler step of `dq/dt = q_dot`, `dq_dot/dt = q_ddot`; returns `(q', q_dot')`.

    Works element-wise on scalars and arrays, in Python and in numba-compiled code.
    """
    q_dot_next = q_dot + dt * q_ddot
    q_next = q + dt * (q_dot_next if semi_implicit else q_dot)
    return q_next, q_dot_next


@register_jitable
def euler_pair(q0, q0_dot, q1, q1_dot, q0_ddot, q1_ddot, dt, semi_implicit):
    """One Euler step of two coordinates, in the suite's state order `(q0, q0_dot, q1,
    q1_dot)`; returns the next state in that order."""
    q0, q0_dot = euler(q0, q0_dot, q0_ddot, dt, semi_implicit)
    q1, q1_dot = euler(q1, q1_dot, q1_ddot, dt, semi_implicit)
    return q0, q0_dot, q1, q1_dot
