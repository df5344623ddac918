"""The JAX peer of the speed benchmark (`benchmarks/jax_peer.py`) computes lwrl's algorithm:
the same features and plant steps, and its agents learn as lwrl's do. It measures no speed
here. CI does not install JAX; these tests run where it is (the `jax` extra)."""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("jax", reason="the JAX peer needs JAX (the jax extra); CI does not "
                                  "install it")

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from benchmarks import agent_speed, jax_peer  # noqa: E402
from lwrl import tasks  # noqa: E402
from lwrl.runners.config import RunConfig  # noqa: E402
from lwrl.runners.run import make_agents  # noqa: E402
from lwrl.tasks import cartpole, mountain_car  # noqa: E402


@pytest.mark.parametrize("task", list(jax_peer.TASKS))
def test_the_peer_computes_lwrls_features(task):
    """The peer's NRBF features equal `agent/nrbf.py`'s, far outside the ranges too (the
    underflow guard and the clamp)."""
    agent, _, _ = jax_peer.peer_agents(task, 1)
    config = RunConfig(task=task)
    features = config.settings.feature_map(config.task_spec.ranges.low, config.task_spec.ranges.high)
    rng = np.random.default_rng(0)
    low, high = np.array(features.low), np.array(features.high)
    states = low + (high - low) * rng.uniform(-0.5, 1.5, size=(200, len(low)))
    states[:5] *= [[1.0], [50.0], [-1e3], [1e20], [-1e200]]
    ours = np.asarray(jax.vmap(lambda s: jax_peer.features(agent, s))(states))
    np.testing.assert_allclose(ours, features.features(states), rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(ours.sum(axis=1), 1.0, rtol=1e-12)
    # the two factors the learner keeps (`feature_factors`) form the very same products
    two = np.asarray(jax.vmap(lambda s: jax_peer.joined(*jax_peer.feature_factors(agent, s)))(
        states))
    np.testing.assert_array_equal(two, ours)


def test_the_peer_steps_the_tasks_plants():
    """One step of the peer's plants equals the task modules' own `step` and `outcome`."""
    rng = np.random.default_rng(1)
    for state in rng.uniform((-1.2, -0.07), (0.5, 0.07), size=(100, 2)):
        for thrust in mountain_car.THRUSTS:
            expected = np.array(mountain_car.step(*state, thrust, np.asarray(mountain_car.NOMINAL)))
            ours = np.asarray(jax_peer.mountain_car_step(state, thrust))
            np.testing.assert_allclose(ours, expected, rtol=1e-14, atol=1e-17)
            reward, terminal = jax_peer.mountain_car_outcome(ours)
            assert (float(reward), bool(terminal)) == tuple(
                mountain_car.outcome(*expected, np.asarray(mountain_car.NOMINAL))[:2])
    for state in rng.uniform((-2.5, -2.0, -0.25, -3.0), (2.5, 2.0, 0.25, 3.0), size=(100, 4)):
        for force in cartpole.FORCES:
            expected = np.array(cartpole.step(*state, force, cartpole.TIMESTEP, True, False,
                                              np.asarray(cartpole.NOMINAL)))
            ours = np.asarray(jax_peer.cartpole_step(state, force))
            np.testing.assert_allclose(ours, expected, rtol=1e-13, atol=1e-15)
            reward, terminal = jax_peer.cartpole_outcome(ours)
            expected_outcome = cartpole.outcome(*expected, cartpole.TRACK_LIMIT,
                                                np.asarray(cartpole.NOMINAL))
            assert (float(reward), bool(terminal)) == (float(expected_outcome[0]),
                                                        bool(expected_outcome[1]))


def test_the_peer_learns_mountain_car_as_lwrl_does():
    """The paper's best Mountain-Car agent (replacing traces, alpha 3.9, lambda 0.9,
    epsilon 0, NRBF 8 x 8), 30 agents x 40 episodes, in the peer and in lwrl's compiled
    loop: both about 60 steps per episode over episodes 31 to 40 (the paper's Fig. 3), from
    hundreds in the first. Measured: the peer 60.1 ± 1.9, lwrl 60.8 ± 2.3 (means ± standard
    errors over agents); their random streams differ, so their numbers do too."""
    steps = jax_peer.learning_check(agents=30, episodes=40)
    peer, ours = np.mean(steps["JAX peer"][:, 30:40]), np.mean(steps["lwrl"][:, 30:40])
    assert peer < 90 and ours < 90
    assert abs(peer - ours) < 15  # about 4.5 standard errors of the difference
    assert np.mean(steps["JAX peer"][:, 0]) > 200  # it did have to learn


TRAJECTORY_STEPS, EPISODE_LIMIT = 400, 60
"""The fixed trajectory: its transitions, and the step limit of its episodes (short, so that
episodes end both at terminal states and by truncation)."""


def lwrl_trajectory(task):
    """lwrl's paper agent of `task` (one agent, seed 0) on the task's own plant
    (`benchmarks.agent_speed.PLANTS`) for `TRAJECTORY_STEPS` transitions, episodes cut at
    `EPISODE_LIMIT` steps; Mountain-Car's first episode starts near the goal so that it
    ends at a terminal state. Returns the agent's first start and action, and per
    transition: the next state, reward, terminal and truncated flags, the next episode's
    start, the action lwrl took at the next observed state (s', or the start after a
    terminal state) and after a truncation its first action at the start, and lwrl's
    features, Q, TD error and weights after the transition."""
    config = RunConfig(task=task, agents=1, plant="analytic")
    definition = tasks.definition(config.domain, config.task_name)
    agent = make_agents(config)
    plant = agent_speed.PLANTS[task]
    rng = np.random.default_rng(0)
    starts = definition.initial_states(rng, TRAJECTORY_STEPS)
    if task.startswith("mountain_car"):
        starts[0] = (0.4, 0.03)
    arrays = agent.arrays
    one = np.ones(1)

    def observe(first, reward, discount, state):
        return int(agent.step(np.array([first]), reward * one, discount * one, state[None, :])[0])

    episode, state = 0, starts[0]
    first = dict(start=starts[0], action=observe(True, 0.0, 1.0, starts[0]))
    steps, rows = 0, []
    for _ in range(TRAJECTORY_STEPS):
        taken = rows[-1]["restart_action"] if rows else first["action"]
        next_state, reward, terminal = plant(state, definition.controls[taken])
        next_state = np.array(next_state, dtype=np.float64)
        steps += 1
        truncated = not terminal and steps >= EPISODE_LIMIT
        action = observe(False, reward, 0.0 if terminal else 1.0, next_state)
        row = dict(next_state=next_state, reward=float(reward), terminal=bool(terminal),
                   truncated=truncated, start=starts[episode + 1], action=action,
                   delta=float(arrays.delta[0]))
        state = next_state
        if terminal or truncated:
            episode, steps = episode + 1, 0
            state = starts[episode]
            row["restart_action"] = observe(True, 0.0, 1.0, state)
            if terminal:
                row["action"] = row["restart_action"]
        row.setdefault("restart_action", row["action"])
        row.update(phi=arrays.phi[0, arrays.slot[0]].copy(), q=arrays.q[0].copy(),
                   weights=arrays.weights[0].copy())
        rows.append(row)
    return first, rows


@pytest.mark.parametrize("task", list(jax_peer.TASKS))
def test_the_peer_updates_as_lwrls_learner_step_by_step(task):
    """On a fixed trajectory with fixed actions (lwrl's agent's own, on the task's plant,
    episodes ending at terminal states and by truncation), the peer's learner step
    (`learner_step`, and `restart` after a truncation: the code its benchmark scans) gives
    after every transition lwrl's features of the next observed state, Q there, TD error and
    weights, to round-off (the peer contracts Q with the features' two factors, lwrl sums
    features times weights in another order)."""
    agent, hyper, keys = jax_peer.peer_agents(task, 1)
    hyper = tuple(h[0] for h in hyper)
    first, rows = lwrl_trajectory(task)
    assert any(r["terminal"] for r in rows) and any(r["truncated"] for r in rows)
    carry, _ = jax_peer.initial_carry(jax_peer.TASKS[task], agent, keys)
    carry = jax.tree.map(lambda x: x[0], carry)
    carry, _ = jax_peer.restart(agent, carry, first["start"], lambda q: first["action"])

    @jax.jit
    def step(carry, next_state, reward, terminal, truncated, start, action, restart_action):
        carry, seen = jax_peer.learner_step(agent, carry, hyper, next_state, reward, terminal,
                                            truncated, start, lambda q: action)
        restarted, q = jax_peer.restart(agent, carry, start, lambda q: restart_action)
        return (jax.tree.map(lambda new, old: jnp.where(truncated, new, old), restarted, carry),
                seen["delta"], jnp.where(truncated, q, seen["q"]))

    scale = max(1.0, max(np.abs(r["weights"]).max() for r in rows))
    for t, row in enumerate(rows):
        carry, delta, q = step(carry, row["next_state"], row["reward"], row["terminal"],
                               row["truncated"], row["start"], row["action"],
                               row["restart_action"])
        where = f"{task}, transition {t}"
        np.testing.assert_allclose(np.asarray(jax_peer.joined(carry.head, carry.tail)),
                                   row["phi"], rtol=1e-12, atol=1e-300, err_msg=where)
        np.testing.assert_allclose(float(delta), row["delta"], rtol=0, atol=1e-12 * scale,
                                   err_msg=where)
        np.testing.assert_allclose(np.asarray(q), row["q"], rtol=0, atol=1e-12 * scale,
                                   err_msg=where)
        np.testing.assert_allclose(np.asarray(carry.weights).reshape(row["weights"].shape),
                                   row["weights"], rtol=0, atol=1e-12 * scale, err_msg=where)
        assert int(carry.action) == row["restart_action"]


def test_the_peers_groups_run_the_agents_each_as_alone():
    """The benchmark's block runs the agents in groups (`vmap` within a group, `lax.map` over
    groups): every grouping gives each agent the same episodes and weights, truncations
    (the time limit cut to 30 steps) and terminal states included."""
    task = dataclasses.replace(jax_peer.TASKS["cartpole.balance"], step_limit=30)
    agent, hyper, keys = jax_peer.peer_agents(task.name, 4)
    results = []
    for group in (4, 1):
        carry, block_keys = jax_peer.initial_carry(task, agent, keys)
        block = jax_peer.make_block(task, agent, 4, length=200, group=group)
        steps = []
        for _ in range(2):
            carry, block_keys, episode_steps = block(carry, block_keys, hyper)
            steps.append(np.asarray(episode_steps))
        results.append((np.concatenate(steps), np.asarray(carry.weights)))
    episodes, weights = results[0]
    assert (episodes == 30).any() and ((episodes > 0) & (episodes < 30)).any()
    for other_episodes, other_weights in results[1:]:
        np.testing.assert_array_equal(other_episodes, episodes)
        np.testing.assert_allclose(other_weights, weights, rtol=1e-12, atol=1e-15)
