"""The learner contract (`agent.learner_contract`), checked for every learner of the registry on every
task of the suite it fits (a learner of networks on `NETWORK_TASKS`, alone and in a batch
on `ALONE_TASK`: each case compiles its JAX programs or builds its PyTorch models),
through the checks lwrl ships (`lwrl.testing`): a new learner is one module and a registry
line, and these tests hold it to the contract without an edit here; what is about lwrl's own
registry and learners stays here."""

import dataclasses
import itertools

import numpy as np
import pytest
from conftest import learner_case

from lwrl import agent as learners
from lwrl import tasks, testing
from lwrl.agent.learner_contract import LearnerForm
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents
from lwrl.settings import base_type

FITS = [(learner, task) for learner, task in itertools.product(learners.LEARNER_NAMES, tasks.TASK_NAMES)
        if testing.fits(learner, task)]
"""(learner, task) of every learner on every task it fits, made with the learner's kind of
actions (`Learner.actions`)."""
MISFITS = [(learner, task) for learner, task in itertools.product(learners.LEARNER_NAMES, tasks.TASK_NAMES)
           if (learner, task) not in FITS]
NETWORK_TASKS = ("cartpole.balance",)
"""The task a learner of networks (`networks`) is checked on: each of its cases compiles
JAX programs (seconds each) or builds PyTorch models, and a learner sees only the task's
spec, so whether it keeps the contract is asked on one task, the one whose shapes a learner
that took its sizes from anywhere but the spec would get wrong: the cart-pole's four
observed variables and two actions (Mountain-Car has two and three, the acrobot four and
three). Every other learner (the compiled loop's) is checked on every task it fits."""


def networks(name: str) -> bool:
    """Whether learner `name` is one of networks: a JAX population (`Learner.population`) or
    a learner whose settings choose its networks' layers (`net_arch`: Stable-Baselines3's).
    An outside learner of neither, a table say, is checked on every task."""
    learner = learners.learner(name)
    return learner.population or "net_arch" in {field.name for field in
                                                 dataclasses.fields(learner.settings)}


PAIRS = [(learner, task) for learner, task in FITS
         if not networks(learner) or task in NETWORK_TASKS]
"""The (learner, task) pairs the contract's checks run on."""
CASES = [learner_case(learner, task) for learner, task in PAIRS]
"""`PAIRS` as test cases, skipped (saying why) where the learner's libraries are not
installed."""
ALONE_TASK = NETWORK_TASKS[0]
"""Where a learner of networks is checked alone and in a batch: a run of one agent compiles a
JAX program of its own, and the property (nothing crosses the batch's axis, which a batch of
one has too) is the learner's whatever the task."""
ALONE_CASES = [learner_case(learner, task) for learner, task in PAIRS
               if not networks(learner) or task == ALONE_TASK]


def test_the_registry_names_each_learner_once():
    assert learners.LEARNER_NAMES == tuple(learners.LEARNERS)
    assert learners.DEFAULT_LEARNER == "sarsa"
    for learner in learners.LEARNERS.values():
        testing.check_learner_declaration(learner)
    with pytest.raises(ValueError, match="unknown learner 'no_such'; available: sarsa, "):
        learners.learner("no_such")


def test_settings_shared_by_name_mean_one_kind_of_value():
    """One flag serves every learner that has a setting of that name: its type is one."""
    seen = {}
    for learner in learners.LEARNERS.values():
        for field in dataclasses.fields(learner.settings):
            kind = base_type(field.type)
            assert seen.setdefault(field.name, kind) == kind, (learner.name, field.name)


@pytest.mark.parametrize("learner, task", CASES)
def test_every_run_path_gives_the_same_numbers(learner, task):
    testing.check_learner_run_paths(learner, task)


@pytest.mark.parametrize("learner, task", ALONE_CASES)
def test_an_agent_is_the_same_alone_and_in_a_batch(learner, task):
    testing.check_learner_alone_as_in_a_batch(learner, task)


@pytest.mark.parametrize("learner, task", CASES)
def test_the_arrays_the_loops_read(learner, task):
    testing.check_learner_arrays(learner, task)


@pytest.mark.parametrize("learner, task", CASES)
def test_acting_greedily_touches_nothing(learner, task):
    testing.check_learner_greedy_touches_nothing(learner, task)


@pytest.mark.parametrize("learner, task", CASES)
def test_saved_agents_load_and_go_on_identically(learner, task):
    testing.check_learner_save_and_load(learner, task)


@pytest.mark.parametrize("learner, task", CASES)
def test_values_over_a_grid_are_the_values_at_its_states(learner, task):
    testing.check_learner_values_on_a_grid(learner, task)


@pytest.mark.parametrize("learner, task", MISFITS)
def test_a_learner_says_in_one_line_where_it_does_not_fit(learner, task):
    testing.check_learner_refuses_misfit(learner, task)


@pytest.mark.parametrize("learner, task", CASES)
def test_a_learner_learns_in_c_or_says_in_one_line_why_not(learner, task):
    testing.check_learner_in_c(learner, task)


def test_some_learner_learns_in_c():
    assert any(isinstance(make_agents(RunConfig(task=task, learner=learner, agents=1)).learner_form(0),
                          LearnerForm)
               for learner, task in PAIRS if learner == learners.DEFAULT_LEARNER)


def test_a_broken_contract_is_one_line_naming_the_learner_the_task_and_the_check(monkeypatch):
    """A failure of a check, NumPy's several-line assertions included, is a ContractError of
    one line; a learner that is not the registry's is refused as such."""
    learner, task = PAIRS[0]
    with pytest.raises(testing.ContractError) as error:
        testing.check_learner_refuses_misfit(learner, task)
    assert str(error.value) == (f"learner {learner!r} on task {task!r}: check_learner_refuses_"
                                f"misfit: a run on a task it does not fit is not refused")
    compiled = testing.run_compiled

    def shifted(*args, **options):
        results = compiled(*args, **options)
        results.steps[0, 0] += 1
        return results

    monkeypatch.setattr(testing, "run_compiled", shifted)
    compiling = next(pair for pair in PAIRS if learners.learner(pair[0]).compiles)
    with pytest.raises(testing.ContractError) as error:
        testing.check_learner_run_paths(*compiling)
    message = str(error.value)
    assert "\n" not in message and message.startswith(
        f"learner {compiling[0]!r} on task {compiling[1]!r}: check_learner_run_paths: ")
    assert "the compiled loop and the batched stepper: steps differ" in message
    stranger = dataclasses.replace(learners.learner(learner))
    with pytest.raises(testing.ContractError, match="not in lwrl's registry; declare its LEARNER "
                                                    "under the entry-point group 'lwrl.learners'"):
        testing.check_learner(stranger)


@pytest.mark.parametrize("shared, fault", [
    (lambda settings: [4], "shared gives [4], not a tuple"),
    (lambda settings: (np.int64(4),), "shared gives (np.int64(4),), not JSON values"),
], ids=["a list", "numpy's integer"])
def test_what_shapes_a_program_is_declared_as_a_tuple_of_json_values(monkeypatch, shared, fault):
    """`Learner.shared` names a run's batch (`runners.sweep.batch_key`): a declaration whose
    values are no tuple of JSON values is refused in one line."""
    declared = dataclasses.replace(learners.learner("dqn_jax"), shared=shared)
    monkeypatch.setitem(learners.LEARNERS, "dqn_jax", declared)
    with pytest.raises(testing.ContractError) as error:
        testing.check_learner_declaration("dqn_jax")
    assert str(error.value).startswith(f"learner 'dqn_jax': check_learner_declaration: {fault}")


def test_a_learner_whose_libraries_are_missing_is_configured_but_not_made(monkeypatch):
    """Whether a learner fits a task does not depend on what is installed: a run of a
    learner whose libraries are missing is a configuration like any (a report names it),
    and making its agents, or checking it, is refused in one line naming the extra."""
    from lwrl.agent import jax_population
    monkeypatch.setattr(jax_population, "missing_jax", lambda: True)
    config = RunConfig(task="cartpole.balance", learner="stream_q", agents=2)
    assert testing.fits("stream_q", "cartpole.balance")
    with pytest.raises(ValueError, match=r"^stream_q needs JAX \(not installed\): pip install "
                                         r"'lwrl\[jax\]'$"):
        make_agents(config)
    with pytest.raises(testing.ContractError, match=r"^learner 'stream_q': check_learner: "
                                                    r"stream_q needs JAX"):
        testing.check_learner("stream_q", ["cartpole.balance"])


def test_check_learner_runs_every_check_on_the_tasks_it_fits_and_the_misfit_check_elsewhere(
        monkeypatch):
    """`check_learner` checks the declaration, then each of `LEARNER_CHECKS` on each task it
    fits and `check_learner_refuses_misfit` on the others (every task when none are given)."""
    learner = next(learner for learner, _ in MISFITS)
    checks, called = testing.LEARNER_CHECKS, []
    monkeypatch.setattr(testing, "LEARNER_CHECKS", tuple(
        lambda *pair, check=check: called.append((check.__name__, *pair)) for check in checks))
    monkeypatch.setattr(testing, "check_learner_refuses_misfit",
                        lambda *pair: called.append(("check_learner_refuses_misfit", *pair)))
    testing.check_learner(learners.learner(learner))
    assert called == [(check, learner, task) for task in tasks.TASK_NAMES
                      for check in ([check.__name__ for check in checks]
                                    if (learner, task) in FITS else
                                    ["check_learner_refuses_misfit"])]
    assert len(checks) == 7
