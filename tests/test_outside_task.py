"""A domain from another package joins lwrl's suite through its entry point alone
(`tasks.outside_domains`), with no lwrl file edited: the toy package `tests/toy_task`
(`lwrl_toy_task`: a point mass on a line, written against the public task contract, with an
analytic plant and a MuJoCo plant whose MJCF model it ships) installed, `lwrl train` (with a
Rerun recording) and `lwrl eval` run it, the dm_env and Gymnasium registrations take it and
Gymnasium's checker passes it, and the contract tests of the suite hold it; a bad entry point
is skipped with one warning line.

Installed as tests/test_outside_learner.py installs its toy (its `install` and `child` are
these): really, by pip (`installed_toys`, tests/conftest.py), for the checks that run lwrl
with it; by hand for the check of the entry points in this process and the distribution of
bad entry points beside it: a `.dist-info` directory (METADATA, entry_points.txt) in a
directory on `sys.path`, with the package copied beside it, as an installer puts it. The
checks of an installed domain run in child processes: the registry is made once, as
`lwrl.tasks` is imported, and read then by other modules (the commands' task choices, the
Gymnasium ids).
"""

import csv
import dataclasses
import importlib.util
import json
import pathlib
import shutil
import sys
import tomllib

import mujoco
import numpy as np
import pytest
import rerun as rr

from lwrl import agent, tasks
from test_outside_learner import admitted, child, install, warned_as_expected

TOY = pathlib.Path(__file__).resolve().parent / "toy_task"
"""The toy package's project: its source (`lwrl_toy_task/`) and its pyproject.toml."""
WRONG = {
    "broken": ("lwrl_toy_task.missing:DOMAIN",
               "fails to import (ModuleNotFoundError: No module named 'lwrl_toy_task.missing')"),
    "cartpole": ("lwrl_toy_task.toy_mass:DOMAIN", "takes the name of lwrl.tasks.cartpole's domain"),
    "dotted": ("lwrl_wrong:DOTTED", "names the domain 'dotted' with the task or domain name "
               "'re.ach': names are letters, digits and _"),
    "misnamed": ("lwrl_toy_task.toy_mass:DOMAIN",
                 "names the domain 'toy_mass': an entry point's name must be its domain's"),
    "reach": ("lwrl_toy_task.toy_mass:reach",
              "names a function, not a Domain (lwrl.tasks.domain_contract)"),
    "toy_mass": ("lwrl_toy_task.toy_mass:DOMAIN",
                 "takes the name of lwrl_toy_task.toy_mass's domain"),
}
"""`{name: (target, what is wrong)}`: the entry points of a distribution `lwrl-wrong`, which
comes after `lwrl-toy-task` (so its `toy_mass` finds the name taken), in the order of their
names; its module `lwrl_wrong` holds a domain with a task name that `DOMAIN.TASK` would
split."""
WRONG_MODULE = ("import dataclasses\n"
                "from lwrl_toy_task.toy_mass import DOMAIN\n"
                "DOTTED = dataclasses.replace(DOMAIN, name='dotted', "
                "tasks={'re.ach': DOMAIN.tasks['reach']})\n")
IDS = ["lwrl/toy_mass-reach-mujoco-v0", "lwrl/toy_mass-reach-analytic-v0",
       "lwrl/toy_mass-reach-mujoco-continuous-v0", "lwrl/toy_mass-reach-analytic-continuous-v0"]
"""The toy's Gymnasium ids: its task on each plant of a single environment, with discrete
actions and with continuous ones."""
CONTRACT = ("test_architecture.py", "test_suite.py", "test_batched.py", "test_disturbances.py",
            "test_continuous_actions.py", "test_parameters.py", "test_run.py", "test_viz.py",
            "test_conventions.py", "test_domain_facts.py", "test_gymnasium_envs.py",
            "test_gymnasium_render.py", "test_gymnasium_vector.py", "test_jax_tasks.py",
            "test_mjx_plant.py", "test_learners.py")
"""The test files that hold every domain, task and plant of the registry to the suite's
contract, each parametrised over the registry as it collects: the domain's declarations,
the dm_env environments on each plant and the batch, the sensors and the actuator,
continuous actions, the parameters and the MJCF model set to them, the run paths and their
recordings, the viewer, the parts' facts it has, Gymnasium (single, rendered, vector), the
JAX and MJX plants, and the learners on the task."""
LEARNERS = ("sarsa", "actor_critic", "ase_ace")
"""The learners the contract runs on the toy (the learner contract's checks of every
learner on every task are tests/test_learners.py's): the default's compiled loop on
discrete actions, a compiled loop on continuous ones, and a learner the task does not fit,
which says so."""
NOT_CONTRACT = ("tests/test_compare.py::test_explicit_euler_departs_more_and_gains_energy"
                "[toy_mass.reach]",)
"""A finding about lwrl's own domains, not a contract: on their oscillators explicit Euler
gains energy and departs further than the semi-implicit scheme; on a free mass the two
depart alike (by dt^2 / 2 per unit of pushed acceleration, in opposite directions)."""


def install_wrong(site: pathlib.Path) -> None:
    install(site, "lwrl-wrong", "0.1",
            {tasks.ENTRY_POINT_GROUP: {point: target for point, (target, _) in WRONG.items()}})
    (site / "lwrl_wrong.py").write_text(WRONG_MODULE)


@pytest.fixture
def site(tmp_path) -> pathlib.Path:
    """A directory of installed distributions: the toy package, as its pyproject.toml
    declares it, its source and model copied in."""
    site = tmp_path / "site"
    project = tomllib.loads((TOY / "pyproject.toml").read_text())["project"]
    install(site, project["name"], project["version"], project["entry-points"])
    shutil.copytree(TOY / "lwrl_toy_task", site / "lwrl_toy_task",
                    ignore=shutil.ignore_patterns("__pycache__"))
    return site


@pytest.fixture
def installed_site(installed_toys, tmp_path) -> pathlib.Path:
    """A directory of installed distributions: the toy package as pip installed it."""
    site = tmp_path / "installed"
    shutil.copytree(installed_toys["toy_task"], site)
    return site


@pytest.fixture
def importable(site, monkeypatch):
    """The site's modules importable in this process, and forgotten afterwards."""
    monkeypatch.syspath_prepend(str(site))
    yield
    for name in [name for name in sys.modules
                 if name.split(".")[0] in ("lwrl_toy_task", "lwrl_wrong")]:
        del sys.modules[name]


def test_bad_entry_points_are_skipped_with_one_warning_line_each(site, importable):
    """From the installed distributions' own entry points: the toy joins; each bad one is
    skipped with one line naming it, its distribution and what is wrong, in the order of
    their names; the registry it is added beside is left as it was."""
    install_wrong(site)
    found, messages = admitted(site, tasks.ENTRY_POINT_GROUP, tasks.outside_domains,
                               tasks.DOMAINS)
    from lwrl_toy_task import toy_mass

    assert found == {"toy_mass": toy_mass.DOMAIN}
    assert warned_as_expected(messages, tasks.ENTRY_POINT_GROUP, WRONG)


@pytest.mark.slow
def test_an_installed_domain_joins_the_registry_as_lwrl_tasks_is_imported(installed_site):
    """After lwrl's own domains, with its task and plants; the bad entry points warn then,
    and `-W` makes them errors."""
    install_wrong(installed_site)
    shown = child(installed_site, "-c", "from lwrl import tasks; print(*tasks.TASK_NAMES); "
                              "print(*tasks.PLANTS['toy_mass'])")
    assert shown.returncode == 0, shown.stderr
    assert [line.split() for line in shown.stdout.splitlines()] == [
        [*tasks.TASK_NAMES, "toy_mass.reach"], ["mujoco", "analytic", "mjx"]]
    assert warned_as_expected([line.split("UserWarning: ", 1)[1]
                               for line in shown.stderr.splitlines() if "UserWarning: " in line],
                              tasks.ENTRY_POINT_GROUP, WRONG)
    strict = child(installed_site, "-W", f"error:{tasks.ENTRY_POINT_GROUP} entry point", "-c",
                   "import lwrl.tasks")
    assert strict.returncode == 1
    assert "UserWarning: lwrl.tasks entry point 'broken" in strict.stderr


def read_chunks(path) -> dict:
    """`{entity path: [(static, record batch), ...]}` of an .rrd's recording."""
    chunks: dict = {}
    for chunk in rr.chunk.RrdReader(path).stream():
        chunks.setdefault(chunk.entity_path.lstrip("/"), []).append(
            (chunk.is_static, chunk.to_record_batch()))
    return chunks


def toy_model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(TOY / "lwrl_toy_task" / "toy_mass.xml"))


@pytest.mark.slow
def test_lwrl_train_and_eval_run_the_installed_task(installed_site, tmp_path):
    """`lwrl train toy_mass.reach` on its default plant, MuJoCo (the compiled loop stepping
    the toy's model), writes what every run writes, and `lwrl eval` runs the agents it
    saved; on the analytic plant with continuous actions (`actor_critic`), `--rrd` records
    its episodes with the viewer's scene drawn from the toy's own MJCF model, the mass moving
    with the recorded positions."""
    out, saved, recording = tmp_path / "run", tmp_path / "agents.npz", tmp_path / "run.rrd"
    trained = child(installed_site, "-m", "lwrl.cli", "train", "toy_mass.reach", "--agents", "2",
                    "--episodes", "3", "--out", str(out), "--save", str(saved))
    assert trained.returncode == 0, trained.stderr
    assert "toy_mass.reach on the mujoco plant: 2 agents" in trained.stdout
    config = json.loads((out / "config.json").read_text())
    assert (config["task"], config["plant"], config["learner"]) == ("toy_mass.reach", "mujoco",
                                                                    "sarsa")
    own = {field.name: field.metadata["per_task"]  # no paper agent's settings: the learner's
           for field in dataclasses.fields(agent.learner("sarsa").settings)
           if "per_task" in field.metadata}
    assert own and {name: config["settings"][name] for name in own} == own
    with open(out / "episodes.csv") as file:
        rows = list(csv.DictReader(file))
    assert len(rows) == 6 and all(1 <= float(row["steps"]) <= 200 for row in rows)
    evaluated = child(installed_site, "-m", "lwrl.cli", "eval", str(saved), "--episodes", "1")
    assert evaluated.returncode == 0, evaluated.stderr
    assert "toy_mass.reach on the mujoco plant: 2 saved agents, greedy" in evaluated.stdout

    recorded = child(installed_site, "-m", "lwrl.cli", "train", "toy_mass.reach", "--plant",
                     "analytic", "--learner", "actor_critic", "--action-kind", "continuous",
                     "--agents", "1", "--episodes", "2", "--rrd", str(recording))
    assert recorded.returncode == 0, recorded.stderr
    chunks = read_chunks(recording)
    model = toy_model()
    geoms = {f"scene/{model.body(model.geom_bodyid[g]).name or 'world'}/{model.geom(g).name}"
             for g in range(model.ngeom)}
    assert {"scene/mass/mass", "scene/world/target"} <= geoms <= set(chunks)
    assert all(static for path in geoms for static, _ in chunks[path])
    positions = [np.concatenate([np.array(batch.column("Scalars:scalars").to_pylist()).ravel()
                                 for static, batch in chunks[path] if not static])
                 for path in sorted(path for path in chunks if path.startswith(
                     "signals/state/position/"))]
    assert len(positions) == 2  # the run's first and last episodes
    moved = np.concatenate([np.array(batch.column("Transform3D:translation").to_pylist(),
                                     dtype=np.float64).reshape(-1, 3)
                            for static, batch in chunks["scene/mass"] if not static])
    np.testing.assert_allclose(moved[:, 0], np.concatenate(positions).ravel(), atol=1e-6)


LACKS = """
from lwrl.agent.paper_settings import paper_settings
from lwrl.export import device
from lwrl.studies.paper.benchmark.references import ClassicalPolicy
from lwrl.studies.robustness import plan
from lwrl import tasks

definition = tasks.definition("toy_mass", "reach")
for ask in (lambda: device.plant_header("toy_mass.reach"),
            lambda: ClassicalPolicy(definition, [definition.physical]),
            lambda: plan.axes("toy_mass.reach"), lambda: paper_settings("toy_mass.reach")):
    try:
        ask()
    except ValueError as error:
        print(error)
"""


@pytest.mark.slow
def test_what_the_toy_brings_no_facts_for_is_refused_in_one_line(installed_site, tmp_path):
    """The toy is a spec and its physics: the device programs' plant in C, the benchmark's
    classical controller, the robustness axes, the paper agent's settings and the plant
    comparison's tolerances are each asked for and refused in one line naming the entry-point group to add one under;
    the command exits with status 2."""
    asked = child(installed_site, "-c", LACKS)
    assert asked.returncode == 0, asked.stderr
    groups = ["lwrl.c_plants", "lwrl.classical", "lwrl.robustness", "lwrl.paper_settings"]
    lines = asked.stdout.splitlines()
    assert len(lines) == len(groups)
    for line, group in zip(lines, groups):
        assert "'toy_mass'" in line and f"of the group '{group}'" in line
    compared = child(installed_site, "-m", "lwrl.cli", "compare", "toy_mass.reach", "--out",
                     str(tmp_path / "compare"))
    assert compared.returncode == 2 and not compared.stdout.strip(), compared.stdout
    assert "of the group 'lwrl.plant_comparisons'" in compared.stderr
    assert len(compared.stderr.strip().splitlines()) == 1, compared.stderr


GYMNASIUM = """
import json
import warnings
import dm_env
import gymnasium
from gymnasium.utils.env_checker import check_env
import lwrl.gym
from lwrl import tasks

for plant in tasks.ENVIRONMENT_PLANTS["toy_mass"]:
    env = tasks.load("toy_mass", "reach", plant=plant, seed=0)
    assert isinstance(env, dm_env.Environment) and env.reset().first()
ids = [id_ for id_ in lwrl.gym.ENV_IDS + lwrl.gym.CONTINUOUS_ENV_IDS if "toy_mass" in id_]
print(*ids)
for id_ in ids:
    env = gymnasium.make(id_)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    print(json.dumps([id_, str(env.action_space), sorted({str(w.message) for w in caught})]))
"""


@pytest.mark.slow
def test_gymnasium_registers_the_installed_task_and_its_checker_passes_it(installed_site):
    """`import lwrl.gym` registers `lwrl/toy_mass-reach-{plant}-v0` (and the continuous
    ids) for its dm_env environments' plants, and `check_env` passes each, warning only
    that the velocity's bound is infinite, as it is."""
    ran = child(installed_site, "-c", GYMNASIUM)
    assert ran.returncode == 0, ran.stderr
    lines = ran.stdout.splitlines()
    assert lines[0].split() == IDS
    infinite = {"A Box observation space minimum value is -infinity. This is probably too low.",
                "A Box observation space maximum value is infinity. This is probably too high."}
    for id_, line in zip(IDS, lines[1:], strict=True):
        name, space, messages = json.loads(line)
        assert name == id_
        assert space == ("Box(-1.0, 1.0, (1,), float64)" if "continuous" in id_ else "Discrete(3)")
        assert {message.removeprefix("\x1b[33mWARN: ").removesuffix("\x1b[0m")
                for message in messages} == infinite


NEEDS = {"test_jax_tasks.py": "jax", "test_mjx_plant.py": "mujoco.mjx"}
"""The contract files that skip whole where an optional backend is missing: the module each
imports or skips."""


def runnable(files) -> list:
    """`files` but those whose backend (`NEEDS`) this environment has not installed."""
    def installed(module: str) -> bool:
        try:
            return importlib.util.find_spec(module) is not None
        except ModuleNotFoundError:  # a parent package missing
            return False
    return [name for name in files if name not in NEEDS or installed(NEEDS[name])]


@pytest.mark.slow
def test_the_contract_tests_hold_the_installed_task(installed_site):
    """The contract's test files (`CONTRACT`) parametrise over the registry as they collect:
    with the toy installed, each of their checks over domains, tasks or plants takes the toy
    too (on the learners of `LEARNERS`), and passes, or is skipped where this machine cannot
    run it (headless OpenGL)."""
    learners = " or ".join(f"[{learner}-toy_mass" for learner in LEARNERS)
    ran = child(installed_site, "-m", "pytest", *(f"tests/{name}" for name in CONTRACT), "-v",
                "-p", "no:cacheprovider", "-k", f"toy_mass and (not test_learners or {learners})",
                *(f"--deselect={test}" for test in NOT_CONTRACT))
    assert ran.returncode == 0, ran.stdout[-3000:]
    toy = [line for line in ran.stdout.splitlines() if "toy_mass" in line and "::" in line]
    assert toy and all(" PASSED" in line or " SKIPPED" in line for line in toy), toy
    assert {line.split("::")[0].removeprefix("tests/") for line in toy} == set(runnable(CONTRACT))
    ran_learners = {line.split("[")[1].split("-toy_mass")[0] for line in toy
                    if line.startswith("tests/test_learners.py")}
    assert ran_learners == set(LEARNERS)
