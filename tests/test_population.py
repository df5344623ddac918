"""The JAX population learners (`ppo_jax`, `dqn_jax`) against Stable-Baselines3's own training
step: from the same weights and the same data, one update of each gives SB3's weights (to
float32 round-off); and what the population path promises beside the learner contract
(`tests/test_learners.py`): the task's starts, the physics drawn per episode, each agent's
own sensors and actuator, refusals in one line, learning."""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("jax", reason="the population learners need the jax extra: pip install 'lwrl[jax]'")

from lwrl import agent as learners, tasks  # noqa: E402
from lwrl.agent.stable_baselines import missing_libraries, spaces_env  # noqa: E402
from lwrl.runners import episodes as episode_records, population, sweep  # noqa: E402
from lwrl.runners.config import RunConfig, task_spec  # noqa: E402
from lwrl.runners.run import make_agents, run  # noqa: E402
from lwrl.tasks.randomisation import check_ranges, draws  # noqa: E402
from conftest import one_line_error  # noqa: E402

TASK = task_spec("cartpole.balance")
needs_sb3 = pytest.mark.skipif(bool(missing_libraries()), reason="needs the baselines extra: "
                               "pip install 'lwrl[baselines]'")
EVALUATED = RunConfig(task="pendulum.swingup", learner="dqn_jax", agents=1, episodes=3, seed=5,
                      plant="analytic", task_options={"time_limit": 2.0}, timesteps=300,
                      buffer_size=100, learning_starts=50, net_arch="16")
"""A small dqn_jax run to evaluate (greedily, without learning): the tests of the physics and
the sensors share its compiled programs (one per batch size and longest action delay)."""
FIELDS = ("steps", "returns", "uptime", "truncated", "diverged_episode")


def evaluated(config, **options):
    """`(agents, results)` of `config`'s new agents run greedily without learning."""
    return run(config, learn=False, greedy=True, **options)


def sb3_model(kind, settings, seed=0):
    """An SB3 model set up as `agent.stable_baselines.ModelAgents` sets it up."""
    import stable_baselines3
    from stable_baselines3.common.logger import Logger
    common = dict(learning_rate=settings.learning_rate, gamma=settings.gamma,
                  max_grad_norm=settings.max_grad_norm, seed=seed, device="cpu",
                  policy_kwargs={"net_arch": settings.layers()})
    env = spaces_env(len(TASK.state_names), TASK.action)
    if kind == "ppo":
        model = stable_baselines3.PPO(
            "MlpPolicy", env, n_steps=settings.n_steps, batch_size=settings.batch_size,
            n_epochs=settings.n_epochs, gae_lambda=settings.gae_lambda,
            clip_range=settings.clip_range, ent_coef=settings.ent_coef, vf_coef=settings.vf_coef,
            **common)
    else:
        model = stable_baselines3.DQN(
            "MlpPolicy", env, buffer_size=settings.buffer_size, batch_size=settings.batch_size,
            learning_starts=0, tau=settings.tau, train_freq=settings.train_freq,
            gradient_steps=settings.gradient_steps,
            target_update_interval=settings.target_update_interval, **common)
    model.set_logger(Logger(folder=None, output_formats=[]))
    model._setup_learn(total_timesteps=settings.timesteps)
    return model


def copy_into(torch, layers, linears):
    """JAX layers `[(W (in, out), b)]` into torch `Linear`s (weight (out, in))."""
    with torch.no_grad():
        for (w, b), linear in zip(layers, linears):
            linear.weight.copy_(torch.from_numpy(np.asarray(w).T.copy()))
            linear.bias.copy_(torch.from_numpy(np.asarray(b).copy()))


def linears(torch, module):
    return [m for m in module.modules() if isinstance(m, torch.nn.Linear)]


def assert_layers_close(layers, modules, torch):
    for (w, b), linear in zip(layers, modules):
        np.testing.assert_allclose(np.asarray(w).T, linear.weight.detach().numpy(), rtol=2e-5, atol=2e-6)
        np.testing.assert_allclose(np.asarray(b), linear.bias.detach().numpy(), rtol=2e-5, atol=2e-6)


@needs_sb3
def test_one_ppo_update_is_sb3s_train():
    """A rollout of 8 transitions (two episodes, one cut by a time limit), one epoch of one
    minibatch (so the order of the minibatch does not matter): SB3's GAE and `PPO.train`
    give the weights `ppo_jax`'s update gives."""
    import jax
    import jax.numpy as jnp
    import torch
    settings = learners.learner("ppo_jax").settings(
        net_arch="8,8", n_steps=8, batch_size=8, n_epochs=1, timesteps=1000, ent_coef=0.01,
        learning_rate=0.01)
    agents = make_agents(RunConfig(task="cartpole.balance", learner="ppo_jax", agents=1,
                                  **{f.name: getattr(settings, f.name)
                                     for f in dataclasses.fields(settings)}))
    rng = np.random.default_rng(0)
    state = jax.tree.map(lambda x: x[0], agents.state)
    observations = rng.normal(size=(9, 4)).astype(np.float32)
    actions = rng.integers(2, size=8).astype(np.int32)
    rewards = rng.normal(size=8).astype(np.float32)
    starts = np.array([1, 0, 0, 0, 1, 0, 0, 0], dtype=np.float32)
    log_probs, values = agents.forward(state["params"], jnp.asarray(observations))
    buffer = {"observations": jnp.asarray(observations[:8]), "actions": jnp.asarray(actions),
              "rewards": jnp.asarray(rewards), "starts": jnp.asarray(starts),
              "values": values[:8], "log_probs": log_probs[jnp.arange(8), actions]}
    program = agents.program()
    hyper = {name: jnp.asarray(values_[0]) for name, values_ in program.hyper.items()}
    updated = program.update({**state, "buffer": buffer}, jnp.asarray(observations[8]),
                             jnp.float32(0.0), hyper, 7, True)

    model = sb3_model("ppo", settings)
    policy = model.policy
    copy_into(torch, state["params"]["actor"], linears(torch, policy.mlp_extractor.policy_net)
              + [policy.action_net])
    copy_into(torch, state["params"]["critic"], linears(torch, policy.mlp_extractor.value_net)
              + [policy.value_net])
    for t in range(8):
        model.rollout_buffer.add(observations[t:t + 1], actions[t:t + 1, None], rewards[t:t + 1],
                                 starts[t:t + 1].astype(bool),
                                 torch.tensor([float(values[t])]),
                                 torch.tensor([float(log_probs[t, actions[t]])]))
    model.rollout_buffer.compute_returns_and_advantage(
        last_values=torch.tensor([[float(values[8])]]), dones=np.array([False]))
    model.num_timesteps = 8
    model._update_current_progress_remaining(8, settings.timesteps)
    model.train()
    assert_layers_close(updated["params"]["actor"],
                        linears(torch, policy.mlp_extractor.policy_net) + [policy.action_net], torch)
    assert_layers_close(updated["params"]["critic"],
                        linears(torch, policy.mlp_extractor.value_net) + [policy.value_net], torch)


@needs_sb3
def test_one_dqn_update_is_sb3s_train():
    """A replay buffer of one transition repeated (so the batch SB3 samples is the one JAX
    samples), one gradient step: SB3's `DQN.train` gives the weights `dqn_jax`'s gives."""
    import jax
    import jax.numpy as jnp
    import torch
    settings = learners.learner("dqn_jax").settings(
        net_arch="8,8", buffer_size=16, batch_size=4, gradient_steps=1, train_freq=1,
        timesteps=1000, learning_rate=0.01, learning_starts=0, max_grad_norm=0.5)
    agents = make_agents(RunConfig(task="cartpole.balance", learner="dqn_jax", agents=1,
                                  **{f.name: getattr(settings, f.name)
                                     for f in dataclasses.fields(settings)}))
    rng = np.random.default_rng(1)
    state = jax.tree.map(lambda x: x[0], agents.state)
    target = jax.tree.map(lambda x: x + 0.1, state["params"])  # a target apart from the net
    observation, next_observation = rng.normal(size=(2, 4)).astype(np.float32)
    buffer = {"observations": jnp.tile(observation, (16, 1)),
              "next_observations": jnp.tile(next_observation, (16, 1)),
              "actions": jnp.ones(16, jnp.int32), "rewards": jnp.full(16, 0.5, jnp.float32),
              "terminals": jnp.zeros(16, jnp.float32), "count": jnp.int32(16)}
    program = agents.program()
    hyper = {name: jnp.asarray(values_[0]) for name, values_ in program.hyper.items()}
    updated = program.update({**state, "buffer": buffer, "target": target}, None, None, hyper,
                             15, True)

    model = sb3_model("dqn", settings)
    copy_into(torch, state["params"], linears(torch, model.q_net))
    copy_into(torch, target, linears(torch, model.q_net_target))
    for _ in range(16):
        model.replay_buffer.add(observation[None].astype(np.float64),
                                next_observation[None].astype(np.float64), np.array([[1]]),
                                np.array([0.5]), np.array([False]), [{}])
    model.num_timesteps = 16
    model._update_current_progress_remaining(16, settings.timesteps)
    model.train(gradient_steps=1, batch_size=4)
    assert_layers_close(updated["params"], linears(torch, model.q_net), torch)


OFF_POLICY = dict(buffer_size=5000, train_freq=16, learning_starts=50, batch_size=16,
                  net_arch="8")
"""An off-policy learner's settings in `short_training`: a buffer larger than its 300 steps."""


def short_training(name: str) -> RunConfig:
    """Three agents of `name` learning over three Mountain-Car episodes of at most 100 steps,
    `timesteps` 300 (PPO's rollouts of 64 steps; DQN's and SAC's learning from step 50): the
    tests of the starts, the chunks, the replay buffer and a crowded process share its
    compiled program."""
    learner = learners.learner(name)
    settings = learner.settings(timesteps=300, **({"n_steps": 64, "batch_size": 32}
                                                  if name == "ppo_jax" else OFF_POLICY))
    return RunConfig(task="mountain_car.cost_to_go", learner=name, agents=3, episodes=3, seed=4,
                     plant="analytic", settings=settings, actions=learner.actions,
                     task_options={"time_limit": 100})


@pytest.mark.parametrize("name", ["ppo_jax", "dqn_jax"])
def test_episodes_start_where_every_learners_start(name, monkeypatch):
    """Agent b's episode k starts where `runners.episodes.episode_starts` puts it (the
    protocol's starts, drawn from the agent's seed as every loop draws them): here a start
    one step from Mountain-Car's goal for the second episode of every agent."""
    drawn = []

    def starts(definition, seeds, episodes):
        values = episode_records.episode_starts(definition, seeds, episodes)
        values[:, 1] = (0.49, 0.07)
        drawn.append((list(seeds), episodes))
        return values
    monkeypatch.setattr(population, "episode_starts", starts)
    _, results = run(short_training(name))
    assert drawn == [([4, 5, 6], 3)]
    np.testing.assert_array_equal(results.steps[:, 1], 1.0)
    np.testing.assert_array_equal(results.returns[:, 1], 0.0)
    assert np.all(np.isfinite(results.steps))


@pytest.mark.parametrize("name", ["ppo_jax", "dqn_jax"])
def test_how_the_program_is_cut_into_chunks_changes_no_number(name, monkeypatch):
    """The runner steps the batch in compiled chunks of `CHUNK` steps (so that progress is
    reported and Ctrl-C stops between two): chunks of 7 steps give the same episodes and
    weights as the default's, an episode and a rollout crossing many chunk boundaries."""
    config = short_training(name)
    whole_agent, whole = run(config)
    monkeypatch.setattr(population, "CHUNK", 7)
    chunked_agent, chunked = run(config)
    for field in ("steps", "returns", "uptime", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(chunked, field), getattr(whole, field))
    np.testing.assert_array_equal(chunked_agent.arrays.weights, whole_agent.arrays.weights)


def test_randomised_physics_runs_each_episode_at_the_compiled_loops_draws():
    """`randomise`: `results.physical` holds the values the compiled loop draws for the same
    seeds and episodes (`tasks.randomisation.draws`), and each greedy episode is the JAX
    environment's stepped by hand at its episode's values, under the agent's greedy actions,
    not the paper's plant's."""
    import jax
    import lwrl.jax

    config = dataclasses.replace(EVALUATED, randomise={"mass": (0.5, 2.0), "torque": (1.0, 8.0)})
    agent, results = evaluated(config)
    parameters = tasks.domain("pendulum").parameters
    drawn = draws(parameters, check_ranges(parameters, config.randomise),
                  parameters.values(None, 1), config.seeds, 3)
    assert set(results.physical) == {"mass", "torque"}
    for name, values in results.physical.items():
        np.testing.assert_array_equal(values, drawn[:, :, parameters.position(name)])
    env, _ = lwrl.jax.make("pendulum.swingup", time_limit=2.0)
    step = jax.jit(env.step_env)
    starts = episode_records.episode_starts(env.definition, config.seeds, 3)
    for k in range(3):
        observation, state = env.start(jax.random.PRNGKey(0), starts[0, k])
        steps, total, ended = 0, 0.0, False
        while not ended:
            action = int(np.argmax(agent.action_values(np.asarray(observation)[None])[0, 0]))
            observation, state, reward, terminated, truncated, _ = step(
                jax.random.PRNGKey(steps), state, action, drawn[0, k])
            steps, total, ended = steps + 1, total + float(reward), bool(terminated | truncated)
        assert steps == results.steps[0, k]
        np.testing.assert_allclose(total, results.returns[0, k], rtol=1e-9)
    _, nominal = evaluated(dataclasses.replace(config, randomise={}))
    assert not np.any(np.isclose(nominal.returns, results.returns, rtol=1e-6))


@pytest.mark.parametrize("task, budget", [("pendulum.swingup", None), ("cartpole.balance", 12)])
def test_an_episode_is_kept_as_the_numba_loops_keep_it(task, budget):
    """One definition of an episode in its two forms, the population program's `finish` and
    the numba loops' `runners.episodes.finish_episode`: the same greedy agents on the same
    episodes, through the population program and through the stepped loop on the analytic
    plant (`Agents.step`), give the same steps, up-times and truncations and the same
    returns to rounding; time limits (the pendulum), terminal states (the cart-pole) and a
    budget that cuts an episode and leaves the last unrun."""
    from lwrl.runners.stepped import run_batched
    from lwrl.tasks.batched import BatchedEnv

    config = dataclasses.replace(EVALUATED, task=task, budget=budget)
    agent, program = evaluated(config)
    domain, name = tasks.split_name(task)
    env = BatchedEnv(domain, name, "analytic", seeds=config.seeds, time_limit=2.0)
    stepped = run_batched(env, agent, config.episodes, learn=False, greedy=True, budget=budget)
    for field in ("steps", "uptime", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(program, field), getattr(stepped, field), err_msg=field)
    np.testing.assert_allclose(program.returns, stepped.returns, rtol=1e-12)
    assert np.isnan(program.steps).any() == (budget is not None)


def test_each_agent_of_a_batch_senses_and_acts_with_its_own_options(monkeypatch):
    """Two runs that differ in their sensors and actuator, joined into one batch as the sweep
    joins them (a robustness evaluation's cells): each agent's episodes are, bit for bit,
    those it has alone with its own options; one compiled program serves every noise level
    and delay (up to the longest, which shapes it); and the noise and the delay change the
    episodes. The process is held uncrowded (`runners.mappings`): a worker that had compiled
    many programs let them all go in the middle of the test, and compiled one again."""
    from lwrl.runners import mappings
    monkeypatch.setattr(mappings, "crowded", lambda: False)
    noisy = dataclasses.replace(EVALUATED, observation_noise={"angle": 0.05,
                                                              "angular_velocity": 0.2},
                                action_noise=0.5)
    late = dataclasses.replace(EVALUATED, seed=6, action_delay=2)
    batch = [noisy, late]
    assert len(sweep.batches(batch)) == 1
    _, together = evaluated(noisy, agents=make_agents(*batch), seeds=[5, 6], batch=batch)
    alone = [evaluated(config)[1] for config in batch]
    for b, results in enumerate(alone):
        for field in FIELDS:
            np.testing.assert_array_equal(getattr(results, field)[0],
                                          getattr(together, field)[b], err_msg=field)
    programs = set(population._CHUNKS)
    quiet = evaluated(dataclasses.replace(noisy, observation_noise={}, action_noise=0.0))[1]
    prompt = evaluated(dataclasses.replace(late, action_delay=0))[1]
    assert set(population._CHUNKS) == programs  # no new one: noise and delay are data
    assert not np.any(quiet.returns == alone[0].returns)
    assert not np.any(prompt.returns == alone[1].returns)


@pytest.mark.parametrize("change, message", [
    (dict(plant="mujoco", task="cartpole.balance"), "runs on the plants of lwrl.jax: analytic, mjx"),
])
def test_what_the_population_path_does_not_run_is_refused_in_one_line(change, message):
    config = RunConfig(**{**dict(task="cartpole.balance", learner="ppo_jax", agents=2,
                                 episodes=1, plant="analytic"), **change})
    with pytest.raises(ValueError) as error:
        run(config)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_batchs_bad_sensor_options_are_refused_in_one_line():
    agent = make_agents(dataclasses.replace(EVALUATED, agents=2))
    for options, message in (({"action_delay": [1, 2, 3]}, "action_delay must be one whole "
                              "number or 2, one per environment"),
                             ({"observation_noise": {"angle": [0.1, -1.0]}},
                              "observation_noise['angle'] must be a finite number"),
                             ({"randomise": {"mass": (2.0, 1.0)}}, "randomise['mass'] must be")):
        one_line_error(lambda: population.run_population("pendulum", "swingup", agent, 1, [0, 1],
                                                         **options), message)


def test_a_batch_of_settings_that_cannot_be_batched_is_refused_in_one_line():
    first = learners.learner("ppo_jax").settings(n_steps=64, batch_size=64)
    second = dataclasses.replace(first, batch_size=32)
    with pytest.raises(ValueError) as error:
        learners.learner("ppo_jax").make([first, second], TASK, [0, 1])
    assert "must share batch_size" in str(error.value) and "\n" not in str(error.value)


def test_a_batch_of_a_kind_already_made_compiles_no_initialiser():
    """Agents of the same class, first settings and task share one jitted initialiser (a
    program made for each batch compiled anew, 1.5 s here), compiled once for batches of any
    size; other first settings get their own, and each batch's agents start as they would
    alone."""
    import jax
    from lwrl.agent import jax_population
    config = RunConfig(task="cartpole.balance", learner="dqn_jax", agents=2, net_arch="8")
    first, again = make_agents(config), make_agents(dataclasses.replace(config, seed=5))
    other = make_agents(dataclasses.replace(config, learning_rate=0.01))
    assert jax_population.initialiser(first) is jax_population.initialiser(again)
    assert jax_population.initialiser(other) is not jax_population.initialiser(first)
    alone = make_agents(dataclasses.replace(config, agents=1, seed=6))
    assert jax_population.initialiser(alone)._cache_size() == 1
    for batched, single in zip(*(jax.tree_util.tree_leaves(a.state) for a in (again, alone))):
        np.testing.assert_array_equal(np.asarray(batched)[1], np.asarray(single)[0])


@pytest.mark.parametrize("name", ["dqn_jax", "sac_jax"])
def test_a_replay_buffer_holds_what_its_agents_can_store_and_changes_no_number(name, monkeypatch):
    """An off-policy agent stores a transition only while it learns, `timesteps` (rounded up
    to a whole `train_freq`: 304 of `short_training`'s 300 at 16) at most: its buffer is
    made that size where `buffer_size` is larger, and the episodes and weights are those of
    a buffer of `buffer_size`."""
    from lwrl.agent import jax_population
    config = short_training(name)
    assert jax_population.replay_capacity([config.settings]) == 304
    assert jax_population.replay_capacity([dataclasses.replace(config.settings,
                                                                buffer_size=100)]) == 100
    capped_agent, capped = run(config)
    assert capped_agent.state["buffer"]["rewards"].shape == (3, 304)
    module = "lwrl.agent.dqn_jax" if name == "dqn_jax" else "lwrl.agent.off_policy_jax"
    monkeypatch.setattr(f"{module}.replay_capacity", lambda s: list(s)[0].buffer_size)
    monkeypatch.setattr(jax_population, "_INITIALISERS", {})
    whole_agent, whole = run(config)
    assert whole_agent.state["buffer"]["rewards"].shape == (3, 5000)
    for field in ("steps", "returns", "uptime", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(capped, field), getattr(whole, field))
    np.testing.assert_array_equal(capped_agent.arrays.weights, whole_agent.arrays.weights)


CACHE_PROBE = """
import jax
from lwrl.runners.config import RunConfig
from lwrl.runners.run import run
run(RunConfig(task="mountain_car.cost_to_go", learner="ars", agents=1, episodes=1,
              plant="analytic", task_options={"time_limit": 20.0}))
print(jax.config.jax_compilation_cache_dir)
"""


@pytest.mark.parametrize("asked", [False, True])
def test_the_persistent_compilation_cache_is_used_only_where_asked(asked, tmp_path):
    """A cache write has aborted a process (runners.population): without LWRL_JAX_CACHE=1 a
    population run leaves JAX's persistent cache off, with it the cache is lwrl's."""
    import os
    import subprocess
    import sys

    env = {key: value for key, value in os.environ.items()
           if key != population.JAX_CACHE and not key.startswith("JAX_")}
    env["LWRL_CACHE_DIR"] = str(tmp_path)
    if asked:
        env[population.JAX_CACHE] = "1"
    done = subprocess.run([sys.executable, "-c", CACHE_PROBE], capture_output=True, text=True,
                          env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    directory = done.stdout.strip().splitlines()[-1]
    assert directory == (str(tmp_path / "jax") if asked else "None")


def test_a_crowded_process_lets_its_compiled_programs_go_and_computes_the_same(monkeypatch):
    """A process past half its memory mappings' limit (`runners.mappings`) releases every
    compiled program before compiling another: the run compiles afresh and its numbers are
    those of the uncrowded run."""
    from lwrl.runners import mappings
    config = short_training("dqn_jax")
    kept_agent, kept = run(config)
    assert population._CHUNKS
    stale = object()
    monkeypatch.setattr(population, "_CHUNKS", {"another program": stale})  # this run's to compile
    monkeypatch.setattr(mappings, "count", lambda: mappings.limit() // 2 + 1)
    monkeypatch.setattr(mappings, "_after_release", 0)  # restored after the test
    released_agent, released = run(config)
    assert list(population._CHUNKS.values()) != [stale] and len(population._CHUNKS) == 1
    for field in ("steps", "returns", "truncated", "diverged_episode"):
        np.testing.assert_array_equal(getattr(released, field), getattr(kept, field))
    np.testing.assert_array_equal(released_agent.arrays.weights, kept_agent.arrays.weights)


def test_the_mappings_are_counted_against_the_systems_limit():
    from lwrl.runners import mappings
    assert 0 < mappings.count() < mappings.limit()  # Linux, where the tests run
    assert not mappings.crowded()


def test_a_release_that_leaves_the_process_crowded_is_not_repeated_until_it_grows(monkeypatch):
    """After a release that leaves a process past half its limit (mappings JAX does not
    hold), the next is due only once it holds MARGIN of the limit more."""
    from lwrl.runners import mappings
    held = {"now": 40_000}
    monkeypatch.setattr(mappings, "count", lambda: held["now"])
    monkeypatch.setattr(mappings, "limit", lambda: 65_530)
    monkeypatch.setattr(mappings, "_after_release", 0)
    assert mappings.crowded()
    population.release_when_crowded()
    assert mappings._after_release == 40_000 and not mappings.crowded()
    held["now"] = 40_000 + 8_000
    assert not mappings.crowded()
    held["now"] = 40_000 + 8_200
    assert mappings.crowded()
