"""Open-loop comparison of the plants: the same starts and actions on every plant.

The plants, named as in the report:

- `reference`: the MJCF model in MuJoCo with the RK4 integrator at Δt / N (N =
  `REFERENCE_SUBSTEPS` steps of 1 ms per control step of Δt = 0.02 s, the control held);
  `reference_2x` halves its step again and estimates the reference's own error;
- `mujoco`: the MJCF model with MuJoCo's Euler at Δt (semi-implicit), the suite's plant;
- `semi_implicit` and `explicit`: the paper's equations (pendulum section 4.2, cart-pole
  section 4.3) with Euler's method in its two readings (`tasks.integrators`).

Divergence is measured on the configuration variables the domain names with their
tolerances (`studies.compare.domains`; its angles wrapped to [-π, π] before differencing); a trial leaves the tolerance at
the first step where some variable's error exceeds it. Energy is the mechanical energy of
the MJCF model (`mujoco.mj_energyPos` + `mj_energyVel`), whose masses and lengths are the
paper's.
"""

import dataclasses

import mujoco
import numpy as np
import pandas as pd

from lwrl import models
from lwrl import tasks
from lwrl.tasks.integrators import INTEGRATORS
from lwrl.tasks.plants import MujocoPlant
from lwrl.studies.compare.domains import COMPARISONS

REFERENCE = "reference"
REFERENCE_CHECK = "reference_2x"
COMPARED = ("mujoco", *INTEGRATORS)
"""The plants compared with the reference: the suite's two plants and the explicit reading."""
LABELS = {REFERENCE: "MuJoCo RK4, Δt/20 (reference)", REFERENCE_CHECK: "MuJoCo RK4, Δt/40",
          "mujoco": "MuJoCo Euler", "semi_implicit": "analytic semi-implicit Euler",
          "explicit": "analytic explicit Euler"}
REFERENCE_SUBSTEPS = 20
"""RK4 steps of the reference per control step (1 ms each)."""
PAIRS = (("mujoco", REFERENCE), ("semi_implicit", REFERENCE), ("explicit", REFERENCE),
         ("mujoco", "semi_implicit"), (REFERENCE, REFERENCE_CHECK))
"""(plant, against) pairs whose divergence is measured: each plant against the reference,
MuJoCo against the analytic plant with its scheme, and the reference against its halved step."""


def tolerances(domain: str) -> dict:
    """`{variable: error}`: the configuration variables compared and the error (rad, m) a
    plant may have before it counts as having left the reference (the domain's)."""
    return dict(COMPARISONS.of(domain).tolerances)


def reference_model(domain: str, substeps: int) -> mujoco.MjModel:
    """The domain's MJCF model with RK4 at a timestep of Δt / `substeps`."""
    plants = tasks.domain(domain).plants
    model = mujoco.MjModel.from_xml_string(models.read(plants.model))
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model.opt.timestep = plants.timestep / substeps
    return model


def plant(domain: str, name: str, batch_size: int, substeps: int = REFERENCE_SUBSTEPS):
    """The batched plant `name` (one of `LABELS`) of a domain with a MuJoCo model."""
    plants = tasks.domain(domain).plants
    if plants.model is None:
        raise ValueError(f"{domain} has no MuJoCo model to compare with; compare: "
                         f"{', '.join(d for d, m in tasks.DOMAINS.items() if m.model)}")
    if name == "mujoco":
        return plants.batch("mujoco", batch_size)
    if name in INTEGRATORS:
        return plants.batch("analytic", batch_size, name)
    if name in (REFERENCE, REFERENCE_CHECK):
        n = substeps * (2 if name == REFERENCE_CHECK else 1)
        return MujocoPlant(reference_model(domain, n), plants.mujoco_physics.ACTUATOR,
                           batch_size, n, plants.limit)
    raise ValueError(f"unknown plant {name!r}; allowed: {', '.join(LABELS)}")


def random_trials(definition, seeds, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Per seed, the task's start and `steps` uniformly random actions, both drawn from
    `numpy.random.default_rng(seed)` in that order: `(starts (B, d), actions (B, T))`."""
    starts, actions = [], []
    for seed in seeds:
        rng = np.random.default_rng(seed)
        starts.append(definition.initial_states(rng, 1)[0])
        actions.append(rng.integers(definition.num_actions, size=steps))
    return np.array(starts), np.array(actions, dtype=np.int64).reshape(len(starts), steps)


def trajectories(stepper, starts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """`(B, T + 1, d)` states of a batched plant from `starts (B, d)` under `controls (B, T)`
    (no termination, no time limit)."""
    states = np.empty((len(starts), controls.shape[1] + 1, starts.shape[1]))
    states[:, 0] = starts
    for t in range(controls.shape[1]):
        states[:, t + 1] = stepper.step(states[:, t], controls[:, t])
    return states


def energy(domain: str, states: np.ndarray) -> np.ndarray:
    """Mechanical energy (J) of states `(..., d)`: kinetic plus gravitational, from the MJCF
    model (the paper's masses and lengths; the pendulum: m l² θ̇²/2 + m g l cos θ up to a
    constant, section 4.2)."""
    model = reference_model(domain, 1)
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    data = mujoco.MjData(model)
    flat = np.asarray(states, dtype=np.float64).reshape(-1, states.shape[-1])
    result = np.empty(len(flat))
    for i, state in enumerate(flat):
        data.qpos[:] = state[0::2]
        data.qvel[:] = state[1::2]
        mujoco.mj_forward(model, data)
        result[i] = data.energy.sum()
    return result.reshape(states.shape[:-1])


def energy_starts(definition, seeds) -> np.ndarray:
    """Starts of the zero-action energy trials, one per seed: the domain's `rest_start`
    where its task's start is an equilibrium zero action never leaves, else the task's."""
    rest_start = COMPARISONS.of(definition.domain).rest_start
    return np.array([definition.initial_states(np.random.default_rng(seed), 1)[0]
                     if rest_start is None else rest_start(np.random.default_rng(seed))
                     for seed in seeds])


def errors(definition, states: np.ndarray, against: np.ndarray) -> dict:
    """`{variable: (B, T + 1) |error|}` of the compared configuration variables (angles
    modulo 2π)."""
    result = {}
    for name in tolerances(definition.domain):
        j = definition.state_names.index(name)
        difference = states[..., j] - against[..., j]
        if name in definition.angles:
            difference = (difference + np.pi) % (2 * np.pi) - np.pi
        result[name] = np.abs(difference)
    return result


def steps_within(domain: str, error: dict) -> np.ndarray:
    """`(B,)` per trial, the first step at which some variable's error exceeds its tolerance,
    or -1 where none does within the horizon."""
    outside = np.any([error[name] > tolerance for name, tolerance in tolerances(domain).items()],
                     axis=0)
    return np.where(outside.any(axis=1), outside.argmax(axis=1), -1)


@dataclasses.dataclass
class OpenLoop:
    """The open-loop study's tidy tables."""

    steps: pd.DataFrame
    """Per pair, variable and step: `median`, `q25`, `q75` and `max` of |error| over trials."""
    trials: pd.DataFrame
    """Per pair and seed: the step and time at which the trial left the tolerance
    (`left`: False where it stayed within it to the horizon), and per variable the maximum
    |error| over the first second, the first ten seconds and the whole horizon."""
    energy: pd.DataFrame
    """Per plant and seed, zero action: the reference's energy change over the horizon
    (`reference_change_J`, friction), and the plant's energy minus the reference's at the
    horizon (`drift_J`) and its largest magnitude on the way (`max_abs_drift_J`)."""
    timestep: float
    horizon: int
    """Control steps of the trials."""
    substeps: int


def open_loop(task: str, seeds, steps: int | None = None,
              substeps: int = REFERENCE_SUBSTEPS) -> OpenLoop:
    """Run every plant of `LABELS` from the same starts under the same random actions (one
    trial per seed, `random_trials`) for `steps` control steps (default: the task's
    episode length), and under zero action from `energy_starts`; measure the divergence of
    each pair of `PAIRS` and the energy drift of each plant against the reference."""
    domain, name = task.split(".")
    definition = tasks.definition(domain, name)
    steps = int(definition.step_limit) if steps is None else int(steps)
    seeds = list(seeds)
    starts, actions = random_trials(definition, seeds, steps)
    controls = np.asarray(definition.controls)[actions]
    rest_starts = energy_starts(definition, seeds)
    runs, energies = {}, {}
    for plant_name in LABELS:
        stepper = plant(domain, plant_name, len(seeds), substeps)
        runs[plant_name] = trajectories(stepper, starts, controls)
        if plant_name != REFERENCE_CHECK:
            energies[plant_name] = energy(domain, trajectories(
                stepper, rest_starts, np.zeros_like(controls, dtype=np.float64)))
    timestep = definition.control_timestep
    step_rows, trial_rows = [], []
    for first, second in PAIRS:
        error = errors(definition, runs[first], runs[second])
        leaves = steps_within(domain, error)
        pair = dict(plant=first, against=second)
        for variable, values in error.items():
            quartiles = np.percentile(values, [25, 50, 75], axis=0)
            step_rows.append(pd.DataFrame(dict(
                pair, variable=variable, step=np.arange(steps + 1),
                time_s=np.arange(steps + 1) * timestep, median=quartiles[1], q25=quartiles[0],
                q75=quartiles[2], max=values.max(axis=0))))
        windows = {f"{seconds}_s": int(round(seconds / timestep)) for seconds in (1, 10)}
        for b, seed in enumerate(seeds):
            row = dict(pair, seed=seed, left=bool(leaves[b] >= 0),
                       steps_within=int(leaves[b]) if leaves[b] >= 0 else steps,
                       time_within_s=(leaves[b] if leaves[b] >= 0 else steps) * timestep)
            for variable, values in error.items():
                for window, window_steps in windows.items():
                    row[f"{variable}_max_{window}"] = values[b, :window_steps + 1].max()
                row[f"{variable}_max_horizon"] = values[b].max()
            trial_rows.append(row)
    reference = energies[REFERENCE]
    energy_rows = [dict(plant=plant_name, seed=seed,
                        reference_change_J=reference[b, -1] - reference[b, 0],
                        drift_J=values[b, -1] - reference[b, -1],
                        max_abs_drift_J=np.abs(values[b] - reference[b]).max())
                   for plant_name, values in energies.items() if plant_name != REFERENCE
                   for b, seed in enumerate(seeds)]
    return OpenLoop(pd.concat(step_rows, ignore_index=True), pd.DataFrame(trial_rows),
                    pd.DataFrame(energy_rows), timestep, steps, substeps)
