"""Plants that step a batch of states: the paper's equations, or MuJoCo.

A plant maps states `(B, d)` and controls `(B,)` to the next states `(B, d)`, one control
step of the task. States are in the task's order, which interleaves each coordinate with its
velocity: `(q0, q0_dot, q1, q1_dot, ...)`.
"""

import dataclasses
from typing import Callable, Optional

import mujoco
import numpy as np

import models
from tasks.integrators import check_integrator

class AnalyticPlant:
    """The paper's difference equations as array functions.

    `step_columns(*state_columns, control)` returns the next state's columns; it is the
    domain's own `step` with its time step and integrator bound.
    """

    def __init__(self, step_columns: Callable, timestep: float):
        self._step_columns = step_columns
        self.timestep = timestep

    def step(self, state: np.ndarray, control: np.ndarray) -> np.ndarray:
        columns = self._step_columns(*np.moveaxis(state, -1, 0), control)
        return np.stack(columns, axis=-1)


class MujocoPlant:
    """B copies of an MJCF model, one `MjData` each, stepped with `mj_step`.

    The model's timestep must equal the control step (one `mj_step` per agent step).
    """

    def __init__(self, model: mujoco.MjModel, actuator: str, batch_size: int):
        self.model = model
        self.timestep = float(model.opt.timestep)
        self._actuator = model.actuator(actuator).id
        self._datas = [mujoco.MjData(model) for _ in range(batch_size)]

    def step(self, state: np.ndarray, control: np.ndarray) -> np.ndarray:
        next_state = np.empty_like(state)
        for data, row, u, out in zip(self._datas, state, control, next_state):
            data.qpos[:] = row[0::2]
            data.qvel[:] = row[1::2]
            data.ctrl[self._actuator] = u
            mujoco.mj_step(self.model, data)
            out[0::2] = data.qpos
            out[1::2] = data.qvel
        return next_state


@dataclasses.dataclass(frozen=True)
class DomainPlants:
    """How a domain builds its plants, batched (`batch`) or as a dm_control Physics
    (`physics`).

    `step(*state_columns, control[, dt, semi_implicit])` is the domain's analytic step; it
    takes the Euler time step and scheme when `euler` is true.
    """

    step: Callable
    timestep: float
    analytic_physics: type
    euler: bool = True
    mujoco_physics: Optional[type] = None
    """Physics class of the MuJoCo plant, whose `ACTUATOR` is the driven actuator; None
    where the domain has no MuJoCo plant."""
    model: Optional[str] = None
    """Name of the domain's MJCF file in `models/`."""

    @property
    def names(self) -> tuple:
        """The domain's plants, the default first."""
        return ("mujoco", "analytic") if self.model else ("analytic",)

    def batch(self, plant: str, batch_size: int, integrator: str = "semi_implicit"):
        """A plant stepping `batch_size` states at once."""
        if plant == "mujoco":
            model = mujoco.MjModel.from_xml_string(models.read(self.model))
            return MujocoPlant(model, self.mujoco_physics.ACTUATOR, batch_size)
        if not self.euler:
            return AnalyticPlant(self.step, self.timestep)
        semi_implicit = check_integrator(integrator)
        return AnalyticPlant(
            lambda *columns: self.step(*columns, self.timestep, semi_implicit), self.timestep)

    def physics(self, plant: str, integrator: str = "semi_implicit"):
        """The dm_control Physics of one environment."""
        if plant == "mujoco":
            return self.mujoco_physics.from_xml_string(models.read(self.model))
        return self.analytic_physics(self.batch("analytic", 1, integrator))
