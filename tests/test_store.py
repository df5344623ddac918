"""The runs directory of a sweep: damaged files are named, set aside and recomputed; two
processes on one directory share the batches; a stale claim is taken over; the ledger
counts what each computed batch cost."""

import json
import os
import subprocess
import sys
import threading
import time

import pandas as pd
import pytest

from lwrl.runners import sweep
from lwrl.runners.config import RunConfig
from lwrl.runners.store import RunStore, compute_spent, cpu


def grid(alphas=(0.5, 1.0, 2.0)):
    """Three one-agent Mountain-Car runs that `sweep.batches` joins into one batch."""
    return [RunConfig(task="mountain_car.cost_to_go", alpha=alpha, agents=1, episodes=2)
            for alpha in alphas]


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """The results of the grid swept once into a fresh directory."""
    results, computed = sweep.run_sweep(grid(), tmp_path_factory.mktemp("clean"))
    assert computed == 3
    return results


def test_damaged_run_files_are_named_set_aside_and_recomputed(tmp_path, clean, capsys):
    sweep.run_sweep(grid(), tmp_path)
    store, configs = RunStore(tmp_path), grid()
    store.path(configs[0]).write_bytes(b"")  # empty
    with open(store.path(configs[1]), "r+b") as file:  # truncated
        file.truncate(20)
    whole = store.path(configs[2]).read_bytes()  # its compressed data no deflate stream
    store.path(configs[2]).write_bytes(whole[:10] + b"\xff" * (len(whole) - 10))
    results, computed = sweep.run_sweep(configs, tmp_path)
    lines = capsys.readouterr().err.splitlines()
    damaged = [line for line in lines if "is damaged" in line]
    assert len(damaged) == 3 and all("its run is computed again" in line for line in damaged)
    assert all(str(store.path(config)) in line for config, line in zip(configs, damaged))
    assert (store.directory / (store.path(configs[0]).name + ".damaged")).exists()
    assert computed == 3  # the three damaged runs, as one batch
    pd.testing.assert_frame_equal(results, clean)


def test_the_ledger_counts_each_computed_batch_once_across_calls(tmp_path):
    """A line per computed batch in `compute.jsonl`, naming its runs and the CPU; a call that
    computes nothing adds nothing, and one that computes more adds its own line."""
    sweep.run_sweep(grid(), tmp_path)
    first = compute_spent(tmp_path)
    assert first["runs"] == 3 and first["wall_s"] > 0 and first["cpu_s"] > 0
    assert len(first["hosts"]) == 1
    sweep.run_sweep(grid(), tmp_path)
    assert compute_spent(tmp_path) == first
    sweep.run_sweep(grid((0.25, 4.0)), tmp_path)
    lines = RunStore(tmp_path).ledger.read_text().splitlines()
    assert len(lines) == 2 and compute_spent(tmp_path)["runs"] == 5
    line = json.loads(lines[1])
    second = set(line["runs"])  # the lines of these runs only: the second
    assert compute_spent(tmp_path, second) == {"runs": 2, "wall_s": line["wall_s"],
                                               "cpu_s": line["cpu_s"], "hosts": first["hosts"]}
    assert compute_spent(tmp_path, second - {min(second)})["runs"] == 0  # a line is whole
    assert all(json.loads(line)["cpu"] == cpu() for line in lines)  # what JAX's numbers depend on
    assert compute_spent(tmp_path / "nowhere") == {"runs": 0, "wall_s": 0.0, "cpu_s": 0.0,
                                                   "hosts": []}


def sleeper(claim=None):
    """A live process of this host, holding the claim file `claim` if given."""
    hold = f"from lwrl import outputs; outputs.claim({str(claim)!r}); " if claim else ""
    process = subprocess.Popen([sys.executable, "-c", f"{hold}print(flush=True); "
                                "import time; time.sleep(60)"], stdout=subprocess.PIPE)
    process.stdout.readline()
    return process


def test_a_batch_claimed_by_a_live_process_is_left_to_it(tmp_path, clean):
    """Another process has claimed the batch: this sweep computes nothing of it and waits
    until its runs are there."""
    configs, store = grid(), RunStore(tmp_path)
    claim = store._claim_path(configs)
    other = sleeper(claim)
    try:
        def the_other_process_finishes():
            time.sleep(1.0)
            for config, (table, records) in zip(configs, sweep.run_batch(configs)):
                store.write(config, table, records)
            other.kill()  # the other process ends, its claim file left behind
            other.wait()

        thread = threading.Thread(target=the_other_process_finishes)
        thread.start()
        results, computed = sweep.run_sweep(configs, tmp_path, wait_seconds=0.2)
        thread.join()
    finally:
        other.kill()
        other.wait()
    assert computed == 0
    pd.testing.assert_frame_equal(results, clean)


def test_a_stale_claim_is_taken_over(tmp_path, clean):
    store = RunStore(tmp_path)
    other = sleeper(store._claim_path(grid()))
    other.kill()
    other.wait()  # gone, its claim file left behind
    assert store._claim_path(grid()).read_text() == f"{os.uname().nodename} {other.pid}\n"
    results, computed = sweep.run_sweep(grid(), tmp_path, wait_seconds=0.2)
    assert computed == 3 and not list(store.directory.glob("*.claim"))
    pd.testing.assert_frame_equal(results, clean)


def test_the_local_backend_claims_a_batch_only_as_it_starts_it(tmp_path, monkeypatch):
    """A second process on the directory finds the batches not yet started unclaimed: as a
    batch starts, the claims held are its own and those of batches started before it
    whose files are still being written."""
    configs = grid() + [RunConfig(task="pendulum.swingup", agents=1, episodes=1)]
    store, started, held, compute = RunStore(tmp_path), [], [], sweep.run_batch

    def recording(batch, *options):
        started.append(store._claim_path(batch).name)
        held.append({path.name for path in tmp_path.glob("runs/*.claim")})
        return compute(batch, *options)

    monkeypatch.setattr(sweep, "run_batch", recording)
    _, computed = sweep.run_sweep(configs, tmp_path)
    assert computed == 4 and len(started) == 2
    assert all(started[i] in claims and claims <= set(started[:i + 1])
               for i, claims in enumerate(held))
    assert not list(tmp_path.glob("runs/*.claim"))


def test_a_table_that_cannot_be_written_stops_the_sweep_and_the_others_are_kept(tmp_path,
                                                                                monkeypatch):
    """The tables are written on a thread of their own: a write that fails there reaches
    the caller, every other finished batch is on disk, and no claim is left behind."""
    configs = grid() + [RunConfig(task="pendulum.swingup", agents=1, episodes=1)]
    store, write = RunStore(tmp_path), RunStore.write

    def failing(self, config, table, records):
        if config.task_name == "swingup":
            raise OSError("no space left on device")
        write(self, config, table, records)

    monkeypatch.setattr(RunStore, "write", failing)
    with pytest.raises(OSError, match="no space left"):
        sweep.run_sweep(configs, tmp_path)
    assert [store.path(config).exists() for config in configs] == [True, True, True, False]
    assert not list(tmp_path.glob("runs/*.claim"))
