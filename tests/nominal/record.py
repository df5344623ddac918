"""Numbers of every plant and run path at the nominal physics, recorded once as a fixture.

`python tests/nominal/record.py` computes them and writes `tests/nominal/reference.npz`
with the platform they were computed on (`platform_of`); `tests/test_nominal.py` computes
them again and asserts that every array is the same, bit for bit, where the platform is the
same (elsewhere the libraries may round otherwise: record them there from the same code). The fixture was written by the code before the physical constants became parameters
(issue 23): with the parameters at their nominal values, every plant, every run path and
every learning result stays what it was.

What is recorded, per domain (random states and controls from fixed seeds):

- the analytic plant's batched step under each integrator and equations, over 25 steps;
- the numba-compiled `transition` of 16 states: next state, observation, outcome;
- MuJoCo's batched step (`mujoco.rollout`) and the compiled loop's engine step
  (`tasks.engine.step_state`), over 25 steps;
- a dm_env environment on each plant (`tasks.load`), 120 random actions;
- a `BatchedEnv` of 3 environments on each plant, 150 random actions;
- a short learning run on each plant through the compiled loop, and through the stepped
  loop over `BatchedEnv` on the analytic plant.
"""

import itertools
import pathlib
import platform
import sys

import mujoco
import numba
import numpy as np

from lwrl import tasks
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run
from lwrl.runners.stepped import run_batched
from lwrl.tasks.batched import BatchedEnv
from lwrl.tasks.engine import close_workspace, engine_plant, open_workspace, step_state

FIXTURE = pathlib.Path(__file__).with_name("reference.npz")
STATES = 16
STEPS = 25
SPREAD = {"mountain_car": [1.0, 0.08], "pendulum": [4.0, 8.0], "cartpole": [2.6, 3.0, 0.25, 3.0],
          "acrobot": [7.0, 14.0, 7.0, 30.0]}
"""Half widths of the random states (the acrobot's speeds past their limits)."""


def _task(domain: str) -> str:
    return next(iter(tasks.domain(domain).tasks))


def _starts_and_controls(domain: str, seed: int):
    definition = tasks.definition(domain, _task(domain))
    rng = np.random.default_rng(seed)
    states = rng.uniform(-1, 1, size=(STATES, len(definition.state_names))) * SPREAD[domain]
    controls = rng.choice(np.asarray(definition.controls), size=(STATES, STEPS))
    return states, controls


def _trajectory(plant, states, controls) -> np.ndarray:
    out = [states]
    for t in range(controls.shape[1]):
        out.append(plant.step(out[-1], controls[:, t]))
    return np.stack(out, axis=1)


@numba.njit
def _engine_trajectory(plant, states, controls, out):
    workspace = open_workspace(plant)
    for i in range(states.shape[0]):
        out[i, 0] = states[i]
        for t in range(controls.shape[1]):
            step_state(plant, workspace, out[i, t], controls[i, t], out[i, t + 1])
    close_workspace(plant, workspace)


def _variants(domain: str):
    """`(name, plant options)` of the analytic plant's readings."""
    names = tasks.plant_option_names(domain, "analytic")
    choices = [("semi_implicit", "explicit") if name == "integrator" else ("paper", "kfnnet")
               for name in names]
    for values in itertools.product(*choices):
        yield "_".join(values) or "plain", dict(zip(names, values))


def _transition(domain: str, options: dict, states, controls) -> dict:
    definition = tasks.definition(domain, _task(domain))
    plants = tasks.domain(domain).plants
    transition = numba.njit(definition.transition)
    semi_implicit = options.get("integrator", "semi_implicit") == "semi_implicit"
    slips = options.get("equations", "paper") == "kfnnet"
    arguments = definition.loop_arguments()
    next_states, observations = np.empty_like(states), np.empty_like(states)
    outcome = np.empty((len(states), 3))
    for i, state in enumerate(states):
        outcome[i] = transition(state, controls[i, 0], next_states[i], observations[i],
                                plants.timestep, semi_implicit, slips, arguments)
    return {"next": next_states, "observation": observations, "outcome": outcome}


def _dm_env(domain: str, plant: str) -> dict:
    env = tasks.load(domain, _task(domain), plant=plant, seed=3)
    rng = np.random.default_rng(4)
    records = {"observation": [], "reward": [], "discount": [], "step_type": []}
    step = env.reset()
    for _ in range(120):
        records["observation"].append(np.array(list(step.observation.values())))
        records["reward"].append(np.nan if step.reward is None else step.reward)
        records["discount"].append(np.nan if step.discount is None else step.discount)
        records["step_type"].append(int(step.step_type))
        step = env.reset() if step.last() else env.step(int(rng.integers(env.action_spec().num_values)))
    records = {name: np.array(values) for name, values in records.items()}
    records["uptime"] = np.array(env.task.uptime)
    return records


def _batched(domain: str, plant: str) -> dict:
    env = BatchedEnv(domain, _task(domain), plant, seeds=[0, 5, 9])
    rng = np.random.default_rng(6)
    records = {"observation": [], "reward": [], "discount": [], "step_type": [], "uptime": []}
    step = env.reset()
    for _ in range(150):
        step = env.step(rng.integers(env.num_actions, size=env.batch_size))
        for name in ("observation", "reward", "discount", "step_type"):
            records[name].append(np.array(getattr(step, name)))  # a copy: it may be the state
        records["uptime"].append(env.uptime.copy())
    return {name: np.array(values) for name, values in records.items()}


def _learning(config) -> dict:
    _, results = run(config)
    return {"steps": results.steps, "returns": results.returns, "uptime": results.uptime}


def _stepped(config) -> dict:
    env = BatchedEnv(config.domain, config.task_name, config.plant_name, config.seeds,
                     **config.plant_options, **config.task_options)
    results = run_batched(env, make_agents(config), config.episodes)
    return {"steps": results.steps, "returns": results.returns, "uptime": results.uptime}


def compute() -> dict:
    """`{name: array}` of every recorded number (see the module)."""
    arrays = {}
    for index, domain in enumerate(tasks.DOMAINS):
        states, controls = _starts_and_controls(domain, index)
        plants = tasks.domain(domain).plants
        for name, options in _variants(domain):
            arrays[f"{domain}/analytic/{name}"] = _trajectory(
                plants.batch("analytic", STATES, **options), states, controls)
            for key, value in _transition(domain, options, states, controls).items():
                arrays[f"{domain}/transition/{name}/{key}"] = value
        if plants.model is not None:
            arrays[f"{domain}/mujoco"] = _trajectory(plants.batch("mujoco", STATES), states, controls)
            engine = engine_plant(plants.model, plants.mujoco_physics.ACTUATOR, plants.substeps)
            out = np.empty((STATES, STEPS + 1, states.shape[1]))
            _engine_trajectory(engine, states, controls, out)
            arrays[f"{domain}/engine"] = out
        for plant in tasks.ENVIRONMENT_PLANTS[domain]:
            for key, value in _dm_env(domain, plant).items():
                arrays[f"{domain}/dm_env/{plant}/{key}"] = value
            for key, value in _batched(domain, plant).items():
                arrays[f"{domain}/batched/{plant}/{key}"] = value
            config = RunConfig(task=f"{domain}.{_task(domain)}", plant=plant, agents=2, episodes=3)
            for key, value in _learning(config).items():
                arrays[f"{domain}/learning/{plant}/{key}"] = value
        config = RunConfig(task=f"{domain}.{_task(domain)}", plant="analytic", agents=2, episodes=2)
        for key, value in _stepped(config).items():
            arrays[f"{domain}/stepped/analytic/{key}"] = value
    return arrays


def platform_of() -> str:
    """What the numbers depend on besides the code: the machine and its C library, the
    versions of Python, NumPy, numba and MuJoCo, and the CPU features NumPy dispatches on
    (its SIMD functions round some results otherwise than the C library)."""
    from numpy._core import _multiarray_umath

    features = sorted(name for name, on in _multiarray_umath.__cpu_features__.items() if on)
    return (f"{platform.machine()} {'-'.join(platform.libc_ver())} python {platform.python_version()} "
            f"numpy {np.__version__} numba {numba.__version__} mujoco {mujoco.__version__} "
            f"cpu {','.join(features)}")


def main() -> None:
    arrays = {**compute(), "platform": np.array(platform_of())}
    np.savez_compressed(FIXTURE, **arrays)
    print(f"wrote {len(arrays)} arrays to {FIXTURE}", file=sys.stderr)


if __name__ == "__main__":
    main()
