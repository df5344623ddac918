"""The counted arithmetic each learner declares (`Learner.arithmetic`, `agent.arithmetic`):
every learner of the registry counts on every task it fits, the shared counts and one
learner of each kind equal their hand-computed values, and the JAX learners count as their
Stable-Baselines3 counterparts, whose networks and updates they share."""

import dataclasses
import itertools

import pytest

from lwrl import agent as learners
from lwrl import tasks
from lwrl.agent.arithmetic import Count, NotCounted, mlp_forward, mlp_parameters, nrbf_decision
from lwrl.runners.config import RunConfig, task_spec

FITS = [(name, task) for name, task in itertools.product(learners.LEARNER_NAMES, tasks.TASK_NAMES)
        if learners.learner(name).fits(task_spec(task, actions=learners.learner(name).actions)) is None
        and learners.learner(name).arithmetic is not None]
"""(learner, task) of every learner that counts its arithmetic (an installed one need not) on
every task it fits."""
TWINS = {"ppo_jax": "ppo", "dqn_jax": "dqn"}
"""Each JAX learner and its Stable-Baselines3 counterpart."""


def counts_of(name: str, task: str, steps=None, settings: dict | None = None):
    """The counts of learner `name` on `task`: with its defaults there (`RunConfig`), or with
    `settings` (a deep learner's, which take nothing from the task)."""
    learner = learners.learner(name)
    if settings is not None:
        return learner.arithmetic(learner.settings(**settings), task_spec(task), steps)
    config = RunConfig(task=task, learner=name, actions=learner.actions)
    return learner.arithmetic(config.settings, config.task_spec, steps)


def test_every_learner_of_lwrls_own_counts_its_arithmetic():
    import importlib
    for module in learners.LEARNER_MODULES:
        assert importlib.import_module(f"lwrl.agent.{module}").LEARNER.arithmetic is not None, module


@pytest.mark.parametrize("name, task", FITS)
def test_every_learner_counts_a_decision_and_a_learning_step(name, task):
    """Positive multiply-adds for a learning step, which holds the decision of its action
    (ASE/ACE's greedy decision reads one weight: no multiply-add), over a long run and a
    short one."""
    for steps in (None, 1000):
        counts = counts_of(name, task, steps)
        assert counts.step.macs > 0 and counts.decision.macs >= 0 and counts.update.macs >= 0
        assert counts.step.macs >= counts.decision.macs and counts.step.exps >= counts.decision.exps
        assert counts.source


def test_an_mlp_forward_pass_and_its_parameters():
    """2 -> 64 -> 64 -> 3: 2·64 + 64·64 + 64·3 multiply-adds, one tanh per hidden unit (ReLU:
    none), and (2 + 1)·64 + (64 + 1)·64 + (64 + 1)·3 weights and biases."""
    assert mlp_forward([2, 64, 64, 3], True) == Count(2 * 64 + 64 * 64 + 64 * 3, 128)
    assert mlp_forward([2, 64, 64, 3], False) == Count(4416, 0)
    assert mlp_parameters([2, 64, 64, 3]) == 3 * 64 + 65 * 64 + 65 * 3 == 4547


def test_an_nrbf_grids_greedy_decision():
    """Mountain-Car's 8 x 8 grid, 3 actions: 2·8 exponentials, the outer product's 8 + 64
    multiply-adds and 3·64 for Q(s, .); the cart-pole's 6^4 grid, 2 actions: 4·6
    exponentials, 6 + 36 + 216 + 1296 and 2·1296."""
    assert nrbf_decision(2, 8, 3) == Count(8 + 64 + 3 * 64, 16)
    assert nrbf_decision(4, 6, 2) == Count(6 + 36 + 216 + 1296 + 2 * 1296, 24)


def test_sarsas_learning_step_on_mountain_car():
    """The paper's agent (8 x 8 grid, 3 actions): its decision (264 multiply-adds) and its
    update, N for Q(s, a), A N for the traces' decay and A N for the weights' (7·64), at
    every step; the same as `benchmarks.arithmetic_bound`'s model of an agent-step."""
    counts = counts_of("sarsa", "mountain_car.cost_to_go")
    assert counts.decision == Count(264, 16)
    assert counts.update == Count(7 * 64)
    assert counts.step == Count(264 + 7 * 64, 16)
    assert counts_of("sarsa", "mountain_car.cost_to_go", 7) == counts  # the same at every step


def test_the_linear_learners_do_not_count_cmac_features():
    for name in ("sarsa", "true_online_sarsa"):
        config = RunConfig(task="mountain_car.cost_to_go", learner=name)
        cmac = dataclasses.replace(config.settings, features="cmac")
        with pytest.raises(NotCounted, match="cmac features"):
            learners.learner(name).arithmetic(cmac, config.task_spec)


def test_dqns_learning_step_over_a_run():
    """The deep-speed benchmark's DQN on the pendulum (2 -> 64 -> 64 -> 2, ReLU: 4352
    multiply-adds, 4482 parameters), 1024 steps: (1024 - 100) // 4 = 231 training calls of
    32 transitions at 4 forward passes each (forward, backward, target) and 10 per parameter
    for the optimiser; no target update (every 10 000 steps)."""
    counts = counts_of("dqn", "pendulum.swingup", 1024, dict(
        buffer_size=50_000, learning_starts=100, net_arch="64,64", timesteps=100_000))
    call = 32 * 4 * 4352 + 10 * 4482
    assert counts.decision == Count(4352, 0)
    assert counts.update == Count(call * 231 / 1024, 0)
    assert counts.step == Count(4352 + call * 231 / 1024, 0)


def test_ppos_learning_step_over_a_run():
    """The deep-speed benchmark's PPO on the pendulum: actor 2 -> 64 -> 64 -> 2 (4352
    multiply-adds, 128 tanh, 4482 parameters), critic 2 -> 64 -> 64 -> 1 (4288, 128, 4417);
    1024 steps hold 2 rollouts of 512, each learned 10 times: per transition 3 forward
    passes of both and 128 + 128 + 2·2 + 1 exponentials, per minibatch of 64 (8 a rollout)
    10 per parameter."""
    counts = counts_of("ppo", "pendulum.swingup", 1024, dict(
        n_steps=512, batch_size=64, n_epochs=10, net_arch="64,64", timesteps=100_000))
    rollout = 10 * (512 * Count(3 * (4352 + 4288), 261) + Count(8 * 10 * (4482 + 4417)))
    assert counts.decision == Count(4352, 128)
    assert counts.update == rollout * (2 / 1024) == Count(273104.6875, 2610)
    assert counts.step == Count(4352 + 4288 + 273104.6875, 128 + 128 + 2 + 2610)


@pytest.mark.parametrize("twin", TWINS)
def test_the_jax_learners_count_as_their_counterparts(twin):
    """Same settings, same counts: on every task, with the defaults and each of the
    counterpart's tuned sets, over a long run and short ones."""
    sb3 = TWINS[twin]
    for task, settings, steps in itertools.product(
            tasks.TASK_NAMES, [{}, *learners.learner(sb3).tuned.values()], (None, 100, 1024)):
        assert counts_of(twin, task, steps, settings) == counts_of(sb3, task, steps, settings)
