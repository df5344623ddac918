"""The physical parameters of each domain (`tasks.parameters`): declared once, carried to
every plant and run path, set in the MuJoCo models, and refused in one line when bad.

At the paper's values nothing changes (`test_nominal.py`). Away from them (each value
scaled by 2^u, u ~ U[-1, 1], `conftest.off_nominal`), the two plants agree as closely as at
the paper's values (`test_plant_check.py`'s bounds, measured maxima in each test), a batch
whose environments each have values of their own is those environments one by one, and the
run paths give one set of numbers.
"""

import dataclasses
import inspect
import pathlib
import math

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lwrl import models, tasks
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run_batched, run_compiled, run_dm_env
from lwrl.studies.compare.open_loop import random_trials
from lwrl.tasks.batched import BatchedEnv
from lwrl.tasks.engine import engine_plant
from lwrl.tasks.plants import MujocoPlant
from conftest import off_nominal
from test_engine import step_states

MODEL_DOMAINS = [name for name, domain in tasks.DOMAINS.items() if domain.model]
SEEDS = range(20)


def first_task(domain: str) -> str:
    return next(iter(tasks.domain(domain).tasks))


# --- the declarations -------------------------------------------------------------------------

@pytest.mark.parametrize("domain", tasks.DOMAINS)
def test_each_domain_declares_its_parameters_and_its_docstring_lists_them(domain):
    """Every parameter has a symbol, a unit and a finite range around the paper's value; the
    domain's docstring (its specification) names each with its nominal value and range."""
    parameters = tasks.domain(domain).parameters
    assert parameters.items and len(set(parameters.names)) == len(parameters.names)
    module = inspect.getmodule(tasks.domain(domain).plants.step)
    for parameter in parameters.items:
        assert parameter.symbol and parameter.unit and parameter.doc
        assert parameter.low <= parameter.nominal <= parameter.high
        assert (f"`{parameter.name}` {parameter.symbol} ({parameter.unit}) {parameter.nominal:g}, "
                f"in [{parameter.low:g}, {parameter.high:g}]") in " ".join(module.__doc__.split())


@pytest.mark.parametrize("domain", tasks.DOMAINS)
def test_a_task_is_at_the_papers_values_unless_told(domain):
    definition = tasks.definition(domain, first_task(domain))
    assert definition.physical == tuple(tasks.domain(domain).parameters.nominal)
    name = tasks.domain(domain).parameters.names[0]
    other = tasks.definition(domain, first_task(domain), params={name: definition.physical[0] * 1.5})
    assert other.physical == (definition.physical[0] * 1.5, *definition.physical[1:])


@pytest.mark.parametrize("domain, controls, parameter", [
    ("mountain_car", (-1.0, 0.0, 1.0), None),
    ("pendulum", (-5.0, 5.0), "torque"),
    ("cartpole", (-10.0, 10.0), "force"),
    ("acrobot", (-1.0, 0.0, 1.0), "torque"),
])
def test_the_actions_controls_follow_the_actuators_parameter(domain, controls, parameter):
    """The paper's controls at its values; a stronger actuator scales each action's control
    (Mountain-Car's thrust gain is in its equation instead)."""
    assert tasks.definition(domain, first_task(domain)).controls == controls
    if parameter is not None:
        stronger = tasks.definition(domain, first_task(domain), params={parameter: 2 * max(controls)})
        assert stronger.controls == tuple(2 * control for control in controls)


# --- the MuJoCo models --------------------------------------------------------------------------

def model_arrays(model: mujoco.MjModel) -> dict:
    arrays = {name: getattr(model, name) for name in dir(model) if not name.startswith("_")
              and isinstance(getattr(model, name, None), np.ndarray)}
    arrays.update({f"opt.{name}": np.asarray(getattr(model.opt, name)) for name in dir(model.opt)
                   if not name.startswith("_") and isinstance(getattr(model.opt, name), (np.ndarray, float, int))})
    return arrays


@pytest.mark.parametrize("domain", MODEL_DOMAINS)
def test_the_model_set_to_the_papers_values_is_the_file(domain):
    """`edit_model` at the paper's values compiles to the MJCF file's model, array for array:
    the MuJoCo plant's numbers at nominal values are the file's."""
    plants = tasks.domain(domain).plants
    ours = model_arrays(plants.mujoco_model())
    files = model_arrays(mujoco.MjModel.from_xml_string(models.read(plants.model)))
    assert sorted(ours) == sorted(files)
    for name in files:
        np.testing.assert_array_equal(ours[name], files[name], err_msg=name, strict=True)


def inertia_about(model, body, joint) -> float:
    """A body's inertia about its hinge (`test_models.test_inertia_about_the_hinge`)."""
    body, joint = model.body(body), model.joint(joint)
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, body.iquat)
    rotation = rotation.reshape(3, 3)
    axis = joint.axis / np.linalg.norm(joint.axis)
    offset = body.ipos - joint.pos
    return (axis @ rotation @ np.diag(body.inertia) @ rotation.T @ axis
            + body.mass[0] * (offset @ offset - (offset @ axis) ** 2))


def test_the_models_take_the_values():
    """Off the paper's values each model has the masses, inertias about the hinges, lengths,
    frictions, gravity and actuator ranges the equations use."""
    rng = np.random.default_rng(3)
    cartpole, pendulum, acrobot = (tasks.domain(name) for name in ("cartpole", "pendulum", "acrobot"))
    p = dict(zip(cartpole.parameters.names, off_nominal("cartpole", rng)))
    model = cartpole.plants.mujoco_model(list(p.values()))
    assert (model.body("cart").mass[0], model.body("pole").mass[0]) == (p["cart_mass"], p["pole_mass"])
    assert inertia_about(model, "pole", "hinge") == pytest.approx(
        4 / 3 * p["pole_mass"] * p["half_length"] ** 2, rel=1e-12)
    assert model.joint("hinge").damping[0] == p["pole_friction"]
    np.testing.assert_array_equal(model.actuator("cart_friction").forcerange,
                                  [-p["cart_friction"], p["cart_friction"]])
    np.testing.assert_array_equal(model.actuator("force").ctrlrange, [-p["force"], p["force"]])
    np.testing.assert_array_equal(model.opt.gravity, [0, 0, -p["gravity"]])
    frictionless = cartpole.plants.mujoco_model(cartpole.parameters.values({"cart_friction": 0.0}))
    assert not frictionless.actuator("cart_friction").biasprm[2]

    p = dict(zip(pendulum.parameters.names, off_nominal("pendulum", rng)))
    model = pendulum.plants.mujoco_model(list(p.values()))
    assert inertia_about(model, "pendulum", "hinge") == pytest.approx(
        p["mass"] * p["length"] ** 2, rel=1e-11)
    assert model.joint("hinge").damping[0] == p["friction"]
    np.testing.assert_array_equal(model.actuator("torque").ctrlrange, [-p["torque"], p["torque"]])

    p = dict(zip(acrobot.parameters.names, off_nominal("acrobot", rng)))
    model = acrobot.plants.mujoco_model(list(p.values()))
    for link, joint in (("1", "shoulder"), ("2", "elbow")):
        body = {"1": "upper_link", "2": "lower_link"}[link]
        assert inertia_about(model, body, joint) == pytest.approx(
            p[f"link_inertia_{link}"] + p[f"link_mass_{link}"] * p[f"link_com_{link}"] ** 2, rel=1e-12)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    shoulder = model.body("upper_link").pos[2]
    assert data.geom_xpos[model.geom("tip").id][2] - shoulder == pytest.approx(
        -p["link_length_1"] - p["link_length_2"])
    assert model.geom("goal").pos[2] - shoulder == pytest.approx(p["link_length_1"])


# --- the plants agree away from the paper's values --------------------------------------------

def off_nominal_trials(domain: str, steps: int):
    """Per seed, the task's start, random actions and values of its own: `(starts, controls,
    rows)`, the controls those of each seed's actuator."""
    definition = tasks.definition(domain, first_task(domain))
    starts, actions = random_trials(definition, SEEDS, steps)
    rows = off_nominal(domain, np.random.default_rng(7), len(SEEDS))
    controls = definition.controls_at(rows)[np.arange(len(SEEDS))[:, None], actions]
    return starts, controls, rows


def trajectories(plant, starts, controls, rows) -> np.ndarray:
    """`(B, T + 1, d)`: the batch stepped with each state at its own parameter values."""
    states = [starts]
    for t in range(controls.shape[1]):
        states.append(plant.step(states[-1], controls[:, t], rows))
    return np.stack(states, axis=1)


@pytest.mark.parametrize("domain, steps, bound", [
    # Measured: 1.8e-14 (cart-pole, 50 steps), 1.6e-11 and 6.0e-11 (pendulum, 50 and 200),
    # 1.2e-14 and 7.8e-14 (acrobot, 50 and 200); the nominal bounds of test_plant_check.
    ("cartpole", 50, 1e-13), ("pendulum", 50, 5e-11), ("pendulum", 200, 5e-10),
    ("acrobot", 50, 1e-13), ("acrobot", 200, 1e-12),
])
def test_the_plants_agree_away_from_the_papers_values(domain, steps, bound):
    """One batch of 20 random-action trials, each at parameter values of its own, on
    MuJoCo (a model per trial, `mujoco.rollout`) and on the semi-implicit equations."""
    starts, controls, rows = off_nominal_trials(domain, steps)
    plants = tasks.domain(domain).plants
    mujoco_states = trajectories(plants.batch("mujoco", len(SEEDS)), starts, controls, rows)
    analytic_states = trajectories(plants.batch("analytic", len(SEEDS)), starts, controls, rows)
    worst = np.abs(mujoco_states - analytic_states).max(axis=(0, 1))
    assert np.all(worst < bound), worst


def test_the_cartpole_plants_fail_together_away_from_the_papers_values():
    """Random-action episodes to failure at values of their own: both plants fail on the same
    step and agree until then. Measured: at most 1.8e-15, episodes of 5 to 54 steps."""
    starts, controls, rows = off_nominal_trials("cartpole", 200)
    plants = tasks.domain("cartpole").plants
    definition = tasks.definition("cartpole", "balance")
    runs = [trajectories(plants.batch(plant, len(SEEDS)), starts, controls, rows)
            for plant in ("mujoco", "analytic")]
    for i, row in enumerate(rows):
        failed = [np.flatnonzero(definition.outcomes(states[i, 1:], np.tile(row, (200, 1)))[1])
                  for states in runs]
        assert len(failed[0]) and failed[0][0] == failed[1][0]
        end = failed[0][0] + 2
        assert np.abs(runs[0][i, :end] - runs[1][i, :end]).max() < 1e-12


@pytest.mark.parametrize("domain", MODEL_DOMAINS)
def test_the_compiled_loops_engine_steps_the_model_at_the_values(domain):
    """The compiled loop's MuJoCo step (`tasks.engine`) of the model at other values is
    `mujoco.rollout`'s, bit for bit, and not the paper's model's."""
    plants = tasks.domain(domain).plants
    values = off_nominal(domain, np.random.default_rng(2))
    rng = np.random.default_rng(0)
    states = rng.normal(scale=1.0, size=(16, len(tasks.definition(domain, first_task(domain)).state_names)))
    controls = rng.uniform(-0.5, 0.5, size=16)
    ours = np.empty_like(states)
    model = plants.mujoco_model(values)
    step_states(engine_plant(model, plants.mujoco_physics.ACTUATOR, plants.substeps), states,
                 controls, ours)
    rollout = MujocoPlant(model, plants.mujoco_physics.ACTUATOR, 16, plants.substeps)
    np.testing.assert_array_equal(ours, rollout.step(states, controls))
    nominal = MujocoPlant(plants.mujoco_model(), plants.mujoco_physics.ACTUATOR, 16, plants.substeps)
    assert not np.array_equal(ours, nominal.step(states, controls))


# --- every path takes them --------------------------------------------------------------------

def time_steps(env, actions) -> list:
    """`(observation, reward, discount)` of a dm_env environment under `actions`."""
    steps, step = [], env.reset()
    for action in actions:
        step = env.reset() if step.last() else env.step(int(action))
        steps.append((np.array(list(step.observation.values())), step.reward, step.discount))
    return steps


@pytest.mark.parametrize("domain, plant", [(d, p) for d in tasks.DOMAINS for p in tasks.ENVIRONMENT_PLANTS[d]])
def test_a_batch_spans_a_grid_of_values(domain, plant):
    """`BatchedEnv(params={name: one value per environment})`: each environment is the
    single environment `tasks.load(params=its values)`, step by step."""
    parameters = tasks.domain(domain).parameters
    rows = off_nominal(domain, np.random.default_rng(4), 3)
    seeds = [1, 2, 3]
    rng = np.random.default_rng(5)
    env = BatchedEnv(domain, first_task(domain), plant, seeds,
                     params={name: rows[:, j] for j, name in enumerate(parameters.names)},
                     time_limit=60 if domain == "mountain_car" else 1.0)
    actions = rng.integers(env.num_actions, size=(80, 3))
    batch = [env.reset()] + [env.step(a) for a in actions]
    np.testing.assert_array_equal(env.physical, rows)
    for b, seed in enumerate(seeds):
        single = tasks.load(domain, first_task(domain), plant=plant, seed=seed,
                            params=dict(zip(parameters.names, rows[b])),
                            time_limit=60 if domain == "mountain_car" else 1.0)
        for t, (observation, reward, discount) in enumerate(time_steps(single, actions[:, b])):
            np.testing.assert_array_equal(batch[t + 1].observation[b], observation)
            assert batch[t + 1].reward[b] == (0.0 if reward is None else reward)
            assert batch[t + 1].discount[b] == (1.0 if discount is None else discount)


@pytest.mark.parametrize("plant", ["analytic", "mujoco"])
def test_the_run_paths_give_one_set_of_numbers_at_other_values(plant):
    """A heavier pole and a weaker push (`params=`): the compiled loop, the batched stepper
    and a dm_env environment give the same episodes and weights, and not the paper's."""
    params = {"pole_mass": 0.3, "force": 7.0}
    config = RunConfig(task="cartpole.balance", plant=plant, agents=2, episodes=4, seed=8)
    compiled_agent, batched_agent, nominal_agent = (make_agents(config) for _ in range(3))
    compiled = run_compiled("cartpole", "balance", compiled_agent, 4, config.seeds, plant=plant,
                            params=params)
    batched = run_batched(BatchedEnv("cartpole", "balance", plant, config.seeds, params=params),
                          batched_agent, 4)
    for field in ("steps", "returns", "uptime"):
        np.testing.assert_array_equal(getattr(compiled, field), getattr(batched, field))
    np.testing.assert_array_equal(compiled_agent.weights, batched_agent.weights)
    single_agent = make_agents(RunConfig(task="cartpole.balance", agents=1, episodes=4, seed=9))
    single = run_dm_env(tasks.load("cartpole", "balance", plant=plant, seed=9, params=params),
                        single_agent, 4)
    np.testing.assert_array_equal(single.steps[0], compiled.steps[1])
    np.testing.assert_array_equal(single_agent.weights[0], compiled_agent.weights[1])
    nominal = run_compiled("cartpole", "balance", nominal_agent, 4, config.seeds, plant=plant)
    assert not np.array_equal(nominal.steps, compiled.steps)


def test_gymnasium_takes_the_parameters():
    """`gymnasium.make(id, params=...)` is `tasks.load(params=...)`."""
    gymnasium = pytest.importorskip("gymnasium")
    import lwrl.gym  # noqa: F401
    params = {"mass": 1.3, "torque": 4.0}
    env = gymnasium.make("lwrl/pendulum-swingup-mujoco-v0", params=params)
    single = tasks.load("pendulum", "swingup", plant="mujoco", seed=6, params=params)
    observation, _ = env.reset(seed=6)
    np.testing.assert_array_equal(observation, list(single.reset().observation.values()))
    for action in [0, 1, 1, 0, 1]:
        observation, reward, *_ = env.step(action)
        step = single.step(action)
        np.testing.assert_array_equal(observation, list(step.observation.values()))
        assert reward == step.reward


def test_the_mjx_plant_takes_one_set_of_values():
    """MJX steps the model at the batch's values as the C engine does; a batch whose
    environments have different values is refused in one line."""
    pytest.importorskip("mujoco.mjx", reason="the mjx plant needs MJX: pip install 'lwrl[mjx]'")
    values = off_nominal("cartpole", np.random.default_rng(1))
    plants = tasks.domain("cartpole").plants
    rng = np.random.default_rng(0)
    states, controls = rng.uniform(-0.2, 0.2, size=(20, 4)), rng.uniform(-5, 5, size=20)
    mjx, engine = (plants.batch(name, 20, physical=values) for name in ("mjx", "mujoco"))
    for _ in range(50):
        mjx_states, states = mjx.step(states, controls), engine.step(states, controls)
        assert np.abs(mjx_states - states).max() < 1e-10
    with pytest.raises(ValueError, match="^the mjx plant takes one set of parameter values"):
        BatchedEnv("cartpole", "balance", "mjx", [0, 1], params={"pole_mass": [0.1, 0.2]})


# --- bad values -------------------------------------------------------------------------------

def entry_points(domain: str):
    """Each way a user gives parameter values, as a function of `params`."""
    task = first_task(domain)
    return {
        "load": lambda params: tasks.load(domain, task, params=params),
        "task_kwargs": lambda params: tasks.load(domain, task, task_kwargs={"params": params}),
        "batched": lambda params: BatchedEnv(domain, task, seeds=[0, 1], params=params),
    }


def bad_params(domain: str):
    """Parameter mappings that must be refused: an unknown name, a value that is not a
    number, not finite, outside its range, or (for one environment) not one number."""
    parameters = tasks.domain(domain).parameters
    names = st.sampled_from(parameters.names)

    def outside(name):
        parameter = parameters.items[parameters.names.index(name)]
        return st.one_of(st.floats(max_value=parameter.low, exclude_max=True, allow_nan=False),
                         st.floats(min_value=parameter.high, exclude_min=True, allow_nan=False))

    return st.one_of(
        st.builds(lambda word: {word: 1.0}, st.text(min_size=1, max_size=12).filter(
            lambda word: word not in parameters.names)),
        names.flatmap(lambda name: st.builds(lambda value: {name: value}, st.one_of(
            outside(name), st.sampled_from([math.nan, math.inf, -math.inf, "0.2", None, True,
                                            [1.0, 2.0, 3.0], [[1.0]], {}]))),
        ),
        st.sampled_from(["pole_mass=0.2", [("mass", 1.0)], 3.0]),
    )


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), domain=st.sampled_from(list(tasks.DOMAINS)),
       entry=st.sampled_from(["load", "task_kwargs", "batched"]))
def test_bad_parameter_values_are_one_line_naming_what_is_allowed(data, domain, entry):
    params = data.draw(bad_params(domain), label="params")
    with pytest.raises(ValueError) as raised:
        entry_points(domain)[entry](params)
    message = str(raised.value)
    assert "\n" not in message and "Traceback" not in message
    parameters = tasks.domain(domain).parameters
    if isinstance(params, dict) and set(params) - set(parameters.names):
        assert message.startswith("unknown parameter") and all(name in message for name in parameters.names)
    elif isinstance(params, dict):
        name = next(iter(params))
        parameter = parameters.items[parameters.names.index(name)]
        assert message.startswith(name) and f"[{parameter.low:g}, {parameter.high:g}]" in message
    else:
        assert message.startswith("params must be a mapping")


def test_the_docs_have_each_domains_parameters():
    """The tasks page's tables (docs/guide/tasks.md) are `lwrl tasks --parameters`'s: the
    site's hook writes them in from the declarations where the page marks their place."""
    import importlib.util

    from lwrl.cli.tasks import parameter_tables

    docs = pathlib.Path(__file__).resolve().parents[1] / "docs"
    spec = importlib.util.spec_from_file_location("lwrl_docs_hooks", docs / "hooks.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    page = (docs / "guide" / "tasks.md").read_text()
    assert hooks.PARAMETER_TABLES in page, "mark the tables' place on the tasks page"
    assert parameter_tables() in hooks.generate(page)


def test_a_parameter_declared_in_its_domain_alone_reaches_every_path(monkeypatch, capsys):
    """Adding a parameter is one more `Parameter` in its domain's `PARAMETERS` (and the
    equations that read it, in the same module): the settings, `lwrl train`'s flags and help,
    `lwrl tasks --parameters`, randomisation, a batch and the compiled loop take it from the
    declaration, with nothing else changed (no other room names a parameter:
    `test_architecture.py`). Here one that the equations do not read, so its runs are the
    paper's."""
    from lwrl.runners.run import run
    from lwrl.tasks.parameters import Parameter, Parameters
    from conftest import run_cli

    domain = tasks.domain("pendulum")
    added = Parameter("bob_radius", "r", "m", 0.05, 0.01, 0.5, "the bob's radius")
    parameters = Parameters(*domain.parameters.items, added)
    # What the module would hold with the declaration added: its PARAMETERS, and its DOMAIN
    # built from them.
    monkeypatch.setattr(inspect.getmodule(domain.plants.step), "PARAMETERS", parameters)
    plants = dataclasses.replace(domain.plants, parameters=parameters)
    monkeypatch.setitem(tasks.DOMAINS, "pendulum", dataclasses.replace(domain, plants=plants))
    status, out, _ = run_cli(["train", "--help"], capsys)
    assert status == 0 and added.allowed() in " ".join(out.split())
    status, out, _ = run_cli(["tasks", "--parameters"], capsys)
    assert status == 0 and "| `bob_radius` | r | m | 0.05 | 0.01 to 0.5 | the bob's radius |" in out
    status, _, err = run_cli(["train", "pendulum.swingup", "--param", "bob_radius=2"], capsys)
    assert status == 2 and len(err) == 1 and "[0.01, 0.5]" in err[0]
    assert BatchedEnv("pendulum", "swingup", "analytic", [0, 1],
                      params={"bob_radius": [0.1, 0.2]}).physical[:, -1].tolist() == [0.1, 0.2]
    nominal = RunConfig(task="pendulum.swingup", plant="analytic", agents=2, episodes=3,
                        task_options={"time_limit": 4.0})
    added_config = dataclasses.replace(nominal, params={"bob_radius": 0.1},
                                       randomise={"bob_radius": (0.02, 0.4)})
    assert added_config.key != nominal.key
    paper_agent, paper = run(nominal)
    added_agent, added_run = run(added_config)
    np.testing.assert_array_equal(added_run.steps, paper.steps)
    np.testing.assert_array_equal(added_agent.weights, paper_agent.weights)
    drawn = added_run.physical["bob_radius"]
    assert drawn.shape == (2, 3) and np.all((drawn >= 0.02) & (drawn <= 0.4))
