"""DQN (Mnih et al. 2015, "Human-level control through deep reinforcement learning", Nature
518, 529-533) as Stable-Baselines3 implements it (`stable_baselines3.DQN`), one SB3 model per
agent, stepped by lwrl's loop (`agent.stable_baselines`: how, and why the numbers are SB3's).

Per time step, as SB3's `OffPolicyAlgorithm.collect_rollouts` does it: the transition into the
observation goes into the replay buffer (`_store_transition`; a terminal state has done = 1, a
truncation is marked a time-out, `handle_timeout_termination`), then `_on_step` (the target
network every `target_update_interval` steps, the exploration rate from its linear schedule),
then, every `train_freq` steps past `learning_starts`, `train(gradient_steps, batch_size)`:
Huber loss on r + gamma (1 - done) max_a Q_target(s', a) - Q(s, a), Adam, gradients clipped to
`max_grad_norm`. The action at the observation is then epsilon-greedy on Q (uniform before
`learning_starts`), as `DQN.predict`.

In the contract's terms: `q` holds Q(s, .) of the online network at the latest observation;
`delta` the TD error r + gamma d max Q(s') - Q(s, a) of the latest transition under the online
network (NaN where there is none); `weights` the online Q-network's parameters, flattened; the
greedy controller is that network as C (`mlp_policy` in `export/templates`).
"""

import dataclasses

import numpy as np

from lwrl.agent.arithmetic import (BACKWARD_MACS, OPTIMISER_MACS, Count, Counts, mlp_forward,
                                   mlp_parameters)
from lwrl.agent.learner_contract import ControllerForm, Learner
from lwrl.agent.stable_baselines import (ModelAgents, ModelSettings, buffer_bytes,
                                         load_arrays, network_bytes, sb3_unavailable,
                                         policy_features, saved_arrays, sequential_forward,
                                         td_error)
from lwrl.settings import check_count, check_positive, check_unit_interval, setting

BUFFER = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")
"""The replay buffer's arrays a saved agent keeps (SB3's `ReplayBuffer`'s)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class DqnSettings(ModelSettings):
    """SB3's DQN; defaults SB3's (rl-baselines3-zoo's for a task it has not tuned)."""

    buffer_size: int = setting(1_000_000)
    """Transitions the replay buffer holds."""
    learning_starts: int = setting(100, per_agent=True)
    """Steps of uniformly random actions before learning starts."""
    batch_size: int = setting(32, per_agent=True)
    """Transitions per gradient step."""
    tau: float = setting(1.0, per_agent=True)
    """Polyak coefficient of the target network's update (1: a copy)."""
    train_freq: int = setting(4, per_agent=True)
    """Steps between training calls."""
    gradient_steps: int = setting(1, per_agent=True)
    """Gradient steps per training call (-1: as many as steps collected)."""
    target_update_interval: int = setting(10_000, per_agent=True)
    """Steps between target network updates."""
    exploration_fraction: float = setting(0.1, per_agent=True)
    """Fraction of `timesteps` over which epsilon falls from its initial to its final value."""
    exploration_initial_eps: float = setting(1.0, per_agent=True)
    """Epsilon at the start."""
    exploration_final_eps: float = setting(0.05, per_agent=True)
    """Epsilon after the exploration fraction."""

    def check(self, task) -> None:
        super().check(task)
        for name in ("buffer_size", "batch_size", "train_freq", "target_update_interval"):
            check_count(name, getattr(self, name), 1)
        check_count("learning_starts", self.learning_starts, 0)
        if self.gradient_steps != -1:
            check_count("gradient_steps", self.gradient_steps, 1)
        check_positive("tau", self.tau)
        for name in ("tau", "exploration_fraction", "exploration_initial_eps", "exploration_final_eps"):
            check_unit_interval(name, getattr(self, name))

    def label(self) -> str:
        return f"dqn-{self.net_arch.replace(',', 'x')}-lr{self.learning_rate:g}-t{self.timesteps}"

    def describe(self, dim: int) -> str:
        return (f"DQN (Stable-Baselines3), MLP {self.net_arch}, lr {self.learning_rate:g} "
                f"({self.learning_rate_schedule}), gamma {self.gamma:g}, buffer {self.buffer_size}, "
                f"batch {self.batch_size}, train every {self.train_freq} steps x "
                f"{self.gradient_steps}, target every {self.target_update_interval}, epsilon "
                f"{self.exploration_initial_eps:g} -> {self.exploration_final_eps:g} over "
                f"{self.exploration_fraction:g} of {self.timesteps} steps")


class DqnAgents(ModelAgents):
    """B independent SB3 DQN models (see the module)."""

    COUNTERS = ("num_timesteps", "_n_calls", "_n_updates", "exploration_rate",
                "_current_progress_remaining")
    PENDING = "stored"

    def _model(self, settings: DqnSettings, env, seed):
        from stable_baselines3.common import utils
        return self.sb3.DQN(
            "MlpPolicy", env, learning_rate=settings.schedule(settings.learning_rate, utils),
            buffer_size=settings.buffer_size, learning_starts=settings.learning_starts,
            batch_size=settings.batch_size, tau=settings.tau, gamma=settings.gamma,
            train_freq=settings.train_freq, gradient_steps=settings.gradient_steps,
            target_update_interval=settings.target_update_interval,
            exploration_fraction=settings.exploration_fraction,
            exploration_initial_eps=settings.exploration_initial_eps,
            exploration_final_eps=settings.exploration_final_eps,
            max_grad_norm=settings.max_grad_norm, policy_kwargs={"net_arch": settings.layers()},
            replay_buffer_kwargs={"handle_timeout_termination": True}, seed=seed, device="cpu")

    @staticmethod
    def _networks(model):
        return [model.q_net]

    def _fresh(self, b: int) -> dict:
        """The agent's place in the loop: learning, inside an episode (`open`), the action it
        took and whether its transition went into the buffer, the draws to give back."""
        return {"learning": True, "open": False, "action": np.zeros(1, dtype=np.int64),
                "stored": False, "undo": None}

    def _q(self, b: int, observation):
        """Q(s, .) `(1, A)` of agent b's online network (a tensor): `QNetwork.forward`, op for
        op (`sequential_forward`)."""
        q_net = self.models[b].q_net
        with self.torch.no_grad():
            features = policy_features(self.sb3, q_net, self._tensor(observation))
            return sequential_forward(self.torch, q_net.q_net, features)

    def _step_one(self, b, first, reward, discount, observation, learn, greedy) -> int:
        model, own, arrays = self.models[b], self.own[b], self.arrays
        previous = arrays.q[b, own["action"][0]]  # Q(s, a) of the transition ending here
        if self._arrive(b, first, reward, discount, observation, learn, previous):
            return 0
        q = self._q(b, observation)
        arrays.q[b] = q[0].numpy()
        if not first:
            arrays.delta[b] = td_error(reward, discount, model.gamma, float(arrays.q[b].max()), previous)
        action = self._choose(b, q, learn, greedy)
        model._last_obs = observation
        own["action"] = np.array([action])
        return action

    def _truncated(self, b) -> None:
        """As `ModelAgents._truncated`: the transition is marked a time-out."""
        model, own = self.models[b], self.own[b]
        if own["undo"] is not None:
            self.states[b].restore(own["undo"])
        if own["stored"]:
            buffer = model.replay_buffer
            last = (buffer.pos - 1) % buffer.buffer_size
            buffer.dones[last], buffer.timeouts[last] = 1.0, 1.0
        own["stored"] = False

    def _record(self, b, reward, discount, observation) -> None:
        """SB3's step after `env.step`: store, count, `_on_step`, and train when it is time."""
        model, own = self.models[b], self.own[b]
        model._store_transition(model.replay_buffer, own["action"], observation,
                                np.array([reward], dtype=np.float32),
                                np.array([discount == 0.0]), [{}])
        own["stored"] = discount > 0.0  # a time-out, should the episode end here
        model.num_timesteps += 1
        model._update_current_progress_remaining(model.num_timesteps, model._total_timesteps)
        model._on_step()
        if model.num_timesteps % model.train_freq.frequency == 0:
            if model.num_timesteps > model.learning_starts:
                steps = model.gradient_steps if model.gradient_steps >= 0 else model.train_freq.frequency
                if steps > 0:
                    model.train(batch_size=model.batch_size, gradient_steps=steps)
                    model.policy.set_training_mode(False)
                    self._trained(b)
            self._horizon_reached(b)

    def _choose(self, b, q, learn, greedy) -> int:
        """`DQN.predict` on the latest observation (uniform before `learning_starts`),
        greedy where asked or once learning is over; the draws are kept to give back."""
        model, own = self.models[b], self.own[b]
        if self._acts_greedily(b, learn, greedy):
            return int(q.argmax(dim=1)[0])
        own["undo"] = self.states[b].snapshot()
        if model.num_timesteps < model.learning_starts and learn:
            return int(np.array([model.action_space.sample()])[0])
        if np.random.rand() < model.exploration_rate:
            return int(np.array([model.action_space.sample()])[0])
        return int(q.argmax(dim=1)[0])

    def action_values(self, states, weights=None) -> np.ndarray:
        """Q(s, .) of the online network, `(B, ..., A)` (or `(..., A)` for `weights`)."""
        return self._over_agents(states, weights, lambda networks, flat: networks[0](
            self._tensor(flat)).numpy().astype(np.float64))

    def controller(self, b: int) -> ControllerForm:
        """The greedy Q-network, argmax_a Q(s, a), as a plain MLP forward pass in C
        (`mlp_policy`)."""
        return mlp_form(self.torch, self.models[b].q_net.q_net, self.arrays.weights[b],
                        self.task, "ReLU")

    def _buffer_saved(self, b: int, prefix: str) -> dict:
        return saved_arrays(self.models[b].replay_buffer, prefix, BUFFER)

    def _buffer_loaded(self, b: int, prefix: str, arrays: dict) -> None:
        load_arrays(self.models[b].replay_buffer, prefix, arrays, BUFFER)


def mlp_form(torch, sequential, weights, task, activation: str) -> ControllerForm:
    """An MLP of `Linear` layers with `activation` between them (`torch.nn.Sequential`) as the
    export's `mlp_policy` template takes it: every layer's weights (row-major, out x in) then
    its biases, one flat array; the layer sizes; the activation's C macro. What follows the
    last layer is the template's (none for discrete actions, tanh for a continuous one)."""
    layers = [module for module in sequential if isinstance(module, torch.nn.Linear)]
    sizes = [layers[0].in_features] + [layer.out_features for layer in layers]
    flat = np.concatenate([np.concatenate([layer.weight.detach().cpu().numpy().ravel(),
                                           layer.bias.detach().cpu().numpy()]) for layer in layers])
    return ControllerForm(
        template="mlp_policy",
        values={"weights": flat.astype(np.float64), "sizes": ", ".join(map(str, sizes)),
                "layers": len(layers), "widest": max(sizes), "parameters": len(flat),
                "activation": activation.upper(), "shape": " -> ".join(map(str, sizes)),
                "low": np.array(task.ranges.low, dtype=np.float64), "high": np.array(task.ranges.high, dtype=np.float64)},
        stored=("weights",), ranges=(task.ranges.low, task.ranges.high), check=lambda real: None)


def make(settings, task, seeds) -> DqnAgents:
    """B DQN agents, agent b an SB3 model with `settings[b]` seeded with `seeds[b]`."""
    return DqnAgents(settings, task, seeds)


def load(document, arrays) -> DqnAgents:
    """The agents `DqnAgents.saved` wrote (a ValueError if the parts do not fit)."""
    return DqnAgents.loaded(document, arrays, DqnSettings)


def memory(settings, task) -> int:
    """Bytes of one agent: its replay buffer, and the online and target networks with Adam's
    two moments (four copies of the parameters)."""
    dim = len(task.state_names)
    return (buffer_bytes(settings.buffer_size, dim, 2, 3)
            + network_bytes(dim, settings.layers(), task.action.n, 4))


def arithmetic(settings, task, steps: int | None = None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`; `dqn_jax`'s too): one Q MLP of
    `net_arch`, ReLU (no exponential). A greedy decision is one forward pass of Q. An
    agent-step of learning is that forward pass for the epsilon-greedy action and its share
    of the updates: every `train_freq` steps past `learning_starts`, `gradient_steps`
    gradient steps, each over `batch_size` transitions a forward and backward pass of the
    online network (3 forward passes, `BACKWARD_MACS`) and a forward pass of the target
    network, and `OPTIMISER_MACS` per parameter; every `target_update_interval` steps the
    target's Polyak update (2 per parameter). Amortised over `steps` steps of learning from
    an agent's first (the training calls in them), or per step of a long run where None."""
    dim, actions, layers = len(task.state_names), task.action.n, settings.layers()
    sizes = [dim, *layers, actions]
    q, parameters = mlp_forward(sizes, False), mlp_parameters(sizes)
    gradient_steps = (settings.gradient_steps if settings.gradient_steps >= 0
                      else settings.train_freq)
    call = gradient_steps * (settings.batch_size * (1 + BACKWARD_MACS + 1) * q
                             + Count(OPTIMISER_MACS * parameters))
    interval = settings.target_update_interval
    if steps:
        calls = (steps // settings.train_freq
                 - min(settings.learning_starts, steps) // settings.train_freq) / steps
        targets = (steps // interval) / steps
    else:
        calls, targets = 1 / settings.train_freq, 1 / interval
    update = call * calls + Count(2 * parameters * targets)
    return Counts(q, q + update, update,
                  f"Q {'-'.join(map(str, sizes))} ReLU ({parameters} parameters); "
                  f"{gradient_steps} x {settings.batch_size} transitions every "
                  f"{settings.train_freq} steps from step {settings.learning_starts} "
                  f"({__name__}.arithmetic)")


ZOO_SETS = {
    "MountainCar-v0": dict(timesteps=120_000, learning_rate=4e-3, batch_size=128, buffer_size=10_000,
                           learning_starts=1000, gamma=0.98, target_update_interval=600,
                           train_freq=16, gradient_steps=8, exploration_fraction=0.2,
                           exploration_final_eps=0.07, net_arch="256,256"),
    "CartPole-v1": dict(timesteps=50_000, learning_rate=2.3e-3, batch_size=64, buffer_size=100_000,
                        learning_starts=1000, gamma=0.99, target_update_interval=10,
                        train_freq=256, gradient_steps=128, exploration_fraction=0.16,
                        exploration_final_eps=0.04, net_arch="256,256"),
    "Acrobot-v1": dict(timesteps=100_000, learning_rate=6.3e-4, batch_size=128, buffer_size=50_000,
                       learning_starts=0, gamma=0.99, target_update_interval=250, train_freq=4,
                       gradient_steps=-1, exploration_fraction=0.12, exploration_final_eps=0.1,
                       net_arch="256,256"),
}
"""rl-baselines3-zoo's DQN sets (policy MlpPolicy; `stable_baselines.ZOO`)."""
CHECKED = dict(net_arch="16,16", batch_size=16, buffer_size=64, learning_starts=20,
               target_update_interval=50)
"""What the contract's checks run DQN with (`Learner.checked`): small networks and batches,
updates from step 20 of their 120, a replay buffer that wraps and a target network copied
within them."""

LEARNER = Learner(
    name="dqn", title="DQN (Stable-Baselines3): an MLP Q-network, replay and a target network",
    source="Mnih et al. (2015), Nature 518; Raffin et al. (2021), JMLR 22(268): stable_baselines3.DQN",
    settings=DqnSettings, make=make, load=load, memory=memory,
    unavailable=sb3_unavailable("dqn"),
    tuned=ZOO_SETS, checked=CHECKED, arithmetic=arithmetic)
"""The `dqn` learner as the registry holds it (`agent.LEARNERS`)."""
DqnAgents.learner = LEARNER
