"""What each learner costs: CPU per agent-step of the JAX population learners (`ppo_jax`,
`dqn_jax`, `sac_jax`, `td3_jax`) against their Stable-Baselines3 twins (`ppo`, `dqn`, `sac`,
`td3`: the pairs of `PAIRS`), their compile time, and for every learner of the registry the
counted arithmetic of one greedy decision and one agent-step of learning beside the time
measured.

Workload (`FULL`): the pendulum swing-up (`pendulum.swingup`, analytic plant) cut at a
`time_limit` of 10.24 s, 512 steps: the task has no terminal state, so every agent takes
512 steps an episode and 1024 in its 2 episodes (exactly one chunk of the population
program, `runners.population.CHUNK`, so no scanned step is spent on finished agents), with
each pair's kind of action (`Learner.actions`): discrete for PPO and DQN, continuous (the
torque itself) for SAC and TD3. The twins of a pair take the same settings
(`Workload.settings`): PPO with rollouts of 512 (one rollout an episode: two updates per
agent), 10 epochs of minibatches of 64, MLP 64,64; DQN with SB3's defaults but MLP 64,64, a
replay buffer of 50 000 and learning from step 100; SAC and TD3 likewise, their defaults
(SB3's and rl-baselines3-zoo's Pendulum-v1 sets: a minibatch of 256, one gradient step every
step; the learners' as the implementations study and `lwrl train` run them) but MLP 64,64,
a replay buffer of 50 000 and learning from step 100 (TD3's default waits 10 000 steps,
longer than the run); `timesteps` 100 000 for all, so that every agent learns throughout
the run. Agent b has seed b.

One run of this script measures:

1. **CPU per agent-step**, `time.process_time()` (every thread of the process) over a whole
   `runners.run.run(config)` from new agents, divided by its agent-steps (the sum of
   `results.steps`), and its wall time likewise. Each measurement repeats the run until
   `--seconds` of wall time have passed (at least `MIN_RUNS` runs; one for a batch of
   SB3's agents, whose run lasts from half a minute to minutes, SAC's and TD3's the longest
   with a gradient step every agent-step) and reports the median over the runs; the JAX
   learners' first run compiles (the program is cached in the process by its shape,
   `runners.population._CHUNKS`) and is not timed. SB3's learners (one model per
   agent, stepped one after another, torch on one thread) at 1, 16 and 64 agents, after an
   untimed warm-up run of one agent; the JAX learners at 1, 16 and 64 agents, under two
   conditions (3.).
2. **Greedy decisions**: the same at 16 agents with `learn=False, greedy=True` (an
   evaluation: no update, the greedy action), one thread.
3. **One thread against both cores** (JAX): every JAX measurement runs in a subprocess of
   this script (`--worker`), one per condition, whose environment is set before JAX is
   imported. *One thread*: `XLA_FLAGS="--xla_cpu_multi_thread_eigen=false
   intra_op_parallelism_threads=1"` and the process pinned to one core
   (`os.sched_setaffinity`), because the flag alone does not keep XLA on one thread: with
   it, and without it, XLA's CPU client runs the program on two `tf_XLAEigen` threads,
   both running at once a fifth to a third of the time (measured at 64 `ppo_jax` agents
   while writing this benchmark); pinned, XLA starts one such thread. *Both cores*: neither. The
   script checks the condition it got: how many XLA threads the process has, the busiest
   thread's share of the process's CPU time (from `/proc/self/task`), and, over one extra
   run of the largest batch, how often two XLA threads were running at once (sampled every
   2 ms). SB3's learners are one thread by construction (lwrl sets torch to one thread,
   `agent.stable_baselines.torch_modules`), measured in this process; the busiest-thread
   share checks that too. The compiled learners (the table of 5.) run in this process with
   lwrl's loop on one worker thread (`agent.threads.set_workers(1)`).
4. **Compile time** of each JAX learner: the first run's wall time minus the second's
   (the same work), with how many XLA programs the first run compiled (JAX's
   `/jax/core/compile/backend_compile_duration` events: the population program and the
   small programs of the eager operations around it) and whether any later run compiled
   again (it must not). JAX's persistent compilation cache is off unless `--cached`, which
   turns it on in the workers (`LWRL_JAX_CACHE=1`, `runners.population.JAX_CACHE`; then a
   later process loads the program from lwrl's cache and the "compile" is a load).
5. **Counted arithmetic** of every learner of the registry (`lwrl.agent.LEARNERS`), on the
   benchmark's settings (the twins) or its task's defaults (the others, on the workload's
   task where they fit it, else on the first task of the suite they fit): multiply-adds
   (MACs) and exponentials (exp, tanh, log and cos count one each) of one greedy decision
   and of one agent-step of learning (its action and its share of the updates, amortised
   over the measured run), from the shapes, as each learner declares them
   (`Learner.arithmetic`, in its module, from what `agent.arithmetic` shares, each
   function citing what it counts): the NRBF grid, the MLPs' layers, the replay ratio,
   epochs and minibatches. A learner that declares no counts (`arithmetic` None), or whose
   settings its counts do not cover (CMAC features), is "not counted". Beside each
   count: the CPU time per agent-step measured at 16 agents on one thread and the ns per
   counted MAC (which includes the plant's step and the loop, not counted).

Ratios are of times measured in the same run of this script; the machine's load average is
printed with every measurement, since other jobs change what the figures mean (CPU time
less than wall time). The aims (from the issue, `AIMS`): `ppo_jax` at most 1/20 of SB3 PPO's
CPU per agent-step at 16 agents, `dqn_jax` at most 1/4 of SB3 DQN's; SAC and TD3 have none.

Run from the repository root (the JAX part needs the `jax` extra, the SB3 part the
`baselines` extra; either part is skipped, saying so, without its extra):

    python -m benchmarks.deep_speed            # 10-20 minutes on two loaded cores for PPO
                                               # and DQN, SAC and TD3 beyond that
    python -m benchmarks.deep_speed --quick    # smoke test: tiny networks and episodes
    python -m benchmarks.deep_speed --learners ppo ppo_jax   # these measured, all counted
"""

import argparse
import contextlib
import dataclasses
import json
import os
import pathlib
import platform
import statistics
import subprocess
import sys
import threading
import time

import numpy as np

from benchmarks.agent_speed import cpu_model, plural
from lwrl import agent as learners
from lwrl import tasks
from lwrl.agent.arithmetic import Counts, NotCounted
from lwrl.agent.threads import set_workers, workers
from lwrl.runners import population
from lwrl.runners.config import RunConfig, task_spec
from lwrl.runners.run import run

ROOT = pathlib.Path(__file__).resolve().parents[1]
TASK = "pendulum.swingup"
"""The workload's task: no terminal state, so every agent takes as many steps."""
PAIRS = {"ppo": "ppo_jax", "dqn": "dqn_jax", "sac": "sac_jax", "td3": "td3_jax"}
"""Each SB3 learner and its JAX twin."""
AIMS = {"ppo": 20, "dqn": 4}
"""The issue's aims: the twin at most 1/N of the SB3 learner's CPU per agent-step."""
FAMILY = {**{sb3: sb3 for sb3 in PAIRS}, **{twin: sb3 for sb3, twin in PAIRS.items()}}
"""Which settings (`Workload.settings`) each learner of a pair takes."""
ONE_THREAD_FLAGS = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
CONDITIONS = ("one", "both")
"""One thread, both cores (module docstring, 3.)."""
MIN_RUNS = 2
"""Timed runs of a measurement at least (after the untimed first of the JAX learners)."""
MAX_RUNS = 40
"""Timed runs of a measurement at most."""
SAMPLE_PERIOD = 0.002
"""Seconds between two samples of the running XLA threads."""


@dataclasses.dataclass(frozen=True)
class Workload:
    """What is run: the episodes, the batch sizes and the twins' settings."""

    time_limit: float
    """Seconds of an episode of `TASK` (50 steps a second)."""
    episodes: int
    agents: tuple
    reference: int
    """The batch size of the aims, the greedy runs and the counted-arithmetic table."""
    settings: dict
    """`{family: {setting: value}}`, the twins' settings."""
    other_episodes: int
    """Episodes per agent of a learner measured on another task than `TASK` (they end on
    terminal states there)."""


REPLAY = dict(buffer_size=50_000, learning_starts=100, net_arch="64,64", timesteps=100_000)
"""The off-policy learners' settings (DQN, SAC, TD3): the rest their defaults."""
QUICK_REPLAY = dict(buffer_size=64, learning_starts=2, batch_size=4, net_arch="8", timesteps=1000)
FULL = Workload(time_limit=10.24, episodes=2, agents=(1, 16, 64), reference=16, settings={
    "ppo": dict(n_steps=512, batch_size=64, n_epochs=10, net_arch="64,64", timesteps=100_000),
    "dqn": REPLAY, "sac": REPLAY, "td3": REPLAY}, other_episodes=20)
QUICK = Workload(time_limit=0.16, episodes=2, agents=(1, 2), reference=2, settings={
    "ppo": dict(n_steps=8, batch_size=4, n_epochs=2, net_arch="8", timesteps=1000),
    "dqn": QUICK_REPLAY, "sac": QUICK_REPLAY, "td3": QUICK_REPLAY}, other_episodes=2)
QUICK_SECONDS = 0.05
"""Time budget per measurement with `--quick`."""


# --- Counted arithmetic ----------------------------------------------------------------------

def counted(learner, settings, task, steps: int | None = None) -> Counts | str:
    """The counts `learner` declares (`Learner.arithmetic`) with `settings` on `task`
    (`TaskSpec`), its updates amortised over `steps` steps of learning per agent; "not
    counted" with the reason for a learner without counts (its `arithmetic` None) or
    settings it does not count (`NotCounted`)."""
    if learner.arithmetic is None:
        return f"not counted ({learner.name} declares no counts)"
    try:
        return learner.arithmetic(settings, task, steps)
    except NotCounted as reason:
        return f"not counted ({reason})"


# --- Configurations --------------------------------------------------------------------------

def home_task(name: str) -> str | None:
    """The task a learner is measured on: `TASK` where it fits, else the suite's first task
    it fits (None: none)."""
    learner = learners.learner(name)
    for task in (TASK, *(f"{domain}.{task}" for domain, task in tasks.ALL_TASKS)):
        if learner.fits(task_spec(task, actions=learner.actions)) is None:
            return task
    return None


def config_of(name: str, agents: int, workload: Workload) -> RunConfig:
    """The run of `agents` agents of learner `name`: the twins on the workload with its
    settings, the others with their task's defaults."""
    task = home_task(name)
    options = {"time_limit": workload.time_limit} if task == TASK else {}
    episodes = workload.episodes if task == TASK else workload.other_episodes
    settings = {}
    if name in FAMILY:
        settings["settings"] = learners.learner(name).settings(**workload.settings[FAMILY[name]])
    return RunConfig(task=task, learner=name, agents=agents, episodes=episodes, seed=0,
                     plant="analytic", task_options=options,
                     actions=learners.learner(name).actions, **settings)


def episode_steps(workload: Workload) -> int:
    """Steps of an episode of `TASK` cut at the workload's time limit."""
    return int(tasks.definition(*tasks.split_name(TASK), time_limit=workload.time_limit).step_limit)


def skip_reason(name: str) -> str | None:
    """Why learner `name` is not measured here (a missing extra, no task it fits), or None."""
    learner = learners.learner(name)
    if home_task(name) is None:
        return learner.fits(task_spec(TASK, actions=learner.actions))
    return learner.unavailable()


# --- Measuring -------------------------------------------------------------------------------

def thread_cpu() -> dict:
    """`{thread id: (name, CPU seconds)}` of this process's threads (Linux; else empty)."""
    threads = {}
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    try:
        ids = os.listdir("/proc/self/task")
    except OSError:
        return threads
    for tid in ids:
        try:
            with open(f"/proc/self/task/{tid}/stat") as stat:
                fields = stat.read().rsplit(")", 1)[1].split()
            with open(f"/proc/self/task/{tid}/comm") as comm:
                name = comm.read().strip()
        except OSError:
            continue
        threads[tid] = (name, (int(fields[11]) + int(fields[12])) / tick)
    return threads


def busiest_share(before: dict, after: dict) -> float | None:
    """The busiest thread's share of the CPU time the threads took between two
    `thread_cpu` snapshots (None where unknown or too little to tell)."""
    spent = [seconds - before.get(tid, (None, 0.0))[1] for tid, (_, seconds) in after.items()]
    total = sum(spent)
    return max(spent) / total if spent and total >= 0.05 else None


def xla_threads() -> list:
    """The ids of this process's XLA worker threads (named `tf_XLA...`)."""
    return [tid for tid, (name, _) in thread_cpu().items() if name.startswith("tf_XLA")]


class Sampler:
    """Within: every `SAMPLE_PERIOD` s, how many XLA threads are running (state R)."""

    def __init__(self):
        self.samples, self.stop = [], threading.Event()

    def _sample(self) -> None:
        while not self.stop.is_set():
            running = 0
            for tid in xla_threads():
                try:
                    with open(f"/proc/self/task/{tid}/stat") as stat:
                        running += stat.read().rsplit(")", 1)[1].split()[0] == "R"
                except OSError:
                    pass
            self.samples.append(running)
            time.sleep(SAMPLE_PERIOD)

    def __enter__(self):
        self.thread = threading.Thread(target=self._sample, daemon=True)
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()

    def concurrent(self) -> float | None:
        """The fraction of samples with at least two XLA threads running."""
        return sum(s >= 2 for s in self.samples) / len(self.samples) if self.samples else None


@dataclasses.dataclass
class Measurement:
    """Timed runs of one learner, batch size, condition and mode, and what was checked."""

    learner: str
    agents: int
    condition: str
    """`one` (one thread) or `both` (both cores)."""
    greedy: bool
    task: str
    steps: list = dataclasses.field(default_factory=list)
    walls: list = dataclasses.field(default_factory=list)
    cpus: list = dataclasses.field(default_factory=list)
    loads: list = dataclasses.field(default_factory=list)
    """The 1-minute load average at the start of each timed run."""
    busiest: float | None = None
    """The busiest thread's share of the CPU time over the timed runs."""
    first_wall: float | None = None
    """The untimed first run's wall time (the JAX learners: it compiles)."""
    compiles: int = 0
    """XLA programs compiled (or loaded) in the first run."""
    compile_seconds: float = 0.0
    cache_hits: int = 0
    recompiles: int = 0
    """XLA programs compiled in the timed runs (must be 0)."""
    chunks_added: int = 0
    """Population programs the first run added to `runners.population._CHUNKS`."""
    xla_threads: int | None = None
    concurrent: float | None = None
    """Fraction of samples, over one extra run, with two XLA threads running at once."""
    pinned: int | None = None
    """The core the process was pinned to (one thread), or None."""

    @property
    def cpu_per_step(self) -> float:
        return statistics.median(c / s for c, s in zip(self.cpus, self.steps))

    @property
    def wall_per_step(self) -> float:
        return statistics.median(w / s for w, s in zip(self.walls, self.steps))

    def timed(self, config: RunConfig) -> None:
        """One timed run of `config`, from new agents."""
        self.loads.append(os.getloadavg()[0])
        wall, cpu = time.perf_counter(), time.process_time()
        _, results = run(config, learn=not self.greedy, greedy=self.greedy)
        self.walls.append(time.perf_counter() - wall)
        self.cpus.append(time.process_time() - cpu)
        self.steps.append(int(np.nansum(results.steps)))

    def repeat(self, config: RunConfig, seconds: float, min_runs: int = MIN_RUNS) -> None:
        """Timed runs until `seconds` of wall time (`min_runs` to `MAX_RUNS` runs)."""
        before = thread_cpu()
        while len(self.walls) < min_runs or (sum(self.walls) < seconds
                                             and len(self.walls) < MAX_RUNS):
            self.timed(config)
        self.busiest = busiest_share(before, thread_cpu())


@contextlib.contextmanager
def one_thread():
    """Within: lwrl's loops run a batch on one thread (`agent.threads.set_workers`)."""
    before = workers()
    set_workers(1)
    try:
        yield
    finally:
        set_workers(before)


def measure_here(name: str, agents: int, workload: Workload, seconds: float,
                 greedy: bool = False, warm_up: bool = False) -> Measurement:
    """A measurement in this process on one thread (SB3's learners, whose torch has one
    thread; the compiled learners, whose loop gets one worker thread): timed runs for
    `seconds`, at least `MIN_RUNS` of one agent and one of a batch (whose runs are long:
    SB3's agents step one after another); `warm_up` runs one agent in the same mode first,
    untimed (imports, compiled kernels)."""
    config = config_of(name, agents, workload)
    measurement = Measurement(name, agents, "one", greedy, config.task)
    with one_thread():
        if warm_up:
            start = time.perf_counter()
            run(config_of(name, 1, workload), learn=not greedy, greedy=greedy)
            measurement.first_wall = time.perf_counter() - start
        measurement.repeat(config, seconds, MIN_RUNS if agents == 1 else 1)
    return measurement


# --- The JAX worker (a subprocess per condition) ---------------------------------------------

def worker(spec: dict) -> None:
    """Run `spec`'s JAX jobs under its condition; one JSON line per measurement on stdout."""
    pinned = None
    if spec["condition"] == "one" and hasattr(os, "sched_setaffinity"):
        pinned = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {pinned})  # before JAX starts its threads
    late = "jax" in sys.modules
    import jax
    import jax.monitoring

    if late:
        print("deep_speed worker: JAX was imported before the condition was set", file=sys.stderr)
    if not spec["cached"]:
        jax.config.update("jax_enable_compilation_cache", False)
    events = {"compiles": 0, "seconds": 0.0, "hits": 0}

    def on_duration(event, seconds, **_):
        if event == "/jax/core/compile/backend_compile_duration":
            events["compiles"] += 1
            events["seconds"] += seconds

    def on_event(event, **_):
        if event == "/jax/compilation_cache/cache_hits":
            events["hits"] += 1

    jax.monitoring.register_event_duration_secs_listener(on_duration)
    jax.monitoring.register_event_listener(on_event)
    workload = QUICK if spec["quick"] else FULL
    for job in spec["jobs"]:
        config = config_of(job["learner"], job["agents"], workload)
        m = Measurement(job["learner"], job["agents"], spec["condition"], job["greedy"],
                        config.task, pinned=pinned)
        chunks, before = len(population._CHUNKS), dict(events)
        start = time.perf_counter()
        run(config, learn=not m.greedy, greedy=m.greedy)
        m.first_wall = time.perf_counter() - start
        m.compiles = events["compiles"] - before["compiles"]
        m.compile_seconds = events["seconds"] - before["seconds"]
        m.cache_hits = events["hits"] - before["hits"]
        m.chunks_added = len(population._CHUNKS) - chunks
        compiled = events["compiles"]
        m.repeat(config, spec["seconds"])
        m.recompiles = events["compiles"] - compiled
        m.xla_threads = len(xla_threads())
        if job.get("sample"):
            with Sampler() as sampler:
                run(config, learn=not m.greedy, greedy=m.greedy)
            m.concurrent = sampler.concurrent()
        print(json.dumps(dataclasses.asdict(m)), flush=True)
        mode = ", greedy" if m.greedy else ""
        print(f"deep_speed: {m.learner} x {m.agents} ({m.condition}{mode}) "
              f"{1e6 * m.cpu_per_step:,.1f} us CPU per agent-step", file=sys.stderr, flush=True)


def run_worker(condition: str, jobs: list, quick: bool, seconds: float, cached: bool) -> list:
    """The measurements of `jobs` in a subprocess under `condition`."""
    env = dict(os.environ)
    env.pop("XLA_FLAGS", None)
    if condition == "one":
        env["XLA_FLAGS"] = ONE_THREAD_FLAGS
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    env.pop(population.JAX_CACHE, None)
    if cached:
        env[population.JAX_CACHE] = "1"
    spec = {"condition": condition, "jobs": jobs, "quick": quick, "seconds": seconds,
            "cached": cached}
    done = subprocess.run([sys.executable, "-m", "benchmarks.deep_speed", "--worker",
                           json.dumps(spec)], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                          text=True, check=True)
    return [Measurement(**json.loads(line)) for line in done.stdout.splitlines()
            if line.startswith("{")]


# --- Output ----------------------------------------------------------------------------------

def us(seconds: float) -> str:
    """Microseconds, with a decimal below 100."""
    value = 1e6 * seconds
    return f"{value:,.1f}" if value < 100 else f"{value:,.0f}"


def cell(m: Measurement | None) -> str:
    """CPU µs per agent-step (wall µs)."""
    return "—" if m is None else f"{us(m.cpu_per_step)} ({us(m.wall_per_step)})"


def ratio(sb3: Measurement | None, twin: Measurement | None) -> str:
    return "—" if sb3 is None or twin is None else f"{sb3.cpu_per_step / twin.cpu_per_step:,.1f}"


def share(value: float | None) -> str:
    return "n/a" if value is None else f"{100 * value:.0f} %"


def run_line(m: Measurement) -> str:
    """What one measurement ran, and the load average then."""
    low, high = min(m.loads), max(m.loads)
    loads = f"{low:.2f}" if round(low, 2) == round(high, 2) else f"{low:.2f} to {high:.2f}"
    condition = "one thread" if m.condition == "one" else "both cores"
    mode = "greedy, no learning" if m.greedy else "learning"
    return (f"- {m.learner} x {m.agents} on {m.task} ({condition}, {mode}): "
            f"{plural(len(m.walls), 'timed run')} of {m.steps[0]:,} agent-steps, "
            f"median {us(m.cpu_per_step)} us CPU / {us(m.wall_per_step)} us wall per "
            f"agent-step; busiest thread {share(m.busiest)} of the CPU; load average "
            f"(1 min) at the runs' start {loads}")


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="CPU per agent-step of the JAX learners (ppo_jax, dqn_jax, sac_jax, "
                    "td3_jax) against SB3's PPO, DQN, SAC and TD3 (1, 16, 64 agents; one "
                    "thread and both cores), their compile time, and "
                    "every learner's counted arithmetic beside its measured time; prints "
                    "Markdown tables.")
    parser.add_argument("--seconds", type=float, default=3.0,
                        help="wall time per JAX measurement and per one-agent measurement "
                             "(at least 2 timed runs each; default: 3)")
    parser.add_argument("--quick", action="store_true",
                        help="smoke test: tiny networks and episodes, 1 and 2 agents")
    parser.add_argument("--cached", action="store_true",
                        help="let JAX load programs from lwrl's persistent compilation cache "
                             "(then the compile times are load times)")
    parser.add_argument("--conditions", nargs="+", choices=CONDITIONS, default=list(CONDITIONS),
                        metavar="CONDITION",
                        help="the JAX learners' conditions measured: one (one thread) and "
                             "both (both cores); default: both of them")
    parser.add_argument("--learners", nargs="+", choices=learners.LEARNER_NAMES,
                        default=list(learners.LEARNER_NAMES), metavar="LEARNER",
                        help="the learners measured (every learner's arithmetic is counted "
                             "all the same); default: every learner of the registry")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if not args.seconds > 0:
        parser.error(f"--seconds must be positive; got {args.seconds}")
    if args.quick:
        args.seconds = QUICK_SECONDS
    return args


def main(argv=None) -> None:
    args = parse_args(argv)
    if args.worker:
        worker(json.loads(args.worker))
        return
    script_start = time.perf_counter()
    workload = QUICK if args.quick else FULL
    reference = workload.reference
    command = "python -m benchmarks.deep_speed " + " ".join(sys.argv[1:] if argv is None else argv)
    header = [f"Command: `{command.strip()}`",
              f"Host: platform.processor() {platform.processor()!r} ({platform.machine()}), "
              f"CPU {cpu_model()}, "
              f"os.cpu_count() {os.cpu_count()}; load average at the start "
              f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}"]
    names = list(learners.LEARNERS)
    skipped = {name: skip_reason(name) for name in names}
    skipped = {name: reason for name, reason in skipped.items() if reason}
    measured: dict = {}  # (learner, agents, condition, greedy) -> Measurement

    # 1. The JAX learners, one subprocess per condition.
    timed = [name for name in names if name in args.learners and name not in skipped]
    population = [name for name in timed if learners.learner(name).population]
    if population:
        for condition in args.conditions:
            jobs = []
            for name in population:
                sizes = workload.agents if name in FAMILY else (reference,)
                jobs += [{"learner": name, "agents": agents, "greedy": False,
                          "sample": agents == max(sizes)} for agents in sizes]
                if condition == "one":
                    jobs.append({"learner": name, "agents": reference, "greedy": True})
            for m in run_worker(condition, jobs, args.quick, args.seconds, args.cached):
                measured[(m.learner, m.agents, m.condition, m.greedy)] = m

    # 2. The others in this process: SB3's learners (one thread), the compiled ones.
    for name in timed:
        if learners.learner(name).population:
            continue
        sizes = workload.agents if name in FAMILY else (reference,)
        for index, agents in enumerate(sizes):
            m = measure_here(name, agents, workload, args.seconds, warm_up=index == 0)
            measured[(name, agents, "one", False)] = m
            print(f"deep_speed: {name} x {agents} {1e6 * m.cpu_per_step:,.1f} us CPU per "
                  "agent-step", file=sys.stderr, flush=True)
        measured[(name, reference, "one", True)] = measure_here(
            name, reference, workload, args.seconds, greedy=True, warm_up=True)

    get = lambda *key: measured.get(key)
    print("\n".join(header))
    print(f"\nWorkload: {TASK}, analytic plant, time_limit {workload.time_limit:g} s "
          f"({episode_steps(workload)} steps an episode, no terminal state), "
          f"{workload.episodes} episodes per agent, agent b with seed b. Settings of both "
          "twins:")
    for sb3, twin in PAIRS.items():
        settings = learners.learner(sb3).settings(**workload.settings[sb3])
        print(f"- {sb3} and {twin}: {settings.describe(2)}")
    for name, reason in skipped.items():
        print(f"- {name}: skipped: {reason}")
    unlisted = [name for name in names if name not in args.learners]
    if unlisted:
        print(f"- not measured (not among --learners), counted only: {', '.join(unlisted)}")

    print("\n## CPU per agent-step\n")
    print("Median over the timed runs of CPU time (all threads) per agent-step, in µs, wall "
          "time in parentheses; SB3's learners are one thread by construction (torch on one "
          "thread), so one measurement stands for both conditions.\n")
    for sb3, twin in PAIRS.items():
        print(f"| agents | {sb3} (SB3, one thread) | {twin}, one thread | {twin}, both cores "
              f"| {sb3} / {twin} CPU, one thread | {sb3} / {twin} CPU, both cores |")
        print("|---:|---:|---:|---:|---:|---:|")
        for agents in workload.agents:
            a, one, both = (get(sb3, agents, "one", False), get(twin, agents, "one", False),
                            get(twin, agents, "both", False))
            print(f"| {agents} | {cell(a)} | {cell(one)} | {cell(both)} | {ratio(a, one)} | "
                  f"{ratio(a, both)} |")
        print()

    print(f"## Aims, at {reference} agents (CPU per agent-step)\n")
    for sb3, aim in AIMS.items():
        twin = PAIRS[sb3]
        for condition, label in (("one", "one thread"), ("both", "both cores")):
            a, b = get(sb3, reference, "one", False), get(twin, reference, condition, False)
            if a is None or b is None:
                reason = (skipped.get(sb3) or skipped.get(twin)
                          or ("not among --learners" if {sb3, twin} - set(args.learners)
                              else "not among --conditions" if condition not in args.conditions
                              else "missing"))
                print(f"- {twin} at most 1/{aim} of {sb3}'s, {label}: not measured ({reason})")
                continue
            factor = a.cpu_per_step / b.cpu_per_step
            verdict = "met" if factor >= aim else "not met"
            print(f"- {twin} at most 1/{aim} of {sb3}'s, {label}: {us(b.cpu_per_step)} µs "
                  f"against {us(a.cpu_per_step)} µs, 1/{factor:,.1f}: **{verdict}**")

    jax_runs = [m for m in measured.values() if learners.learner(m.learner).population]
    if jax_runs:
        print("\n## One thread against both cores (JAX)\n")
        for condition in CONDITIONS:
            runs = [m for m in jax_runs if m.condition == condition]
            if not runs:
                continue
            sampled = [m for m in runs if m.concurrent is not None]
            setting = (f"XLA_FLAGS=\"{ONE_THREAD_FLAGS}\", pinned to core {runs[0].pinned}"
                       if condition == "one" else "XLA_FLAGS unset, not pinned")
            busiest = [m.busiest for m in runs if m.busiest is not None]
            print(f"- {'one thread' if condition == 'one' else 'both cores'} ({setting}): "
                  f"{plural(max(m.xla_threads or 0 for m in runs), 'XLA thread')} in the "
                  f"process; the busiest thread's share of the CPU "
                  f"{share(min(busiest) if busiest else None)} to "
                  f"{share(max(busiest) if busiest else None)} over the measurements; "
                  + "; ".join(f"two XLA threads running at once in {share(m.concurrent)} of "
                              f"the samples of a run of {m.agents} {m.learner} agents"
                              for m in sampled))
        wall_cpu = [f"{m.learner} x {m.agents} {m.condition}: CPU / wall "
                    f"{m.cpu_per_step / m.wall_per_step:.2f}"
                    for m in jax_runs if not m.greedy and m.agents == max(workload.agents)]
        if wall_cpu:
            print(f"- CPU time over wall time: {'; '.join(wall_cpu)} (above 1 only where "
                  "threads overlap; other jobs' load pulls it down)")

        print("\n## Compile time (JAX)\n")
        print("| learner | agents | condition | mode | first run, wall s | second run, wall s | "
              "compile = first - second, s | XLA programs in the first run (from the disk "
              "cache), their s | population programs added to `_CHUNKS` | XLA programs compiled "
              "in the later runs |")
        print("|---|---:|---|---|---:|---:|---:|---:|---:|---:|")
        for m in sorted(jax_runs, key=lambda m: (m.learner, m.greedy, m.condition, m.agents)):
            print(f"| {m.learner} | {m.agents} | {m.condition} | "
                  f"{'greedy' if m.greedy else 'learning'} | {m.first_wall:.2f} | "
                  f"{m.walls[0]:.2f} | {m.first_wall - m.walls[0]:.2f} | {m.compiles} "
                  f"({m.cache_hits}), {m.compile_seconds:.1f} | {m.chunks_added} | "
                  f"{m.recompiles} |")

    print(f"\n## Counted arithmetic per agent-step, beside the time measured ({reference} "
          "agents, one thread)\n")
    print("MACs: multiply-adds; exp: exponentials (exp, tanh, log, cos). A learning agent-step "
          "is its action and its share of the updates, amortised over the measured run; ns "
          "per MAC is the measured CPU time over the counted MACs (the plant's step and the "
          "loop are in the time, not in the count).\n")
    print("| learner | task | greedy decision: MACs | exp | learning agent-step: MACs | exp | "
          "of which updates: MACs | learning: CPU µs per agent-step | ns per MAC | greedy: "
          "CPU µs per agent-step | ns per MAC |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    sources = []
    for name in names:
        task = home_task(name) or TASK
        config = None if name in skipped else config_of(name, reference, workload)
        steps_per_agent = episode_steps(workload) * workload.episodes if task == TASK else None
        counts = (counted(learners.learner(name), config.settings, config.task_spec,
                          steps_per_agent) if config else f"not counted ({skipped[name]})")
        learning, greedy = get(name, reference, "one", False), get(name, reference, "one", True)
        if isinstance(counts, str):
            print(f"| {name} | {task} | {counts} | | | | | {cell(learning)} | | {cell(greedy)} | |")
            continue
        sources.append(f"- {name}: {counts.source}")

        def per_mac(m, count):
            if m is None or not count.macs:
                return "—"
            return f"{1e9 * m.cpu_per_step / count.macs:.3g}"
        print(f"| {name} | {task} | {counts.decision.macs:,.0f} | {counts.decision.exps:,.0f} | "
              f"{counts.step.macs:,.0f} | {counts.step.exps:,.0f} | {counts.update.macs:,.0f} | "
              f"{cell(learning)} | {per_mac(learning, counts.step)} | {cell(greedy)} | "
              f"{per_mac(greedy, counts.decision)} |")
    print("\nWhere the counts come from (each learner's `arithmetic`, from the settings):")
    print("\n".join(sources))

    print("\nRuns measured (each from new agents; the busiest thread's share of the process's "
          "CPU time over them, from /proc/self/task):")
    print("\n".join(run_line(m) for m in measured.values()))
    print(f"\nLoad average at the end {' '.join(f'{x:.2f}' for x in os.getloadavg())}; total "
          f"{time.perf_counter() - script_start:.0f} s.")


if __name__ == "__main__":
    main()
