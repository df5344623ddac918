"""lwrl's agents on dm_control's suite and Gymnasium: adapters, episode ends, errors, a small
learning run and the command line."""

import importlib.util
import json
import sys

import dm_env
import numpy as np
import pytest
from dm_env import specs

from lwrl.cli import main as cli
from lwrl.adapters.external import DmEnvAdapter, ExternalConfig, GymAdapter, load, run_external

needs_gymnasium = pytest.mark.skipif(importlib.util.find_spec("gymnasium") is None,
                                     reason="gymnasium is not installed (the dev extra has it)")


def test_dm_control_observations_are_flattened_in_key_order_and_actions_are_the_given_values():
    from dm_control import suite

    adapter = load("dmc:cartpole.balance", seed=5, actions=(-1.0, 0.0, 0.5))
    raw = suite.load("cartpole", "balance", task_kwargs={"random": 5})
    ts, raw_ts = adapter.reset(), raw.reset()
    np.testing.assert_array_equal(ts.observation, np.concatenate(
        [raw_ts.observation["position"], raw_ts.observation["velocity"]]))
    assert adapter.dim == 5 and adapter.num_actions == 3
    assert adapter.observation_spec().shape == (5,)
    for index, value in enumerate((-1.0, 0.0, 0.5)):
        ts, raw_ts = adapter.step(index), raw.step([value])
        assert adapter.env.physics.data.ctrl[0] == value
        np.testing.assert_array_equal(ts.observation, np.concatenate(list(raw_ts.observation.values())))
        assert ts.reward == raw_ts.reward


def test_dm_control_episodes_end_at_the_time_limit_without_a_terminal_state():
    """dm_control's episodes are truncated (discount 1 at the last step), never terminal."""
    config, _, results = run_external(ExternalConfig(
        env="dmc:pendulum.swingup", episodes=2, agents=2, seed=3))
    np.testing.assert_array_equal(results.steps, 1000)
    assert results.truncated.all()
    assert np.isnan(results.uptime).all()
    assert config.low == (-1.0, -1.0, -8.0) and config.actions == (-1.0, 0.0, 1.0)


class _Countdown:
    """A Gymnasium-like environment: observation (steps left, last action); action 1
    terminates, otherwise the episode is truncated after `limit` steps."""

    def __init__(self, limit=3, dim=2):
        import gymnasium

        self.observation_space = gymnasium.spaces.Box(-10.0, 10.0, (dim,))
        self.action_space = gymnasium.spaces.Discrete(2, start=4)
        self.limit, self.dim, self.seeds = limit, dim, []

    def reset(self, seed=None):
        self.seeds.append(seed)
        self.left = self.limit
        return np.zeros(self.dim, dtype=np.float32), {}

    def step(self, action):
        self.left -= 1
        observation = np.full(self.dim, self.left, dtype=np.float32)
        observation[1] = action
        return observation, 2.0, action == 5, self.left == 0, {}


@needs_gymnasium
def test_gymnasium_terminated_is_terminal_and_truncated_is_not():
    env = GymAdapter(_Countdown(), "gym:countdown", seed=7)
    assert env.reset().first()
    ts = env.step(0)  # Discrete(2, start=4): index 0 is action 4
    assert ts.mid() and ts.reward == 2.0 and ts.discount == 1.0
    np.testing.assert_array_equal(ts.observation, [2.0, 4.0])
    env.step(0)
    ts = env.step(0)
    assert ts.last() and ts.discount == 1.0  # truncated: the agent bootstraps
    assert env.step(1).first()  # stepped after the end: a new episode, the action ignored
    ts = env.step(1)
    assert ts.last() and ts.discount == 0.0  # terminated
    assert env.env.seeds == [7, None]  # seeded once, then the seeded generator goes on


@needs_gymnasium
def test_gymnasium_runs_keep_terminal_and_truncated_episodes_apart():
    """CartPole-v1's early episodes fail (terminated); MountainCar-v0's hit 200 steps."""
    _, _, cartpole = run_external(ExternalConfig(env="gym:CartPole-v1", episodes=3, agents=2))
    assert not cartpole.truncated.any() and (cartpole.steps < 500).all()
    _, _, car = run_external(ExternalConfig(env="gym:MountainCar-v0", episodes=2, agents=2))
    assert car.truncated.all() and (car.steps == 200).all()


@needs_gymnasium
def test_gymnasium_seeds_and_continuous_actions():
    import gymnasium

    observation, _ = gymnasium.make("CartPole-v1").reset(seed=3)
    np.testing.assert_array_equal(load("gym:CartPole-v1", seed=3).reset().observation, observation)
    pendulum = load("gym:Pendulum-v1", seed=0, actions=(-2.0, 0.0, 2.0))
    assert pendulum.num_actions == 3
    action = pendulum.env_action(2)
    assert action.dtype == np.float32 and action.tolist() == [2.0]


@needs_gymnasium
def test_mountain_car_agents_learn_within_twenty_episodes():
    """Gymnasium's Mountain-Car with the paper's agent: the first 5 episodes hit the 200-step
    limit (197.75 steps on average, measured); episodes 11 to 20 average 143.5 (4 agents,
    seeds 0..3), bounded here at 175."""
    _, _, results = run_external(ExternalConfig(env="gym:MountainCar-v0", episodes=20, agents=4))
    assert results.steps[:, :5].mean() > 190
    assert results.steps[:, 10:].mean() < 175


@needs_gymnasium
def test_gymnasium_missing_is_one_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "gymnasium", None)
    with pytest.raises(ValueError, match=r"gym: environments need gymnasium: pip install"):
        load("gym:CartPole-v1", seed=0)


@needs_gymnasium
def test_too_many_observation_dimensions():
    with pytest.raises(ValueError) as error:
        GymAdapter(_Countdown(dim=7), "gym:countdown", seed=0)
    assert "has 7 observation dimensions; the NRBF grid (n^d neurons) takes 1 to 6" in str(error.value)


def assert_one_error_line(argv, message, capsys):
    """`lwrl train ARGV` exits with status 2 and one line on standard error holding `message`
    (argparse's own errors exit through SystemExit)."""
    try:
        status = cli.main(["train", *argv])
    except SystemExit as exit_:
        status = exit_.code
    lines = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(lines) == 1 and message in lines[0], lines


@pytest.mark.parametrize("argv, message", [
    (["dmc:pendulum.swingup", "--low", "-1", "--high", "1"],
     "dmc:pendulum.swingup has 3 observation dimensions; got 1 ranges"),
    (["dmc:pendulum.swingup", "--low", "1,1,1", "--high", "-1,2,2"],
     "low must be finite and below a finite high in every dimension"),
    (["dmc:pendulum.swingup", "--actions", "-2,0,2"],
     "action value -2 is outside the action's bounds [-1, 1]"),
    (["dmc:acrobot.swingup"], "give the values to use, e.g. --actions -1,0,1"),
    (["dmc:walker.walk", "--actions", "-1,1"], "has 24 observation dimensions"),
    (["dmc:reacher.easy", "--actions", "-1,1"], "only one-dimensional actions can be discretised"),
    (["dmc:cartpole.nope"], "Level 'nope' does not exist in domain 'cartpole'"),
    (["dmc:cartpole"], "dm_control environments are written dmc:DOMAIN.TASK"),
    (["dmc:cartpole.balance", "--plant", "mujoco"], "--plant applies to lwrl's own tasks only"),
    (["pendulum.swingup", "--actions", "-1,1"], "--actions applies to dmc: and gym: environments only"),
    (["pendulum.swing"], "invalid choice: 'pendulum.swing'"),
])
def test_bad_input_is_one_line_and_exit_2(argv, message, capsys):
    assert_one_error_line(argv, message, capsys)


@needs_gymnasium
@pytest.mark.parametrize("argv, message", [
    (["gym:CartPole-v1", "--actions", "0,1"], "has 2 discrete actions, used by index"),
    (["gym:FrozenLake-v1"], "observes a Discrete(16); only Box observations"),
    (["gym:CartPole-v1", "--trace", "accumulating", "--low", "0", "--high", "1"],
     "has 4 observation dimensions; got 1 ranges"),
])
def test_bad_gymnasium_input_is_one_line_and_exit_2(argv, message, capsys):
    assert_one_error_line(argv, message, capsys)


@needs_gymnasium
def test_cli_trains_on_gymnasium_and_writes_the_run(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.main(["train", "gym:CartPole-v1", "--episodes", "2", "--agents", "1",
                     "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "gym:CartPole-v1: 1 agent, accumulating traces" in printed and "nan" not in printed
    assert "nrbf 6^4, actions 2 discrete, 2 episodes" in printed
    config = json.loads((out / "config.json").read_text())
    assert config["env"] == "gym:CartPole-v1" and len(config["settings"]["low"]) == 4
    assert len((out / "episodes.csv").read_text().splitlines()) == 3


def test_cli_reads_negative_action_values_and_ranges(capsys):
    assert cli.main(["train", "dmc:pendulum.swingup", "--episodes", "1", "--agents", "1",
                     "--actions", "-1,1", "--low", "-1,-1,-9.5", "--high", "1,1,9.5",
                     "--centroids", "4", "--gamma", "0.9"]) == 0
    assert "gamma 0.9, nrbf 4^3, actions -1, 1, 1 episode" in capsys.readouterr().out


def test_an_episode_ending_in_a_terminal_state_has_discount_0():
    """A dm_env environment's own terminal state passes through the adapter as it is."""
    class Terminal(dm_env.Environment):
        def reset(self):
            return dm_env.restart({"x": np.array([1.0, 2.0]), "v": np.float64(3.0)})

        def step(self, action):
            return dm_env.termination(1.0, {"x": np.array([action, 0.0]), "v": np.float64(0.0)})

        def observation_spec(self):
            return {"x": specs.Array((2,), float), "v": specs.BoundedArray((), float, -1.0, 1.0)}

        def action_spec(self):
            return specs.DiscreteArray(2)

    adapter = DmEnvAdapter(Terminal(), "dmc:terminal")
    np.testing.assert_array_equal(adapter.reset().observation, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(adapter.low, [-np.inf, -np.inf, -1.0])
    ts = adapter.step(1)
    assert ts.last() and ts.discount == 0.0
    np.testing.assert_array_equal(ts.observation, [1.0, 0.0, 0.0])


@needs_gymnasium
def test_learning_curves_of_a_run(tmp_path, capsys):
    """`lwrl.studies.other_suites` draws a run's curve and states its first and final tenth."""
    from lwrl.studies.other_suites import plot_run

    run_dir = tmp_path / "car"
    assert cli.main(["train", "gym:MountainCar-v0", "--episodes", "10", "--agents", "2",
                     "--out", str(run_dir)]) == 0
    line = plot_run(str(run_dir), str(tmp_path / "figures"))
    assert line.startswith("gym:MountainCar-v0: return -200.0 ± 0.0 in episodes 1-1, ")
    assert line.endswith("in episodes 10-10 (2 agents, seeds 0..1)")
    assert (tmp_path / "figures" / "car.png").exists() and (tmp_path / "figures" / "car.svg").exists()
