"""Plants that step a batch of states: the paper's equations, or MuJoCo (its C engine, or
MJX in `tasks.mjx_plant`).

A plant maps states `(B, d)` and controls `(B,)` to the next states `(B, d)`, one control
step of the task. States are in the task's order, which interleaves each coordinate with its
velocity: `(q0, q0_dot, q1, q1_dot, ...)`. A plant is made at one set of the domain's
physical parameter values (`tasks.parameters`; the paper's by default); `step(state,
control, physical)` takes one row of values per state instead, `(B, P)`, where a batch spans
several.
"""

import copy
import dataclasses
import functools
import os
from importlib.resources.abc import Traversable
from typing import Callable, Optional, Union

import mujoco
from mujoco import rollout
import numpy as np

from lwrl import models
from lwrl.tasks.integrators import check_integrator
from lwrl.tasks.parameters import Parameters, columns

EQUATIONS = ("paper", "kfnnet")
"""The analytic plant's equations: the paper's, or with the suspected slips of the author's
R code, kfnnet (SPEC.md, "Known traps"; each domain's `step` says what they change)."""


def check_equations(equations: str) -> bool:
    """Return True for `kfnnet` (the slips), False for `paper`; reject anything else."""
    if equations not in EQUATIONS:
        raise ValueError(f"unknown equations {equations!r}; allowed: {', '.join(EQUATIONS)}")
    return equations == "kfnnet"


class AnalyticPlant:
    """The paper's difference equations as array functions.

    `step_columns(*state_columns, control, p=p)` returns the next state's columns; it is the
    domain's own `step` with its time step, integrator and equations bound. `physical` are
    the plant's parameter values `(P,)`.
    """

    takes_rows = True
    """`step` takes parameter values per state."""

    def __init__(self, step_columns: Callable, timestep: float, physical):
        self._step_columns = step_columns
        self.timestep = timestep
        """Seconds (Mountain-Car: steps) per agent step."""
        self.physical = np.asarray(physical, dtype=np.float64)
        """The plant's parameter values `(P,)`, where `step` is given none per state."""

    def step(self, state: np.ndarray, control: np.ndarray, physical=None) -> np.ndarray:
        """The next states of `state` `(B, d)` under `control` `(B,)`, at the plant's
        parameter values or at `physical`, one row `(B, P)` per state."""
        p = columns(self.physical if physical is None else physical)
        return np.stack(self._step_columns(*np.moveaxis(state, -1, 0), control, p=p), axis=-1)


def apply_limit(limit: Optional[Callable], state: np.ndarray) -> np.ndarray:
    """`state` `(B, d)` after the domain's element-wise `limit` (`DomainPlants.limit`; None:
    no limit)."""
    if limit is None:
        return state
    return np.stack(limit(*np.moveaxis(state, -1, 0)), axis=-1)


class MujocoPlant:
    """B copies of an MJCF model stepped with `mujoco.rollout`, one thread per core.

    One agent step is `substeps` calls of `mj_step` with the control held (default 1: the
    model's timestep is the control step; more, with a smaller timestep, for a fine
    reference). The full physics state is time, qpos and qvel: the models have no
    activations and no contacts, so nothing else carries over between steps. With
    `model_at(values)`, the model at other parameter values, `step` takes parameter values
    per state (`takes_rows`) and steps each state in its own model.
    """

    _STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS

    def __init__(self, model: mujoco.MjModel, actuator: str, batch_size: int, substeps: int = 1,
                 limit: Optional[Callable] = None, model_at: Optional[Callable] = None):
        self.model = model
        """The compiled MJCF model every state is stepped in (without `model_at`)."""
        self._model_at = model_at
        self.takes_rows = model_at is not None
        """Whether `step` takes parameter values per state (with `model_at`)."""
        self.substeps = int(substeps)
        """MuJoCo steps per agent step."""
        self._limit = limit
        self.timestep = float(model.opt.timestep) * self.substeps
        """Seconds per agent step: the model's timestep times `substeps`."""
        self._actuator = model.actuator(actuator).id
        threads = max(1, min(batch_size, os.cpu_count() or 1))
        self._datas = [mujoco.MjData(model) for _ in range(threads)]
        self._rollout = rollout.Rollout(nthread=threads)
        if mujoco.mj_stateSize(model, self._STATE) != 1 + model.nq + model.nv:
            raise ValueError(f"model {model.names[:20]!r} has state beyond time, qpos and qvel")

    def models(self, physical) -> list:
        """One model per row of parameter values `(B, P)` (`DomainPlants.mujoco_model`,
        compiled once per values), which `mujoco.rollout` steps state by state."""
        if self._model_at is None:
            raise ValueError("this MuJoCo plant has one model; it takes no parameter values "
                             "per state")
        return [self._model_at(row) for row in np.asarray(physical, dtype=np.float64)]

    def step(self, state: np.ndarray, control: np.ndarray, physical=None) -> np.ndarray:
        """The next states of `state` `(B, d)` under `control` `(B,)`, in the plant's model or
        in the models of the parameter values `physical`, one row `(B, P)` per state."""
        if len(state) == 0:  # mujoco.rollout crashes on an empty batch
            return state.copy()
        model = self.model if physical is None else self.models(physical)
        nq = self.model.nq
        physics_state = np.zeros((len(state), 1 + nq + self.model.nv))
        physics_state[:, 1:1 + nq] = state[:, 0::2]
        physics_state[:, 1 + nq:] = state[:, 1::2]
        controls = np.zeros((len(state), self.substeps, self.model.nu))
        controls[:, :, self._actuator] = np.asarray(control)[:, None]
        after, _ = self._rollout.rollout(model, self._datas, physics_state, controls,
                                         nstep=self.substeps)
        next_state = np.empty_like(state)
        next_state[:, 0::2] = after[:, -1, 1:1 + nq]
        next_state[:, 1::2] = after[:, -1, 1 + nq:]
        return apply_limit(self._limit, next_state)


BATCHED_ONLY = ("mjx",)
"""Plants that step batches only (`DomainPlants.batch`), not a dm_env environment: MJX,
whose one call per step pays off over a batch but costs tens of C steps for one state, and
which needs JAX; a single environment runs on the C engine, the reference
(`tasks.mjx_plant`)."""


@functools.lru_cache(maxsize=None)
def _shared_model(name: str, edit_model: Callable, values: tuple) -> mujoco.MjModel:
    """`models/<name>.xml` as a `mujoco.MjSpec`, set to the parameter `values` by the
    domain's `edit_model` and compiled: once per process and values, and kept (compiled
    code holds its address)."""
    spec = mujoco.MjSpec.from_string(models.read(name))
    edit_model(spec, np.array(values, dtype=np.float64))
    return spec.compile()


@dataclasses.dataclass(frozen=True)
class DomainPlants:
    """How a domain builds its plants, batched (`batch`) or as a dm_control Physics
    (`physics`), at its physical parameter values (the paper's unless given).

    `step(*state_columns, control[, dt, semi_implicit, slips], p)` is the domain's analytic
    step of one agent step at the parameter values `p`; it takes the Euler time step, scheme
    and equations when `euler` is true.
    """

    step: Callable
    """The domain's analytic step of one agent step (see the class)."""
    timestep: float
    """Seconds (or steps) of one agent step."""
    analytic_physics: type
    """Physics class of the analytic plant (an `AnalyticPhysics`)."""
    parameters: Parameters
    """The domain's physical parameters (`tasks.parameters`), the layout of `p`."""
    euler: bool = True
    """Whether `step` integrates by Euler's method, taking its time step, scheme and
    equations (Mountain-Car's difference equation does not)."""
    analytic_options: tuple = ("integrator", "equations")
    """The options of the analytic plant (`tasks.plant_option_names`): the Euler scheme and
    the equations' readings where the domain has them; none without Euler's method."""
    mujoco_physics: Optional[type] = None
    """Physics class of the MuJoCo plant, whose `ACTUATOR` is the driven actuator; None
    where the domain has no MuJoCo plant."""
    model: Optional[Union[str, Traversable]] = None
    """Name of the domain's MJCF file in `models/`, or, for a domain of another package, the
    file itself (`importlib.resources.files(package) / "model.xml"`, or a `pathlib.Path`):
    what `models.read` takes."""
    edit_model: Optional[Callable] = None
    """`edit_model(spec, p)`: the model's `mujoco.MjSpec` set to the parameter values `p`
    (`(P,)`), given with `model`; the domain's docstring says how each parameter enters."""
    substeps: int = 1
    """MuJoCo steps (of the model's timestep) per agent step, the control held."""
    limit: Optional[Callable] = None
    """`limit(*state_columns) -> state_columns`, element-wise: what the task bounds after
    each agent step (e.g. velocity limits). The analytic `step` applies it itself; the
    MuJoCo plants apply it after MuJoCo's steps."""
    limit_state: Optional[Callable] = None
    """`limit_state(state)`: `limit` of one state `(d,)` in place, numba-jitable, for the
    compiled loop's MuJoCo steps; given with `limit`."""

    @property
    def names(self) -> tuple:
        """The domain's plants, the default first: with a model, the C engine (`mujoco`),
        the equations and MJX (`mjx`, `BATCHED_ONLY`)."""
        return ("mujoco", "analytic", "mjx") if self.model else ("analytic",)

    @property
    def environment_names(self) -> tuple:
        """The plants of a single dm_env environment (`physics`): all but `BATCHED_ONLY`."""
        return tuple(name for name in self.names if name not in BATCHED_ONLY)

    def values(self, physical=None) -> np.ndarray:
        """`physical`, one value per parameter `(P,)`, or the paper's values where None."""
        if physical is None:
            return np.asarray(self.parameters.nominal, dtype=np.float64)
        values = np.asarray(physical, dtype=np.float64)
        if values.shape != (len(self.parameters.items),):
            raise ValueError(f"parameter values must be one per parameter "
                             f"({', '.join(self.parameters.names)}); got shape {values.shape}")
        return values

    def mujoco_model(self, physical=None) -> mujoco.MjModel:
        """The MJCF model at the parameter values `physical` `(P,)` (the paper's where
        None), compiled once per process and values and shared: copy it to change it."""
        return _shared_model(self.model, self.edit_model, tuple(self.values(physical).tolist()))

    def batch(self, plant: str, batch_size: int, integrator: str = "semi_implicit",
              equations: str = "paper", physical=None):
        """A plant stepping `batch_size` states at once, at the parameter values `physical`
        `(P,)` (the paper's where None)."""
        values = self.values(physical)
        if plant == "mjx":
            from lwrl.tasks.mjx_plant import MjxPlant  # here: it imports this module
            return MjxPlant(self.mujoco_model(values), self.mujoco_physics.ACTUATOR, batch_size,
                            self.substeps, self.limit)
        if plant == "mujoco":
            return MujocoPlant(self.mujoco_model(values), self.mujoco_physics.ACTUATOR,
                               batch_size, self.substeps, self.limit, model_at=self.mujoco_model)
        if not self.euler:
            return AnalyticPlant(lambda *columns, p: self.step(*columns, p), self.timestep, values)
        semi_implicit, slips = check_integrator(integrator), check_equations(equations)
        return AnalyticPlant(
            lambda *columns, p: self.step(*columns, self.timestep, semi_implicit, slips, p),
            self.timestep, values)

    def physics(self, plant: str, integrator: str = "semi_implicit", equations: str = "paper",
                physical=None):
        """The dm_control Physics of one environment at the parameter values `physical`
        `(P,)` (the paper's where None)."""
        if plant in BATCHED_ONLY:
            raise ValueError(f"the {plant} plant steps batches only (lwrl train, tasks.batched); "
                             f"one environment runs on: {', '.join(self.environment_names)}")
        if plant == "mujoco":
            values = self.values(physical)
            physics = self.mujoco_physics.from_mujoco_model(copy.copy(self.mujoco_model(values)))
            physics.substeps, physics.limit, physics.physical = self.substeps, self.limit, values
            physics.model_at = self.mujoco_model
            return physics
        return self.analytic_physics(self.batch("analytic", 1, integrator, equations, physical))
