"""dm_control `Physics` for the suite's two plants, with one state interface.

Both classes expose `state_vector()` / `set_state_vector(s)` in the task's variable order and
`set_control(u)` for the one actuated quantity, so that one `Task` serves both plants. Domain
modules add one-line accessors named after the quantities (`pole_angle()`, ...).
"""

import copy

import numpy as np
from dm_control import mujoco as dm_mujoco
from dm_control.mujoco import wrapper
from dm_control.rl import control

from lwrl.tasks.task_definition import check_finite_state
from lwrl.tasks.plants import AnalyticPlant


class AnalyticPhysics(control.Physics):
    """A dm_control Physics that steps the paper's equations (a batch of one)."""

    STATE_NAMES: tuple = ()
    """The domain's state variables' names (a domain's class sets them)."""

    def __init__(self, plant: AnalyticPlant):
        self._plant = plant
        self.reset()

    def step(self, n_sub_steps=1):
        """Advance the state `n_sub_steps` control timesteps with the control held."""
        for _ in range(n_sub_steps):
            self._state = self._plant.step(self._state, self._control)
            self._time += self._plant.timestep

    @property
    def physical(self) -> np.ndarray:
        """The plant's physical parameter values `(P,)` (`tasks.parameters`)."""
        return self._plant.physical

    def set_physical(self, values) -> None:
        """Step at the parameter values `values` `(P,)` from now on (a new episode's)."""
        self._plant.physical = np.asarray(values, dtype=np.float64)

    def time(self):
        """Seconds simulated since the reset."""
        return self._time

    def timestep(self):
        """Seconds per step: the plant's control timestep."""
        return self._plant.timestep

    def set_control(self, control_value):
        """Hold the control `control_value` from the next step on."""
        self._control = np.array([control_value], dtype=np.float64)

    def reset(self):
        """The zero state and control, at time 0."""
        self._state = np.zeros((1, len(self.STATE_NAMES)))
        self._control = np.zeros(1)
        self._time = 0.0

    def after_reset(self):
        """Nothing to recompute: the state is the whole of the plant."""

    def check_divergence(self):
        """A dm_control `PhysicsError` where the state is not finite."""
        if not np.all(np.isfinite(self._state)):
            raise control.PhysicsError(f"state is not finite: {self._state[0].tolist()}")

    def state_vector(self) -> np.ndarray:
        """The state in the task's variable order, shape `(d,)`."""
        return self._state[0].copy()

    def set_state_vector(self, state) -> None:
        """Set the state `(d,)`, in the task's variable order (finite, or a ValueError)."""
        self._state = check_finite_state(state, self.STATE_NAMES).reshape(1, -1).copy()


class MujocoPhysics(dm_mujoco.Physics):
    """dm_control's MuJoCo Physics with the suite's state interface.

    The state vector interleaves `qpos` and `qvel` joint by joint (joint angles are not
    wrapped); `set_control` drives the actuator named `ACTUATOR` and leaves any passive
    actuator (the cart's friction) alone.
    """

    STATE_NAMES: tuple = ()
    """The domain's state variables' names (a domain's class sets them)."""
    ACTUATOR: str = ""
    """The name of the MJCF actuator the agent drives."""
    substeps: int = 1
    """MuJoCo steps per agent step (`DomainPlants.substeps`)."""
    limit = None
    """The domain's state limit after each agent step (`DomainPlants.limit`), or None."""
    physical = None
    """The physical parameter values `(P,)` the model was set to (`DomainPlants.physics`)."""
    model_at = None
    """`model_at(values)`: the domain's model at other parameter values
    (`DomainPlants.mujoco_model`), for `set_physical`."""

    @classmethod
    def from_mujoco_model(cls, model):
        """The Physics of a compiled `mujoco.MjModel` (e.g. an MJCF model set to other
        parameter values, `DomainPlants.mujoco_model`), which it keeps and may change."""
        return cls.from_model(wrapper.MjModel(model))

    def set_physical(self, values) -> None:
        """Step the model at the parameter values `values` `(P,)` from now on (a new
        episode's): the Physics reloads from a copy of that model (`model_at`)."""
        values = np.asarray(values, dtype=np.float64)
        self._reload_from_data(wrapper.MjData(wrapper.MjModel(copy.copy(self.model_at(values)))))
        self.physical = values

    def step(self, nstep=1):
        """`nstep` agent steps: `substeps` MuJoCo steps each, then the domain's limit."""
        for _ in range(nstep):
            super().step(self.substeps)
            if self.limit is not None:
                self.set_state_vector(np.array(self.limit(*self.state_vector())))

    def state_vector(self) -> np.ndarray:
        """The state `(d,)`: `qpos` and `qvel` interleaved joint by joint."""
        return np.column_stack([self.data.qpos, self.data.qvel]).ravel()

    def set_state_vector(self, state) -> None:
        """Set `qpos` and `qvel` from the state `(d,)` (finite, or a ValueError), and
        recompute what depends on the positions."""
        state = check_finite_state(state, self.STATE_NAMES)
        self.data.qpos[:] = state[0::2]
        self.data.qvel[:] = state[1::2]
        # dm_control's legacy step reuses the position-dependent quantities of the last
        # mj_step1/mj_forward, so they must describe the state just set.
        self.forward()

    def set_control(self, control_value):
        """Drive the actuator `ACTUATOR` with `control_value`."""
        self.named.data.ctrl[self.ACTUATOR] = control_value


def physics_classes(domain: str, accessors: type | None, state_names: tuple, actuator: str):
    """A domain's `(analytic, MuJoCo)` Physics classes: its accessor mixin (None: none) over
    each plant.

    `actuator` names the MJCF actuator that the action drives.
    """
    mixins = () if accessors is None else (accessors,)
    analytic = type(f"AnalyticPhysics{domain}", (*mixins, AnalyticPhysics), {
        "STATE_NAMES": state_names, "__doc__": f"The paper's {domain} equations as a dm_control Physics."})
    mujoco = type(f"MujocoPhysics{domain}", (*mixins, MujocoPhysics), {
        "STATE_NAMES": state_names, "ACTUATOR": actuator, "__doc__": f"The MJCF {domain} in MuJoCo."})
    return analytic, mujoco
