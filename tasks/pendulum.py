"""Pendulum swing-up with limited torque (Doya 2000), as in Främling (2008), section 4.2.

A pendulum hangs from a hinge and must be swung up and balanced upright, with a torque too
weak to lift it directly. Two plants: `mujoco` (`models/pendulum.xml`) and `analytic` (the
paper's equation with Euler's method).

Task `swingup`:

- **Actions** (`DiscreteArray`, 2 values): index 0, 1 apply the torque -tau_max, +tau_max,
  tau_max = 5 N m. With `actions="continuous"` (`BoundedArray` of shape (1,), float64,
  named `torque`): the torque tau itself, in [-tau_max, tau_max]; one outside is clipped to
  it, as the motor saturates (the MJCF motor's control range is the same).
- **Observations** (float64 scalars): `angle` theta in rad, wrapped to [-pi, pi], 0 upright,
  positive toward +x; `angular_velocity` theta_dot in rad/s (unbounded; about +-1.5 in
  practice near the top, more when swinging).
- **Dynamics**: m l^2 theta_dd = -mu theta_d + m g l sin(theta) + tau with m = 1 kg,
  l = 1 m, g = 9.81 m/s^2, mu = 0.01 N m s/rad (the paper prints "-pi theta_d", a slip for
  mu), integrated at dt = 0.02 s.
- **Parameters** (`PARAMETERS`; the task option `params={name: value}`, the others at the
  paper's values): `mass` m (kg) 1, in [0.1, 10]; `length` l (m) 1, in [0.1, 10];
  `gravity` g (m/s^2) 9.81, in [0, 30]; `friction` mu (N m s/rad) 0.01, in [0, 1];
  `torque` tau_max (N m) 5, in [0.1, 50], the torque of each action, -tau_max or +tau_max.
  The MuJoCo plant takes them into its model through `mujoco.MjSpec`, recompiled
  (`edit_model`): a length moves the point mass, and with it the drawn rod and bob, so the
  model is compiled anew rather than patched field by field; the friction is the hinge's
  damping, the torque the motor's control range.
- **Reward** (on entering a state): r1 = cos(theta) - 0.7; where |theta| <= pi/5 it is
  r1 - |theta_dot| instead.
- **Start**: theta ~ U[-pi, pi], theta_dot = 0.
- **Episode end**: no terminal state; truncated (discount 1) after `time_limit` = 60 s
  (3000 steps).
- **Up-time**: seconds with |theta| <= pi/2; more than 40 s means balanced to the end.
- **Normalisation ranges** (`RANGES`) and the paper's **agent** (its settings in
  `agent.paper_settings`; the paper's best, Fig. 5): NRBF 10 x 10 over theta in [-pi, pi],
  theta_dot in [-1.5, 1.5] (speeds outside allowed); replacing traces, alpha 1.5, lambda
  0.4, epsilon 0.1; 10 agents x 200 episodes (the author's script).
"""


import numpy as np
from numba.extending import register_jitable

from lwrl.tasks.task_definition import TaskDefinition, step_limit, wrap_angle
from lwrl.tasks.domain_contract import Domain
from lwrl.tasks.integrators import euler
from lwrl.tasks.parameters import Parameter, Parameters
from lwrl.tasks.physics import physics_classes
from lwrl.tasks.plants import DomainPlants

STATE_NAMES = ("angle", "angular_velocity")
"""The names of the pendulum's state variables, in the state vector's order."""
PARAMETERS = Parameters(
    Parameter("mass", "m", "kg", 1.0, 0.1, 10.0, "the point mass"),
    Parameter("length", "l", "m", 1.0, 0.1, 10.0, "hinge to the point mass"),
    Parameter("gravity", "g", "m/s^2", 9.81, 0.0, 30.0, "gravity's acceleration"),
    Parameter("friction", "mu", "N m s/rad", 0.01, 0.0, 1.0, "viscous friction at the hinge"),
    Parameter("torque", "tau_max", "N m", 5.0, 0.1, 50.0,
              "the torque of each action, -tau_max or +tau_max"),
)
"""The pendulum's physical constants (section 4.2) as parameters."""
P = PARAMETERS.index
"""Where each parameter sits in a parameter vector `p`: `p[P.mass]`."""
NOMINAL = PARAMETERS.nominal
"""The paper's values: `NOMINAL.mass` is 1 kg."""
TIMESTEP = 0.02
"""dt (s) of one agent step."""
TIME_LIMIT = 60.0
"""Episode length (s)."""
SHAPING_ANGLE = np.pi / 5
"""Within this |theta| the reward also penalises the speed."""
UP_ANGLE = np.pi / 2
"""Within this |theta| the pendulum counts as up."""
POINT_INERTIA = 1e-12
"""The MJCF point mass's own inertia about its centre, relative to m l^2 (MuJoCo needs a
positive one): 1e-12 kg m^2 at the paper's m = l = 1."""


@register_jitable
def angular_acceleration(angle, angular_velocity, torque, p):
    """theta_dd from m l^2 theta_dd = -mu theta_d + m g l sin(theta) + tau at the parameter
    values `p` (`PARAMETERS`)."""
    mass, length = p[P.mass], p[P.length]
    return (-p[P.friction] * angular_velocity + mass * p[P.gravity] * length * np.sin(angle)
            + torque) / (mass * length * length)


@register_jitable
def step(angle, angular_velocity, torque, dt, semi_implicit, slips, p):
    """One Euler step of the pendulum at the parameter values `p`; the angle is not wrapped
    (like MuJoCo's hinge).

    With `slips` (the author's kfnnet code, SPEC.md "Known traps"), the acceleration is
    scaled by dt once more: theta_d' = theta_d + dt^2 theta_dd."""
    acceleration = angular_acceleration(angle, angular_velocity, torque, p)
    if slips:
        acceleration = acceleration * dt
    return euler(angle, angular_velocity, acceleration, dt, semi_implicit)


def controls(p):
    """tau of each action at the parameter values `p`: -tau_max, +tau_max."""
    return -p[P.torque], p[P.torque]


TORQUES = tuple(float(torque) for torque in controls(np.asarray(NOMINAL)))
"""tau (N m) of each action at the paper's values: -5, +5."""


@register_jitable
def reward(angle, angular_velocity):
    """r1 = cos(theta) - 0.7, minus |theta_dot| where |theta| <= pi/5 (section 4.2)."""
    near_top = np.abs(wrap_angle(angle)) <= SHAPING_ANGLE
    return np.cos(angle) - 0.7 - np.abs(angular_velocity) * near_top


@register_jitable
def is_up(angle):
    """True where |theta| <= pi/2: the time counted as up-time."""
    return np.abs(wrap_angle(angle)) <= UP_ANGLE


@register_jitable
def outcome(angle, angular_velocity, p):
    """(reward, terminal, up) on entering a state; no state is terminal (whatever the
    parameters `p`)."""
    return reward(angle, angular_velocity), False, is_up(angle)


@register_jitable
def arrive(state, observation, arguments):
    """The observation of entering one state `(2,)`, written into `observation`, and the
    state's `outcome`; `arguments` = ((), p)."""
    observation[0], observation[1] = wrap_angle(state[0]), state[1]
    return outcome(state[0], state[1], arguments[1])


@register_jitable
def transition(state, control, next_state, observation, dt, semi_implicit, slips, arguments):
    """One Euler step of one state `(2,)` for compiled loops; `arguments` = ((), p)."""
    next_state[0], next_state[1] = step(state[0], state[1], control, dt, semi_implicit, slips,
                                        arguments[1])
    return arrive(next_state, observation, arguments)


def initial_states(rng: np.random.Generator, count: int) -> np.ndarray:
    """theta ~ U[-pi, pi], theta_dot = 0, `(count, 2)`."""
    return np.stack([rng.uniform(-np.pi, np.pi, size=count), np.zeros(count)], axis=-1)


def _observe(state):
    return np.stack([wrap_angle(state[..., 0]), state[..., 1]], axis=-1)


RANGES = ((-np.pi, -1.5), (np.pi, 1.5))
"""The normalisation ranges `(low, high)` of theta and theta_dot (the paper's, Fig. 5)."""


def swingup(time_limit: float = TIME_LIMIT, params=None) -> TaskDefinition:
    """The paper's swing-up task; `time_limit` in seconds, `params` the physical parameters'
    values `{name: value}` (`PARAMETERS`)."""
    return TaskDefinition(
        domain="pendulum", task="swingup", state_names=STATE_NAMES, controls_of=controls,
        control_name="torque",
        control_timestep=TIMESTEP, step_limit=step_limit(time_limit, TIMESTEP),
        initial_states=initial_states, observe=_observe, outcome=outcome, transition=transition,
        arrive=arrive,
        bounds=((-np.pi, -np.inf), (np.pi, np.inf)), ranges=RANGES, angles=("angle",),
        physical=tuple(PARAMETERS.values(params).tolist()),
    )


class _Accessors:
    """One-line accessors named after the quantities, for both plants."""

    def angle(self) -> float:
        """theta (rad), wrapped to [-pi, pi]."""
        return float(wrap_angle(self.state_vector()[0]))

    def angular_velocity(self) -> float:
        """theta_dot (rad/s)."""
        return self.state_vector()[1]


def edit_model(spec, p) -> None:
    """`models/pendulum.xml`'s spec at the parameter values `p`: the point mass m at l from
    the hinge (with the rod and the bob drawn to it), whose own inertia MuJoCo needs
    positive: `POINT_INERTIA` m l^2, which changes m l^2 by the same factor 1 + 1e-12 at any
    values; gravity; the hinge's damping mu; the motor's control range +-tau_max."""
    spec.option.gravity = [0.0, 0.0, -p[P.gravity]]
    body, mass, length = spec.body("pendulum"), p[P.mass], p[P.length]
    body.mass = mass
    body.ipos = [0.0, 0.0, length]
    body.inertia = [POINT_INERTIA * mass * length * length] * 3
    spec.geom("rod").fromto = [0.0, 0.0, 0.0, 0.0, 0.0, length]
    spec.geom("bob").pos = [0.0, 0.0, length]
    spec.joint("hinge").damping[0] = p[P.friction]
    spec.actuator("torque").ctrlrange = [-p[P.torque], p[P.torque]]


AnalyticPhysicsPendulum, MujocoPhysicsPendulum = physics_classes("Pendulum", _Accessors, STATE_NAMES, "torque")
DOMAIN = Domain(
    name="pendulum", tasks={"swingup": swingup},
    plants=DomainPlants(step=step, timestep=TIMESTEP, analytic_physics=AnalyticPhysicsPendulum,
                        parameters=PARAMETERS, mujoco_physics=MujocoPhysicsPendulum,
                        model="pendulum", edit_model=edit_model))
"""The pendulum's domain: its tasks, its plants and its physical parameters."""
