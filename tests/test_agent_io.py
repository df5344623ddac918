"""Saving and loading agents: one .npz file, no pickle, bad files refused in one line."""

import json

import numpy as np
import pytest
from conftest import learner_case

from lwrl.agent import io as agent_io
from lwrl.agent.cmac import CMAC
from lwrl.agent.sarsa import BatchedSarsa
from lwrl.agent.stable_baselines import ModelAgents
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run_compiled


@pytest.fixture
def trained(tmp_path):
    """Three Mountain-Car agents after 5 episodes, saved with their configuration."""
    config = RunConfig(task="mountain_car.cost_to_go", plant="analytic", agents=3, episodes=5,
                       trace="accumulating", alpha=1.0, lam=0.8)
    agent = make_agents(config)
    run_compiled("mountain_car", "cost_to_go", agent, 5, config.seeds)
    path = tmp_path / "agent.npz"
    agent_io.save(path, agent, {"config": {"task": config.task}})
    return agent, path


def test_round_trip_keeps_everything_and_learning_continues_identically(trained):
    agent, path = trained
    loaded, metadata = agent_io.load(path)
    assert metadata == {"config": {"task": "mountain_car.cost_to_go"}}
    np.testing.assert_array_equal(loaded.weights, agent.weights)
    for field in ("streams", "alpha", "gamma", "lam", "epsilon", "trace"):
        np.testing.assert_array_equal(getattr(loaded.arrays, field), getattr(agent.arrays, field))
    assert loaded.features == agent.features
    more = run_compiled("mountain_car", "cost_to_go", agent, 3, [7, 8, 9])
    more_loaded = run_compiled("mountain_car", "cost_to_go", loaded, 3, [7, 8, 9])
    np.testing.assert_array_equal(more.steps, more_loaded.steps)
    np.testing.assert_array_equal(loaded.weights, agent.weights)


def test_cmac_agents_round_trip(tmp_path):
    cmac = CMAC((-1.2, -0.07), (0.5, 0.07), tilings=10, normalise_alpha=True)
    agent = BatchedSarsa(cmac, 3, alpha=0.5, lam=0.9, epsilon=0.0, trace="replacing_reset", seeds=[4])
    agent_io.save(tmp_path / "cmac.npz", agent)
    loaded, _ = agent_io.load(tmp_path / "cmac.npz")
    assert loaded.features == cmac
    np.testing.assert_array_equal(loaded.arrays.alpha, agent.arrays.alpha)  # 0.05 both


def rewrite(path, **changes):
    """The saved archive with some arrays replaced (None removes one)."""
    with np.load(path) as archive:
        arrays = {name: archive[name] for name in archive.files}
    for name, value in changes.items():
        if value is None:
            del arrays[name]
        else:
            arrays[name] = value
    np.savez(path, **arrays)


def document_with(path, **changes):
    with np.load(path) as archive:
        document = json.loads(str(archive["document"]))
    document.update(changes)
    return np.array(json.dumps(document))


@pytest.mark.parametrize("damage, message", [
    (lambda p: p.write_text("not an archive"), "not a NumPy .npz archive"),
    (lambda p: rewrite(p, document=None), "missing document"),
    (lambda p: rewrite(p, weights=np.zeros((3, 64, 2))), r"weights of shape \(3, 64, 2\) do not fit"),
    (lambda p: rewrite(p, document=np.array("{not json")), "unreadable description"),
    (lambda p: rewrite(p, document=document_with(p, format="lwrl-agent/99")), "format 'lwrl-agent/99'"),
    (lambda p: rewrite(p, document=document_with(p, trace=["dutch"] * 3)), "unknown trace 'dutch'"),
    (lambda p: np.savez(p, weights=np.array([{"a": 1}], dtype=object)), "not a NumPy .npz archive"),
])
def test_bad_files_are_refused(trained, damage, message):
    _, path = trained
    damage(path)
    with pytest.raises(ValueError, match=message):
        agent_io.load(path)


def test_missing_file(tmp_path):
    with pytest.raises(ValueError, match="no such agent file"):
        agent_io.load(tmp_path / "absent.npz")


def old_layout(document: dict, arrays: dict, agents) -> tuple[dict, dict]:
    """`(document, arrays)` as `agent.io` wrote them before learners said what they have: the
    number of actions in every document (1 for continuous actions), the task (where a learner
    kept one) as its name, state names, discrete actions (0: continuous), normalisation ranges
    and kind of actions (a list for the Stable-Baselines3 learners, a dict for the JAX
    populations), and SAC's and TD3's Q1 of the action taken as `q` `(B, 1)`."""
    document = {**document, "num_actions": 1 if agents.continuous else agents.action_space.n}
    if "task" in document:
        spec = agents.task
        fields = [spec.name, list(spec.state_names), 0 if spec.continuous else spec.action.n,
                  list(spec.ranges.low), list(spec.ranges.high), spec.actions]
        document["task"] = (fields if isinstance(agents, ModelAgents) else
                            dict(zip(("name", "state_names", "num_actions", "low", "high",
                                      "actions"), fields)))
    if "taken" in arrays:
        arrays = {**arrays, "q": arrays.pop("taken")[:, None]}
    return document, arrays


@pytest.mark.parametrize("learner, task, actions", [
    learner_case(learner, task, actions) for learner, task, actions in (("sarsa", "mountain_car.cost_to_go", "discrete"),
                                   ("actor_critic", "pendulum.swingup", "continuous"),
                                   ("ars", "mountain_car.cost_to_go", "discrete"),
                                   ("sac", "pendulum.swingup", "continuous"))])
def test_a_file_from_before_learners_said_what_they_have_loads(tmp_path, learner, task, actions):
    """A file of the earlier layout (made here from today's) loads as the agents it holds:
    the same weights, the same greedy actions, the same spec where the learner keeps one
    (but for what the old file did not say)."""
    config = RunConfig(task=task, learner=learner, actions=actions, plant="analytic", agents=2,
                       episodes=1)
    agents = make_agents(config)
    if agents.learner.compiles:  # its arrays are all it has: weights that act
        agents.arrays.weights[:] = np.random.default_rng(0).normal(size=agents.arrays.weights.shape)
    path = tmp_path / "old.npz"
    agent_io.save(path, agents, {"config": {"task": task}})
    with np.load(path) as archive:
        arrays = {name: archive[name] for name in archive.files}
    document, arrays = old_layout(json.loads(str(arrays.pop("document"))), arrays, agents)
    assert "num_actions" in document
    np.savez(path, **arrays, document=np.array(json.dumps(document)))
    loaded, metadata = agent_io.load(path)
    assert type(loaded) is type(agents) and metadata == {"config": {"task": task}}
    np.testing.assert_array_equal(loaded.arrays.weights, agents.arrays.weights)
    assert loaded.action_space == agents.action_space
    if hasattr(agents, "task"):
        assert (loaded.task.name, loaded.task.state_names, loaded.task.ranges) == \
            (agents.task.name, agents.task.state_names, agents.task.ranges)
    if "taken" in agents.arrays._fields:
        np.testing.assert_array_equal(loaded.arrays.taken, agents.arrays.taken)
    observations = np.random.default_rng(1).uniform(*agents.value_box(), size=(2, agents.dim))
    first, zeros = np.ones(2, dtype=bool), np.zeros(2)
    np.testing.assert_array_equal(
        loaded.step(first, zeros, zeros + 1, observations, learn=False, greedy=True),
        agents.step(first, zeros, zeros + 1, observations, learn=False, greedy=True))
