"""A toy domain of lwrl from outside lwrl: a point mass on a line, pushed to the origin and
held there. A task's spec and physics, nothing else (no classical controller, C plant, plant
comparison, robustness axes, scene or paper agent's settings: each part that needs one
refuses it in one line naming its entry-point group), written against lwrl's task contract
(`lwrl.tasks.*`, `lwrl.kernels.copy_into`) and admitted by its entry point `toy_mass =
lwrl_toy_task.toy_mass:DOMAIN` of the group `lwrl.tasks` (pyproject.toml) alone.

Task `reach`: actions index -F, 0, +F, or with `actions="continuous"` the force itself in
[-F, F]; observations `position` x (m) and `velocity` v (m/s); m x_dd = u at dt = 0.05 s,
Euler's method on the `analytic` plant, MuJoCo on `mujoco` (`toy_mass.xml`); parameters
`mass` m (kg) 1, in [0.1, 10] and `force` F (N) 1, in [0.1, 10]; reward +1 within 0.1 m of
the origin (up-time), -1 and terminal beyond |x| = 1 m; starts x ~ U[-0.8, 0.8], v = 0;
truncated after `time_limit` = 10 s. Normalisation ranges x in [-1, 1], v in [-2, 2].
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
from lwrl.tasks.task_definition import TaskDefinition, step_limit

STATE_NAMES = ("position", "velocity")
PARAMETERS = Parameters(
    Parameter("mass", "m", "kg", 1.0, 0.1, 10.0, "the point mass"),
    Parameter("force", "F", "N", 1.0, 0.1, 10.0, "the push of each action, -F, 0 or +F"))
P = PARAMETERS.index
TIMESTEP, TARGET, LIMIT = 0.05, 0.1, 1.0
"""dt (s); the target's and the track's |x| (m)."""
BOUND = 3.0
"""|x| (m) of every observation: from rest, the largest push F/m = 100 m/s^2 gains under
25 m/s before the mass crosses the track, so a step ends at most 1 m past it."""


@register_jitable
def step(position, velocity, force, dt, semi_implicit, slips, p):
    """One Euler step of m x_dd = u at the parameter values `p` (`slips` changes nothing)."""
    return euler(position, velocity, force / p[P.mass], dt, semi_implicit)


def controls(p):
    """u of each action at the parameter values `p`: -F, 0, +F."""
    return -p[P.force], 0.0, p[P.force]


@register_jitable
def outcome(position, velocity, p):
    """(reward, terminal, up) on entering a state."""
    near, out = np.abs(position) <= TARGET, np.abs(position) > LIMIT
    return 1.0 * near - 1.0 * out, out, near


@register_jitable
def arrive(state, observation, arguments):
    """The observation (the state itself) and the `outcome` of entering one state `(2,)`."""
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
    return np.stack([rng.uniform(-0.8, 0.8, size=count), np.zeros(count)], axis=-1)


def observe(state):
    """The observation of states `(..., 2)`: the states themselves."""
    return state


def reach(time_limit: float = 10.0, params=None) -> TaskDefinition:
    """Push the mass to the origin and hold it there (`params`: `{name: value}`)."""
    return TaskDefinition(
        domain="toy_mass", task="reach", state_names=STATE_NAMES, controls_of=controls,
        control_name="force", control_timestep=TIMESTEP,
        step_limit=step_limit(time_limit, TIMESTEP), initial_states=initial_states,
        observe=observe, outcome=outcome, transition=transition, arrive=arrive,
        bounds=((-BOUND, -np.inf), (BOUND, np.inf)), ranges=((-LIMIT, -2.0), (LIMIT, 2.0)),
        physical=tuple(PARAMETERS.values(params).tolist()))


def edit_model(spec, p) -> None:
    """`toy_mass.xml`'s spec at the parameter values `p`: the mass, the motor's range +-F."""
    spec.body("mass").mass = p[P.mass]
    spec.actuator("force").ctrlrange = [-p[P.force], p[P.force]]


ANALYTIC, MUJOCO = physics_classes("ToyMass", None, STATE_NAMES, "force")
DOMAIN = Domain(name="toy_mass", tasks={"reach": reach}, plants=DomainPlants(
    step=step, timestep=TIMESTEP, analytic_physics=ANALYTIC, parameters=PARAMETERS,
    analytic_options=("integrator",), mujoco_physics=MUJOCO, edit_model=edit_model,
    model=importlib.resources.files(__package__) / "toy_mass.xml"))
"""The toy domain: its task and its plants."""
