"""A task of the suite on its MuJoCo model, in JAX: the environment of `lwrl.jax.environment`
whose plant is MJX (`lwrl.jax.make(name, plant="mjx")`), so that a program traced by JAX,
such as a population learner's (`runners.population`), trains on MuJoCo's model.

Everything but the plant is the analytic environment's (start, observation, reward,
termination, truncation, up-time, sensors, continuous actions). The plant is the mjx plant's
(`tasks.mjx_plant`): the domain's compiled MJCF model (`DomainPlants.mujoco_model`) with its
actuator and substeps, MuJoCo clipping the control to the actuator's range, then the
domain's `limit` (`DomainPlants.limit`, traced by `lwrl.jax.translate.as_jax`). The step is
`tasks.mjx_plant.state_step`, the function `MjxPlant` batches, so the two cannot drift
apart; both agree with the C engine (`MujocoPlant`) to round-off, not bit for bit
(`tests/test_jax_mjx.py`, `tests/test_mjx_plant.py`).

The physical parameters are fixed: MuJoCo's compiler derives the model's fields from them
(inertias, subtree masses, an actuator switched off at zero friction), which a traced step
cannot redo, so the environment steps the one model compiled at the values it is made with
(`make`'s `params`, the paper's by default: `default_params`). `params` given to its
functions must be those values: others are refused in one line where they are concrete, and
cannot be checked inside a traced program (`runners.population` checks a run's values before
its program starts). A batch spanning several parameter values runs on the analytic plant.
It steps in float64 (`jax.config.update("jax_enable_x64", True)`), MuJoCo's numbers.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from lwrl import tasks
from lwrl.jax.environment import Environment
from lwrl.jax.translate import as_jax
from lwrl.tasks.mjx_plant import state_step


@dataclasses.dataclass(frozen=True, eq=False)
class MjxEnvironment(Environment):
    """`DOMAIN.TASK` on its MuJoCo model stepped by MJX, in JAX (`lwrl.jax.make(name,
    plant="mjx")`): `Environment`'s functions, at the parameter values it is made with."""

    def check_params(self, params):
        """`Environment.check_params`, and where `params` is concrete (not traced), a
        one-line ValueError unless each of its rows is `default_params`, the model's values."""
        params = super().check_params(params)
        if isinstance(params, jax.core.Tracer):
            return params
        names = tasks.domain(self.definition.domain).parameters.names
        model = np.asarray(self.default_params)
        rows = np.asarray(params).reshape(-1, len(names))
        wrong = np.argwhere(rows != model)
        if len(wrong):
            row, j = wrong[0]
            raise ValueError(f"the mjx plant steps one model, at one set of parameter values "
                             f"(the environment's, make's params); got {names[j]} {rows[row, j]} "
                             f"where it has {model[j]}: values that differ between agents or "
                             f"episodes run on the analytic plant")
        return params

    def plant(self, physics, control, params):
        """MuJoCo's next state `(d,)` of the model at `default_params` (`params` is not
        read: `check_params`): the mjx plant's `state_step`, then the domain's `limit`."""
        plants = tasks.domain(self.definition.domain).plants
        step = state_step(plants.mujoco_model(self.definition.physical),
                          plants.mujoco_physics.ACTUATOR, plants.substeps)
        state = step(physics, control)
        if plants.limit is None:
            return state
        return jnp.stack(as_jax(plants.limit, self.dtype)(*state))
