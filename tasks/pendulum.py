"""Pendulum swing-up with limited torque (Doya 2000), as in Främling (2008), section 4.2.

A pendulum hangs from a hinge and must be swung up and balanced upright, with a torque too
weak to lift it directly. Two plants: `mujoco` (`models/pendulum.xml`) and `analytic` (the
paper's equation with Euler's method).

Task `swingup`:

- **Actions** (`DiscreteArray`, 2 values): index 0, 1 apply the torque tau = -5, +5 N m.
- **Observations** (float64 scalars): `angle` theta in rad, wrapped to [-pi, pi], 0 upright,
  positive toward +x; `angular_velocity` theta_dot in rad/s (unbounded; about +-1.5 in
  practice near the top, more when swinging).
- **Dynamics**: m l^2 theta_dd = -mu theta_d + m g l sin(theta) + tau with m = 1 kg,
  l = 1 m, g = 9.81 m/s^2, mu = 0.01 N m s/rad (the paper prints "-pi theta_d", a slip for
  mu), integrated at dt = 0.02 s.
- **Reward** (on entering a state): r1 = cos(theta) - 0.7; where |theta| <= pi/5 it is
  r1 - |theta_dot| instead.
- **Start**: theta ~ U[-pi, pi], theta_dot = 0.
- **Episode end**: no terminal state; truncated (discount 1) after `time_limit` = 60 s
  (3000 steps).
- **Up-time**: seconds with |theta| <= pi/2; more than 40 s means balanced to the end.
- **Agent** (the paper's best, Fig. 5): NRBF 10 x 10 over theta in [-pi, pi], theta_dot in
  [-1.5, 1.5] (speeds outside allowed); replacing traces, alpha 1.5, lambda 0.4, epsilon
  0.1; 10 agents x 200 episodes (the author's script).
- **Compared** (`lwrl compare`): the angle, within 0.05 rad of the reference; 10 greedy
  episodes per agent and plant in transfer (the starts are random).
"""

import numpy as np
from numba.extending import register_jitable

from lwrl.tasks.task_definition import RunDefaults, TaskDefinition, step_limit, wrap_angle
from lwrl.tasks.domain_contract import Domain, PlantComparison
from lwrl.tasks.integrators import euler
from lwrl.tasks.physics import physics_classes
from lwrl.tasks.plants import DomainPlants

STATE_NAMES = ("angle", "angular_velocity")
TORQUES = (-5.0, 5.0)
"""tau (N m) of each action."""
MASS = 1.0
"""m (kg)."""
LENGTH = 1.0
"""l (m), hinge to the point mass."""
GRAVITY = 9.81
"""g (m/s^2)."""
FRICTION = 0.01
"""mu (N m s/rad), viscous friction at the hinge."""
TIMESTEP = 0.02
"""dt (s) of one agent step."""
TIME_LIMIT = 60.0
"""Episode length (s)."""
SHAPING_ANGLE = np.pi / 5
"""Within this |theta| the reward also penalises the speed."""
UP_ANGLE = np.pi / 2
"""Within this |theta| the pendulum counts as up."""


@register_jitable
def angular_acceleration(angle, angular_velocity, torque):
    """theta_dd from m l^2 theta_dd = -mu theta_d + m g l sin(theta) + tau."""
    return (-FRICTION * angular_velocity + MASS * GRAVITY * LENGTH * np.sin(angle) + torque) / (
        MASS * LENGTH * LENGTH)


@register_jitable
def step(angle, angular_velocity, torque, dt, semi_implicit, slips):
    """One Euler step of the pendulum; the angle is not wrapped (like MuJoCo's hinge).

    With `slips` (the author's kfnnet code, SPEC.md "Known traps"), the acceleration is
    scaled by dt once more: theta_d' = theta_d + dt^2 theta_dd."""
    acceleration = angular_acceleration(angle, angular_velocity, torque)
    if slips:
        acceleration = acceleration * dt
    return euler(angle, angular_velocity, acceleration, dt, semi_implicit)


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
def outcome(angle, angular_velocity):
    """(reward, terminal, up) on entering a state; no state is terminal."""
    return reward(angle, angular_velocity), False, is_up(angle)


@register_jitable
def arrive(state, observation, params):
    """The observation of entering one state `(2,)`, written into `observation`, and the
    state's `outcome`."""
    observation[0], observation[1] = wrap_angle(state[0]), state[1]
    return outcome(state[0], state[1])


@register_jitable
def transition(state, control, next_state, observation, dt, semi_implicit, slips, params):
    """One Euler step of one state `(2,)` for compiled loops."""
    next_state[0], next_state[1] = step(state[0], state[1], control, dt, semi_implicit, slips)
    return arrive(next_state, observation, params)


def initial_states(rng: np.random.Generator, count: int) -> np.ndarray:
    """theta ~ U[-pi, pi], theta_dot = 0, `(count, 2)`."""
    return np.stack([rng.uniform(-np.pi, np.pi, size=count), np.zeros(count)], axis=-1)


def _observe(state):
    return np.stack([wrap_angle(state[..., 0]), state[..., 1]], axis=-1)


PAPER_AGENT = RunDefaults(n=10, low=(-np.pi, -1.5), high=(np.pi, 1.5), trace="replacing",
                          alpha=1.5, lam=0.4, epsilon=0.1, episodes=200, agents=10)
"""The paper's best agent (Fig. 5); epsilon and the protocol of the author's script."""


def swingup(time_limit: float = TIME_LIMIT) -> TaskDefinition:
    """The paper's swing-up task; `time_limit` in seconds."""
    return TaskDefinition(
        domain="pendulum", task="swingup", state_names=STATE_NAMES, controls=TORQUES,
        control_timestep=TIMESTEP, step_limit=step_limit(time_limit, TIMESTEP),
        initial_states=initial_states, observe=_observe, outcome=outcome, transition=transition,
        arrive=arrive,
        bounds=((-np.pi, -np.inf), (np.pi, np.inf)), defaults=PAPER_AGENT, angles=("angle",),
    )


class _Accessors:
    """One-line accessors named after the quantities, for both plants."""

    def angle(self) -> float:
        """theta (rad), wrapped to [-pi, pi]."""
        return float(wrap_angle(self.state_vector()[0]))

    def angular_velocity(self) -> float:
        """theta_dot (rad/s)."""
        return self.state_vector()[1]


AnalyticPhysicsPendulum, MujocoPhysicsPendulum = physics_classes("Pendulum", _Accessors, STATE_NAMES, "torque")
DOMAIN = Domain(
    name="pendulum", tasks={"swingup": swingup},
    plants=DomainPlants(step=step, timestep=TIMESTEP, analytic_physics=AnalyticPhysicsPendulum,
                        mujoco_physics=MujocoPhysicsPendulum, model="pendulum"),
    value_axes=("angle", "angular_velocity"),
    comparison=PlantComparison(tolerances={"angle": 0.05}, transfer_episodes=10))
