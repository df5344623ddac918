"""A run's budget of environment steps per agent (`RunConfig.budget`, `lwrl train
--budget`): every agent takes exactly the budget (unless its episodes end first), the
episode that spends it is cut there and recorded as truncated, what came before is the run
without a budget (so a shorter budget's run is the start of a longer one's), and the
compiled and stepped loops agree on it; the JAX populations' path spends it alike."""

import numpy as np
import pytest
from conftest import one_line_error

from lwrl.agent import jax_population
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run
from lwrl.runners.stepped import run_batched
from lwrl.tasks.batched import BatchedEnv


@pytest.mark.parametrize("task", ["mountain_car.cost_to_go", "cartpole.balance"])
def test_a_budget_cuts_the_run_it_would_have_been(task):
    config = RunConfig(task=task, agents=3, episodes=8, seed=0)
    _, free = run(config)
    budget = int(np.nansum(free.steps, axis=1).min() * 0.6)
    _, cut = run(RunConfig(task=task, agents=3, episodes=8, seed=0, budget=budget))
    np.testing.assert_array_equal(np.nansum(cut.steps, axis=1), budget)
    for b in range(3):
        last = int(np.flatnonzero(np.isfinite(cut.steps[b]))[-1])
        assert last < 7 and np.isnan(cut.steps[b, last + 1:]).all()
        np.testing.assert_array_equal(cut.steps[b, :last], free.steps[b, :last])
        np.testing.assert_array_equal(cut.returns[b, :last], free.returns[b, :last])
        assert cut.steps[b, last] <= free.steps[b, last]
        assert cut.truncated[b, last] == (cut.steps[b, last] < free.steps[b, last]
                                          or free.truncated[b, last])


def test_the_stepped_loop_spends_a_budget_as_the_compiled_loop_does():
    config = RunConfig(task="mountain_car.cost_to_go", agents=3, episodes=8, seed=4, budget=700)
    _, compiled = run(config)
    env = BatchedEnv(config.domain, config.task_name, config.plant_name, config.seeds)
    stepped = run_batched(env, make_agents(config), config.episodes, budget=config.budget)
    for field in ("steps", "returns", "truncated"):
        np.testing.assert_array_equal(getattr(stepped, field), getattr(compiled, field))


def test_a_budget_larger_than_the_run_changes_nothing_and_no_budget_keeps_the_key():
    config = RunConfig(task="mountain_car.cost_to_go", agents=2, episodes=3, seed=0)
    _, free = run(config)
    _, large = run(RunConfig(task="mountain_car.cost_to_go", agents=2, episodes=3, seed=0,
                             budget=10**9))
    np.testing.assert_array_equal(large.steps, free.steps)
    assert RunConfig(task="mountain_car.cost_to_go", budget=None).key == \
        RunConfig(task="mountain_car.cost_to_go").key


@pytest.mark.parametrize("budget", [0, -5, 2.5, True])
def test_a_budget_is_a_whole_number_of_steps(budget):
    one_line_error(lambda: RunConfig(task="mountain_car.cost_to_go", budget=budget),
                   "budget must be an integer >= 1")


@pytest.mark.skipif(jax_population.missing_jax(), reason=f"JAX is not installed ({jax_population.EXTRA})")
def test_a_population_spends_a_budget_as_the_other_loops_do():
    """The JAX path (one program whatever the budget: it is data): every agent takes exactly
    the budget, its cut episode truncated, the episodes before it those of the run without."""
    def config(budget=None):
        return RunConfig(task="mountain_car.cost_to_go", learner="dqn_jax", agents=2, episodes=6,
                         seed=0, timesteps=2000, buffer_size=1000, learning_starts=100,
                         net_arch="16,16", task_options={"time_limit": 40.0}, budget=budget)
    _, free = run(config())
    budget = int(np.nansum(free.steps, axis=1).min() * 0.6)
    _, cut = run(config(budget))
    np.testing.assert_array_equal(np.nansum(cut.steps, axis=1), budget)
    for b in range(2):
        last = int(np.flatnonzero(np.isfinite(cut.steps[b]))[-1])
        np.testing.assert_array_equal(cut.steps[b, :last], free.steps[b, :last])
        np.testing.assert_array_equal(cut.returns[b, :last], free.returns[b, :last])
        assert cut.truncated[b, last] and np.isnan(cut.steps[b, last + 1:]).all()


def test_a_budgeted_runs_table_keeps_the_episodes_it_ran(tmp_path):
    from lwrl.runners.sweep import run_sweep
    config = RunConfig(task="mountain_car.cost_to_go", agents=2, episodes=500, seed=0, budget=900)
    table, computed = run_sweep([config], str(tmp_path))
    assert computed == 1 and table["steps"].notna().all()
    assert table.groupby("seed")["steps"].sum().tolist() == [900, 900]
    assert table["truncated"].groupby(table["seed"]).last().all()  # each cut at the budget


def _dqn(budget, agents=2):
    return RunConfig(task="mountain_car.cost_to_go", learner="dqn_jax", agents=agents,
                     episodes=300, seed=0, timesteps=3000, buffer_size=1000, learning_starts=100,
                     net_arch="16,16", task_options={"time_limit": 40.0}, budget=budget)


@pytest.mark.skipif(jax_population.missing_jax(), reason=f"JAX is not installed ({jax_population.EXTRA})")
def test_a_family_of_budgets_is_computed_as_one_run_and_gives_each_run_bit_for_bit(tmp_path):
    """The runs of a population learner that differ in their budget only are one run, the
    longest, the others its checkpoints (`runners.sweep.families`): each one's table and
    kept agents are those of the run computed alone, and the ledger has one line for them.
    The budgets fall inside the first chunk, on a chunk's end, and across chunks."""
    from lwrl.runners.population import CHUNK
    from lwrl.runners.store import RunStore, ledger_lines
    from lwrl.runners.sweep import families, run_sweep
    configs = [_dqn(budget) for budget in (300, CHUNK, 2 * CHUNK + 77)]
    assert families(configs + [_dqn(300, agents=3)]) == [configs, [_dqn(300, agents=3)]]
    together, alone = tmp_path / "together", tmp_path / "alone"
    table, computed = run_sweep(configs, str(together), keep_agents=True)
    assert computed == 3 and len(ledger_lines(together)) == 1
    for config in configs:
        run_sweep([config], str(alone), keep_agents=True)
    assert len(ledger_lines(alone)) == 3
    for config in configs:
        mine, theirs = (RunStore(directory).read([config]) for directory in (together, alone))
        assert mine.groupby("seed")["steps"].sum().tolist() == [config.budget] * 2
        assert mine.equals(theirs)
        with np.load(RunStore.agents_file(together, config.key)) as a, \
                np.load(RunStore.agents_file(alone, config.key)) as b:
            assert sorted(a.files) == sorted(b.files)
            for name in a.files:
                np.testing.assert_array_equal(a[name], b[name], err_msg=name)


@pytest.mark.skipif(jax_population.missing_jax(), reason=f"JAX is not installed ({jax_population.EXTRA})")
@pytest.mark.parametrize("smaller", [0, 500, 900, 2.5])
def test_a_checkpoint_is_a_smaller_budget(smaller):
    one_line_error(lambda: run(_dqn(500), checkpoints={smaller: print}),
                   "a checkpoint is a budget of steps from 1 to the run's budget (500) exclusive")


@pytest.mark.parametrize("option", [{"checkpoints": {100: print}}, {"resume": "r.npz"}])
def test_only_a_population_learner_takes_checkpoints_or_resumes(option):
    one_line_error(lambda: run(RunConfig(task="mountain_car.cost_to_go", budget=900), **option),
                   f"{next(iter(option))} is for population learners only; sarsa is not one")
