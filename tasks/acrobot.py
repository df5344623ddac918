"""Acrobot swing-up (Sutton 1996; Sutton and Barto 1998, section 11.3).

Two links hang from a fixed joint, the shoulder; only the second joint, the elbow, is driven,
with a torque too weak to lift the arm directly: the agent must pump energy in to swing the
tip above the shoulder. The physics is the book's (the "book" dynamics of Gymnasium's
Acrobot-v1, whose default differs in one term). Two plants: `mujoco` (`models/acrobot.xml`)
and `analytic` (the book's equations with Euler's method).

Task `swingup`:

- **Actions** (`DiscreteArray`, 3 values): index 0, 1, 2 apply the elbow torque
  tau = -tau_max, 0, +tau_max, tau_max = 1 N m. With `actions="continuous"` (`BoundedArray`
  of shape (1,), float64, named `torque`): the elbow torque itself, in [-tau_max,
  tau_max], held over the four Euler steps; one outside is clipped to it, as the motor
  saturates (the MJCF motor's control range is the same).
- **Observations** (float64 scalars): `shoulder_angle` theta1 in rad, wrapped to
  [-pi, pi], 0 hanging straight down; `shoulder_angular_velocity` theta1_dot in rad/s,
  within [-4 pi, 4 pi]; `elbow_angle` theta2 in rad, link 2 relative to link 1, wrapped to
  [-pi, pi], 0 straight; `elbow_angular_velocity` theta2_dot in rad/s, within
  [-9 pi, 9 pi]. A positive angle swings a link's free end toward -x in the model.
- **Dynamics** (the book's), with m1 = m2 = 1 kg, l1 = l2 = 1 m, lc1 = lc2 = 0.5 m (joint to
  centre of mass), I1 = I2 = 1 kg m^2 (about the centre of mass), g = 9.8 m/s^2:
  d1 = m1 lc1^2 + m2 (l1^2 + lc2^2 + 2 l1 lc2 cos theta2) + I1 + I2,
  d2 = m2 (lc2^2 + l1 lc2 cos theta2) + I2,
  phi2 = m2 lc2 g cos(theta1 + theta2 - pi/2),
  phi1 = -m2 l1 lc2 theta2_dot^2 sin theta2 - 2 m2 l1 lc2 theta2_dot theta1_dot sin theta2
         + (m1 lc1 + m2 l1) g cos(theta1 - pi/2) + phi2,
  theta2_dd = (tau + d2/d1 phi1 - m2 l1 lc2 theta1_dot^2 sin theta2 - phi2)
              / (m2 lc2^2 + I2 - d2^2/d1),
  theta1_dd = -(d2 theta2_dd + phi1) / d1;
  four Euler steps of dt = 0.05 s per action (an agent step is 0.2 s), the torque held;
  after the four (not after each) the velocities are clipped to theta1_dot in [-4 pi, 4 pi],
  theta2_dot in [-9 pi, 9 pi]. The angles are not wrapped in the state (like MuJoCo's
  hinges).
- **Parameters** (`PARAMETERS`; the task option `params={name: value}`, the others at the
  book's values): `link_mass_1` m1 (kg) 1, in [0.1, 10]; `link_mass_2` m2 (kg) 1, in
  [0.1, 10]; `link_length_1` l1 (m) 1, in [0.1, 10]; `link_length_2` l2 (m) 1, in
  [0.1, 10]; `link_com_1` lc1 (m) 0.5, in [0.05, 10]; `link_com_2` lc2 (m) 0.5, in
  [0.05, 10]; `link_inertia_1` I1 (kg m^2) 1, in [0.01, 100]; `link_inertia_2` I2 (kg m^2)
  1, in [0.01, 100]; `gravity` g (m/s^2) 9.8, in [0, 30]; `torque` tau_max (N m) 1, in
  [0.1, 10]. The goal line stays one link (l1) above the shoulder. The MuJoCo plant
  takes them into its model through `mujoco.MjSpec`, recompiled (`edit_model`): a length
  moves the elbow, the centres of mass, the drawn links, the tip and the goal line, so the
  model is compiled anew rather than patched field by field; the torque is the motor's
  control range.
- **Reward**: -1 every step, 0 on the step that reaches the goal (cost to go).
- **Start**: all four variables 0, at rest hanging down (deterministic); with the task option
  `start_spread` s > 0 each variable drawn uniformly in [-s, s] around that rest for every
  episode (Gymnasium's Acrobot-v1 start, s = 0.1).
- **Episode end**: terminal (discount 0) when the tip is more than one link above the
  shoulder, -l1 cos theta1 - l2 cos(theta1 + theta2) > l1; truncated (discount 1) after
  `time_limit` = 2000 s (10 000 steps), a safety cap (the book has none).
- **Up-time**: none (reported as NaN).
- **Normalisation ranges** (`RANGES`) and the paper's **agent** (its settings in
  `agent.paper_settings`; found for this suite, `docs/acrobot/README.md`; the book's agent is a tile
  coding, not an NRBF): NRBF 6^4 over theta1, theta2 in [-pi, pi], theta1_dot in
  [-2 pi, 2 pi], theta2_dot in [-4 pi, 4 pi] (half and four ninths of the limits, which
  hold 99.6 % or more of the states of the learning agents' episodes; speeds outside
  allowed); replacing traces, alpha 1.0, lambda 0.9, epsilon 0 (the zero weights are
  optimistic against rewards of -1, so the greedy agent explores, as on Mountain-Car);
  10 agents x 200 episodes. A small search over alpha, lambda and the speed ranges on the
  analytic plant chose them: the steps per episode fall from about 900 in the first
  episode to 80-90 after about 100 episodes, with no episode at the time limit.
"""

import math

import numpy as np
from numba.extending import register_jitable

from lwrl.tasks.task_definition import TaskDefinition, step_limit, wrap_angle
from lwrl.tasks.domain_contract import Domain
from lwrl.tasks.integrators import euler_pair
from lwrl.tasks.parameters import Parameter, Parameters
from lwrl.tasks.physics import physics_classes
from lwrl.tasks.plants import DomainPlants

STATE_NAMES = ("shoulder_angle", "shoulder_angular_velocity", "elbow_angle",
               "elbow_angular_velocity")
"""The names of the acrobot's state variables, in the state vector's order."""
PARAMETERS = Parameters(
    Parameter("link_mass_1", "m1", "kg", 1.0, 0.1, 10.0, "link 1's mass"),
    Parameter("link_mass_2", "m2", "kg", 1.0, 0.1, 10.0, "link 2's mass"),
    Parameter("link_length_1", "l1", "m", 1.0, 0.1, 10.0, "link 1's length, shoulder to elbow"),
    Parameter("link_length_2", "l2", "m", 1.0, 0.1, 10.0, "link 2's length, elbow to tip"),
    Parameter("link_com_1", "lc1", "m", 0.5, 0.05, 10.0, "shoulder to link 1's centre of mass"),
    Parameter("link_com_2", "lc2", "m", 0.5, 0.05, 10.0, "elbow to link 2's centre of mass"),
    Parameter("link_inertia_1", "I1", "kg m^2", 1.0, 0.01, 100.0,
              "link 1's moment of inertia about its centre of mass"),
    Parameter("link_inertia_2", "I2", "kg m^2", 1.0, 0.01, 100.0,
              "link 2's moment of inertia about its centre of mass"),
    Parameter("gravity", "g", "m/s^2", 9.8, 0.0, 30.0, "gravity's acceleration (the book's)"),
    Parameter("torque", "tau_max", "N m", 1.0, 0.1, 10.0,
              "the elbow torque of the pushing actions, -tau_max or +tau_max"),
)
"""The book's physical constants (Sutton and Barto 1998, section 11.3) as parameters."""
P = PARAMETERS.index
"""Where each parameter sits in a parameter vector `p`: `p[P.link_mass_1]`."""
NOMINAL = PARAMETERS.nominal
"""The book's values: `NOMINAL.link_com_1` is 0.5 m."""
SUBSTEPS = 4
"""Euler steps per agent step."""
SUBSTEP = 0.05
"""dt (s) of one Euler step (the MJCF model's timestep)."""
TIMESTEP = SUBSTEPS * SUBSTEP
"""Seconds of one agent step: 0.2."""
MAX_SHOULDER_SPEED = 4.0 * math.pi
"""|theta1_dot| is clipped to this (rad/s) after each agent step."""
MAX_ELBOW_SPEED = 9.0 * math.pi
"""|theta2_dot| is clipped to this (rad/s) after each agent step."""
TIME_LIMIT = 2000.0
"""Episode length (s): a safety cap of 10 000 steps."""


@register_jitable
def mass_matrix(elbow_angle, p):
    """(d1, d2, d22): the mass matrix [[d1, d2], [d2, d22]] of the book's equations at the
    parameter values `p` (`PARAMETERS`), with d22 = m2 lc2^2 + I2."""
    link_mass_1, link_mass_2 = p[P.link_mass_1], p[P.link_mass_2]
    length_1, com_1, com_2 = p[P.link_length_1], p[P.link_com_1], p[P.link_com_2]
    inertia_2 = p[P.link_inertia_2]
    cos_elbow = np.cos(elbow_angle)
    d1 = (link_mass_1 * (com_1 * com_1)
          + link_mass_2 * (length_1 * length_1 + com_2 * com_2
                           + 2.0 * length_1 * com_2 * cos_elbow)
          + p[P.link_inertia_1] + inertia_2)
    d2 = link_mass_2 * (com_2 * com_2 + length_1 * com_2 * cos_elbow) + inertia_2
    return d1, d2, link_mass_2 * (com_2 * com_2) + inertia_2


@register_jitable
def accelerations(shoulder_angle, shoulder_angular_velocity, elbow_angle,
                  elbow_angular_velocity, torque, p):
    """(theta1_dd, theta2_dd) of the book's equations (Sutton and Barto 1998, section 11.3)
    at the parameter values `p`."""
    d1, d2, d22 = mass_matrix(elbow_angle, p)
    link_mass_2, length_1, com_2 = p[P.link_mass_2], p[P.link_length_1], p[P.link_com_2]
    gravity = p[P.gravity]
    sin_elbow = np.sin(elbow_angle)
    coupling = link_mass_2 * length_1 * com_2
    phi2 = link_mass_2 * com_2 * gravity * np.cos(shoulder_angle + elbow_angle - np.pi / 2)
    phi1 = (-coupling * elbow_angular_velocity ** 2 * sin_elbow
            - 2.0 * coupling * elbow_angular_velocity * shoulder_angular_velocity * sin_elbow
            + (p[P.link_mass_1] * p[P.link_com_1] + link_mass_2 * length_1) * gravity
            * np.cos(shoulder_angle - np.pi / 2)
            + phi2)
    elbow_acceleration = (torque + d2 / d1 * phi1
                          - coupling * shoulder_angular_velocity ** 2 * sin_elbow - phi2) / (
        d22 - d2 * d2 / d1)
    shoulder_acceleration = -(d2 * elbow_acceleration + phi1) / d1
    return shoulder_acceleration, elbow_acceleration


@register_jitable
def euler_step(shoulder_angle, shoulder_angular_velocity, elbow_angle, elbow_angular_velocity,
               torque, dt, semi_implicit, p):
    """One Euler step of dt (one MuJoCo step of the model when `semi_implicit`) at the
    parameter values `p`."""
    shoulder_acceleration, elbow_acceleration = accelerations(
        shoulder_angle, shoulder_angular_velocity, elbow_angle, elbow_angular_velocity, torque, p)
    return euler_pair(shoulder_angle, shoulder_angular_velocity, elbow_angle,
                      elbow_angular_velocity, shoulder_acceleration, elbow_acceleration, dt,
                      semi_implicit)


@register_jitable
def limit(shoulder_angle, shoulder_angular_velocity, elbow_angle, elbow_angular_velocity):
    """The state with the velocities clipped to [-4 pi, 4 pi] and [-9 pi, 9 pi], after each
    agent step (`DomainPlants.limit`); the angles pass through."""
    shoulder_angular_velocity = np.minimum(np.maximum(
        shoulder_angular_velocity, -MAX_SHOULDER_SPEED), MAX_SHOULDER_SPEED)
    elbow_angular_velocity = np.minimum(np.maximum(
        elbow_angular_velocity, -MAX_ELBOW_SPEED), MAX_ELBOW_SPEED)
    return shoulder_angle, shoulder_angular_velocity, elbow_angle, elbow_angular_velocity


@register_jitable
def limit_state(state):
    """`limit` of one state `(4,)` in place, for compiled loops."""
    state[0], state[1], state[2], state[3] = limit(state[0], state[1], state[2], state[3])


@register_jitable
def step(shoulder_angle, shoulder_angular_velocity, elbow_angle, elbow_angular_velocity,
         torque, dt, semi_implicit, slips, p):
    """One agent step of `dt` (0.2 s) at the parameter values `p`: four Euler steps of
    dt / 4, the torque held, then the velocity limit. The angles are not wrapped (like
    MuJoCo's hinges). `slips` is ignored: the author's code has no acrobot, so there is no
    reading of its slips."""
    state = (shoulder_angle, shoulder_angular_velocity, elbow_angle, elbow_angular_velocity)
    for _ in range(SUBSTEPS):
        state = euler_step(state[0], state[1], state[2], state[3], torque, dt / SUBSTEPS,
                           semi_implicit, p)
    return limit(state[0], state[1], state[2], state[3])


def controls(p):
    """tau of each action at the parameter values `p`: -tau_max, 0, +tau_max."""
    return -p[P.torque], 0.0, p[P.torque]


TORQUES = tuple(float(torque) for torque in controls(np.asarray(NOMINAL)))
"""tau (N m) at the elbow of each action at the book's values: -1, 0, +1."""


@register_jitable
def tip_height(shoulder_angle, elbow_angle, p):
    """Height of the tip above the shoulder (m): -l1 cos theta1 - l2 cos(theta1 + theta2)."""
    return (-p[P.link_length_1] * np.cos(shoulder_angle)
            - p[P.link_length_2] * np.cos(shoulder_angle + elbow_angle))


@register_jitable
def reached_goal(shoulder_angle, elbow_angle, p):
    """True where the tip is more than one link (l1) above the shoulder: the terminal states."""
    return tip_height(shoulder_angle, elbow_angle, p) > p[P.link_length_1]


@register_jitable
def outcome(shoulder_angle, shoulder_angular_velocity, elbow_angle, elbow_angular_velocity, p):
    """(reward, terminal, up) on entering a state at the parameter values `p`: -1, or 0 on
    reaching the goal, which is terminal; no up-time."""
    goal = reached_goal(shoulder_angle, elbow_angle, p)
    return goal - 1.0, goal, False


@register_jitable
def arrive(state, observation, arguments):
    """The observation of entering one state `(4,)`, written into `observation`, and the
    state's `outcome`; `arguments` = ((), p)."""
    observation[0], observation[1] = wrap_angle(state[0]), state[1]
    observation[2], observation[3] = wrap_angle(state[2]), state[3]
    return outcome(state[0], state[1], state[2], state[3], arguments[1])


@register_jitable
def transition(state, control, next_state, observation, dt, semi_implicit, slips, arguments):
    """One agent step of one state `(4,)` for compiled loops; `arguments` = ((), p)."""
    next_state[0], next_state[1], next_state[2], next_state[3] = step(
        state[0], state[1], state[2], state[3], control, dt, semi_implicit, slips, arguments[1])
    return arrive(next_state, observation, arguments)


def initial_states(rng: np.random.Generator, count: int) -> np.ndarray:
    """All zeros, `(count, 4)`: at rest hanging down (the book's start is deterministic)."""
    del rng
    return np.zeros((count, len(STATE_NAMES)))


def spread_starts(spread: float):
    """`initial_states` for the option `start_spread`: each of the four variables uniform in
    [-spread, spread] around the rest hanging down (Gymnasium's Acrobot-v1 draws its starts
    so, spread 0.1); `initial_states` itself where `spread` is 0."""
    if spread < 0 or not math.isfinite(spread):
        raise ValueError(f"start_spread must be a finite number >= 0; got {spread!r}")
    if spread == 0:
        return initial_states
    return lambda rng, count: rng.uniform(-spread, spread, size=(count, len(STATE_NAMES)))


def _observe(state):
    state = np.asarray(state, dtype=np.float64)
    return np.stack([wrap_angle(state[..., 0]), state[..., 1], wrap_angle(state[..., 2]),
                     state[..., 3]], axis=-1)


BOUNDS = ((-np.pi, -MAX_SHOULDER_SPEED, -np.pi, -MAX_ELBOW_SPEED),
          (np.pi, MAX_SHOULDER_SPEED, np.pi, MAX_ELBOW_SPEED))
"""Every observation: the wrapped angles and the velocity limits."""
RANGES = ((-np.pi, -2 * np.pi, -np.pi, -4 * np.pi), (np.pi, 2 * np.pi, np.pi, 4 * np.pi))
"""The normalisation ranges `(low, high)` of theta1, theta1_dot, theta2, theta2_dot (found
for this suite, docs/acrobot/README.md)."""


def swingup(time_limit: float = TIME_LIMIT, params=None,
            start_spread: float = 0.0) -> TaskDefinition:
    """The book's swing-up task; `time_limit` in seconds (a truncation), `params` the
    physical parameters' values `{name: value}` (`PARAMETERS`), `start_spread` the half-width
    of the starts around the rest (`spread_starts`; 0, the book's: at rest)."""
    return TaskDefinition(
        domain="acrobot", task="swingup", state_names=STATE_NAMES, controls_of=controls,
        control_name="torque",
        control_timestep=TIMESTEP, step_limit=step_limit(time_limit, TIMESTEP),
        initial_states=spread_starts(start_spread), observe=_observe, outcome=outcome,
        transition=transition, arrive=arrive,
        bounds=BOUNDS, ranges=RANGES, angles=("shoulder_angle", "elbow_angle"),
        has_uptime=False, physical=tuple(PARAMETERS.values(params).tolist()),
    )


class _Accessors:
    """One-line accessors named after the quantities, for both plants."""

    def shoulder_angle(self) -> float:
        """theta1 (rad), wrapped to [-pi, pi], 0 hanging down."""
        return float(wrap_angle(self.state_vector()[0]))

    def shoulder_angular_velocity(self) -> float:
        """theta1_dot (rad/s)."""
        return self.state_vector()[1]

    def elbow_angle(self) -> float:
        """theta2 (rad), relative to link 1, wrapped to [-pi, pi]."""
        return float(wrap_angle(self.state_vector()[2]))

    def elbow_angular_velocity(self) -> float:
        """theta2_dot (rad/s)."""
        return self.state_vector()[3]

    def tip_height(self) -> float:
        """The tip's height above the shoulder (m); the goal is above l1 (1 m)."""
        state = self.state_vector()
        return float(tip_height(state[0], state[2], self.physical))


def edit_model(spec, p) -> None:
    """`models/acrobot.xml`'s spec at the parameter values `p`: each link's mass, centre of
    mass lc below its joint and inertia I about it; the elbow l1 below the shoulder; the
    drawn links, the tip and the goal line one link (l1) above the shoulder; gravity; the
    motor's control range +-tau_max."""
    spec.option.gravity = [0.0, 0.0, -p[P.gravity]]
    upper, lower = spec.body("upper_link"), spec.body("lower_link")
    for body, mass, com, inertia in ((upper, P.link_mass_1, P.link_com_1, P.link_inertia_1),
                                     (lower, P.link_mass_2, P.link_com_2, P.link_inertia_2)):
        body.mass, body.ipos, body.inertia = p[mass], [0.0, 0.0, -p[com]], [p[inertia]] * 3
    lower.pos = [0.0, 0.0, -p[P.link_length_1]]
    spec.geom("upper_link").fromto = [0.0, 0.0, 0.0, 0.0, 0.0, -p[P.link_length_1]]
    spec.geom("lower_link").fromto = [0.0, 0.0, 0.0, 0.0, 0.0, -p[P.link_length_2]]
    spec.geom("tip").pos = [0.0, 0.0, -p[P.link_length_2]]
    goal = spec.geom("goal")
    goal.pos = [goal.pos[0], goal.pos[1], upper.pos[2] + p[P.link_length_1]]
    spec.actuator("torque").ctrlrange = [-p[P.torque], p[P.torque]]


AnalyticPhysicsAcrobot, MujocoPhysicsAcrobot = physics_classes("Acrobot", _Accessors, STATE_NAMES, "torque")
DOMAIN = Domain(
    name="acrobot", tasks={"swingup": swingup},
    plants=DomainPlants(step=step, timestep=TIMESTEP, analytic_physics=AnalyticPhysicsAcrobot,
                        parameters=PARAMETERS, analytic_options=("integrator",),
                        mujoco_physics=MujocoPhysicsAcrobot, model="acrobot",
                        edit_model=edit_model, substeps=SUBSTEPS, limit=limit,
                        limit_state=limit_state))
"""The acrobot's domain: its tasks, its plants and its physical parameters."""
