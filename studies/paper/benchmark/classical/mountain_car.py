"""Mountain-Car's classical controller: energy pumping, full thrust along the velocity."""

from lwrl.studies.paper.benchmark.classical.controller import Classical


def thrust_along_velocity(state, p) -> float:
    """The classical controller's thrust a at one state `(2,)`: +1 where v >= 0, else -1.

    Energy pumping: the thrust's work k a v per step is then k |v| >= 0, so the car's energy
    (v^2 / 2 + (g / 3) sin 3x per unit mass, the slope being sin 3x) grows as fast as the
    thrust can make it, whatever the parameters `p`, and the swings grow until one clears the
    right hill. At v = 0 it pushes forward, toward the goal: at the left wall, which stops
    the car, that is the only way out; elsewhere v = 0 lasts one step."""
    del p
    return 1.0 if state[1] >= 0.0 else -1.0


CLASSICAL = Classical(
    control=thrust_along_velocity,
    source="energy pumping, a = sign(v) (SPEC.md, \"The benchmark's protocol\"): the thrust's "
           "power k a v is then k |v|, the most the actuator can give",
    summary="full thrust along the velocity, forward at rest")
"""Mountain-Car's classical controller: from the paper's random starts (seeded) it reaches
the goal within 200 steps (tests/test_classical.py)."""
