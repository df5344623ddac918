"""A typed, visible package: the public surface importable from `lwrl` as documented,
`py.typed`, mypy resolving every `lwrl.*` module and holding the package to its
configuration (pyproject.toml), no function hiding a submodule of its own package, and
`import lwrl.tasks` working from the repository's root without an install."""

import importlib
import importlib.util
import inspect
import pathlib
import pkgutil
import subprocess
import sys

import pytest

import lwrl

ROOT = pathlib.Path(__file__).resolve().parents[1]
PUBLIC = {"RunConfig": "lwrl.runners.config", "run": "lwrl.runners.run",
          "make_agents": "lwrl.runners.run", "EpisodeResults": "lwrl.runners.episodes",
          "load": "lwrl.tasks", "definition": "lwrl.tasks", "BatchedEnv": "lwrl.tasks.batched",
          "TASK_NAMES": "lwrl.tasks", "ALL_TASKS": "lwrl.tasks", "DOMAINS": "lwrl.tasks",
          "PLANTS": "lwrl.tasks", "LEARNERS": "lwrl.agent", "LEARNER_NAMES": "lwrl.agent"}
"""What users import from `lwrl` (README, the package's docstring): a name that goes fails."""


@pytest.mark.parametrize("name", sorted(PUBLIC))
def test_the_public_surface_is_where_users_look(name):
    assert name in lwrl.__all__ and name in dir(lwrl)
    assert getattr(lwrl, name) is getattr(importlib.import_module(PUBLIC[name]), name)
    assert f"`{name}" in lwrl.__doc__, f"{name} is not documented in lwrl's docstring"


def test_every_public_name_is_documented_and_tested():
    assert set(lwrl.__all__) - {"__version__"} == set(PUBLIC) == set(lwrl.PUBLIC)
    with pytest.raises(AttributeError, match="has no attribute 'RunConfg'"):
        lwrl.RunConfg


def test_importing_lwrl_imports_no_room():
    code = "import sys, lwrl; print(sorted(m for m in sys.modules if m.startswith('lwrl.')))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=120, check=True)
    assert result.stdout.strip() == "[]"


def packages():
    """Every package of lwrl, imported."""
    found = [lwrl]
    for info in pkgutil.walk_packages(lwrl.__path__, "lwrl."):
        if info.name == "lwrl.jax" and importlib.util.find_spec("jax") is None:
            continue  # the tasks in JAX come with the jax extra
        if info.ispkg and not info.name.startswith(("lwrl.studies", "lwrl.cli")):
            found.append(importlib.import_module(info.name))
    return found + [importlib.import_module(name) for name in ("lwrl.studies", "lwrl.cli")]


def test_no_function_or_class_shadows_a_submodule_of_its_package():
    """`tasks.definition` is a function, so the module that held `TaskDefinition` is called
    `task_definition`: `import lwrl.tasks.X as m` always gives the module X."""
    shadowing = []
    for package in packages():
        submodules = {info.name for info in pkgutil.iter_modules(package.__path__)}
        for name, value in vars(package).items():
            if name in submodules and (inspect.isfunction(value) or inspect.isclass(value)):
                shadowing.append(f"{package.__name__}.{name}")
    assert shadowing == []
    assert callable(lwrl.tasks.definition) and callable(lwrl.tasks.domain)
    assert importlib.import_module("lwrl.tasks.task_definition").TaskDefinition is lwrl.tasks.TaskDefinition


def test_the_package_is_typed():
    assert (ROOT / "lwrl" / "py.typed").exists()


def test_lwrl_tasks_imports_from_the_repository_root_without_an_install():
    """The rooms are linked into lwrl/ (lwrl/tasks -> ../tasks), so the path finder finds
    them as the wheel lays them out, without setuptools' editable finder."""
    code = ("import sys\n"
            "sys.meta_path[:] = [finder for finder in sys.meta_path\n"
            "                    if 'editable' not in type(finder).__module__ + str(finder)]\n"
            "import lwrl.tasks, lwrl.runners.run, lwrl.models\n"
            "print(lwrl.tasks.__file__); print(lwrl.models.path('cartpole'))\n")
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    tasks_file, model = result.stdout.splitlines()
    assert pathlib.Path(tasks_file) == ROOT / "lwrl" / "tasks" / "__init__.py"
    assert pathlib.Path(model).resolve() == ROOT / "models" / "cartpole.xml"


def mypy(*arguments, cwd=ROOT) -> subprocess.CompletedProcess:
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("the type check needs mypy (pip install -e '.[dev]')")
    return subprocess.run([sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"),
                           *arguments], cwd=cwd, capture_output=True, text=True, timeout=600)


def test_mypy_passes_on_the_package():
    result = mypy()
    assert result.returncode == 0, result.stdout[-3000:]
    assert result.stdout.startswith("Success: no issues found")


USES = """
import lwrl
config = lwrl.RunConfig(task="mountain_car.cost_to_go", agents=2, episodes=2)
agents, results = lwrl.run(config)
env = lwrl.load("cartpole", "balance", plant="mujoco", seed=0)
batch = lwrl.BatchedEnv("pendulum", "swingup", "analytic", seeds=[0, 1])
tasks = lwrl.TASK_NAMES, lwrl.ALL_TASKS, lwrl.DOMAINS, lwrl.PLANTS, lwrl.definition
from lwrl.tasks.task_definition import TaskDefinition
from lwrl.tasks.domain_contract import Domain
"""


def test_mypy_resolves_what_users_write_and_names_what_is_gone(tmp_path):
    (tmp_path / "uses.py").write_text(USES)
    (tmp_path / "gone.py").write_text("import lwrl\nlwrl.RunConfg\n"
                                      "from lwrl.tasks.definition import TaskDefinition\n")
    result = mypy(str(tmp_path / "uses.py"))
    assert result.returncode == 0, result.stdout[-3000:]
    result = mypy(str(tmp_path / "gone.py"))
    assert result.returncode == 1
    assert 'gone.py:2: error: Module has no attribute "RunConfg"' in result.stdout
    assert 'gone.py:3: error: Cannot find implementation or library stub for module named ' \
           '"lwrl.tasks.definition"' in result.stdout
