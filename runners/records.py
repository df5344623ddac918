"""What a run records beside its episodes: what its training cost, timed and counted, and
where it was computed. One table per run, `runs/records/<key>.csv.gz` (`RunStore.write`,
before the run's table), a row per agent; the run's table `runs/<key>.csv.gz` stays its
results alone, the same bytes whenever it is computed again:

| column | what it is |
|---|---|
| `run`, `agent`, `seed` | as in the run's table |
| `steps` | the environment steps the agent took in the run |
| `cpu_s` | its share of the CPU seconds of training: the run's batch's CPU / `cpu_shared_by` |
| `cpu_shared_by` | the agents that shared that CPU: the batch's |
| `multiply_adds`, `transcendentals` | its counted arithmetic over its `steps` (`Learner.arithmetic`); empty where the learner has no count |
| `lwrl_version`, `lwrl_commit` | the package that ran it, and the commit of its checkout (`commit`) |
| `host_cpu` | the CPU it ran on (`runners.store.cpu`) |
| `python`, `libraries` | Python's version, and those of the libraries its numbers depend on that the process had imported (`LIBRARIES`) |

**The CPU of training** is the `time.process_time` of the process that ran the batch (every
thread of it: numba's, XLA's), from the start of its learning loop to the run's end, the
writing of its checkpoints' tables and agents apart, and with what earlier processes spent on
a population run that went on from its kept state (`runners.resume`). It includes the
loop's compilation (a few seconds, once per process and shape) and, on the local backend, the
writing of the previous batch's tables that overlaps it (milliseconds a table). Greedy
evaluations are runs of their own (`RunConfig.trained`) with records of their own: their
CPU is never a training's.

**Each agent's share.** A batch's agents train together, in one numba loop over its agents
or one JAX program over a population, and its CPU is measured once: each agent's share is
that CPU divided by the batch's agents, all of which step to the same budget (a JAX
population steps every agent at every step, those that have stopped included). A family of
budgets computed as one run (`runners.sweep.families`) records at each checkpoint the CPU
spent up to it: the run given the smaller budget names what it cost to get there, the longer
one what it cost in all (each checkpoint adds a chunk run twice,
`runners.population.run_population`).

**The counted arithmetic** of an agent that took `steps` steps is its learner's count per
agent-step of learning times `steps` (`Learner.arithmetic(settings, task, steps)`: its
updates averaged over those steps, as over a run from the start), or per greedy decision
times `steps` for a run that does not learn.

The table's Table Schema is `runners/schemas/records.json` (`runners.table_schema`).

**Not recorded is not zero.** A run written before the records were (the second benchmark's,
`docs/benchmark2`), or a learner without counts, reads as missing values (`read`), never as
0.
"""

import contextlib
import functools
import importlib.metadata
import pathlib
import platform
import subprocess
import sys
import time

import numpy as np
import pandas as pd

import lwrl
from lwrl import agent as learners, outputs
from lwrl.agent.arithmetic import NotCounted
from lwrl.runners.store import RunStore, cpu

COLUMNS = ("run", "agent", "seed", "steps", "cpu_s", "cpu_shared_by", "multiply_adds",
           "transcendentals", "lwrl_version", "lwrl_commit", "host_cpu", "python", "libraries")
"""The records' columns, in order (the module's table says what each is)."""
LIBRARIES = {"numpy": "numpy", "numba": "numba", "scipy": "scipy", "jax": "jax",
             "jaxlib": "jaxlib", "optax": "optax", "mujoco": "mujoco", "torch": "torch",
             "stable_baselines3": "stable-baselines3", "pandas": "pandas"}
"""`{module: distribution}`: the libraries whose versions a run records where its process
imported them (the compiled loops', the JAX programs', the plants', the deep learners')."""
UNKNOWN = "unknown"
"""The commit of a package that does not run from a git checkout (a wheel)."""


class TrainingClock:
    """The CPU seconds (`time.process_time`) of this process since it was made, less what
    was spent inside `aside` blocks (a checkpoint's writing)."""

    def __init__(self):
        self._started = time.process_time()
        self._aside = 0.0

    def seconds(self) -> float:
        """The CPU seconds of training so far."""
        return time.process_time() - self._started - self._aside

    @contextlib.contextmanager
    def aside(self):
        """A block whose CPU is not training's."""
        started = time.process_time()
        try:
            yield
        finally:
            self._aside += time.process_time() - started


SOURCES = ("*.py", "*.toml", "*.xml", "*.c", "*.h", "*.in")
"""The files of a checkout that make lwrl (its code, models, templates and build), those
`commit` checks against the commit: not the outputs a study writes into the checkout."""


@functools.cache
def commit() -> str:
    """The git commit lwrl runs from, where it runs from a checkout (the directory above the
    package holds `.git`), `+modified` after it where its `SOURCES` there differ from it
    (changed, or new and not ignored); `UNKNOWN` elsewhere (a wheel, no git). Read once per
    process: the code it runs was read as it was imported."""
    root = pathlib.Path(lwrl.__file__).resolve().parent.parent
    if not (root / ".git").exists():
        return UNKNOWN
    try:
        head, changed = (subprocess.run(["git", "-C", str(root), *command], capture_output=True,
                                        text=True, check=True).stdout.strip()
                         for command in (["rev-parse", "HEAD"],
                                         ["status", "--porcelain", "--untracked-files=all",
                                          "--", *SOURCES]))
    except (OSError, subprocess.CalledProcessError):
        return UNKNOWN
    return head + ("+modified" if changed else "")


def libraries() -> str:
    """`name version; ...` of the `LIBRARIES` this process has imported, in `LIBRARIES`'
    order."""
    found = []
    for module, distribution in LIBRARIES.items():
        if module in sys.modules:
            try:
                found.append(f"{distribution} {importlib.metadata.version(distribution)}")
            except importlib.metadata.PackageNotFoundError:
                version = getattr(sys.modules[module], "__version__", UNKNOWN)
                found.append(f"{distribution} {version}")
    return "; ".join(found)


def provenance() -> dict:
    """Where a run is computed: lwrl's version and commit, the CPU, Python's and the
    imported libraries' versions (the records' last columns)."""
    return {"lwrl_version": lwrl.__version__, "lwrl_commit": commit(), "host_cpu": cpu(),
            "python": platform.python_version(), "libraries": libraries()}


def counted(config, steps) -> tuple:
    """`(multiply_adds, transcendentals)`, one value per agent of `config` that took
    `steps[b]` steps (see the module); NaN for every agent where its learner has no count of
    these settings (`Learner.arithmetic` None, or `NotCounted`)."""
    steps = np.asarray(steps, dtype=float)
    arithmetic = learners.learner(config.learner).arithmetic
    try:
        if arithmetic is None:
            raise NotCounted(f"{config.learner} has no count")
        counts = [arithmetic(config.settings, config.task_spec, int(taken)) for taken in steps]
    except NotCounted:
        return np.full(len(steps), np.nan), np.full(len(steps), np.nan)
    each = [count.step if config.learn else count.decision for count in counts]
    return (np.array([count.macs for count in each]) * steps,
            np.array([count.exps for count in each]) * steps)


def table(config, results, cpu_s: float, shared_by: int) -> pd.DataFrame:
    """The records of the run `config` that ended with `results` (`EpisodeResults`) after
    `cpu_s` CPU seconds of training of a batch of `shared_by` agents (see the module)."""
    steps = np.nansum(results.steps, axis=1)
    macs, exps = counted(config, steps)
    return pd.DataFrame({"run": config.key, "agent": np.arange(config.agents),
                         "seed": config.seeds, "steps": steps.astype(np.int64),
                         "cpu_s": cpu_s / shared_by, "cpu_shared_by": shared_by,
                         "multiply_adds": macs, "transcendentals": exps,
                         **provenance()}, columns=list(COLUMNS))


def read(out_dir, configs) -> pd.DataFrame:
    """The records of the runs `configs` of the sweep in `out_dir`, one after the other, with
    `recorded` True; a run without them (written before runs recorded them) gives a row per
    agent with its `run`, `agent` and `seed`, every record missing (NaN, never 0) and
    `recorded` False."""
    tables = []
    for config in configs:
        path = RunStore.records_file(out_dir, config.key)
        if path.exists():
            tables.append(outputs.read_table(path).assign(recorded=True))
        else:
            tables.append(pd.DataFrame({"run": config.key, "agent": np.arange(config.agents),
                                        "seed": config.seeds}).reindex(columns=list(COLUMNS))
                          .assign(recorded=False))
    return pd.concat(tables, ignore_index=True)
