"""The house's rules, read from the code: imports point down the rooms, studies do not borrow
from each other, nothing outside `tasks/` knows a domain by name and nothing outside `agent/`
knows a learner or a feature map by name.

The rules on imports are import-linter's contracts in pyproject.toml (`[tool.importlinter]`):
the floors (a layers contract: a module may import its own room and the rooms on lower floors
only), what `agent` and `tasks` may import, and the studies kept apart. Import-linter checks
them over the graph grimp reads from lwrl/, indirect imports included; docs/ARCHITECTURE.md
draws the same floors, and a test holds the drawing to the contract.
"""

import ast
import importlib
import os
import pathlib
import re
import subprocess
import sys
import tomllib

import pytest

from lwrl import agent, tasks, testing
from lwrl.agent.linear import FEATURE_MAPS

ROOT = pathlib.Path(__file__).resolve().parents[1]
IMPORT_CONTRACTS = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
"""import-linter's configuration: the root package and the contracts."""


def floors(layers) -> dict:
    """`{room: floor}` of a layers contract's `layers`, the highest floor first and the
    rooms of one floor separated by `|` (independent: they do not import each other)."""
    return {room.strip(): floor for floor, layer in enumerate(reversed(layers))
            for room in layer.split("|")}


FLOORS = floors(next(contract["layers"] for contract in IMPORT_CONTRACTS["contracts"]
                     if contract["id"] == "floors"))
"""Room -> floor. `gym` is `lwrl/gym.py`, the suite's Gymnasium face (it reads `tasks`, and
`viz.scenes` for what `render()` draws),
`jax` is `lwrl/jax/`, the suite in JAX (it reads `tasks` too), and `testing` is
`lwrl/testing.py`, the contract checks other packages' authors run (it runs the runners);
`kernels`, `outputs`, `settings` and `outside` (`lwrl/kernels.py`, `lwrl/outputs.py`,
`lwrl/settings.py`, `lwrl/outside.py`), the cache of compiled kernels, the writing of whole
files, the settings dataclasses' metadata and the entry points through which other packages
add to the registries, are there for every room. `bench` (`lwrl/bench.py`) is the second
benchmark's face for any library's learner: it reads `studies`, as `cli` does; `testing`
(`lwrl/testing.py`) holds the learner and task contract checks, reading `runners`."""
LWRL_MODULES = ("gym", "kernels", "outputs", "settings", "outside", "spaces", "bench", "testing")
"""The rooms that are one module of `lwrl/`."""
LWRL_PACKAGES = ("jax",)
"""The rooms that are a package inside `lwrl/` (not a top-level folder: a folder `jax/` at
the repository's root would shadow the library for code run from there)."""
DOMAIN_FACTS = ("viz/scenes/", "export/c_plants/", "studies/compare/domains.py",
                "studies/robustness/domains.py", "studies/paper/benchmark/classical/",
                "studies/paper/benchmark/variants.py", "agent/zoo.py", "agent/paper_settings.py")
"""Each part's facts about the domains (`lwrl.outside.DomainFacts`: the viewer's scenes, the
plants in C, the plant comparison's tolerances, the robustness axes, the benchmark's
classical controllers and randomised physics, the zoo's counterparts, the paper agent's
settings) name the domains they are about, and their parameters and state variables."""
NAMING_DOMAINS_ALLOWED = ("studies/paper/", *DOMAIN_FACTS)
"""The paper's study names the tasks of its figures as data, and the parts' facts."""
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


def test_the_package_files_are_found():
    rooms = {room_of(path) for path in package_files()}
    assert rooms == set(FLOORS), rooms


def lint_imports(cwd: pathlib.Path, pythonpath: pathlib.Path | None = None) -> subprocess.CompletedProcess:
    """import-linter's check of pyproject.toml's contracts over the package `lwrl` that a
    process in `cwd` imports (the one at `pythonpath`, if given)."""
    environment = {**os.environ, **({"PYTHONPATH": str(pythonpath)} if pythonpath else {})}
    return subprocess.run([sys.executable, "-c", "import sys; from importlinter.cli import "
                           "lint_imports; sys.exit(lint_imports(sys.argv[1], no_cache=True, "
                           "no_logo=True))", str(ROOT / "pyproject.toml")],
                          cwd=cwd, env=environment, capture_output=True, text=True, timeout=300)


def test_imports_point_down():
    """A module imports its own room and lower floors only, directly or through others;
    `agent` imports no other room but `kernels`, `outputs`, `settings` and `outside`, and
    `tasks` only `models`, `kernels`, `outputs` and `outside`; one study never imports another."""
    result = lint_imports(ROOT)
    assert result.returncode == 0, result.stdout[-5000:] + result.stderr[-2000:]
    assert f"Contracts: {len(IMPORT_CONTRACTS['contracts'])} kept, 0 broken." in result.stdout


def test_the_contracts_find_an_import_that_breaks_them(tmp_path):
    """The contracts are not blind: in a package `lwrl` of empty rooms, a task that imports
    the runners and the settings, a learner that imports a model, a study that imports
    another and a room no floor holds break every one."""
    package = tmp_path / "lwrl"
    for room in FLOORS:
        (package / room).mkdir(parents=True)
        (package / room / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    (package / "tasks" / "__init__.py").write_text("import lwrl.runners\nimport lwrl.settings\n")
    (package / "agent" / "__init__.py").write_text("from lwrl import models\n")
    for study in ("paper", "compare"):
        (package / "studies" / study).mkdir()
    (package / "studies" / "paper" / "__init__.py").write_text("from lwrl.studies.compare import x\n")
    (package / "studies" / "compare" / "__init__.py").write_text("x = 1\n")
    (package / "attic.py").write_text("")
    result = lint_imports(tmp_path, pythonpath=tmp_path)
    assert result.returncode == 1, result.stdout[-3000:] + result.stderr[-2000:]
    assert "lwrl.tasks -> lwrl.runners" in result.stdout and "lwrl.attic" in result.stdout
    assert "lwrl.tasks -> lwrl.settings" in result.stdout
    assert "lwrl.agent -> lwrl.models" in result.stdout
    assert "lwrl.studies.paper -> lwrl.studies.compare" in result.stdout
    assert f"Contracts: 0 kept, {len(IMPORT_CONTRACTS['contracts'])} broken." in result.stdout


def test_the_map_in_architecture_md_is_the_contract():
    """docs/ARCHITECTURE.md's drawing of the house puts each room on the floor the layers
    contract gives it, and draws every room."""
    drawing = (ROOT / "docs" / "ARCHITECTURE.md").read_text().split("```")[1]
    drawn, floor = {}, None
    for line in drawing.splitlines():
        heading = re.match(r" (?:floor (\d+)|outside) ", line)
        if heading:
            floor = int(heading.group(1)) if heading.group(1) else None
        room = re.match(r"(?: floor \d+| outside| {8})   (\S+)", line)
        if room and floor is not None:
            drawn[room.group(1).removeprefix("lwrl/").removesuffix("/").removesuffix(".py")] = floor
    assert drawn == FLOORS


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


@pytest.mark.parametrize("path", files_outside("tasks/", *DOMAIN_FACTS),
                         ids=lambda p: str(p.relative_to(ROOT)))
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
    """Each domain gives its physics: tasks with bounds, defaults and angles over its state
    variables (`lwrl.testing.check_domain_declaration`; what other parts know of it is
    theirs: tests/test_domain_facts.py)."""
    testing.check_domain_declaration(name)


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
