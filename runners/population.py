"""The third run path: B agents of a population learner (`Learner.population`) and their B
copies of a task, stepped together in one jitted JAX program over the suite's JAX tasks
(`lwrl.jax`), as PureJaxRL trains (Lu et al. 2022, "Discovered policy optimisation").

The loop keeps the other loops' protocol and records: agent b's episodes start where
`runners.episodes.episode_starts` draws them from its seed (the same starts as every other
learner's agent b), each episode's steps, return, up-time and truncation are recorded as
`runners.episodes.finish_episode` records them, an agent stops after K episodes or when
its weights stop being finite (the episode it diverged in cut there). Each agent counts its
own steps (`PopulationAgents.clocks`: its rollout's slots, its schedules, the end of its
learning) and the learner's `update` runs as one branch of the program where `update_due`
says for some agent, applied to those agents only: the batch's agents start together and
step together, so the branch runs once per rollout, not at every step to be discarded.

The JAX tasks step the analytic plant (the domain's equations, traced) or, for a domain with
a MuJoCo model, the mjx plant (`lwrl.jax.mjx`: the model stepped by MJX, MuJoCo's C engine
being out of a JAX program's reach), whose one model is compiled at the run's parameter
values: a run on it whose agents or episodes differ in them is refused in one line.

A learner of continuous actions (`Learner.actions`) runs the tasks made with
`actions="continuous"`: its action in [-1, 1] becomes the command `tasks.commands.commands`
names in the actuator's range at the episode's parameter values (the other loops' arithmetic,
traced by JAX: `lwrl.jax.translate.as_jax`), which the JAX task takes as its control.

Agent b's episode k runs at the physical parameter values the other loops give it: row b
of `params`, with the parameters `randomise` names drawn from its seed and k
(`tasks.randomisation.draws`, computed on the host before the program starts, `(B, K, P)`,
and read by each agent at its current episode, as it reads its starts). Its sensors and
actuator are its own (`lwrl.jax.environment.Sensors`, one row per agent: the noise levels
and delays of a batch joining several runs may differ), with the noise drawn from the
agent's JAX stream, not the numba loops' counter-based streams (`tasks.disturbances`): the
same distributions, other numbers.

A run with a budget can also give, on the way, the runs with smaller budgets
(`checkpoints`): the budget cuts a run without changing what came before it, so the run given
budget b is the longer run's agents as they were after b steps, with the episode that spent
them cut there. The chunk that reaches b is run twice from the same carry, once with budget
b (until every agent has stopped: that run's end, its results and a copy of its agents) and
once with the run's own, which goes on; each checkpoint costs a chunk, not a run from the
start, and its numbers are those of the run with budget b, bit for bit (tested).

The program runs in chunks of `CHUNK` steps, so that progress is reported and a Ctrl-C
stops the run between two chunks with every finished episode kept (`interrupted`). A chunk
is compiled once per process for what shapes it (the task, its plant and options, the longest
action delay of the batch, the learner's batch-wide settings and `shared` values, the
batch's size, the episodes, learning or not), the per-agent settings, physics, noise levels and delays being
its arguments. XLA's compiled code is kept on disk beside lwrl's numba kernels
(`lwrl.kernels.cache_root`, JAX's persistent compilation cache) only where the environment
asks for it, `LWRL_JAX_CACHE=1` (`JAX_CACHE`): writing an entry serialises the executable,
and on this project's CPU hosts (jax 0.10.2) that serialisation has aborted the process
(`Fatal Python error: Aborted` in `compilation_cache.put_executable_and_time`), seen
intermittently under load in the full test suite, never on a rerun of the same program. An
abort is not an exception: nothing can catch it, so a cache write must not be able to end a
run that has not asked for the cache. Without it each process compiles its programs once
(seconds), which a run of hours does not notice. Nor can a process that compiles hundreds
of programs die of the memory they map: before compiling, a crowded process lets its
compiled programs go (`release_when_crowded`, `runners.mappings`).
"""

import dataclasses
import os

import numpy as np

from lwrl import kernels, tasks
from lwrl.runners import mappings
from lwrl.runners.episodes import EpisodeResults, episode_starts, step_budget
from lwrl.runners.resume import Resume
from lwrl.settings import check_count
from lwrl.tasks.commands import check_kinds, commands
from lwrl.tasks.randomisation import check_ranges, draws

CHUNK = 1024
"""Steps of the batch per call of the compiled program."""
STREAM = 0x9E37
"""Added to an agent's seed for the key of its actions and its environment's noise, apart
from the key its learner's state starts from."""


def run_population(domain: str, task: str, agents, episodes: int, seeds, learn: bool = True,
                   greedy: bool = False, progress=None, record=(), plant: str = "analytic",
                   integrator: str = "semi_implicit", equations: str = "paper", params=None,
                   observation_noise=None, action_delay=0, action_noise=0.0, randomise=None,
                   budget=None, checkpoints=None, resume=None, **task_options) -> EpisodeResults:
    """Run `agents` (a population learner's agents, `agent.jax_population.PopulationAgents`)
    for `episodes` episodes each on `domain.task`'s JAX plant, agent b from `seeds[b]`'s
    starts with the physical parameter values of row b of `params` (`{name: value or B
    values}`), those `randomise` names drawn anew for each episode, and the sensor and
    actuator options (`tasks.disturbances.OPTIONS`) of one value for every agent or one per
    agent, as `runners.compiled.run_compiled` takes them; `learn` and `greedy` as for
    `Agents.step`; `budget`: environment steps per agent at most (None: no budget), the
    episode that spends them cut there, truncated, as `run_compiled` cuts it (the learner
    sees that step as it would without the budget, so what came before is the same);
    `checkpoints`: `{smaller budget: call(agents, results)}`, each called with a copy of the
    agents and the results the run with that budget would end with (see the module);
    `resume`: `(path, run key)` where the run keeps its state as it goes and from which a
    later call of the same run goes on (`runners.resume`). A
    one-line ValueError for a bad option and for what the path does not
    run: a plant but those of `lwrl.jax` (`PLANTS`), recordings, and on the mjx plant,
    whose one model is compiled at the run's parameter values, values that differ between
    agents or episodes."""
    import jax.numpy as jnp
    import lwrl.jax as jax_tasks

    episodes = check_count("episodes", episodes, 1)
    name = agents.learner.name
    if plant not in jax_tasks.PLANTS:
        raise ValueError(f"{name} runs on the plants of lwrl.jax: {', '.join(jax_tasks.PLANTS)}; "
                         f"got plant {plant!r}")
    if len(record):
        raise ValueError(f"{name} keeps no recordings: it trains as one JAX program")
    batch = agents.batch_size
    parameters = tasks.domain(domain).parameters
    physical = draws(parameters, check_ranges(parameters, randomise),
                     parameters.values(params, batch), seeds, episodes)
    env_options = dict(plant=plant, integrator=integrator, equations=equations, **task_options)
    if plant == "mjx":  # one model, compiled at the run's values (lwrl.jax.mjx)
        env_options["params"] = dict(zip(parameters.names, physical[0, 0].tolist()))
    env, _ = jax_tasks.make(f"{domain}.{task}", **env_options)
    physical = env.check_params(physical)
    check_kinds(name, agents.learner.actions, env.definition, "run_population")
    sensors = env.sensors(batch, observation_noise=observation_noise, action_delay=action_delay,
                          action_noise=action_noise)
    starts = jnp.asarray(episode_starts(env.definition, seeds, episodes))
    program = agents.trained_program()
    shape = (env.name, repr(sorted(env_options.items())), sensors.max_delay, type(agents),
             agents.dim, agents.action_space, repr(_shared_settings(agents.settings[0])),
             agents.shared(), batch, episodes, CHUNK)
    if shape not in _CHUNKS:
        release_when_crowded()
        _use_disk_cache()
        _CHUNKS[shape] = _compiled_chunk(env, program, episodes, agents.learned_tree,
                                         agents.continuous)
    step = _CHUNKS[shape]
    carry = _first_carry(env, agents, starts, sensors, episodes)
    limit = lambda steps: jnp.asarray(min(steps, np.iinfo(np.int32).max), jnp.int32)
    modes = (jnp.asarray(bool(learn)), jnp.asarray(bool(greedy)))
    chunk = lambda carry, steps: step(carry, program.hyper, physical, starts, sensors, limit(steps),
                                      *modes)
    budget = step_budget(budget)
    pending = sorted(_check_checkpoints(checkpoints or {}, budget))
    kept = None
    if resume is not None:
        path, key = resume
        kept = Resume(path, key, step, carry, (program.hyper, physical, starts, sensors,
                                               limit(budget), *modes))
        resumed = kept.load(carry, pending[0] if pending else None)
        if resumed is not None:
            carry = resumed
            if progress is not None:
                progress(int(np.asarray(carry["done"]).sum()))
    interrupted = False
    try:
        while pending or _any(carry["active"]):
            if pending and _reaches(carry, pending[0]):
                smaller = pending.pop(0)
                checkpoints[smaller](*_ended(agents.snapshot(), _run_out(chunk, carry, smaller),
                                             episodes, kept))
                continue
            before = int(np.asarray(carry["done"]).sum())
            carry = chunk(carry, budget)
            if progress is not None:
                progress(int(np.asarray(carry["done"]).sum()) - before)
            if kept is not None and kept.due():
                kept.keep(carry)
    except KeyboardInterrupt:
        interrupted = True
    _, results = _ended(agents, carry, episodes, kept)
    results.interrupted = interrupted
    if kept is not None:
        kept.keep(carry) if interrupted else kept.remove()
    return results


def _any(active) -> bool:
    return bool(np.any(np.asarray(active)))


def _check_checkpoints(checkpoints: dict, budget: int) -> list:
    """The budgets of `checkpoints`, each a positive count below the run's `budget`."""
    for smaller in checkpoints:
        if isinstance(smaller, bool) or not isinstance(smaller, (int, np.integer)) \
                or not 0 < smaller < budget:
            raise ValueError(f"a checkpoint is a budget of steps from 1 to the run's budget "
                             f"({budget}) exclusive; got {smaller!r}")
    return list(checkpoints)


def _reaches(carry, budget: int) -> bool:
    """Whether the next chunk may spend `budget` for an agent still running (or none runs)."""
    active = np.asarray(carry["active"])
    return not active.any() or int(np.asarray(carry["spent"])[active].max()) + CHUNK >= budget


def _run_out(chunk, carry, budget: int) -> dict:
    """`carry` run on with `budget` until every agent has stopped."""
    while _any(carry["active"]):
        carry = chunk(carry, budget)
    return carry


def _ended(agents, carry, episodes: int, kept=None) -> tuple:
    """`(agents, results)`: `agents` given the learners' states and clocks of `carry`, and the
    episodes `carry` finished, with what the processes before this one spent on the run
    where it went on from the state they `kept` (`Resume.earlier`)."""
    agents.finished(carry["learner"], np.asarray(carry["clock"]))
    results = EpisodeResults.empty(agents.batch_size, episodes)
    ran = np.arange(episodes)[None, :] < np.asarray(carry["done"])[:, None]
    for field, values in (("steps", results.steps), ("returns", results.returns),
                          ("uptime", results.uptime)):
        values[ran] = np.asarray(carry[field], dtype=np.float64)[ran]
    results.truncated[ran] = np.asarray(carry["truncated"])[ran]
    results.diverged_episode[:] = np.asarray(carry["diverged_episode"])
    agents.arrays.diverged[:] |= results.diverged_episode >= 0
    if kept is not None:
        results.earlier_compute = kept.earlier
    return agents, results


_CHUNKS: dict = {}
"""The compiled chunks of this process, by what shapes them."""


def release_when_crowded() -> None:
    """Before a compilation: where this process holds more than half the memory mappings
    it may (`runners.mappings`), every compiled program let go (`_CHUNKS` and JAX's caches),
    so that XLA's next compilation cannot die mapping one too many. A chunk needed again is
    compiled again; no number changes."""
    if mappings.crowded():
        import gc

        import jax
        _CHUNKS.clear()
        jax.clear_caches()
        gc.collect()
        mappings.released()


def _shared_settings(settings) -> tuple:
    """The settings a batch shares (not `per_agent`): they shape the program."""
    return tuple((field.name, getattr(settings, field.name)) for field in
                 dataclasses.fields(settings) if not field.metadata.get("per_agent"))


JAX_CACHE = "LWRL_JAX_CACHE"
"""The environment variable that turns JAX's persistent compilation cache on (`1`), at the
risk the module's docstring states."""


def _use_disk_cache() -> None:
    """Where `JAX_CACHE` is `1`: JAX's persistent compilation cache in `<lwrl cache>/jax`, for
    programs that take a second or more to compile (where the cache directory can be
    written). Otherwise nothing: each process compiles its programs (see the module)."""
    if os.environ.get(JAX_CACHE) != "1":
        return
    import jax
    directory = kernels.cache_root() / "jax"
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError:
        return
    if getattr(jax.config, "jax_compilation_cache_dir", None) is None:
        jax.config.update("jax_compilation_cache_dir", str(directory))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


def _first_carry(env, agents, starts, sensors, episodes: int) -> dict:
    """Every agent at its first episode's start, nothing recorded. What needs no JAX
    operation is made by NumPy and put on the device: an operation of JAX's outside a
    program compiles one of its own for each shape."""
    import jax
    batch = agents.batch_size
    clocks = jax.device_put(np.asarray(agents.clocks, np.int32))
    seeds = jax.device_put(np.asarray(agents.seeds, np.uint32) + np.uint32(STREAM))
    keys = jax.vmap(jax.random.fold_in)(  # each agent's stream, where its last run left it
        jax.vmap(jax.random.PRNGKey)(seeds), clocks)
    observation, state = jax.vmap(env.start)(keys, starts[:, 0], sensors)
    nan = np.full((batch, episodes), np.nan)
    records = jax.device_put({
        "start": np.ones(batch, bool), "total": np.zeros(batch),
        "spent": np.zeros(batch, np.int32), "done": np.zeros(batch, np.int32),
        "active": ~np.asarray(agents.arrays.diverged, bool), "steps": nan, "returns": nan,
        "uptime": nan, "truncated": np.zeros((batch, episodes), bool),
        "diverged_episode": np.full(batch, -1, np.int32)})
    return {"learner": agents.state, "env": state, "observation": observation, "key": keys,
            "clock": clocks, **records}


def _compiled_chunk(env, program, episodes: int, weight_tree, continuous: bool):
    """`CHUNK` steps of the batch as one jitted function of the carry, `learn` and `greedy`
    (`run_population`'s) among its arguments, so that one program trains and evaluates;
    `continuous`: the learner's actions are numbers in [-1, 1], scaled to the actuator's
    range."""
    import jax
    import jax.numpy as jnp
    from lwrl.jax.translate import as_jax

    def command(action, physical):
        """What the JAX task takes for `action` at the episode's parameter values `physical`:
        the action itself (an index), or the command a continuous one names."""
        if not continuous:
            return action
        control_range = jnp.stack(env.action_range(physical))
        return as_jax(commands, env.dtype)(control_range[None], action[None])[0]

    def finish(row, ended, steps, total, uptime, truncated):
        """`finish_episode` of one agent where `ended`: its episode's record at `done`
        (one element written, whatever the episodes); the two forms held to each other by
        tests/test_population.py."""
        k = jnp.minimum(row["done"], episodes - 1)
        put = lambda values, value: values.at[k].set(jnp.where(ended, value, values[k]))
        return {**row, "steps": put(row["steps"], steps.astype(row["steps"].dtype)),
                "returns": put(row["returns"], total), "uptime": put(row["uptime"], uptime),
                "truncated": put(row["truncated"], truncated),
                "done": row["done"] + ended.astype(jnp.int32)}

    def choose(row, hyper, modes):
        """One agent's action at its observation, `(action, extras, keys)`: `keys` the
        agent's next random stream and those of its plant's step and of its next start;
        `modes` `(learn, greedy)`."""
        learn, greedy = modes
        clock = row["clock"]
        learning = learn & (clock < hyper["learning_steps"])
        key, act_key, env_key, start_key = jax.random.split(row["key"], 4)
        action, extras = program.act(row["learner"], row["observation"], act_key, hyper,
                                     greedy | ~learning, clock)
        return action, extras, (key, env_key, start_key)

    def choices(carry, hyper, modes):
        """Every agent's `choose`: over the batch at once, or one agent after another where
        the program asks (`Program.mapped`), reading the agents' states but for what
        `Program.unchanged` names (what acting never reads: a replay buffer)."""
        if not program.mapped:
            return jax.vmap(choose, in_axes=(0, 0, None))(carry, hyper, modes)
        acting = {"key": carry["key"], "clock": carry["clock"], "observation": carry["observation"],
                  "learner": {name: value for name, value in carry["learner"].items()
                              if name not in program.unchanged}}
        return jax.lax.map(lambda row: choose(*row, modes), (acting, hyper))

    def agent_step(row, choice, hyper, physical, starts, sensors, budget, learn):
        """One step of one agent, taking its `choice`, in its episode's physics (`physical`
        `(K, P)`) with its sensors, learning or not (`learn`); the step that spends its
        `budget` ends its episode, truncated, and it."""
        action, extras, (key, env_key, start_key) = choice
        clock = row["clock"]
        learning = learn & (clock < hyper["learning_steps"])
        episode_physical = physical[jnp.minimum(row["done"], episodes - 1)]
        observation, state, reward, terminated, truncated, info = env.step_env(
            env_key, row["env"], command(action, episode_physical), episode_physical, sensors)
        learner = program.record(row["learner"], extras, row["observation"], action, reward,
                                 terminated, truncated, observation, hyper, clock,
                                 learning & row["active"])
        spent = row["spent"] + 1
        cut = (spent >= budget) & ~terminated
        ended = terminated | truncated | cut
        total = row["total"] + reward
        new = finish({**row, "learner": learner, "key": key, "spent": spent}, ended,
                     state.steps, total, state.uptime, truncated | cut)
        start_observation, start = env.start(
            start_key, starts[jnp.minimum(new["done"], episodes - 1)], sensors)
        new = {**new, "env": jax.tree.map(lambda a, b: jnp.where(ended, a, b), start, state),
               "observation": jnp.where(ended, start_observation, observation),
               "start": ended, "total": jnp.where(ended, 0.0, total),
               "clock": clock + learn, "due": learning & program.update_due(hyper, clock)}
        new["active"] = (new["done"] < episodes) & (spent < budget)
        rest = [name for name in new if name != "learner"]  # the learner masks its own writes
        kept = jax.tree.map(lambda a, b: jnp.where(row["active"], a, b),
                            {name: new[name] for name in rest}, {name: row[name] for name in rest})
        return {**kept, "learner": learner, "due": new["due"] & row["active"]}

    def diverge(row):
        """An agent whose weights are no longer finite: its episode is cut and it stops."""
        finite = jnp.all(jnp.stack([jnp.all(jnp.isfinite(leaf)) for leaf in
                                    jax.tree.leaves(weight_tree(row["learner"]))]))
        newly = row["active"] & ~finite
        new = finish(row, newly, row["env"].steps, row["total"], row["env"].uptime, False)
        return {**new, "active": new["active"] & finite,
                "diverged_episode": jnp.where(newly, row["done"], row["diverged_episode"])}

    def update(carry, hyper):
        """The learner's update for the agents whose rollout the step just filled: over the
        batch at once, or one agent after another where the program asks (`Program.mapped`),
        computed for the agents due only."""
        arguments = (carry["learner"], carry["observation"], carry["start"].astype(jnp.float32),
                     hyper, carry["clock"] - 1, carry["due"])
        if program.mapped:
            def one(row):
                new = jax.lax.cond(row[-1], lambda: program.update(*row), lambda: row[0])
                return {name: new[name] for name in new if name not in program.unchanged}
            learner = {**carry["learner"], **jax.lax.map(one, arguments)}
        else:
            learner = jax.vmap(program.update)(*arguments)
        return jax.vmap(diverge)({**carry, "learner": learner})

    def one(carry, _, hyper, physical, starts, sensors, budget, modes):
        carry = jax.vmap(agent_step, in_axes=(0, 0, 0, 0, 0, 0, None, None))(
            carry, choices(carry, hyper, modes), hyper, physical, starts, sensors, budget,
            modes[0])
        carry = jax.lax.cond(jnp.any(carry["due"]), lambda c: update(c, hyper), lambda c: c,
                             carry)
        return carry, None

    @jax.jit
    def chunk(carry, hyper, physical, starts, sensors, budget, learn, greedy):
        carry = {**carry, "due": jnp.zeros_like(carry["active"])}
        carry = jax.lax.scan(lambda c, x: one(c, x, hyper, physical, starts, sensors, budget,
                                              (learn, greedy)),
                             carry, None, length=CHUNK)[0]
        return {name: value for name, value in carry.items() if name != "due"}

    return chunk
