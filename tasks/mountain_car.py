"""Mountain-Car (Moore 1991; Singh and Sutton 1996), as in Främling (2008), section 4.1.

An under-powered car in a valley must back up the left slope to gather the momentum that
takes it over the right hill. Its physics is the paper's difference equation, run as a custom
dm_control Physics; there is no MuJoCo plant.

Task `cost_to_go`:

- **Actions** (`DiscreteArray`, 3 values): index 0, 1, 2 apply the thrust a = -1 (reverse),
  0 (none), +1 (forward). With `actions="continuous"` (`BoundedArray` of shape (1,),
  float64, named `thrust`): the thrust a itself, in [-1, 1] (the velocity changes by k a);
  one outside is clipped to it, as an engine saturates.
- **Observations** (float64 scalars): `position` x in [-1.2, 0.5] (beyond 0.5 only in the
  terminal state); `velocity` v in [-0.07, 0.07]. The altitude is sin(3x).
- **Dynamics** (one step): v' = clip(v + 0.001 a - 0.0025 cos(3x), -0.07, 0.07);
  x' = max(x + v', -1.2), and v' = 0 when the left wall clipped x'.
- **Parameters** (`PARAMETERS`; the task option `params={name: value}`, the others at the
  paper's values): `thrust` k (position/step^2) 0.001, in [0.0001, 0.01], the velocity
  change per step and unit of thrust a (v' = v + k a - g cos(3x)); `gravity` g
  (position/step^2) 0.0025, in [0, 0.01], the slope's pull. There is no MuJoCo model to set
  them in.
- **Reward**: -1 every step, 0 on the step that reaches the goal (cost to go).
- **Start**: x ~ U[-1.2, 0.5], v ~ U[-0.07, 0.07] (random, unlike Gymnasium's
  MountainCar-v0).
- **Episode end**: terminal (discount 0) when x' > 0.5; truncated (discount 1) after
  `time_limit` steps (default 10 000, a safety cap: the paper has none). A step counts as
  one unit of time.
- **Up-time**: none (reported as NaN).
- **Normalisation ranges** (`RANGES`) and the paper's **agent** (its settings in
  `agent.paper_settings`; the paper's best, Fig. 3): NRBF 8 x 8 over x in [-1.2, 0.5], v in
  [-0.07, 0.07]; replacing traces, alpha 3.9, lambda 0.9, epsilon 0 (SPEC.md's reading);
  30 agents x 40 episodes.
"""

import numpy as np
from numba.extending import register_jitable

from lwrl.kernels import copy_into
from lwrl.tasks.domain_contract import Domain
from lwrl.tasks.parameters import Parameter, Parameters
from lwrl.tasks.task_definition import TaskDefinition, step_limit
from lwrl.tasks.physics import AnalyticPhysics
from lwrl.tasks.plants import DomainPlants

STATE_NAMES = ("position", "velocity")
"""The names of Mountain-Car's state variables, in the state vector's order."""
THRUSTS = (-1.0, 0.0, 1.0)
"""Thrust a of each action: reverse, none, forward."""
PARAMETERS = Parameters(
    Parameter("thrust", "k", "position/step^2", 0.001, 0.0001, 0.01,
              "velocity change per step and unit of thrust"),
    Parameter("gravity", "g", "position/step^2", 0.0025, 0.0, 0.01,
              "velocity change per step from the slope, times cos(3x)"),
)
"""Mountain-Car's physical constants (section 4.1) as parameters."""
P = PARAMETERS.index
"""Where each parameter sits in a parameter vector `p`: `p[P.gravity]`."""
NOMINAL = PARAMETERS.nominal
"""The paper's values: `NOMINAL.gravity` is 0.0025."""
MIN_POSITION = -1.2
"""The left wall."""
GOAL_POSITION = 0.5
"""Terminal when the position exceeds this."""
MAX_SPEED = 0.07
"""The velocity is bounded to [-MAX_SPEED, MAX_SPEED]."""
STEP_LIMIT = 10_000
"""Default safety cap on an episode's steps (a truncation)."""
TIMESTEP = 1.0
"""One step of the difference equation is one unit of time."""


@register_jitable
def step(position, velocity, thrust, p):
    """One step of the paper's Mountain-Car equations (section 4.1) at the parameter values
    `p` (`PARAMETERS`); element-wise."""
    velocity_next = np.minimum(np.maximum(
        velocity + p[P.thrust] * thrust - p[P.gravity] * np.cos(3.0 * position), -MAX_SPEED),
        MAX_SPEED)
    unclipped = position + velocity_next
    position_next = np.maximum(unclipped, MIN_POSITION)
    velocity_next = velocity_next * (unclipped >= MIN_POSITION)  # the wall stops the car
    return position_next, velocity_next


@register_jitable
def reached_goal(position):
    """True past the goal at x = 0.5: the terminal states."""
    return position > GOAL_POSITION


@register_jitable
def reward(position):
    """-1 per step, 0 on entering the goal."""
    return reached_goal(position) - 1.0


@register_jitable
def outcome(position, velocity, p):
    """(reward, terminal, up) on entering a state: the goal is terminal; no up-time
    (whatever the parameters `p`)."""
    return reward(position), reached_goal(position), False


def controls(p):
    """Thrust a of each action, whatever the parameters `p` (the gain is `thrust`'s)."""
    return THRUSTS


@register_jitable
def arrive(state, observation, arguments):
    """The observation of entering one state `(2,)` (the state itself), written into
    `observation`, and the state's `outcome`; `arguments` = ((), p)."""
    copy_into(observation, state)
    return outcome(state[0], state[1], arguments[1])


@register_jitable
def transition(state, control, next_state, observation, dt, semi_implicit, slips, arguments):
    """One step of one state `(2,)` for compiled loops; `arguments` = ((), p) (`dt`,
    `semi_implicit` and `slips` are unused: the paper's equation is its own integrator)."""
    next_state[0], next_state[1] = step(state[0], state[1], control, arguments[1])
    return arrive(next_state, observation, arguments)


def initial_states(rng: np.random.Generator, count: int) -> np.ndarray:
    """x ~ U[-1.2, 0.5], v ~ U[-0.07, 0.07], `(count, 2)`."""
    return rng.uniform((MIN_POSITION, -MAX_SPEED), (GOAL_POSITION, MAX_SPEED), size=(count, 2))


BOUNDS = ((MIN_POSITION, -MAX_SPEED), (GOAL_POSITION + MAX_SPEED, MAX_SPEED))
"""Every observation of an episode: the goal step moves at most MAX_SPEED past the goal."""
RANGES = ((MIN_POSITION, -MAX_SPEED), (GOAL_POSITION, MAX_SPEED))
"""The normalisation ranges `(low, high)` of x and v: the state's own (the paper's, Fig. 3)."""


def cost_to_go(time_limit: float = STEP_LIMIT, params=None) -> TaskDefinition:
    """The paper's Mountain-Car task; `time_limit` caps an episode's steps, `params` the
    physical parameters' values `{name: value}` (`PARAMETERS`)."""
    return TaskDefinition(
        domain="mountain_car", task="cost_to_go", state_names=STATE_NAMES, controls_of=controls,
        control_name="thrust",
        control_timestep=TIMESTEP, step_limit=step_limit(time_limit, TIMESTEP),
        initial_states=initial_states,
        observe=lambda state: state, outcome=outcome, transition=transition, arrive=arrive,
        bounds=BOUNDS, ranges=RANGES, has_uptime=False,
        physical=tuple(PARAMETERS.values(params).tolist()),
    )


class Physics(AnalyticPhysics):
    """Mountain-Car's custom dm_control Physics: the paper's difference equation."""

    STATE_NAMES = STATE_NAMES
    """The state variables' names: `position`, `velocity`."""

    def position(self) -> float:
        """The car's position x."""
        return self.state_vector()[0]

    def velocity(self) -> float:
        """The car's velocity v."""
        return self.state_vector()[1]

    def altitude(self) -> float:
        """The car's altitude, sin(3x)."""
        return float(np.sin(3.0 * self.position()))


DOMAIN = Domain(
    name="mountain_car", tasks={"cost_to_go": cost_to_go},
    plants=DomainPlants(step=step, timestep=TIMESTEP, analytic_physics=Physics,
                        parameters=PARAMETERS, euler=False, analytic_options=()))
"""Mountain-Car's domain: its tasks, its plants and its physical parameters."""
