"""Compiled kernels are cached on disk: a second process compiles nothing, the cache follows
the sources, and cached code computes what freshly compiled code does."""

import json
import os
import subprocess
import sys

import numba
import numpy as np
import pytest

from lwrl import kernels

RUN = """
import json
import sys
from lwrl.agent.learner_contract import batch_step
from lwrl.agent.sarsa import LEARNER
from lwrl.runners.compiled import compiled_loop
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run, run_batched
from lwrl.tasks.batched import BatchedEnv
from lwrl.tasks import mountain_car, pendulum
config = RunConfig(task="mountain_car.cost_to_go", agents=2, episodes=3)
_, results = run(config)
kernels = {"loop": compiled_loop(mountain_car.cost_to_go(), LEARNER)}
numbers = {"steps": results.steps.tolist()}
if sys.argv[1:] != ["loop"]:
    engine = RunConfig(task="pendulum.swingup", plant="mujoco", agents=2, episodes=1)
    _, engine_results = run(engine)
    stepped = RunConfig(task="acrobot.swingup", plant="mujoco", agents=2, episodes=1)
    stepped_results = run_batched(BatchedEnv("acrobot", "swingup", "mujoco", stepped.seeds,
                                             time_limit=10.0), make_agents(stepped), 1)
    kernels.update(mujoco_loop=compiled_loop(pendulum.swingup(), LEARNER, "mujoco"),
                   batch_step=batch_step(LEARNER))
    numbers.update(returns=stepped_results.returns.tolist(),
                   engine_returns=engine_results.returns.tolist())
stats = {name: kernel.dispatcher.stats for name, kernel in kernels.items()}
print(json.dumps({**numbers,
                  "misses": {name: sum(s.cache_misses.values()) for name, s in stats.items()},
                  "hits": {name: sum(s.cache_hits.values()) for name, s in stats.items()},
                  "cached_in": {name: s.cache_path for name, s in stats.items()}}))
"""
"""Runs the Mountain-Car's compiled loop, the pendulum's on MuJoCo's engine and the
acrobot's stepped batch on it, and prints their numbers and what their kernels' caches did;
with the argument `loop`, the first alone."""


def run_process(cache, *argv) -> dict:
    result = subprocess.run([sys.executable, "-c", RUN, *argv], capture_output=True, text=True,
                            env={**os.environ, "LWRL_CACHE_DIR": str(cache)}, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.splitlines()[-1])


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A process that compiles every kernel and caches it, a second that loads them, and a
    third without a writable cache that compiles the Mountain-Car's loop in memory (the
    fall-back is one path whatever the kernel: each kernel more would cost it seconds)."""
    cache = tmp_path_factory.mktemp("kernels")
    unwritable = cache / "a-file"
    unwritable.write_text("not a directory")
    return run_process(cache), run_process(cache), run_process(unwritable / "below", "loop")


def test_a_second_process_compiles_nothing(runs, tmp_path_factory):
    first, second, _ = runs
    assert all(path.startswith(str(tmp_path_factory.getbasetemp())) for path in first["cached_in"].values())
    assert first["misses"] == {"loop": 1, "mujoco_loop": 1, "batch_step": 1}
    assert second["misses"] == {"loop": 0, "mujoco_loop": 0, "batch_step": 0}
    assert second["hits"] == {"loop": 1, "mujoco_loop": 1, "batch_step": 1}


def test_cached_kernels_compute_what_fresh_ones_do(runs):
    """The first run compiles and caches, the second loads, the third (no writable cache)
    compiles the Mountain-Car's loop in memory: the same numbers, to the bit."""
    first, second, in_memory = runs
    assert first["steps"] == second["steps"] == in_memory["steps"]
    assert first["returns"] == second["returns"]
    assert first["engine_returns"] == second["engine_returns"]
    assert in_memory["cached_in"] == {"loop": None} and in_memory["misses"] == {"loop": 1}


def test_the_cache_follows_the_sources(tmp_path, monkeypatch):
    """A kernel's directory is a digest of the sources: change one and it moves."""
    module = tmp_path / "kernel_source_probe.py"
    module.write_text("VALUE = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import kernel_source_probe  # noqa: F401

    monkeypatch.setattr(kernels, "_DIGESTS", {})
    before = kernels.sources_digest(["kernel_source_probe"])
    module.write_text("VALUE = 2\n")
    monkeypatch.setattr(kernels, "_DIGESTS", {})
    assert kernels.sources_digest(["kernel_source_probe"]) != before
    assert kernels.sources_digest() != before


PROBE_PACKAGE = {
    "__init__.py": "",
    "template.py": "from typing import TYPE_CHECKING\n"
                   "from kernel_probe_package.helper import twice\n"
                   "from kernel_probe_package import scale\n"
                   "if TYPE_CHECKING:\n"
                   "    from kernel_probe_package import annotations\n"
                   "def doubled(x):\n"
                   "    return twice(x) * scale.FACTOR\n",
    "helper.py": "def twice(x):\n"
                 "    from kernel_probe_package.deep import ONE\n"
                 "    return 2 * x * ONE\n",
    "deep.py": "ONE = 1\n",
    "scale.py": "FACTOR = 1\n",
    "annotations.py": "Number = float\n",
    "command.py": '"""Help: double a number."""\nfrom kernel_probe_package.template import doubled\n',
}


@pytest.fixture
def probe_package(tmp_path, monkeypatch):
    """A package whose `template` calls `helper`, which imports `deep` in its body; `scale`
    is imported with `from`, `annotations` for type checkers only, and `command` (a command
    line's module) imports the template."""
    package = tmp_path / "kernel_probe_package"
    package.mkdir()
    for name, text in PROBE_PACKAGE.items():
        (package / name).write_text(text)
    monkeypatch.syspath_prepend(str(tmp_path))
    return package


def key_after(package, monkeypatch, edited: str) -> str:
    """The template's kernel key after a line is added to the module `edited`."""
    path = package / f"{edited}.py"
    path.write_text(path.read_text() + "EDITED = True\n")
    monkeypatch.setattr(kernels, "_DIGESTS", {})
    return kernels.sources_digest(["kernel_probe_package.template"])


def test_a_kernel_s_key_digests_what_it_depends_on_and_nothing_else(probe_package, monkeypatch):
    """An edit to a module the kernel reaches moves its key; an edit elsewhere (a command's
    help, a module imported for type checkers only) leaves it where it was."""
    assert set(kernels.dependencies(["kernel_probe_package.template"])) == {
        "kernel_probe_package", "kernel_probe_package.template", "kernel_probe_package.helper",
        "kernel_probe_package.deep", "kernel_probe_package.scale", *kernels.dependencies([])}
    monkeypatch.setattr(kernels, "_DIGESTS", {})
    key = kernels.sources_digest(["kernel_probe_package.template"])
    for elsewhere in ("command", "annotations"):
        assert key_after(probe_package, monkeypatch, elsewhere) == key, elsewhere
    for reached in ("template", "helper", "deep", "scale"):
        moved = key_after(probe_package, monkeypatch, reached)
        assert moved != key, reached
        key = moved


def test_the_compiled_loop_depends_on_its_task_learner_and_loop_alone():
    """The loop of Mountain-Car and Sarsa is keyed by what it can call: no command, study,
    viewer, other domain or other learner's file is in its key, so editing one compiles
    nothing again."""
    from lwrl.agent.sarsa import LEARNER
    from lwrl.runners.compiled import compiled_loop
    from lwrl.tasks import mountain_car

    loop = compiled_loop(mountain_car.cost_to_go(), LEARNER)
    found = set(kernels.dependencies(loop.modules))
    assert {"lwrl.runners.compiled", "lwrl.tasks.mountain_car", "lwrl.agent.sarsa",
            "lwrl.tasks.disturbances", "lwrl.runners.episodes", "lwrl.kernels"} <= found
    rooms = {name.split(".")[1] for name in found if name != "lwrl"}
    assert rooms <= {"runners", "tasks", "agent", "models", "kernels", "settings", "outside",
                     "spaces"}, rooms
    assert not found & {"lwrl.runners.run", "lwrl.runners.sweep", "lwrl.tasks.cartpole",
                        "lwrl.tasks.pendulum", "lwrl.agent.actor_critic", "lwrl.agent.dqn"}


def test_kernel_names_are_file_names():
    with pytest.raises(ValueError, match="letters, digits and _"):
        kernels.kernel("../evil", lambda: None)


def _row_sums(start, stop, values, out):
    """A template: each row's sum, through a view of the row."""
    for b in range(start, stop):
        row = values[b]
        out[b] = row.sum()


def _fresh_rows(start, stop, values, out):
    """A template that allocates."""
    for b in range(start, stop):
        out[b] = np.zeros(3).sum() + values[b, 0]


def test_a_kernel_without_the_runtime_counts_no_references_and_allocates_nothing(tmp_path, monkeypatch):
    """The compiled loop's views of per-agent rows cost no reference counts; a kernel
    without the runtime refuses to allocate."""
    monkeypatch.setenv("LWRL_CACHE_DIR", str(tmp_path))
    values, out = np.arange(6.0).reshape(2, 3), np.zeros(2)
    counted = kernels.kernel("row_sums_counted", _row_sums)
    uncounted = kernels.kernel("row_sums_uncounted", _row_sums, runtime=False)
    for kernel in (counted, uncounted):
        out[:] = 0.0
        kernel(0, 2, values, out)
        assert out.tolist() == [3.0, 12.0]
    llvm = {kernel: "".join(kernel.dispatcher.inspect_llvm().values())
            for kernel in (counted, uncounted)}
    assert "NRT_incref" in llvm[counted] and "NRT_incref" not in llvm[uncounted]
    with pytest.raises(numba.core.errors.TypingError):
        kernels.kernel("fresh_rows", _fresh_rows, runtime=False)(0, 2, values, out)
    assert all(kernel.path.parent.parent == tmp_path and kernel.path.read_text() == kernel.source
               for kernel in (counted, uncounted))


def test_the_compiled_loops_module_binds_its_task_and_learner_where_a_reader_finds_it():
    """The loop's module, as numba compiles it, names the task's and the learner's
    functions bound in place of the loop's placeholders, and lies in the kernel cache."""
    from lwrl.agent.sarsa import LEARNER
    from lwrl.runners.compiled import compiled_loop
    from lwrl.tasks import mountain_car

    loop = compiled_loop(mountain_car.cost_to_go(), LEARNER)
    assert loop.path.parent.parent == kernels.cache_root() and loop.path.stem == loop.name
    for binding in ("transition = inline_copy(importlib.import_module('lwrl.tasks.mountain_car')"
                    ".transition)",
                    "agent_step = inline_copy(importlib.import_module('lwrl.agent.sarsa').agent_step)",
                    "def _loop("):
        assert binding in loop.source, binding


def test_the_analytic_loop_runs_without_the_runtime():
    from lwrl.agent.sarsa import LEARNER
    from lwrl.runners.compiled import compiled_loop
    from lwrl.tasks import mountain_car, pendulum

    assert not compiled_loop(mountain_car.cost_to_go(), LEARNER).runtime
    assert compiled_loop(pendulum.swingup(), LEARNER, "mujoco").runtime  # it views mjData


def test_one_compile_serves_runs_of_any_length(tmp_path, monkeypatch):
    """The compiled loop's arguments have the same types for one episode as for several (a
    one-episode run's parameter array was a read-only view: a second compile, seconds)."""
    from lwrl.agent.sarsa import LEARNER
    from lwrl.runners.compiled import compiled_loop
    from lwrl.runners.config import RunConfig
    from lwrl.runners.run import run
    from lwrl.tasks import mountain_car

    monkeypatch.setenv("LWRL_CACHE_DIR", str(tmp_path))
    loop = compiled_loop(mountain_car.cost_to_go(), LEARNER)
    compiled = []
    for episodes in (1, 3):
        run(RunConfig(task="mountain_car.cost_to_go", agents=2, episodes=episodes))
        compiled.append(len(loop.dispatcher.signatures))
    assert compiled[1] == compiled[0]
