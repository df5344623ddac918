"""The Stable-Baselines3 learners (`agent.dqn`, `agent.ppo`, `agent.sac`, `agent.td3`):
stepped by lwrl's loop they compute what SB3's own `learn()` computes, to the bit, on the same
environment and seed, terminal states and truncations included, with discrete actions and
continuous ones; their settings are checked in one line; their greedy networks export as
C99 that picks torch's action, or for SAC and TD3 returns it. Tiny budgets (seconds);
skipped, naming the extra, where PyTorch and Stable-Baselines3 are not installed."""

import numpy as np
import pytest

from lwrl.agent import stable_baselines

if stable_baselines.missing_libraries():
    pytest.skip("the baselines extra is not installed (pip install 'lwrl[baselines]')",
                allow_module_level=True)

import gymnasium  # noqa: E402
import torch  # noqa: E402
from stable_baselines3 import DQN, PPO, SAC, TD3  # noqa: E402
from stable_baselines3.common.noise import NormalActionNoise  # noqa: E402

from lwrl.agent import dqn, ppo, sac, td3  # noqa: E402
from lwrl.gym import SuiteEnv  # noqa: E402
from lwrl.tasks.commands import commands  # noqa: E402
from lwrl.runners.config import RunConfig, task_spec  # noqa: E402

TASK = "cartpole.balance"
TIME_LIMIT = 0.6
"""Seconds per episode: 30 steps, so the runs see both pole falls (terminal states) and
truncations."""
SEED = 3


class UnitActions(gymnasium.ActionWrapper):
    """A task of continuous actions as lwrl's continuous learners see it: the action in
    `Box(-1, 1)` becomes the actuator's command as every run loop makes it
    (`tasks.commands`)."""

    def __init__(self, env):
        super().__init__(env)
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)

    def action(self, action):
        control_range = np.array([self.env.unwrapped.definition.control_range])
        return commands(control_range, np.asarray(action, dtype=np.float64).reshape(1))


def environment(actions: str = "discrete"):
    env = SuiteEnv("cartpole", "balance", plant="analytic", time_limit=TIME_LIMIT, actions=actions)
    return UnitActions(env) if actions == "continuous" else env


def lwrl_loop(agents, seed: int, steps: int, calls: int = 10**9):
    """Step one agent through the Gymnasium environment as lwrl's loops do (a terminal
    state gets no action; a truncated episode's last observation gets one, given back at
    the next episode's start) until it has learned for `steps` steps, or for `calls` time
    steps. Returns the episodes' ends seen: (terminal, truncated) counts."""
    env = environment("continuous" if agents.continuous else "discrete")
    observation, _ = env.reset(seed=seed)
    first, reward, discount, truncated = True, 0.0, 1.0, False
    ends = [0, 0]
    for _ in range(calls):
        if agents.models[0].num_timesteps >= steps:
            break
        action = agents.step([first], [reward], [discount], observation[None])[0]
        if (not first and discount == 0.0) or truncated:
            ends[0 if discount == 0.0 else 1] += 1
            observation, _ = env.reset()
            first, reward, discount, truncated = True, 0.0, 1.0, False
            continue
        observation, reward, terminated, truncated, _ = env.step(
            np.array([action]) if agents.continuous else action)
        first, discount = False, 0.0 if terminated else 1.0
    return ends


def parameters(module) -> np.ndarray:
    return torch.nn.utils.parameters_to_vector(module.parameters()).detach().numpy()


DQN_SETTINGS = dict(net_arch="16,16", learning_rate=1e-3, buffer_size=500, learning_starts=40,
                    batch_size=16, train_freq=4, gradient_steps=2, target_update_interval=50,
                    exploration_fraction=0.5, gamma=0.98)
PPO_SETTINGS = dict(net_arch="16,16", learning_rate=1e-3, n_steps=64, batch_size=32, n_epochs=2,
                    gamma=0.98, gae_lambda=0.9)


def sb3_kwargs(settings) -> dict:
    kwargs = {k: v for k, v in settings.items() if k != "net_arch"}
    return dict(kwargs, policy_kwargs={"net_arch": [int(w) for w in settings["net_arch"].split(",")]},
                seed=SEED, device="cpu")


def test_dqn_in_lwrls_loop_is_sb3s_learn_to_the_bit():
    steps = 400
    agents = dqn.make([dqn.DqnSettings(timesteps=steps, **DQN_SETTINGS)], task_spec(TASK), [SEED])
    terminal, truncated = lwrl_loop(agents, SEED, steps)
    assert terminal > 0 and truncated > 0  # both kinds of end were seen
    model = DQN("MlpPolicy", environment(), replay_buffer_kwargs={"handle_timeout_termination": True},
                **sb3_kwargs(DQN_SETTINGS))
    model.learn(total_timesteps=steps)
    mine = agents.models[0]
    assert mine._n_updates == model._n_updates > 0
    np.testing.assert_array_equal(parameters(mine.q_net), parameters(model.q_net))
    np.testing.assert_array_equal(parameters(mine.q_net_target), parameters(model.q_net_target))
    used = model.replay_buffer.pos
    for name in ("observations", "actions", "rewards", "dones", "timeouts"):
        np.testing.assert_array_equal(getattr(mine.replay_buffer, name)[:used],
                                      getattr(model.replay_buffer, name)[:used], err_msg=name)
    assert model.replay_buffer.timeouts[:used].sum() > 0


def test_ppo_in_lwrls_loop_is_sb3s_learn_to_the_bit():
    steps = 3 * PPO_SETTINGS["n_steps"]
    agents = ppo.make([ppo.PpoSettings(timesteps=steps, **PPO_SETTINGS)], task_spec(TASK), [SEED])
    terminal, truncated = lwrl_loop(agents, SEED, steps)
    assert terminal > 0 and truncated > 0
    model = PPO("MlpPolicy", environment(), **sb3_kwargs(PPO_SETTINGS))
    model.learn(total_timesteps=steps)
    assert agents.models[0]._n_updates == model._n_updates > 0
    np.testing.assert_array_equal(parameters(agents.models[0].policy), parameters(model.policy))


OFF_POLICY_SETTINGS = dict(net_arch="8", learning_rate=1e-3, buffer_size=200, learning_starts=20,
                           batch_size=8, gamma=0.98)
"""SAC's and TD3's tiny settings (the replay buffer wraps around within the runs)."""


@pytest.mark.parametrize("learner, algorithm, extra", [
    (sac, SAC, {}),
    (td3, TD3, {"action_noise": NormalActionNoise(np.zeros(1), td3.Td3Settings().noise_std * np.ones(1))}),
])
def test_sac_and_td3_in_lwrls_loop_are_sb3s_learn_to_the_bit(learner, algorithm, extra):
    """Continuous actions: the warm-up's uniform actions, SAC's samples, TD3's noise and the
    updates, through pole falls and truncations (bootstrapped, as time-outs)."""
    steps = 300
    settings = learner.LEARNER.settings(timesteps=steps, **OFF_POLICY_SETTINGS)
    agents = learner.make([settings], task_spec(TASK, actions="continuous"), [SEED])
    terminal, truncated = lwrl_loop(agents, SEED, steps)
    assert terminal > 0 and truncated > 0
    model = algorithm("MlpPolicy", environment("continuous"),
                      replay_buffer_kwargs={"handle_timeout_termination": True}, **extra,
                      **sb3_kwargs(OFF_POLICY_SETTINGS))
    model.learn(total_timesteps=steps)
    mine = agents.models[0]
    assert mine._n_updates == model._n_updates > 0
    np.testing.assert_array_equal(parameters(mine.policy), parameters(model.policy))
    assert model.replay_buffer.full
    for name in ("observations", "actions", "rewards", "dones", "timeouts"):
        np.testing.assert_array_equal(getattr(mine.replay_buffer, name),
                                      getattr(model.replay_buffer, name), err_msg=name)
    assert model.replay_buffer.timeouts.sum() > 0
    if learner is sac:
        np.testing.assert_array_equal(mine.log_ent_coef.detach().numpy(), model.log_ent_coef.detach().numpy())


def test_sac_refuses_a_task_of_discrete_actions_in_one_line():
    with pytest.raises(ValueError, match="--action-kind continuous") as error:
        RunConfig(task="pendulum.swingup", learner="sac")
    assert "\n" not in str(error.value)


def test_after_its_horizon_an_agent_acts_greedily_and_learns_no_more():
    steps = 64
    agents = ppo.make([ppo.PpoSettings(timesteps=steps, **PPO_SETTINGS)], task_spec(TASK), [SEED])
    lwrl_loop(agents, SEED, steps)
    before = agents.arrays.weights.copy()
    lwrl_loop(agents, SEED + 1, steps + 1, calls=3 * PPO_SETTINGS["n_steps"])
    assert agents.models[0].num_timesteps == steps
    np.testing.assert_array_equal(agents.arrays.weights, before)


@pytest.mark.parametrize("learner, settings", [(dqn, DQN_SETTINGS), (ppo, PPO_SETTINGS)])
def test_a_greedy_evaluation_draws_nothing_and_acts_on_each_agents_own_network(learner, settings):
    """Greedy steps without learning, in a batch of two agents: each one's action is the
    argmax of its own network's outputs (`arrays.q`) and every agent's generators are as they
    were, so it goes on learning as if it had not been evaluated."""
    make = dqn.DqnSettings if learner is dqn else ppo.PpoSettings
    agents = learner.make([make(timesteps=100, **settings)] * 2, task_spec(TASK), [SEED, SEED + 1])
    before = [agents.states[b].saved("")[1]["torch"].copy() for b in range(2)]
    numpy_before = [agents.states[b].numpy_state[1].copy() for b in range(2)]
    observations = np.random.default_rng(0).normal(size=(12, 2, 4))
    for t, observation in enumerate(observations):
        actions = agents.step([t == 0] * 2, [1.0] * 2, [1.0] * 2, observation, learn=False, greedy=True)
        np.testing.assert_array_equal(actions, agents.arrays.q.argmax(axis=1))
        assert not np.array_equal(*agents.arrays.q)  # two networks of their own
    for b in range(2):
        np.testing.assert_array_equal(agents.states[b].saved("")[1]["torch"], before[b])
        np.testing.assert_array_equal(agents.states[b].numpy_state[1], numpy_before[b])


@pytest.mark.parametrize("learner, settings", [(dqn, DQN_SETTINGS), (ppo, PPO_SETTINGS)])
def test_the_direct_forward_pass_is_sb3s_to_the_bit(learner, settings):
    """DQN's Q-values (`_q`) and PPO's greedy step (`_forward`), the layers' operations
    called directly, are SB3's own forward pass bit for bit, on a network that has learned."""
    make = dqn.DqnSettings if learner is dqn else ppo.PpoSettings
    agents = learner.make([make(timesteps=200, **settings)], task_spec(TASK), [SEED])
    lwrl_loop(agents, SEED, 200)
    model = agents.models[0]
    assert model._n_updates > 0
    for observation in np.random.default_rng(1).normal(scale=3.0, size=(200, 1, 4)):
        tensor = torch.as_tensor(observation)
        with torch.no_grad():
            if learner is dqn:
                ours, sb3s = [agents._q(0, observation)], [model.q_net(tensor)]
            else:
                ours = agents._forward(0, observation, deterministic=True)
                sb3s = (*model.policy(tensor, deterministic=True),
                        model.policy.get_distribution(tensor).distribution.logits)
        for mine, theirs in zip(ours, sb3s, strict=True):
            assert mine.dtype == theirs.dtype
            np.testing.assert_array_equal(mine.numpy(), theirs.numpy())


def test_models_leave_nothing_under_the_temporary_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile
    monkeypatch.setattr(tempfile, "tempdir", None)
    agents = dqn.make([dqn.DqnSettings(timesteps=64, **DQN_SETTINGS)], task_spec(TASK), [SEED])
    lwrl_loop(agents, SEED, 64)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("learner, setting, value, expected", [
    ("dqn", "net_arch", "64,x", "net_arch must be comma-separated positive integers"),
    ("dqn", "exploration_final_eps", 1.5, "exploration_final_eps"),
    ("ppo", "clip_range", 0.0, "clip_range"),
])
def test_bad_settings_are_one_line(learner, setting, value, expected):
    with pytest.raises(ValueError, match=expected) as error:
        RunConfig(task=TASK, learner=learner, **{setting: value})
    assert "\n" not in str(error.value)


HARNESS = r"""
#include <stdio.h>
#include "lwrl_policy.h"
int main(void)
{
    lwrl_real state[LWRL_STATE_DIM];
    while (fread(state, sizeof(lwrl_real), LWRL_STATE_DIM, stdin) == LWRL_STATE_DIM)
#ifdef LWRL_NUM_ACTIONS
        printf("%d\n", lwrl_act(state));
#else
        printf("%a\n", (double)lwrl_act(state)); /* a continuous action, exact */
#endif
    return 0;
}
"""


def exported_actions(path, out_dir, states, dtype="float"):
    """The actions of the C controller that `export_c` writes of the agent file `path` in
    `out_dir` (`dtype`), built with HARNESS, at `states` `(M, d)`: indices, or reals."""
    import subprocess

    from lwrl.export.c import DTYPES, export_c, find_compiler
    written = export_c(path, out_dir, dtype=dtype)
    (out_dir / "main.c").write_text(HARNESS)
    subprocess.run([find_compiler(), "-O2", "-std=c99", "-I", str(out_dir), "main.c",
                    "lwrl_policy.c", "-o", "act", "-lm"], cwd=out_dir, check=True)
    output = subprocess.run([str(out_dir / "act")], input=states.astype(DTYPES[dtype]).tobytes(),
                            capture_output=True, check=True).stdout.decode().split()
    return written, np.array([float.fromhex(v) if v.startswith(("0x", "-0x")) else int(v)
                              for v in output])


@pytest.mark.parametrize("learner", ["dqn", "ppo"])
def test_the_exported_network_picks_torchs_greedy_action(learner, tmp_path):
    """The C99 forward pass of the trained network (`export_c`, template `mlp_policy`) picks
    the action torch's network picks, on 5000 states in and around the task's ranges."""
    from lwrl.agent import io as agent_io
    module, settings = (dqn, dqn.DqnSettings(timesteps=400, **DQN_SETTINGS)) if learner == "dqn" \
        else (ppo, ppo.PpoSettings(timesteps=192, **PPO_SETTINGS))
    agents = module.make([settings], task_spec(TASK), [SEED])
    lwrl_loop(agents, SEED, settings.timesteps)
    path = tmp_path / "agent.npz"
    agent_io.save(path, agents, {"config": {"task": TASK}})
    states = around_the_ranges(5000).astype(np.float32)
    written, actions = exported_actions(path, tmp_path / "c", states)
    # DQN: the online Q-network, all its weights; PPO: the actor, without the critic
    assert written["weight_bytes"] == 4 * written["parameters"]
    assert (written["parameters"] == agents.arrays.weights.shape[1]) == (learner == "dqn")
    values = agents.action_values(states.astype(np.float64))[0]
    np.testing.assert_array_equal(actions, values.argmax(axis=1))
    assert len(set(values.argmax(axis=1))) > 1  # the test tells actions apart


def around_the_ranges(count: int) -> np.ndarray:
    """`count` states `(count, d)` of the task, uniform in its ranges widened by a quarter
    on each side."""
    low, high = np.array(task_spec(TASK).ranges.low), np.array(task_spec(TASK).ranges.high)
    return low + (high - low) * np.random.default_rng(0).uniform(-0.25, 1.25, (count, len(low)))


@pytest.mark.parametrize("learner", [sac, td3])
def test_the_exported_actor_returns_the_agents_greedy_action(learner, tmp_path):
    """SAC's and TD3's actors after a short training, exported (`export_c`, template
    `mlp_policy` for a continuous action: tanh after the last layer, SAC's log standard
    deviation's head left out): `lwrl_act` returns a real, the Python agent's greedy action
    (`Agents.step`, greedy: SB3's `predict(deterministic=True)`, tanh(mu(s)) in float32)
    within float32's rounding, in float and in double, on 2000 states in and around the
    task's ranges."""
    from lwrl.agent import io as agent_io
    settings = learner.LEARNER.settings(timesteps=300, **OFF_POLICY_SETTINGS)
    agents = learner.make([settings], task_spec(TASK, actions="continuous"), [SEED])
    lwrl_loop(agents, SEED, settings.timesteps)
    path = tmp_path / "agent.npz"
    agent_io.save(path, agents, {"config": {"task": TASK, "actions": "continuous"}})
    states = around_the_ranges(2000).astype(np.float32).astype(np.float64)  # as torch reads them
    python = np.array([agents.step([True], [0.0], [1.0], state[None], learn=False, greedy=True)[0]
                       for state in states])
    assert python.std() > 0.05  # the test tells actions apart
    for dtype in ("float", "double"):
        written, actions = exported_actions(path, tmp_path / dtype, states, dtype)
        np.testing.assert_allclose(actions, python, rtol=0, atol=1e-5)
        assert written["parameters"] < agents.arrays.weights.shape[1]  # the actor alone
    assert "#define LWRL_ACTION_LOW (-10.0f)" in (tmp_path / "float" / "lwrl_policy.h").read_text()
