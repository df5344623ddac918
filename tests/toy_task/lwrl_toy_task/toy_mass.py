"""A toy domain of lwrl, from outside lwrl: a point mass on a line, pushed to the origin and
held there.

It is written against lwrl's public task contract alone (`lwrl.tasks.domain_contract`,
`lwrl.tasks.task_definition`, `lwrl.tasks.parameters`, `lwrl.tasks.plants`,
`lwrl.tasks.physics` and `lwrl.tasks.integrators`, with `lwrl.kernels.copy_into` for the
compiled loops) and reaches lwrl's registry through its entry point `toy_mass =
lwrl_toy_task.toy_mass:DOMAIN` of the group `lwrl.tasks` (pyproject.toml), as any installed
package would; tests/test_outside_task.py installs it so and holds it to the suite's
contract. Two plants: `mujoco` (`toy_mass.xml`, in this package) and `analytic` (the
equation with Euler's method).

Task `reach`:

- **Actions** (`DiscreteArray`, 3 values): index 0, 1, 2 apply the force -F, 0, +F (N),
  F = 1 N. With `actions="continuous"` (`BoundedArray` of shape (1,), float64, named
  `force`): the force u itself, in [-F, F]; one outside is clipped to it (the MJCF motor's
  control range is the same).
- **Observations** (float64 scalars): `position` x in m, within +-1 while the episode
  lasts; `velocity` v in m/s.
- **Dynamics**: m x_dd = u, integrated at dt = 0.05 s (Euler's method, semi-implicit by
  default; `integrator="explicit"` on the analytic plant).
- **Parameters** (`PARAMETERS`; the task option `params={name: value}`, the others at their
  nominal values): `mass` m (kg) 1, in [0.1, 10]; `force` F (N) 1, in [0.1, 10], the push of
  each action, -F, 0 or +F. The MuJoCo plant takes them into its model through
  `mujoco.MjSpec` (`edit_model`): the body's mass, the motor's control range.
- **Reward** (on entering a state): +1 within `TARGET` = 0.1 m of the origin, -1 on
  leaving the track (|x| > `LIMIT` = 1 m), 0 elsewhere.
- **Start**: x ~ U[-0.8, 0.8] m, v = 0.
- **Episode end**: terminal (discount 0) when |x| > 1 m; truncated (discount 1) after
  `time_limit` = 10 s (200 steps).
- **Up-time**: seconds within the target.
- **Agent** (this package's defaults): NRBF 8 x 8 over x in [-1, 1], v in [-2, 2];
  replacing traces, alpha 0.5, lambda 0.9, epsilon 0.1; 10 agents x 100 episodes.

It is a task's spec and physics, nothing else: it brings no classical controller, plant in C,
plant comparison, robustness axes or scene, and the parts that need one refuse it in one line
(a package may add each through that part's entry-point group).
"""

import importlib.resources

import numpy as np
from numba.extending import register_jitable

from lwrl.kernels import copy_into
from lwrl.tasks.domain_contract import Domain
from lwrl.tasks.integrators import euler
from lwrl.tasks.parameters import Parameter, Parameters
from lwrl.tasks.physics import physics_classes
from lwrl.tasks.plants import DomainPlants
from lwrl.tasks.task_definition import RunDefaults, TaskDefinition, step_limit

STATE_NAMES = ("position", "velocity")
PARAMETERS = Parameters(
    Parameter("mass", "m", "kg", 1.0, 0.1, 10.0, "the point mass"),
    Parameter("force", "F", "N", 1.0, 0.1, 10.0, "the push of each action, -F, 0 or +F"),
)
"""The point mass's physical constants as parameters."""
P = PARAMETERS.index
"""Where each parameter sits in a parameter vector `p`: `p[P.mass]`."""
TIMESTEP = 0.05
"""dt (s) of one agent step."""
TIME_LIMIT = 10.0
"""Episode length (s)."""
TARGET = 0.1
"""Within this |x| (m) the mass is at the target."""
LIMIT = 1.0
"""Beyond this |x| (m) the mass has left the track."""
START = 0.8
"""The starts' |x| (m) is at most this."""
BOUND = 3.0
"""|x| (m) of every observation: the step that leaves the track ends at most 1 m past it
(the mass starts at rest, and the largest push F/m = 100 m/s^2 gains under 25 m/s before
it has crossed the track)."""
MODEL = importlib.resources.files(__package__) / "toy_mass.xml"
"""The MJCF model, shipped in this package (`DomainPlants.model`)."""


@register_jitable
def acceleration(force, p):
    """x_dd = u / m at the parameter values `p` (`PARAMETERS`)."""
    return force / p[P.mass]


@register_jitable
def step(position, velocity, force, dt, semi_implicit, slips, p):
    """One Euler step of the point mass at the parameter values `p` (`slips`, the paper's
    readings of lwrl's own domains, changes nothing here)."""
    return euler(position, velocity, acceleration(force, p), dt, semi_implicit)


def controls(p):
    """u of each action at the parameter values `p`: -F, 0, +F."""
    return -p[P.force], 0.0, p[P.force]


@register_jitable
def outcome(position, velocity, p):
    """(reward, terminal, up) on entering a state: +1 at the target, which counts as
    up-time, -1 on leaving the track, which is terminal (whatever the parameters `p`)."""
    near = np.abs(position) <= TARGET
    out = np.abs(position) > LIMIT
    return 1.0 * near - 1.0 * out, out, near


@register_jitable
def arrive(state, observation, arguments):
    """The observation of entering one state `(2,)` (the state itself), written into
    `observation`, and the state's `outcome`; `arguments` = ((), p)."""
    copy_into(observation, state)
    return outcome(state[0], state[1], arguments[1])


@register_jitable
def transition(state, control, next_state, observation, dt, semi_implicit, slips, arguments):
    """One Euler step of one state `(2,)` for compiled loops; `arguments` = ((), p)."""
    next_state[0], next_state[1] = step(state[0], state[1], control, dt, semi_implicit, slips,
                                        arguments[1])
    return arrive(next_state, observation, arguments)


def initial_states(rng: np.random.Generator, count: int) -> np.ndarray:
    """x ~ U[-0.8, 0.8], v = 0, `(count, 2)`."""
    return np.stack([rng.uniform(-START, START, size=count), np.zeros(count)], axis=-1)


def _observe(state):
    return state


DEFAULTS = RunDefaults(n=8, low=(-LIMIT, -2.0), high=(LIMIT, 2.0), trace="replacing",
                       alpha=0.5, lam=0.9, epsilon=0.1, episodes=100, agents=10)
"""This package's defaults for a run of the task."""


def reach(time_limit: float = TIME_LIMIT, params=None) -> TaskDefinition:
    """Push the mass to the origin and hold it there; `time_limit` in seconds, `params` the
    physical parameters' values `{name: value}` (`PARAMETERS`)."""
    return TaskDefinition(
        domain="toy_mass", task="reach", state_names=STATE_NAMES, controls_of=controls,
        control_name="force", control_timestep=TIMESTEP,
        step_limit=step_limit(time_limit, TIMESTEP), initial_states=initial_states,
        observe=_observe, outcome=outcome, transition=transition, arrive=arrive,
        bounds=((-BOUND, -np.inf), (BOUND, np.inf)), defaults=DEFAULTS,
        physical=tuple(PARAMETERS.values(params).tolist()))


class _Accessors:
    """One-line accessors named after the quantities, for both plants."""

    def position(self) -> float:
        """x (m)."""
        return self.state_vector()[0]

    def velocity(self) -> float:
        """v (m/s)."""
        return self.state_vector()[1]


def edit_model(spec, p) -> None:
    """`toy_mass.xml`'s spec at the parameter values `p`: the body's mass m, the motor's
    control range +-F."""
    spec.body("mass").mass = p[P.mass]
    spec.actuator("force").ctrlrange = [-p[P.force], p[P.force]]


AnalyticPhysicsToyMass, MujocoPhysicsToyMass = physics_classes("ToyMass", _Accessors, STATE_NAMES,
                                                               "force")
DOMAIN = Domain(
    name="toy_mass", tasks={"reach": reach},
    plants=DomainPlants(step=step, timestep=TIMESTEP, analytic_physics=AnalyticPhysicsToyMass,
                        parameters=PARAMETERS, analytic_options=("integrator",),
                        mujoco_physics=MujocoPhysicsToyMass, model=MODEL, edit_model=edit_model))
"""The toy domain: its task and its plants."""
