"""The second benchmark's protocol and search (studies/paper/benchmark/protocol.py, search.py):
every row of every task is a valid run under the task's budget, each configuration of the
search is drawn within its stated range, on seeds none of the rows use, the row's own
settings first, the same on every call; and the run of a fraction of the budget differs
from the whole run in its budget alone (so it is the start of it, tests/test_budget.py)."""

import dataclasses

import pytest

from lwrl.agent import jax_population
from lwrl.studies.paper.benchmark import protocol, search

pytestmark = pytest.mark.skipif(
    jax_population.missing_jax(), reason="the benchmark's deep rows run on JAX populations: "
    "pip install 'lwrl[jax]'")


@pytest.mark.parametrize("task", list(protocol.BUDGETS))
def test_every_row_runs_under_the_tasks_budget_and_the_deep_rows_schedules_span_it(task):
    """The light-weight row first (the paper's agent; the actor-critic on a task made with
    continuous actions, every row of it made so), the deep rows on their JAX populations."""
    rows = protocol.rows(task)
    name, actions = protocol.variant(task)
    deep = protocol.deep(task)
    assert rows[0].label == protocol.light(task) == ("paper" if actions == "discrete" else "actor_critic")
    assert set(deep) == ({"dqn", "ppo"} if actions == "discrete" else {"sac", "td3"})
    assert set(deep) <= {row.label for row in rows}
    for row in rows:
        config = protocol.training(task, row, row.settings, 0, protocol.AGENTS)
        assert config.budget == protocol.BUDGETS[task] and config.seeds == list(range(20))
        assert config.episodes * protocol.SHORTEST_EPISODE >= config.budget
        assert config.task == name and config.actions == actions
        if row.label in deep:
            assert config.learner == deep[row.label]
            assert config.settings.timesteps == protocol.BUDGETS[task]


@pytest.mark.parametrize("task", list(protocol.BUDGETS))
def test_a_fraction_of_the_budget_changes_the_budget_alone(task):
    row = protocol.rows(task)[-1]
    whole = protocol.training(task, row, row.settings, 0, 3)
    for fraction in protocol.FRACTIONS:
        part = protocol.training(task, row, row.settings, 0, 3, fraction)
        assert part.budget == round(fraction * whole.budget)
        assert dataclasses.replace(part, budget=whole.budget) == whole


@pytest.mark.parametrize("task", list(protocol.BUDGETS))
def test_the_search_draws_every_rows_configurations_within_their_ranges(task):
    runs = search.runs(task)
    assert len({config.key for config in runs.values()}) == len(runs)
    assert runs == search.runs(task)  # the same draws on every call
    for row in protocol.rows(task):
        configurations = search.configurations(task, row)
        assert len(configurations) == search.CONFIGURATIONS
        assert configurations[0] == row.settings
        base = search.start(task, row)
        for settings in configurations[1:]:
            for item in search.ranges(row):
                value = settings[item.name]
                if isinstance(item, search.Choice):
                    allowed = [base[item.name] + v if item.around else v for v in item.values]
                    assert value in allowed
                else:
                    scale = base[item.name] if getattr(item, "around", False) else 1.0
                    assert scale * item.low <= value <= scale * item.high
        for i in range(search.CONFIGURATIONS):
            config = runs[row.label, i]
            assert set(config.seeds) == set(search.SEEDS)
            assert not set(config.seeds) & set(range(protocol.AGENTS))
            assert config.budget == protocol.BUDGETS[task]


def test_an_unknown_task_is_one_line():
    from conftest import one_line_error
    one_line_error(lambda: protocol.rows("pendulum.balance"), "unknown benchmark task",
                   "allowed: mountain_car.cost_to_go")


def test_the_benchmark_on_mujocos_model_has_the_tasks_whose_domain_has_one():
    from conftest import one_line_error
    assert protocol.tasks_on("analytic") == list(protocol.BUDGETS)
    assert "mountain_car.cost_to_go" not in protocol.tasks_on("mujoco")
    assert "pendulum.swingup-continuous" in protocol.tasks_on("mujoco")
    one_line_error(lambda: protocol.check_task("mountain_car.cost_to_go", "mujoco"),
                   "on the mujoco plant", "allowed: pendulum.swingup,")
