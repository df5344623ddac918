"""A population run stopped part-way goes on from the state it kept (`runners.resume`), with
the numbers of the run computed in one go, bit for bit; a file of another run, or one past a
checkpoint still to give, is not used; a sweep's family stopped after its first
checkpoints keeps their tables and computes the rest only, its ledger counting what the
stopped process spent."""

import numpy as np
import pytest

from lwrl.agent import jax_population
from lwrl.runners import records
from lwrl.runners.config import RunConfig
from lwrl.runners.population import CHUNK
from lwrl.runners.resume import kept
from lwrl.runners.run import run
from lwrl.runners.store import RunStore, ledger_lines

pytestmark = pytest.mark.skipif(jax_population.missing_jax(),
                                reason=f"JAX is not installed ({jax_population.EXTRA})")


def dqn(budget=2500, **settings):
    return RunConfig(task="mountain_car.cost_to_go", learner="dqn_jax", agents=2, episodes=300,
                     seed=0, timesteps=3000, buffer_size=1000, learning_starts=100,
                     net_arch="16,16", task_options={"time_limit": 40.0}, budget=budget,
                     **settings)


def stop_at(call: int):
    """A progress callback that stops the run (as a Ctrl-C) at its `call`-th call."""
    calls = []

    def progress(_):
        calls.append(1)
        if len(calls) == call:
            raise KeyboardInterrupt
    return progress


def same(first, second):
    for field in ("steps", "returns", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(first, field), getattr(second, field), err_msg=field)


def test_a_stopped_run_goes_on_from_its_kept_state_to_the_same_numbers(tmp_path):
    path = tmp_path / "run.resume.npz"
    whole_agents, whole = run(dqn())
    _, stopped = run(dqn(), resume=path, progress=stop_at(2))
    assert stopped.interrupted and kept(path)["steps"] == 2 * CHUNK
    agents, resumed = run(dqn(), resume=path)
    assert not resumed.interrupted and not path.exists()
    same(resumed, whole)
    wall_s, cpu_s = resumed.earlier_compute
    assert wall_s > 0 and cpu_s > 0
    np.testing.assert_array_equal(agents.arrays.weights, whole_agents.arrays.weights)
    np.testing.assert_array_equal(agents.clocks, whole_agents.clocks)


def test_a_kept_state_of_another_run_or_past_a_checkpoint_is_not_used(tmp_path):
    path = tmp_path / "run.resume.npz"
    run(dqn(), resume=path, progress=stop_at(2))
    _, other = run(dqn(learning_rate=1e-3), resume=path)  # another key: from the start
    assert other.earlier_compute == (0.0, 0.0)
    same(other, run(dqn(learning_rate=1e-3))[1])
    run(dqn(), resume=path, progress=stop_at(2))
    given = {}
    _, longest = run(dqn(), resume=path, checkpoints={1500: lambda a, r: given.update(r=r)})
    assert longest.earlier_compute == (0.0, 0.0)  # kept after 2 048 steps: 1 500 is behind
    same(given["r"], run(dqn(1500))[1])


def test_a_stopped_family_keeps_its_checkpoints_and_computes_the_rest(tmp_path):
    from lwrl.runners.sweep import run_batch, run_sweep
    configs = [dqn(300), dqn(CHUNK), dqn(2 * CHUNK + 77)]
    with pytest.raises(KeyboardInterrupt):
        run_batch(configs, stop_at(2), str(tmp_path), True)
    store = RunStore(tmp_path, keep_agents=True)
    assert [store.finished(config) for config in configs] == [True, True, False]
    assert RunStore.resume_file(tmp_path, configs[-1].key).exists()
    _, computed = run_sweep(configs, str(tmp_path), keep_agents=True)
    assert computed == 1 and not RunStore.resume_file(tmp_path, configs[-1].key).exists()
    earlier, this = ledger_lines(tmp_path)
    assert earlier["runs"] == this["runs"] == [configs[-1].key] and earlier["cpu_s"] > 0
    spent = records.read(tmp_path, configs[-1:])  # the stopped process's CPU among it
    total = spent["cpu_s"].iloc[0] * spent["cpu_shared_by"].iloc[0]
    assert earlier["cpu_s"] - 1e-3 <= total <= earlier["cpu_s"] + this["cpu_s"] + 1e-3  # rounded
    alone = tmp_path / "alone"
    for config in configs:
        run_sweep([config], str(alone), keep_agents=True)
        assert store.read([config]).equals(RunStore(alone).read([config]))
