"""Sweeps: many runs (one `RunConfig` each), written to disk as they finish, resumable.

Each run's per-agent, per-episode results go to `OUT/runs/<key>.csv.gz`, where the key is
the run's name and a hash of its whole configuration; the file appears whole (written to a
temporary name, then renamed) only once the run has finished (`runners.store`), after the
run's records, `OUT/runs/records/<key>.csv.gz`: each agent's share of its batch's CPU of
training, its counted arithmetic and where it ran (`runners.records`). Running the
same sweep again skips every run whose file exists, so an interrupted sweep (Ctrl-C, kill,
power cut) resumes where it stopped and recomputes nothing that finished (a batch that was
running when interrupted runs again whole, but for a population learner's, which goes on
from the state it keeps every few minutes, `runners.resume`); a damaged file is set aside and its run
computed again; two processes sweeping into one directory share the batches. A diverged
run is a finished run: its agents' `diverged` column says so.

Runs that differ only in their learner's per-agent settings (Sarsa's trace, alpha, lambda
and epsilon), their agents and seeds are joined into batches that one learner and one
stepper run together (the learner takes those per agent, and an agent's numbers do not
depend on its batch): a grid of small runs costs about as much as one large one. Backends: `local` runs one batch at a time on this machine, on all its cores
(the learner's threads), its progress bar moving as episodes finish; `ray` sends batches
to a Ray cluster (`pip install -e '.[ray]'`), one task each, and writes their results here
as they come back.
"""

import dataclasses
import functools
import json
import sys
import time

import numpy as np
import pandas as pd
import tqdm

from lwrl import agent as learners
from lwrl import outputs
from lwrl.agent import io as agent_io
from lwrl.agent import threads
from lwrl.runners import records
from lwrl.runners.config import RunConfig
from lwrl.runners.run import draw_ahead, make_agents, run
from lwrl.runners.store import RunStore

BACKENDS = ("local", "ray")
"""Where a sweep's batches run: on threads of this process, or on a Ray cluster."""
MAX_BATCH_AGENTS = 512
"""Agents in one batch at most. An interrupted batch is recomputed whole, so this bounds the
work an interrupt loses; beyond a few hundred agents larger batches gain little (MuJoCo
pendulum: 4.0 us of CPU per agent-step at 1024 agents, 5.0 at 256)."""


def batch_key(config) -> str:
    """What the runs of one batch share: every setting but those the metadata marks
    `per_agent` (the learner takes them per agent; agents and seeds), and what of those
    shapes a population learner's program (`Learner.shared`)."""
    key = {field.name: value for field, value in config.flat_fields()
           if not field.metadata.get("per_agent")}
    key["shared"] = learners.learner(config.learner).shared([config.settings])
    return json.dumps(key, sort_keys=True)


def batches(configs, max_agents: int = MAX_BATCH_AGENTS) -> list:
    """The configurations grouped into batches that one learner and one stepper can run:
    same task, plant, learner and protocol, differing only in per-agent settings; at most
    `max_agents` agents (a run larger than that is a batch of its own). Order is kept
    within a batch."""
    groups = {}
    for config in configs:
        groups.setdefault(batch_key(config), []).append(config)
    result = []
    for group in groups.values():
        batch, size = [], 0
        for config in group:
            if batch and size + config.agents > max_agents:
                result.append(batch)
                batch, size = [], 0
            batch.append(config)
            size += config.agents
        result.append(batch)
    return result


def family_key(config) -> str:
    """What the runs of one family share: every setting but the budget."""
    return json.dumps({field.name: value for field, value in config.flat_fields()
                       if field.name != "budget"}, sort_keys=True)


def families(configs) -> list:
    """The configurations as runs to compute, each a list: those of a population learner
    (`Learner.population`) with a budget that differ only in it joined (the longest run
    gives the others on the way, `runners.population.run_population`'s checkpoints), every
    other one alone, once. Order is kept."""
    groups = {}
    for config in {config.key: config for config in configs}.values():
        joins = config.budget is not None and learners.learner(config.learner).population
        groups.setdefault(family_key(config) if joins else config.key, []).append(config)
    return list(groups.values())


def populations(queue, max_agents: int = MAX_BATCH_AGENTS) -> list:
    """`families`' runs, those of a population learner (`Learner.population`) that run one
    program joined: a run alone (no family, not going on from kept agents) joins the others of
    its `batch_key` (budget included) in one batch of at most `max_agents` agents, trained as
    one population and kept apart (`run_batch`), as a search's configurations that differ only
    in per-agent settings; an agent's numbers do not depend on the others of its batch (the
    learner contract). Every other run as it was, first."""
    def joins(family) -> bool:
        config = family[0]
        return (len(family) == 1 and config.trained is None
                and learners.learner(config.learner).population)
    return ([family for family in queue if not joins(family)]
            + batches([family[0] for family in queue if joins(family)], max_agents))


def longest(family):
    """The run of a family (`families`) that computes the others: the one of largest budget."""
    return max(family, key=lambda config: config.budget)


def given_on_the_way(batch) -> set:
    """The keys of the runs of `batch` that a longer run of their family among them gives on
    the way: where `batch` is what one ledger line names (`RunStore.record_compute`), the
    batch computed their steps as that run's first."""
    budgets = [(config, family_key(config)) for config in batch if config.budget is not None]
    longest = {}
    for config, family in budgets:
        longest[family] = max(longest.get(family, config.budget), config.budget)
    return {config.key for config, family in budgets if config.budget < longest[family]}


def trained_agents(configs, directory):
    """The agents of a batch of configurations that go on with the agents of the run
    `configs[0].trained` (kept in `directory`, `RunStore.agents_path`): each configuration's
    agents are that run's, as it ended (`Agents.take_over`), with the configuration's
    settings."""
    kept, _ = agent_io.load(RunStore.agents_file(directory, configs[0].trained))
    agent = make_agents(*configs)
    agent.take_over(kept)
    return agent


def run_batch(configs, progress=None, directory=None, keep_agents: bool = False) -> list:
    """Run several configurations as one batch of agents, or a family (`families`: the
    longest run, the others its checkpoints); per configuration its tidy table and its
    records (`runners.records`: what its training cost, each agent's share of the batch's
    CPU, and where it ran), the table equal to running each alone (agents are independent;
    a budget cuts a run without changing what came before). `progress(agent_episodes)` is
    called as episodes finish. Agents go on from a kept run where the configurations name
    one (`RunConfig.trained`, `trained_agents`); with `keep_agents` each configuration's
    agents are saved to `directory` for such runs."""
    family = len({config.budget for config in configs}) > 1
    base = longest(configs) if family else configs[0]
    joined = [base] if family else configs
    agent = trained_agents(joined, directory) if base.trained else make_agents(*joined)
    population = directory is not None and agent.learner.population
    seeds = [seed for config in joined for seed in config.seeds]
    draw_ahead(base, seeds, joined)  # before the clock: the same for every run
    finished, clock = {}, records.TrainingClock()
    shared_by = sum(config.agents for config in joined)

    def checkpoint(config):
        def reached(agents, results):  # the CPU spent up to the checkpoint
            _finish(finished, config, directory, keep_agents, clock, shared_by,
                    clock.seconds() + results.earlier_compute[1], agents, results)
        return reached

    checkpoints = {config.budget: checkpoint(config)
                   for config in configs if config is not base} if family else None
    name = base.key if len(joined) == 1 else RunStore.batch_name(joined)
    _, results = run(base, agents=agent, seeds=seeds,
                     progress=progress, learn=base.learn, greedy=base.greedy, batch=joined,
                     checkpoints=checkpoints,
                     resume=RunStore.resume_file(directory, name) if population else None)
    cpu_s = clock.seconds() + results.earlier_compute[1]
    if results.interrupted:  # a population run keeps its state and what it spent to go on
        raise KeyboardInterrupt
    if any(results.earlier_compute):  # what the processes stopped before this one spent
        RunStore(directory).record_compute(configs, *results.earlier_compute)
    starts = np.cumsum([0] + [config.agents for config in joined])
    for config, start in zip(joined, starts):
        stop = start + config.agents
        kept = agent.part(start, stop) if keep_agents and len(joined) > 1 else agent
        _finish(finished, config, directory, keep_agents, clock, shared_by, cpu_s, kept,
                results.agents(start, stop), write=False)
    return [finished[config.key] for config in configs]


def _finish(finished: dict, config, directory, keep_agents: bool, clock, shared_by: int,
            cpu_s: float, agents, results, write: bool = True) -> None:
    """Keep `config`'s table and records (`cpu_s` CPU seconds of training of a batch of
    `shared_by` agents) in `finished`, and with `keep_agents` save its `agents`; with
    `write`, they are written at once too (a family's checkpoint: what a stop of the longer
    run later would otherwise lose). What this costs is `clock`'s aside, not training's."""
    with clock.aside():
        finished[config.key] = (results_table(config, results),
                                records.table(config, results, cpu_s, shared_by))
        if keep_agents:
            agent_io.save(RunStore.agents_file(directory, config.key), agents,
                          {"config": dataclasses.asdict(config)})
        if write and directory is not None:
            RunStore(directory).write(config, *finished[config.key])


def results_table(config: RunConfig, results) -> pd.DataFrame:
    """A run's `EpisodeResults` as a tidy table with its configuration on every row; a run
    with a budget of steps (`RunConfig.budget`) keeps the episodes it ran only, not the
    many its episode count allowed and its budget ended before."""
    columns = results.columns(config.seeds)
    if config.budget is not None:  # chosen before the table is made: 1 M rows for 100 agents
        ran = ~np.isnan(columns["steps"])
        columns = {name: values[ran] for name, values in columns.items()}
    return pd.DataFrame({"run": config.key, **config.columns(), **columns})


def _agent_episodes(configs) -> int:
    return sum(config.agents * config.episodes for config in configs)


def timed_batch(configs, progress=None, *options) -> tuple:
    """`(run_batch's tables and records, wall seconds, CPU seconds of the process that ran
    it)`."""
    wall, cpu = time.perf_counter(), time.process_time()
    tables = run_batch(configs, progress, *options)
    return tables, time.perf_counter() - wall, time.process_time() - cpu


def _local(batches_, progress, *options):
    for batch in batches_:
        yield batch, timed_batch(batch, progress, *options)


def _ray(batches_, address, progress, *options):
    try:
        import ray
    except ImportError:
        raise ValueError("the ray backend needs Ray: pip install -e '.[ray]'") from None
    ray.init(address=address, ignore_reinit_error=True, include_dashboard=False,
             log_to_driver=False)
    remote = ray.remote(timed_batch)
    pending = {remote.remote(batch, None, *options): batch for batch in batches_}
    try:
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            batch = pending.pop(done[0])
            timed = ray.get(done[0])
            progress(_agent_episodes(batch))
            yield batch, timed
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)


def run_sweep(configs, out_dir: str, backend: str = "local", workers: int | None = None,
              address: str | None = None, description: str = "sweep",
              wait_seconds: float = 2.0, keep_agents: bool = False) -> tuple[pd.DataFrame, int]:
    """Run every configuration not already in `out_dir`; return all their results and how
    many runs this call computed.

    `workers` caps the threads of the local backend; `address` is the Ray cluster's
    (default: start a local Ray instance). Unreadable run files are set aside and computed
    again (a line on standard error names each). Batches that another process has claimed
    (`runners.store`) are left to it: this call computes the others (the local backend
    claiming each as it starts it), then waits for those, polling every `wait_seconds`, and
    takes over any whose process is gone.

    With `keep_agents`, each run is a batch of its own (or of its family, `families`: runs
    that differ in their budget only, computed as one; or of the runs of a population learner
    that one program runs, `populations`) whose agents are kept beside its
    table (`RunStore.agents_path`; a run is finished once both are there), for runs that
    go on with them (`RunConfig.trained`: an evaluation, `learn=False, greedy=True`), which
    read them from the same directory.
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; allowed: {', '.join(BACKENDS)}")
    if workers is not None:
        if workers < 1:
            raise ValueError(f"workers must be a positive integer; got {workers}")
        threads.set_workers(workers)
    store = RunStore(out_dir, keep_agents)
    for line in store.repair(configs):
        print(line, file=sys.stderr)
    pending = [config for config in configs if not store.finished(config)]
    total, left = _agent_episodes(configs), _agent_episodes(pending)
    queue, computed = populations(families(pending)) if keep_agents else batches(pending), 0
    options = (str(out_dir), keep_agents)
    # the tables of a finished batch are written while the next batch computes
    with tqdm.tqdm(total=total, initial=total - left, desc=description, unit="agent-episode",
                   file=sys.stderr, disable=None, smoothing=0.05) as bar, \
            outputs.BackgroundWriter("lwrl-writer") as writer:
        try:
            while queue:
                queue = [batch for batch in queue if not all(map(store.finished, batch))]
                # the local backend claims each batch as it starts it, leaving the rest to
                # other processes on the directory; Ray starts all it claims at once
                mine = (batch for batch in list(queue)
                        if not all(map(store.finished, batch)) and store.claim(batch))
                finished = (_local(mine, bar.update, *options) if backend == "local"
                            else _ray(list(mine), address, bar.update, *options))
                for batch, (tables, wall_s, cpu_s) in finished:
                    writer.submit(_keep, store, batch, tables, wall_s, cpu_s)
                    computed += len(batch)
                    queue.remove(batch)
                writer.wait()
                if queue:  # claimed by another process: wait for its runs
                    time.sleep(wait_seconds)
        finally:
            try:
                writer.wait()
            finally:
                store.release_all()
    return store.read(configs), computed


def _keep(store: RunStore, batch, tables, wall_s: float, cpu_s: float) -> None:
    """Write a finished batch's tables and records, and what it cost
    (`RunStore.record_compute`), then release its claim."""
    for config, (table, run_records) in zip(batch, tables):
        store.write(config, table, run_records)
    store.record_compute(batch, wall_s, cpu_s)
    store.release(batch)


def write_configs(configs, path: str) -> None:
    """Every run's full configuration, one JSON object per line, with its key."""
    with outputs.atomic_write(path) as file:
        for config in configs:
            file.write(config_line(config))


def config_line(config) -> str:
    """A run's line of `write_configs`: its full configuration as one JSON object, with its
    key."""
    return json.dumps({"run": config.key, **dataclasses.asdict(config)}) + "\n"
