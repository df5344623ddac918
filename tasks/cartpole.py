"""Cart-Pole (Barto, Sutton and Anderson 1983), as in Främling (2008), section 4.3.

A pole hinged on a cart must be kept upright by pushing the cart left or right. Two plants:
`mujoco` (`models/cartpole.xml`) and `analytic` (the paper's equations with Euler's method).

Task `balance`:

- **Actions** (`DiscreteArray`, 2 values): index 0, 1 apply the force F = -10, +10 N to
  the cart (positive toward +x).
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
- **Reward**: 0, and -1 on the failing step.
- **Start**: all four variables 0.
- **Episode end**: terminal (discount 0) when |theta| > 12 deg or, unless
  `track_limit=None`, |x| > `track_limit` (default 2.4 m, as in Barto et al.; the paper
  names only the angle); truncated (discount 1) after `time_limit` = 240 s (12 000 steps).
- **Up-time**: seconds before failure (the pole is up while the episode lasts).
- **Agent** (the author's script; the paper gives no best agent): NRBF 6^4 over
  x in [-2.4, 2.4], x_dot in [-1.5, 1.5], theta in [-12, 12] deg, theta_dot in
  [-150, 150] deg/s; accumulating traces, alpha 0.5, lambda 0.7, epsilon 0.1; 10 agents x
  200 episodes.
- **Compared** (`lwrl compare`): the cart within 0.01 m and the pole within 0.05 rad of the
  reference; 3 greedy episodes per agent and plant in transfer (the start is fixed); the
  energy trials tilt the pole by theta ~ U[-12, 12] deg, since the upright rest is an
  equilibrium.
"""

import math

import numpy as np
from numba.extending import register_jitable

from lwrl.tasks.task_definition import RunDefaults, TaskDefinition, positive_number, step_limit
from lwrl.tasks.domain_contract import Domain, PlantComparison
from lwrl.tasks.integrators import euler_pair
from lwrl.tasks.physics import physics_classes
from lwrl.tasks.plants import DomainPlants

STATE_NAMES = ("cart_position", "cart_velocity", "pole_angle", "pole_angular_velocity")
FORCES = (-10.0, 10.0)
"""F (N) of each action."""
CART_MASS = 1.0
"""mc (kg)."""
POLE_MASS = 0.1
"""m (kg)."""
HALF_LENGTH = 0.5
"""l (m): half the pole's length, hinge to the pole's centre of mass."""
GRAVITY = 9.81
"""g (m/s^2)."""
CART_FRICTION = 0.0005
"""mu_c (N): Coulomb friction of the cart on the track."""
POLE_FRICTION = 0.000002
"""mu_p (N m s/rad): viscous friction at the pole's hinge."""
TOTAL_MASS = CART_MASS + POLE_MASS
"""mc + m (kg)."""
POLE_MASS_LENGTH = POLE_MASS * HALF_LENGTH
"""m l (kg m): a product (Gymnasium's functional cart-pole once had a sum here)."""
TIMESTEP = 0.02
"""dt (s) of one agent step."""
TIME_LIMIT = 240.0
"""Episode length (s)."""
FAIL_ANGLE = math.radians(12.0)
"""The pole has fallen beyond this |theta| (rad)."""
TRACK_LIMIT = 2.4
"""The cart has left the track beyond this |x| (m), by default."""


@register_jitable
def accelerations(cart_velocity, pole_angle, pole_angular_velocity, force, slips):
    """(x_dd, theta_dd) of the paper's Cart-Pole equations (section 4.3).

    With `slips` (the author's kfnnet code, SPEC.md "Known traps"), the theta_d^2 term takes
    the cart's mass for the pole's, mc l theta_d^2 sin(theta), in both equations."""
    sin_theta = np.sin(pole_angle)
    cos_theta = np.cos(pole_angle)
    friction = CART_FRICTION * np.sign(cart_velocity)
    spin_mass_length = CART_MASS * HALF_LENGTH if slips else POLE_MASS_LENGTH
    spin = spin_mass_length * pole_angular_velocity * pole_angular_velocity * sin_theta
    pole_acceleration = (
        GRAVITY * sin_theta
        + cos_theta * (-force - spin + friction) / TOTAL_MASS
        - POLE_FRICTION * pole_angular_velocity / POLE_MASS_LENGTH
    ) / (HALF_LENGTH * (4.0 / 3.0 - POLE_MASS * cos_theta * cos_theta / TOTAL_MASS))
    cart_acceleration = (
        force + spin - POLE_MASS_LENGTH * pole_acceleration * cos_theta - friction) / TOTAL_MASS
    return cart_acceleration, pole_acceleration


@register_jitable
def step(cart_position, cart_velocity, pole_angle, pole_angular_velocity, force, dt,
         semi_implicit, slips):
    """One Euler step of the cart-pole (`slips`: see `accelerations`)."""
    cart_acceleration, pole_acceleration = accelerations(
        cart_velocity, pole_angle, pole_angular_velocity, force, slips)
    return euler_pair(cart_position, cart_velocity, pole_angle, pole_angular_velocity,
                      cart_acceleration, pole_acceleration, dt, semi_implicit)


@register_jitable
def failed(cart_position, pole_angle, track_limit):
    """True where the pole has fallen (|theta| > 12 deg) or the cart has left the track
    (|x| > track_limit; pass `inf` for no limit)."""
    return (np.abs(pole_angle) > FAIL_ANGLE) | (np.abs(cart_position) > track_limit)


@register_jitable
def outcome(cart_position, cart_velocity, pole_angle, pole_angular_velocity, track_limit):
    """(reward, terminal, up) on entering a state: failing is terminal with reward -1;
    the pole is up until then."""
    fail = failed(cart_position, pole_angle, track_limit)
    return 0.0 - 1.0 * fail, fail, np.logical_not(fail)  # 0.0 - 0.0 is +0.0, not -0.0


@register_jitable
def arrive(state, observation, params):
    """The observation of entering one state `(4,)` (the state itself), written into
    `observation`, and the state's `outcome`; `params` = (track_limit,)."""
    observation[:] = state
    return outcome(state[0], state[1], state[2], state[3], params[0])


@register_jitable
def transition(state, control, next_state, observation, dt, semi_implicit, slips, params):
    """One Euler step of one state `(4,)` for compiled loops; `params` = (track_limit,)."""
    next_state[0], next_state[1], next_state[2], next_state[3] = step(
        state[0], state[1], state[2], state[3], control, dt, semi_implicit, slips)
    return arrive(next_state, observation, params)


def initial_states(rng: np.random.Generator, count: int) -> np.ndarray:
    """All zeros, `(count, 4)`: the paper's start is deterministic."""
    del rng
    return np.zeros((count, len(STATE_NAMES)))


def rest_start(rng: np.random.Generator) -> np.ndarray:
    """A start for zero-action trials: the pole tilted by theta ~ U[-12, 12] deg, the rest 0
    (the upright rest is an equilibrium zero action never leaves)."""
    start = initial_states(rng, 1)[0]
    start[2] = rng.uniform(-FAIL_ANGLE, FAIL_ANGLE)
    return start


def bounds(track_limit: float) -> tuple:
    """`(low, high)` holding every observation of an episode. The angle: +-24 deg, twice
    the failure angle, as Gymnasium's CartPole (the angle's speed stays below about 5 rad/s
    while |theta| <= 12 deg, so the failing step passes 12 deg by under 6 deg; an
    adversarial search found 3.8 deg). The position: +-(L + max(L, 1 m)) for the track
    limit L (the cart stays below about 10 m/s on the default track, so a step moves it
    less than 0.3 m); unbounded without a limit. Velocities are unbounded."""
    position, angle, inf = track_limit + max(track_limit, 1.0), 2.0 * FAIL_ANGLE, math.inf
    return (-position, -inf, -angle, -inf), (position, inf, angle, inf)


PAPER_AGENT = RunDefaults(
    n=6, low=(-TRACK_LIMIT, -1.5, -FAIL_ANGLE, -5 * math.pi / 6),
    high=(TRACK_LIMIT, 1.5, FAIL_ANGLE, 5 * math.pi / 6), trace="accumulating", alpha=0.5,
    lam=0.7, epsilon=0.1, episodes=200, agents=10)
"""The author's script's agent and ranges (SPEC.md's readings), the paper's epsilon."""


def balance(time_limit: float = TIME_LIMIT, track_limit=TRACK_LIMIT) -> TaskDefinition:
    """The paper's balancing task; `time_limit` in seconds, `track_limit` in metres or None."""
    limit = (math.inf if track_limit is None
             else positive_number("track_limit", track_limit, "number of metres or None"))
    return TaskDefinition(
        domain="cartpole", task="balance", state_names=STATE_NAMES, controls=FORCES,
        control_timestep=TIMESTEP, step_limit=step_limit(time_limit, TIMESTEP),
        initial_states=initial_states, observe=lambda state: state, outcome=outcome,
        transition=transition, arrive=arrive, bounds=bounds(limit), defaults=PAPER_AGENT,
        angles=("pole_angle",), params=(limit,),
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


AnalyticPhysicsCartpole, MujocoPhysicsCartpole = physics_classes("Cartpole", _Accessors, STATE_NAMES, "force")
DOMAIN = Domain(
    name="cartpole", tasks={"balance": balance},
    plants=DomainPlants(step=step, timestep=TIMESTEP, analytic_physics=AnalyticPhysicsCartpole,
                        mujoco_physics=MujocoPhysicsCartpole, model="cartpole"),
    value_axes=("pole_angle", "pole_angular_velocity"),
    comparison=PlantComparison(tolerances={"cart_position": 0.01, "pole_angle": 0.05},
                               transfer_episodes=3, rest_start=rest_start))
