"""The house's rules, read from the code: imports point down the rooms, studies do not borrow
from each other, nothing outside `tasks/` knows a domain by name and nothing outside `agent/`
knows a learner or a feature map by name.

The rooms and their floors (docs/ARCHITECTURE.md): a module may import its own room and the
rooms on lower floors only.
"""

import ast
import importlib
import pathlib

import numpy as np
import pytest

from lwrl import agent, tasks
from lwrl.agent.linear import FEATURE_MAPS

ROOT = pathlib.Path(__file__).resolve().parents[1]
FLOORS = {"kernels": 0, "outputs": 0, "settings": 0, "outside": 0, "models": 0, "agent": 1,
          "tasks": 1, "analysis": 2, "gym": 2, "jax": 2, "viz": 3, "runners": 4, "adapters": 5,
          "export": 5, "studies": 6, "cli": 7, "bench": 7}
"""Room -> floor. `gym` is `lwrl/gym.py`, the suite's Gymnasium face (it reads `tasks`), and
`jax` is `lwrl/jax/`, the suite in JAX (it reads `tasks` too);
`kernels`, `outputs`, `settings` and `outside` (`lwrl/kernels.py`, `lwrl/outputs.py`,
`lwrl/settings.py`, `lwrl/outside.py`), the cache of compiled kernels, the writing of whole
files, the settings dataclasses' metadata and the entry points through which other packages
add to the registries, are there for every room. `bench` (`lwrl/bench.py`) is the second
benchmark's face for any library's learner: it reads `studies`, as `cli` does."""
LWRL_MODULES = ("gym", "kernels", "outputs", "settings", "outside", "bench")
"""The rooms that are one module of `lwrl/`."""
LWRL_PACKAGES = ("jax",)
"""The rooms that are a package inside `lwrl/` (not a top-level folder: a folder `jax/` at
the repository's root would shadow the library for code run from there)."""
ISOLATED = {"agent": {"kernels", "outputs", "settings", "outside"},
            "tasks": {"models", "kernels", "outputs", "outside"}}
"""Rooms that may import only these others: the learner sees arrays only."""
NAMING_DOMAINS_ALLOWED = ("studies/paper/",)
"""The paper's study names the tasks of its figures as data: the one exception."""
NAMING_LEARNERS_ALLOWED = ("agent/", "studies/paper/")
"""Where a learner or a feature map may be named: its own room, and the paper's study,
whose items are about the paper's learners (NRBF against CMAC, the traces, Table 1's
rivals) and name them as data."""


def room_of(path: pathlib.Path) -> str:
    """The room of a source file: its top-level folder, or the module of `lwrl/`."""
    relative = path.relative_to(ROOT)
    if relative.parts[0] != "lwrl":
        return relative.parts[0]
    return relative.parts[1] if relative.parts[1] in LWRL_PACKAGES else relative.stem


def package_files() -> list:
    """Every module the `lwrl` wheel installs."""
    return sorted(path for room in FLOORS for path in
                  ([ROOT / "lwrl" / f"{room}.py"] if room in LWRL_MODULES
                   else (ROOT / "lwrl" / room).rglob("*.py") if room in LWRL_PACKAGES
                   else (ROOT / room).rglob("*.py"))
                  if path.exists())


def lwrl_imports(tree: ast.AST) -> list:
    """`(line, dotted module)` of every import of an lwrl module (at any depth of the file)."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names if alias.name.startswith("lwrl")]
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("lwrl"):
            if node.module == "lwrl":  # from lwrl import tasks, models
                found += [(node.lineno, f"lwrl.{alias.name}") for alias in node.names]
            else:
                found.append((node.lineno, node.module))
    return found


def imported_room(module: str) -> str:
    return module.split(".")[1] if module.count(".") >= 1 else "lwrl"


def test_the_package_files_are_found():
    rooms = {room_of(path) for path in package_files()}
    assert rooms == set(FLOORS), rooms


@pytest.mark.parametrize("path", package_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_point_down(path):
    """A module imports its own room and lower floors only; `agent` imports no other room and
    `tasks` only `models`; one study never imports another."""
    room = room_of(path)
    tree = ast.parse(path.read_text())
    for line, module in lwrl_imports(tree):
        if module == "lwrl":  # the namespace itself, which imports no room but on demand
            continue
        target = imported_room(module)
        where = f"{path.relative_to(ROOT)}:{line} imports {module}"
        assert target in FLOORS, where
        assert target == room or FLOORS[target] < FLOORS[room], f"{where}: an import up the house"
        if room in ISOLATED and target != room:
            assert target in ISOLATED[room], f"{where}: {room} may import only {ISOLATED[room] or 'itself'}"
        if room == "studies" and target == "studies":
            mine, theirs = path.relative_to(ROOT / "studies").parts[0], module.split(".")[2]
            assert theirs == mine.removesuffix(".py"), f"{where}: a study borrows from another"


def docstring_nodes(tree: ast.AST) -> set:
    """The string constants that are docstrings (of the module, classes, functions, and the
    attribute docstrings after assignments)."""
    found = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if not isinstance(body, list):
            continue
        for statement in body:
            if isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Constant) \
                    and isinstance(statement.value.value, str):
                found.add(id(statement.value))
    return found


def mentions(path: pathlib.Path, words, dotted=()) -> list:
    """`(line, what)` of every place the code of `path` names one of `words`: a string equal
    to one (a comparison, a key, an argument) or, for `dotted`, beginning with one and a dot
    (`cartpole.balance`), a name or an attribute spelled so, or an import of a module so
    named. Docstrings and comments are prose, not code."""
    words, dotted = set(words), set(dotted)
    tree = ast.parse(path.read_text())
    prose = docstring_nodes(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in prose:
            if node.value in words or "." in node.value and node.value.split(".")[0] in dotted:
                found.append((node.lineno, repr(node.value)))
        elif isinstance(node, ast.Attribute) and node.attr in words:
            found.append((node.lineno, f".{node.attr}"))
        elif isinstance(node, ast.Name) and node.id in words:
            found.append((node.lineno, node.id))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            modules = [alias.name for alias in node.names] + [getattr(node, "module", None) or ""]
            modules += [f"{node.module}.{alias.name}" for alias in node.names if getattr(node, "module", None)]
            found += [(node.lineno, f"import {m}") for m in modules if m.split(".")[-1] in words]
    return found


def domain_mentions(path: pathlib.Path) -> list:
    """Where the code names a domain of the suite: a domain or a task name, a task given as
    DOMAIN.TASK, or a domain's module imported or reached as an attribute."""
    return mentions(path, set(tasks.DOMAINS) | set(tasks.TASK_NAMES), dotted=tasks.DOMAINS)


def files_outside(*prefixes) -> list:
    """The package's files but those under `prefixes` (e.g. `tasks/`)."""
    return [path for path in package_files() if not str(path.relative_to(ROOT)).startswith(prefixes)]


@pytest.mark.parametrize("path", files_outside("tasks/", *NAMING_DOMAINS_ALLOWED),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_no_room_but_tasks_names_a_domain(path):
    """Everything about a domain lives in `tasks/<domain>.py` and `models/<domain>.xml`;
    other rooms look it up (`tasks.domain(name)`), so adding a domain touches no other room."""
    assert domain_mentions(path) == []


def test_the_check_finds_a_domain_named_in_code(tmp_path):
    """The check above is not blind: it finds a branch, a table, an import and an attribute."""
    sample = tmp_path / "sample.py"
    sample.write_text('"""Prose may say cartpole."""\n'
                      'from lwrl.tasks import cartpole\n'
                      'TABLE = {"pendulum": 1}\n'
                      'def f(domain):\n'
                      '    """mountain_car in a docstring is prose."""\n'
                      '    return domain == "mountain_car" or cartpole.FAIL_ANGLE or tasks.pendulum\n'
                      'NAME = "cartpole.balance"\n')
    assert sorted(line for line, _ in domain_mentions(sample)) == [2, 2, 3, 6, 6, 6, 7]


def parameter_mentions(path: pathlib.Path) -> list:
    """`(line, name)` of every string in code (not prose) equal to a physical parameter's
    name (`Domain.parameters`)."""
    names = {parameter.name for domain in tasks.DOMAINS.values() for parameter in domain.parameters.items}
    tree = ast.parse(path.read_text())
    prose = docstring_nodes(tree)
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in prose and node.value in names]


@pytest.mark.parametrize("path", files_outside("tasks/"), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_room_but_tasks_names_a_parameter(path):
    """A domain's physical parameters are named in its module alone (`PARAMETERS`); other
    rooms read `Domain.parameters`, so adding a parameter touches no other room."""
    assert parameter_mentions(path) == []


def test_the_check_finds_a_parameter_named_in_code(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text('"""Prose may say pole_mass."""\n'
                      'PARAMS = {"pole_mass": 0.2}\n'
                      'def f(name):\n'
                      '    return name == "link_com_2"\n')
    assert parameter_mentions(sample) == [(2, "pole_mass"), (4, "link_com_2")]


@pytest.mark.parametrize("name", list(tasks.DOMAINS))
def test_every_domain_fills_its_contract(name):
    """Each domain gives what the other rooms look up: tasks with bounds, defaults and angles
    over its state variables, value axes, a drawing or a model, and comparison settings for
    a MuJoCo plant."""
    domain = tasks.domain(name)
    assert domain.name == name and domain.tasks
    assert (domain.model is None) == (domain.drawing is not None), "a model or a drawing"
    assert (domain.model is None) == (domain.comparison is None), "compared where it has a model"
    for task in domain.tasks:
        definition = tasks.definition(name, task)
        state_names = definition.state_names
        assert set(domain.value_axes) <= set(state_names) and len(domain.value_axes) == 2
        assert set(definition.angles) <= set(state_names)
        low, high = definition.bounds
        assert len(low) == len(high) == len(state_names) and np.all(np.less(low, high))
        defaults = definition.defaults
        assert len(defaults.low) == len(defaults.high) == len(state_names)
        if domain.comparison is not None:
            assert set(domain.comparison.tolerances) <= set(state_names)


def learner_names() -> tuple:
    """The words that name a learner or a feature map: their registry names, the modules
    that define them, and the classes those modules define."""
    modules = [f"lwrl.agent.{name}" for name in agent.LEARNER_MODULES]
    modules += [cls.__module__ for cls in FEATURE_MAPS.values()]
    words = set(agent.LEARNER_NAMES) | set(FEATURE_MAPS) | {m.split(".")[-1] for m in modules}
    for module in map(importlib.import_module, modules):
        words |= {name for name, value in vars(module).items()
                  if isinstance(value, type) and value.__module__ == module.__name__}
    return tuple(sorted(words))


def learner_mentions(path: pathlib.Path) -> list:
    """Where the code names a learner or a feature map (`learner_names`)."""
    return mentions(path, learner_names())


@pytest.mark.parametrize("path", files_outside(*NAMING_LEARNERS_ALLOWED),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_no_room_but_agent_names_a_learner_or_a_feature_map(path):
    """Everything about a learner lives in `agent/<learner>.py` (and what it alone needs);
    other rooms go through the learner contract (`agent.learner_contract`) and the registry
    (`agent.LEARNERS`), so adding a learner touches no other room."""
    assert learner_mentions(path) == []


def test_the_check_finds_a_learner_named_in_code(tmp_path):
    """The check above is not blind: it finds an import, a string, a class and an attribute."""
    sample = tmp_path / "sample.py"
    sample.write_text('"""Prose may say sarsa and nrbf."""\n'
                      'from lwrl.agent.sarsa import BatchedSarsa\n'
                      'def f(config):\n'
                      '    """cmac in a docstring is prose."""\n'
                      '    return config.features == "nrbf" or BatchedSarsa or config.cmac\n'
                      'LEARNER = "sarsa"\n')
    assert sorted(line for line, _ in learner_mentions(sample)) == [2, 2, 2, 5, 5, 5, 6]
