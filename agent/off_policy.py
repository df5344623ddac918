"""What lwrl's SB3 learners of continuous actions (`agent.sac`, `agent.td3`) share: an
off-policy actor-critic of Stable-Baselines3 (Raffin et al. 2021, JMLR 22(268)) per agent,
stepped by lwrl's loop as SB3's `OffPolicyAlgorithm.learn()` steps it
(`agent.stable_baselines`: how, and why the numbers are SB3's).

Per time step, as `collect_rollouts` and `learn()` do it: the transition into the observation
goes into the replay buffer (`_store_transition`; a terminal state has done = 1, a truncation
is marked a time-out, `handle_timeout_termination`, so its target bootstraps), `_on_step`,
then, every `train_freq` steps past `learning_starts`, `train(gradient_steps, batch_size)`.
The action at the observation is SB3's `_sample_action`: uniform over [-1, 1] before
`learning_starts` (where the agent learns), else the policy's (SAC's sample, TD3's actor)
plus the action noise (TD3's Gaussian), clipped; greedy, `predict(deterministic=True)`. The
action space is `Box(-1, 1)` (`stable_baselines.spaces_env`), so the action SB3 would give
its environment is the one lwrl's loop scales to the actuator's range (`tasks.commands`).

In the contract's terms: `actions` is `continuous`, with no action values (no `q`); `taken`
`(B,)` holds the first critic's Q1(s, a) of the action taken at the latest observation (as
the replay buffer holds it), from which the next TD error is computed;
`delta` the TD error r + gamma d Q1(s', a') - Q1(s, a) of the latest transition, a' the
action taken at s' (NaN where there is none); `weights` the actor's and the critics'
parameters, flattened (not the target networks'); action values are the actor's greedy
action, state values the first critic's Q1 of it.
"""

import collections
import dataclasses
from typing import ClassVar

import numpy as np

from lwrl.agent.arithmetic import OPTIMISER_MACS, Count, Counts, mlp_forward, mlp_parameters
from lwrl.agent.stable_baselines import (ModelAgents, NetworkSettings, buffer_bytes,
                                         load_arrays, network_bytes, saved_arrays, td_error)
from lwrl.settings import check_count, check_positive, check_unit_interval, setting

BUFFER = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")
"""The replay buffer's arrays a saved agent keeps (SB3's `ReplayBuffer`'s)."""
ZOO = ("DLR-RM/rl-baselines3-zoo, hyperparams/sac.yml and hyperparams/td3.yml (Pendulum-v1) at "
       "commit 22e3ff2450fd92033f7f032915e1f64894a09584")
"""Where the learners' defaults come from (as `stable_baselines.ZOO`): the zoo's Pendulum-v1
sets, SB3's own defaults for what a set leaves out."""
CHECKED = dict(net_arch="16,16", batch_size=16, buffer_size=64, learning_starts=20,
               train_freq=4)
"""What the contract's checks run SAC and TD3 with (`Learner.checked`): small networks and
batches, updates from step 20 of their 120 (TD3's default starts at 10 000), every fourth
step (a gradient step of SB3's costs milliseconds), a replay buffer that wraps within them."""
ADAM_MACS = OPTIMISER_MACS - 2
"""An optimiser step's arithmetic per parameter without the clipping's global norm and
scale (`arithmetic.OPTIMISER_MACS`): SAC and TD3 clip no gradients."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class OffPolicySettings(NetworkSettings):
    """What SAC and TD3 take beside `NetworkSettings` (SB3's names; defaults SB3's, but for
    the horizon and step size both of the zoo's Pendulum-v1 sets give, `ZOO`)."""

    TITLE: ClassVar[str] = ""
    """The algorithm's name (`SAC`, `TD3`)."""

    timesteps: int = setting(20_000)
    """Environment steps of learning, SB3's `total_timesteps` (the zoo's `n_timesteps`);
    the agent then acts greedily."""
    net_arch: str = setting("256,256")
    """Hidden layers' widths of the actor and of each critic, comma-separated (SB3's
    `net_arch`)."""
    learning_rate: float = setting(1e-3, per_agent=True)
    """Adam's step size (the actor's, the critics' and SAC's entropy coefficient's)."""
    buffer_size: int = setting(1_000_000)
    """Transitions the replay buffer holds."""
    learning_starts: int = setting(100, per_agent=True)
    """Steps of uniformly random actions before learning starts."""
    batch_size: int = setting(256, per_agent=True)
    """Transitions per gradient step."""
    tau: float = setting(0.005, per_agent=True)
    """Polyak coefficient of the target networks' update."""
    train_freq: int = setting(1, per_agent=True)
    """Steps between training calls."""
    gradient_steps: int = setting(1, per_agent=True)
    """Gradient steps per training call (-1: as many as steps collected)."""

    def check(self, task) -> None:
        super().check(task)
        for name in ("buffer_size", "batch_size", "train_freq"):
            check_count(name, getattr(self, name), 1)
        check_count("learning_starts", self.learning_starts, 0)
        if self.gradient_steps != -1:
            check_count("gradient_steps", self.gradient_steps, 1)
        check_positive("tau", self.tau)
        check_unit_interval("tau", self.tau)

    def label(self) -> str:
        return (f"{self.TITLE.lower()}-{self.net_arch.replace(',', 'x')}-lr{self.learning_rate:g}"
                f"-t{self.timesteps}")

    def describe(self, dim: int) -> str:
        return (f"{self.TITLE} (Stable-Baselines3), MLP {self.net_arch}, lr {self.learning_rate:g} "
                f"({self.learning_rate_schedule}), gamma {self.gamma:g}, buffer {self.buffer_size}, "
                f"batch {self.batch_size}, train every {self.train_freq} steps x "
                f"{self.gradient_steps} from step {self.learning_starts}, tau {self.tau:g}, "
                f"{self.exploration()}, {self.timesteps} steps")

    def exploration(self) -> str:
        """What the learner's own settings are, in a few words (`describe`)."""
        raise NotImplementedError

    def common(self, schedules) -> dict:
        """The keyword arguments of SB3's constructor these settings give."""
        return dict(learning_rate=self.schedule(self.learning_rate, schedules),
                    buffer_size=self.buffer_size, learning_starts=self.learning_starts,
                    batch_size=self.batch_size, tau=self.tau, gamma=self.gamma,
                    train_freq=self.train_freq, gradient_steps=self.gradient_steps,
                    policy_kwargs={"net_arch": self.layers()},
                    replay_buffer_kwargs={"handle_timeout_termination": True}, device="cpu")

    def training(self, steps: int | None) -> tuple[int, float]:
        """`(gradient steps per training call, training calls per step)` over `steps` steps
        of learning from an agent's first (or per step of a long run where None)."""
        gradient_steps = self.gradient_steps if self.gradient_steps >= 0 else self.train_freq
        if not steps:
            return gradient_steps, 1 / self.train_freq
        calls = steps // self.train_freq - min(self.learning_starts, steps) // self.train_freq
        return gradient_steps, calls / steps


def fits_continuous(name: str):
    """A learner's `fits`: every task made with continuous actions; else one line naming
    `--action-kind continuous`."""
    def fits(task):
        if task.actions != "continuous":
            return (f"{name} takes continuous actions; {task.name} was made with "
                    f"{task.actions} ones: run it with actions='continuous' (--action-kind continuous)")
        return None
    return fits


class OffPolicyAgents(ModelAgents):
    """B independent SB3 off-policy actor-critics (see the module); subclasses build the
    model (`_model`) and name its optimisers."""

    COUNTERS = ("num_timesteps", "_n_updates", "_current_progress_remaining")
    PENDING = "stored"

    Arrays = collections.namedtuple("Arrays", "taken delta diverged weights")
    """`ModelAgents.Arrays` without action values: `taken` `(B,)` in place of `q` (see the
    module)."""

    def value_arrays(self, batch: int) -> dict:
        return {"taken": np.zeros(batch)}

    @staticmethod
    def value_arrays_loaded(arrays: dict) -> dict:
        """Files written before `taken` hold it as `q` `(B, 1)`."""
        if "taken" not in arrays and "q" in arrays:
            return {**arrays, "taken": arrays["q"][:, 0]}
        return arrays

    @staticmethod
    def _networks(model):
        return [model.actor, model.critic]

    def _fresh(self, b: int) -> dict:
        """The agent's place in the loop: learning, inside an episode (`open`), the action it
        took (as the replay buffer holds it) and whether its transition went into the
        buffer, the draws to give back."""
        return {"learning": True, "open": False, "action": np.zeros((1, 1), dtype=np.float32),
                "stored": False, "undo": None}

    def _step_one(self, b, first, reward, discount, observation, learn, greedy) -> float:
        model, own, arrays = self.models[b], self.own[b], self.arrays
        previous = arrays.taken[b]  # Q1(s, a) of the transition ending here
        if self._arrive(b, first, reward, discount, observation, learn, previous):
            return 0.0
        model._last_obs = observation
        if self._acts_greedily(b, learn, greedy):
            action, _ = model.predict(observation, deterministic=True)
            stored = action
        else:
            own["undo"] = self.states[b].snapshot()
            action, stored = model._sample_action(model.learning_starts if learn else 0,
                                                  model.action_noise, 1)
        with self.torch.no_grad():
            q = model.critic.q1_forward(self._tensor(observation), self.torch.as_tensor(stored))
        arrays.taken[b] = float(q[0, 0])
        if not first:
            arrays.delta[b] = td_error(reward, discount, model.gamma, arrays.taken[b], previous)
        own["action"] = np.asarray(stored)
        return float(action[0, 0])

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
                model.train(batch_size=model.batch_size, gradient_steps=steps)
                model.policy.set_training_mode(False)
                self._trained(b)
            self._horizon_reached(b)

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

    def greedy_actions(self, states, weights=None) -> np.ndarray:
        """The actor's greedy action in [-1, 1], `(B, ...)` (or `(...)` for `weights`)."""
        return self._over_agents(states, weights, lambda networks, flat: networks[0]._predict(
            self._tensor(flat), deterministic=True).numpy().astype(np.float64))[..., 0]

    def state_values(self, states, weights=None) -> np.ndarray:
        """The first critic's Q1(s, greedy action), `(B, ...)` (or `(...)` for `weights`)."""
        def values(networks, flat):
            actor, critic = networks
            tensor = self._tensor(flat)
            greedy = actor._predict(tensor, deterministic=True)
            return critic.q1_forward(tensor, greedy).numpy().astype(np.float64)
        return self._over_agents(states, weights, values)[..., 0]

    def _buffer_saved(self, b: int, prefix: str) -> dict:
        return saved_arrays(self.models[b].replay_buffer, prefix, BUFFER)

    def _buffer_loaded(self, b: int, prefix: str, arrays: dict) -> None:
        load_arrays(self.models[b].replay_buffer, prefix, arrays, BUFFER)


def memory(settings, task, actor_outputs: int, actor_copies: int) -> int:
    """Bytes of one agent: its replay buffer, the actor (`actor_outputs` outputs) in
    `actor_copies` float32 copies (parameters, gradients, Adam's two moments, a target) and
    two critics of (s, a) with their targets, gradients and Adam's moments (five copies)."""
    dim, layers = len(task.state_names), settings.layers()
    return (buffer_bytes(settings.buffer_size, dim, 2, 3)
            + network_bytes(dim, layers, actor_outputs, actor_copies)
            + 2 * network_bytes(dim + 1, layers, 1, 5))


def network_counts(settings, task, actor_outputs: int) -> tuple:
    """`(actor, critic, actor parameters, critic parameters, description)`: one forward
    pass (`Count`) and the parameters of the actor MLP (`actor_outputs` outputs) and of one
    critic MLP of (s, a), ReLU (SB3's `create_mlp`), `net_arch` each."""
    dim, layers = len(task.state_names), settings.layers()
    actor_sizes, critic_sizes = [dim, *layers, actor_outputs], [dim + 1, *layers, 1]
    actor, critic = mlp_forward(actor_sizes, False), mlp_forward(critic_sizes, False)
    actor_parameters, critic_parameters = mlp_parameters(actor_sizes), mlp_parameters(critic_sizes)
    return (actor, critic, actor_parameters, critic_parameters,
            f"actor {'-'.join(map(str, actor_sizes))} and 2 critics "
            f"{'-'.join(map(str, critic_sizes))} ReLU ({actor_parameters + 2 * critic_parameters} "
            f"parameters)")


def counted(settings, decision: Count, action: Count, gradient_step: Count, steps, source: str) -> Counts:
    """A learner's `Counts` from its greedy `decision`, the `action` of a step of learning
    and one `gradient_step`'s arithmetic, the gradient steps amortised over `steps`
    (`OffPolicySettings.training`)."""
    gradient_steps, calls = settings.training(steps)
    update = gradient_step * (gradient_steps * calls)
    return Counts(decision, action + update, update,
                  f"{source}; {gradient_steps} x {settings.batch_size} transitions every "
                  f"{settings.train_freq} steps from step {settings.learning_starts}")
