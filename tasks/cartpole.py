"""Cart-Pole (Barto, Sutton and Anderson 1983), as in Främling (2008), section 4.3.

A pole hinged on a cart must be kept upright by pushing the cart left or right. Two plants:
`mujoco` (`models/cartpole.xml`) and `analytic` (the paper's equations with Euler's method).

Task `balance`:

- **Actions** (`DiscreteArray`, 2 values): index 0, 1 apply the force -F, +F to the cart
  (positive toward +x), F = 10 N. With `actions="continuous"` (`BoundedArray` of shape (1,),
  float64, named `force`): the force itself, in [-F, F]; one outside is clipped to it, as
  the motor saturates (the MJCF motor's control range is the same).
- **Observations** (float64 scalars): `cart_position` x in m, within +-2.4 while the
  episode lasts (with the default track limit); `cart_velocity` x_dot in m/s;
  `pole_angle` theta in rad, 0 upright, within +-12 deg (0.2094 rad) while the episode
  lasts, positive toward +x; `pole_angular_velocity` theta_dot in rad/s.
- **Dynamics** (the paper's section 4.3, with sgn(0) = 0):
  theta_dd = [g sin(theta) + cos(theta) (-F - m l theta_d^2 sin(theta) + mu_c sgn(x_d)) / (mc + m)
              - mu_p theta_d / (m l)] / [l (4/3 - m cos^2(theta) / (mc + m))],
  x_dd = [F + m l (theta_d^2 sin(theta) - theta_dd cos(theta)) - mu_c sgn(x_d)] / (mc + m),
  mc = 1.0 kg, m = 0.1 kg, l = 0.5 m (half the pole's length), g = 9.81 m/s^2,
  mu_c = 0.0005 N, mu_p = 0.000002 N m s/rad; dt = 0.02 s.
- **Parameters** (`PARAMETERS`; the task option `params={name: value}`, the others at the
  paper's values): `cart_mass` mc (kg) 1, in [0.1, 10]; `pole_mass` m (kg) 0.1, in
  [0.01, 1]; `half_length` l (m) 0.5, in [0.05, 5]; `gravity` g (m/s^2) 9.81, in [0, 30];
  `cart_friction` mu_c (N) 0.0005, in [0, 1]; `pole_friction` mu_p (N m s/rad) 2e-06, in
  [0, 0.01]; `force` F (N) 10, in [0.1, 100], the push of each action, -F or +F. The
  MuJoCo plant takes them into its model through `mujoco.MjSpec`, recompiled (`edit_model`):
  a length moves the pole's centre of mass and changes its inertia m (2l)^2 / 12 and the
  drawn pole, so the model is compiled anew rather than patched field by field; the
  friction sets the hinge's damping and the cart's friction actuator's force range, the
  force the motor's control range.
- **Reward**: 0, and -1 on the failing step.
- **Start**: all four variables 0.
- **Episode end**: terminal (discount 0) when |theta| > 12 deg or, unless
  `track_limit=None`, |x| > `track_limit` (default 2.4 m, as in Barto et al.; the paper
  names only the angle); truncated (discount 1) after `time_limit` = 240 s (12 000 steps).
- **Up-time**: seconds before failure (the pole is up while the episode lasts).
- **Normalisation ranges** (`RANGES`) and the paper's **agent** (its settings in
  `agent.paper_settings`; the author's script; the paper gives no best agent): NRBF 6^4 over
  x in [-2.4, 2.4], x_dot in [-1.5, 1.5], theta in [-12, 12] deg, theta_dot in
  [-150, 150] deg/s; accumulating traces, alpha 0.5, lambda 0.7, epsilon 0.1; 10 agents x
  200 episodes.
"""

import math

import mujoco
import numpy as np
from numba.extending import register_jitable

from lwrl.kernels import copy_into
from lwrl.tasks.task_definition import TaskDefinition, positive_number, step_limit
from lwrl.tasks.domain_contract import Domain
from lwrl.tasks.integrators import euler_pair
from lwrl.tasks.parameters import Parameter, Parameters
from lwrl.tasks.physics import physics_classes
from lwrl.tasks.plants import DomainPlants

STATE_NAMES = ("cart_position", "cart_velocity", "pole_angle", "pole_angular_velocity")
"""The names of the cart-pole's state variables, in the state vector's order."""
PARAMETERS = Parameters(
    Parameter("cart_mass", "mc", "kg", 1.0, 0.1, 10.0, "the cart's mass"),
    Parameter("pole_mass", "m", "kg", 0.1, 0.01, 1.0, "the pole's mass"),
    Parameter("half_length", "l", "m", 0.5, 0.05, 5.0,
              "half the pole's length, hinge to its centre of mass"),
    Parameter("gravity", "g", "m/s^2", 9.81, 0.0, 30.0, "gravity's acceleration"),
    Parameter("cart_friction", "mu_c", "N", 0.0005, 0.0, 1.0,
              "Coulomb friction of the cart on the track"),
    Parameter("pole_friction", "mu_p", "N m s/rad", 0.000002, 0.0, 0.01,
              "viscous friction at the pole's hinge"),
    Parameter("force", "F", "N", 10.0, 0.1, 100.0, "the push of each action, -F or +F"),
)
"""The cart-pole's physical constants (section 4.3) as parameters."""
P = PARAMETERS.index
"""Where each parameter sits in a parameter vector `p`: `p[P.pole_mass]`."""
NOMINAL = PARAMETERS.nominal
"""The paper's values: `NOMINAL.pole_mass` is 0.1 kg."""
TIMESTEP = 0.02
"""dt (s) of one agent step."""
TIME_LIMIT = 240.0
"""Episode length (s)."""
FAIL_ANGLE = math.radians(12.0)
"""The pole has fallen beyond this |theta| (rad)."""
TRACK_LIMIT = 2.4
"""The cart has left the track beyond this |x| (m), by default."""


@register_jitable
def accelerations(cart_velocity, pole_angle, pole_angular_velocity, force, slips, p):
    """(x_dd, theta_dd) of the paper's Cart-Pole equations (section 4.3) at the parameter
    values `p` (`PARAMETERS`); mc + m and m l are formed once, as a sum and a product.

    With `slips` (the author's kfnnet code, SPEC.md "Known traps"), the theta_d^2 term takes
    the cart's mass for the pole's, mc l theta_d^2 sin(theta), in both equations."""
    cart_mass, pole_mass, half_length = p[P.cart_mass], p[P.pole_mass], p[P.half_length]
    total_mass = cart_mass + pole_mass
    pole_mass_length = pole_mass * half_length
    sin_theta = np.sin(pole_angle)
    cos_theta = np.cos(pole_angle)
    friction = p[P.cart_friction] * np.sign(cart_velocity)
    spin_mass_length = cart_mass * half_length if slips else pole_mass_length
    spin = spin_mass_length * pole_angular_velocity * pole_angular_velocity * sin_theta
    pole_acceleration = (
        p[P.gravity] * sin_theta
        + cos_theta * (-force - spin + friction) / total_mass
        - p[P.pole_friction] * pole_angular_velocity / pole_mass_length
    ) / (half_length * (4.0 / 3.0 - pole_mass * cos_theta * cos_theta / total_mass))
    cart_acceleration = (
        force + spin - pole_mass_length * pole_acceleration * cos_theta - friction) / total_mass
    return cart_acceleration, pole_acceleration


@register_jitable
def step(cart_position, cart_velocity, pole_angle, pole_angular_velocity, force, dt,
         semi_implicit, slips, p):
    """One Euler step of the cart-pole at the parameter values `p` (`slips`: see
    `accelerations`)."""
    cart_acceleration, pole_acceleration = accelerations(
        cart_velocity, pole_angle, pole_angular_velocity, force, slips, p)
    return euler_pair(cart_position, cart_velocity, pole_angle, pole_angular_velocity,
                      cart_acceleration, pole_acceleration, dt, semi_implicit)


def controls(p):
    """F of each action at the parameter values `p`: -F, +F."""
    return -p[P.force], p[P.force]


FORCES = tuple(float(force) for force in controls(np.asarray(NOMINAL)))
"""F (N) of each action at the paper's values: -10, +10."""


@register_jitable
def failed(cart_position, pole_angle, track_limit):
    """True where the pole has fallen (|theta| > 12 deg) or the cart has left the track
    (|x| > track_limit; pass `inf` for no limit), or the state is no number (NaN: the
    equations overflowed, from speeds beyond 1e154)."""
    within = (np.abs(pole_angle) <= FAIL_ANGLE) & (np.abs(cart_position) <= track_limit)
    return np.logical_not(within)


@register_jitable
def outcome(cart_position, cart_velocity, pole_angle, pole_angular_velocity, track_limit, p):
    """(reward, terminal, up) on entering a state: failing is terminal with reward -1;
    the pole is up until then (whatever the parameters `p`)."""
    fail = failed(cart_position, pole_angle, track_limit)
    return 0.0 - 1.0 * fail, fail, np.logical_not(fail)  # 0.0 - 0.0 is +0.0, not -0.0


@register_jitable
def arrive(state, observation, arguments):
    """The observation of entering one state `(4,)` (the state itself), written into
    `observation`, and the state's `outcome`; `arguments` = ((track_limit,), p)."""
    params, p = arguments
    copy_into(observation, state)
    return outcome(state[0], state[1], state[2], state[3], params[0], p)


@register_jitable
def transition(state, control, next_state, observation, dt, semi_implicit, slips, arguments):
    """One Euler step of one state `(4,)` for compiled loops; `arguments` = ((track_limit,),
    p)."""
    next_state[0], next_state[1], next_state[2], next_state[3] = step(
        state[0], state[1], state[2], state[3], control, dt, semi_implicit, slips, arguments[1])
    return arrive(next_state, observation, arguments)


def initial_states(rng: np.random.Generator, count: int) -> np.ndarray:
    """All zeros, `(count, 4)`: the paper's start is deterministic."""
    del rng
    return np.zeros((count, len(STATE_NAMES)))


def bounds(track_limit: float) -> tuple:
    """`(low, high)` holding every observation of an episode. The angle: +-24 deg, twice
    the failure angle, as Gymnasium's CartPole (the angle's speed stays below about 5 rad/s
    while |theta| <= 12 deg, so the failing step passes 12 deg by under 6 deg; an
    adversarial search found 3.8 deg). The position: +-(L + max(L, 1 m)) for the track
    limit L (the cart stays below about 10 m/s on the default track, so a step moves it
    less than 0.3 m); unbounded without a limit. Velocities are unbounded."""
    position, angle, inf = track_limit + max(track_limit, 1.0), 2.0 * FAIL_ANGLE, math.inf
    return (-position, -inf, -angle, -inf), (position, inf, angle, inf)


RANGES = ((-TRACK_LIMIT, -1.5, -FAIL_ANGLE, -5 * math.pi / 6),
          (TRACK_LIMIT, 1.5, FAIL_ANGLE, 5 * math.pi / 6))
"""The normalisation ranges `(low, high)` of x, x_dot, theta and theta_dot (the author's
script's, SPEC.md's readings)."""


def balance(time_limit: float = TIME_LIMIT, track_limit=TRACK_LIMIT, params=None) -> TaskDefinition:
    """The paper's balancing task; `time_limit` in seconds, `track_limit` in metres or None,
    `params` the physical parameters' values `{name: value}` (`PARAMETERS`)."""
    limit = (math.inf if track_limit is None
             else positive_number("track_limit", track_limit, "number of metres or None"))
    return TaskDefinition(
        domain="cartpole", task="balance", state_names=STATE_NAMES, controls_of=controls,
        control_name="force",
        control_timestep=TIMESTEP, step_limit=step_limit(time_limit, TIMESTEP),
        initial_states=initial_states, observe=lambda state: state, outcome=outcome,
        transition=transition, arrive=arrive, bounds=bounds(limit), ranges=RANGES,
        angles=("pole_angle",), params=(limit,),
        physical=tuple(PARAMETERS.values(params).tolist()),
    )


class _Accessors:
    """One-line accessors named after the quantities, for both plants."""

    def cart_position(self) -> float:
        """x (m)."""
        return self.state_vector()[0]

    def cart_velocity(self) -> float:
        """x_dot (m/s)."""
        return self.state_vector()[1]

    def pole_angle(self) -> float:
        """theta (rad), 0 upright."""
        return self.state_vector()[2]

    def pole_angular_velocity(self) -> float:
        """theta_dot (rad/s)."""
        return self.state_vector()[3]


def edit_model(spec, p) -> None:
    """`models/cartpole.xml`'s spec at the parameter values `p`: the masses; the pole's
    centre of mass at l, its inertia m (2l)^2 / 12 about the centre (the 4/3 of the
    equations) and the drawn pole 2l long; gravity; the hinge's damping mu_p; the friction
    actuator's force range +-mu_c (switched off at mu_c = 0, a range MuJoCo refuses); the
    motor's control range +-F."""
    spec.option.gravity = [0.0, 0.0, -p[P.gravity]]
    spec.body("cart").mass = p[P.cart_mass]
    pole, half_length = spec.body("pole"), p[P.half_length]
    pole.mass = p[P.pole_mass]
    pole.ipos = [0.0, 0.0, half_length]
    inertia = p[P.pole_mass] * (2.0 * half_length) ** 2 / 12.0
    pole.inertia = [inertia, inertia, pole.inertia[2]]
    spec.geom("pole").fromto = [0.0, 0.0, 0.0, 0.0, 0.0, 2.0 * half_length]
    spec.joint("hinge").damping[0] = p[P.pole_friction]
    friction = spec.actuator("cart_friction")
    if p[P.cart_friction] > 0.0:
        friction.forcerange = [-p[P.cart_friction], p[P.cart_friction]]
    else:
        friction.forcelimited, friction.biasprm[2] = mujoco.mjtLimited.mjLIMITED_FALSE, 0.0
    spec.actuator("force").ctrlrange = [-p[P.force], p[P.force]]


AnalyticPhysicsCartpole, MujocoPhysicsCartpole = physics_classes("Cartpole", _Accessors, STATE_NAMES, "force")
DOMAIN = Domain(
    name="cartpole", tasks={"balance": balance},
    plants=DomainPlants(step=step, timestep=TIMESTEP, analytic_physics=AnalyticPhysicsCartpole,
                        parameters=PARAMETERS, mujoco_physics=MujocoPhysicsCartpole,
                        model="cartpole", edit_model=edit_model))
"""The cart-pole's domain: its tasks, its plants and its physical parameters."""
