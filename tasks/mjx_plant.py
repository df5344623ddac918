"""The `mjx` plant: B copies of an MJCF model stepped by MJX, MuJoCo's XLA port.

MJX steps the same model (`DomainPlants.mujoco_model`, at the batch's physical parameter
values) with the same Euler step as the C engine, in
float64, as one compiled vector function over the whole batch (the states vmapped, the
substeps in a loop) where the C engine steps the states one by one. It agrees with the C
engine (`MujocoPlant`) to round-off, not bit for bit (XLA orders the arithmetic its own way):
hence a plant of its own, and `mujoco` stays the C engine, the reference, on which every
result stays bit-identical. It steps batches only (`tasks.batched`, `lwrl train`); a dm_env
environment (`tasks.load`) runs on the C engine (`tasks.plants.BATCHED_ONLY`). Its step of
one state (`state_step`) is also the plant of the JAX tasks on MuJoCo's model
(`lwrl.jax.mjx`), inside the population learners' programs.

JAX is an optional extra (`pip install 'lwrl[mjx]'`), imported when a plant is first made.
The plant steps one model: every state of a batch at the same parameter values (a batch
spanning several steps on the C engine, which takes a model per state).
"""

import contextlib
import copy
import functools
import io

import mujoco
import numpy as np

from lwrl.tasks.plants import apply_limit

MOTIONLESS_FLAGS = mujoco.mjtEnableBit.mjENBL_ENERGY
"""Flags the models enable that MJX does not implement (`mjx.put_model` refuses them) and
that do not enter the motion, cleared for MJX: the energy flag only has MuJoCo fill
`MjData.energy`, a diagnostic that is no input to the step."""


def _jax_and_mjx():
    """`(jax, mujoco.mjx)`, or a one-line ValueError naming the extra that installs them."""
    try:
        import jax
        with contextlib.redirect_stdout(io.StringIO()):  # mjx prints that Warp is not installed
            from mujoco import mjx
    except ImportError:
        raise ValueError("the mjx plant needs JAX and MuJoCo MJX: "
                         "pip install 'lwrl[mjx]'") from None
    return jax, mjx


def motion_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of the compiled MJCF model as MJX steps it: `MOTIONLESS_FLAGS` cleared."""
    model = copy.copy(model)
    model.opt.enableflags &= ~int(MOTIONLESS_FLAGS)
    return model


@functools.cache
def state_step(model: mujoco.MjModel, actuator: str, substeps: int):
    """One state's step of a compiled model (one that is kept, as
    `DomainPlants.mujoco_model`'s are), a function JAX traces: `(state (d,), control ()) ->
    state (d,)` in the task's order `(q0, q0_dot, q1, ...)`, `substeps` MJX steps with
    `control` on `actuator` (MuJoCo clips it to the actuator's `ctrlrange`), before the
    domain's `limit`. `compiled_step` batches it; `lwrl.jax`'s mjx environments call it
    inside their programs. Made once per process and model; trace it in 64 bits."""
    jax, mjx = _jax_and_mjx()
    model = motion_model(model)
    actuator_id = model.actuator(actuator).id
    with jax.enable_x64(True), jax.ensure_compile_time_eval():  # concrete, if made in a trace
        device_model = mjx.put_model(model)
        rest = mjx.make_data(device_model)

    def step_one(state, control):
        # A fresh MjData per step, as `MujocoPlant`'s rollout starts from time, qpos and qvel:
        # without contacts or activations nothing else carries over between steps.
        data = rest.replace(qpos=state[0::2], qvel=state[1::2],
                            ctrl=rest.ctrl.at[actuator_id].set(control))
        data = jax.lax.fori_loop(0, substeps, lambda _, data: mjx.step(device_model, data), data)
        return jax.numpy.stack([data.qpos, data.qvel], axis=-1).ravel()

    return step_one


@functools.cache
def compiled_step(model: mujoco.MjModel, actuator: str, substeps: int):
    """The jitted batch step of a compiled model: `(state (B, d), control (B,)) -> state
    (B, d)`, `state_step` over the batch. Made once per process and model; JAX compiles it
    once per batch size. Call it under `jax.enable_x64(True)`."""
    jax = _jax_and_mjx()[0]
    return jax.jit(jax.vmap(state_step(model, actuator, substeps)))


class MjxPlant:
    """B copies of a compiled MJCF model (`DomainPlants.mujoco_model`) stepped by MJX.

    The interface of `MujocoPlant`: one agent step is `substeps` MJX steps with the control
    on `actuator` held, then `limit`. `step` takes up to `batch_size` states (a batched
    environment steps only those whose episode goes on) and pads them to `batch_size`, so
    that JAX compiles one step per batch size, not one per number of running episodes. It
    takes no parameter values per state (`takes_rows`): the batch shares its model.
    """

    takes_rows = False
    """False: the batch shares one model's parameter values."""

    def __init__(self, model: mujoco.MjModel, actuator: str, batch_size: int, substeps: int = 1,
                 limit=None):
        self._jax = _jax_and_mjx()[0]
        self.batch_size = batch_size
        """B, the states a step takes at most."""
        self.substeps = int(substeps)
        """MJX steps per agent step."""
        self.timestep = float(model.opt.timestep) * self.substeps
        """Seconds per agent step: the model's timestep times `substeps`."""
        self._limit = limit
        self._step = compiled_step(model, actuator, self.substeps)
        self._state = np.zeros((batch_size, model.nq + model.nv))
        self._control = np.zeros(batch_size)

    def step(self, state: np.ndarray, control: np.ndarray, physical=None) -> np.ndarray:
        """The states `(n, d)`, n <= `batch_size`, one agent step on with `control` `(n,)`
        held, the domain's `limit` applied; `physical` must be None (`takes_rows`)."""
        if physical is not None:
            raise ValueError("the mjx plant steps one model, every state at the same parameter "
                             "values; step parameter values per state on the mujoco plant")
        count = len(state)
        if count > self.batch_size:
            raise ValueError(f"{count} states for a plant of batch size {self.batch_size}")
        if count == 0:
            return state.copy()
        self._state[:count], self._control[:count] = state, control
        with self._jax.enable_x64(True):
            next_state = np.array(self._step(self._state, self._control))[:count]
        return apply_limit(self._limit, next_state)
