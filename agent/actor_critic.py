"""A continuous actor-critic over the NRBF features: CACLA (van Hasselt and Wiering 2007,
"Reinforcement learning in continuous action spaces", IEEE ADPRL, 272-279) with a TD(lambda)
critic, for a batch of independent agents. Light-weight as the paper's agent is: two linear
functions of the same normalised features (Främling 2008, eq. 8 and 9), one pass over each
per step, no replay and no gradient through a network.

Each agent has an actor and a critic, both linear in the features phibar(s) (`agent.linear`:
the NRBF grid of the paper agent's settings on the task, `agent.paper_settings`, or a CMAC):

- critic V(s) = sum_i v_i phibar_i(s), TD error delta = r + gamma d V(s') - V(s) (d the
  discount, 0 at a terminal state), eligibility traces over the v_i by the Sarsa(lambda)
  rules with one action (`agent.traces`: accumulating, eq. 2, or replacing, eq. 6):
  e <- rule(gamma lambda e, phibar(s)), v <- v + alpha delta e (Sutton 1988's TD(lambda));
- actor mean mu(s) = sum_i w_i phibar_i(s), in the learner's action units [-1, 1]
  (`tasks.commands`: the loops scale it to the actuator's range); Gaussian exploration,
  the action u = clip(mu(s) + sigma n, -1, 1), n ~ N(0, 1) from the agent's stream;
- CACLA's actor update (van Hasselt and Wiering 2007, section IV, their eq. 12): where
  delta > 0 the action did better than expected, and the mean moves toward it,
  w <- w + beta (u - mu(s)) phibar(s); elsewhere the actor is left alone.

Every term is computed with the weights before the step's updates, as in `agent.sarsa`. A
greedy agent acts on mu(s), clipped. Because the actor moves toward actions in [-1, 1] by a
convex step (beta <= 1, the features sum to 1), mu stays within the range: the "squashing"
SPEC.md's actor reads is the clip of the actions it learns from.

Why CACLA rather than Doya (2000)'s actor-critic (section 5: w <- w + beta delta (u - mu)
phibar): CACLA's update does not scale with delta, so its step size does not depend on the
size of the rewards, which differ by orders between the suite's tasks (Mountain-Car's -1 per
step, the pendulum's cos(theta) - 0.7, the cart-pole's -1 at failure); van Hasselt and
Wiering report it more robust to its settings than the delta-weighted rule, and the benchmark
gives every learner the same search, so the one less sensitive to its settings is the fairer
entry.

Its defaults (alpha, beta, lambda, gamma, sigma and the NRBF spread r^2; the grid is the
task's) are those the second benchmark's search chose on the pendulum swing-up with
continuous torque (`lwrl bench run pendulum.swingup-continuous`, docs/FINDINGS.md: 16
configurations drawn around its earlier defaults, `studies.paper.benchmark.protocol.
ACTOR_CRITIC_START`, each trained by 3 agents on seeds 1000 to 1002 of its own for the
task's budget of 90 000 steps and scored greedily), rounded to three figures: the best
configuration's mean normalised score was 0.69 where the earlier defaults' was 0.14. The
earlier discount, 0.98, was Doya's time constant of the value, tau = 1 s, at the 20-ms
control period; the search's 0.95 is tau = 0.39 s.

In the contract's terms: `actions` is `continuous` (the step returns u in [-1, 1]); it has
no action values (no `q`: an actor's mean is not the value of an action); the state value
is the critic's V; `weights` is `(B, 2, N)`, the actor's w and the critic's
v; the TD error is the critic's delta. Its C controller (`lwrl export`) is the greedy actor,
clip(mu(s), -1, 1), over the same NRBF code as the discrete learners'.
"""

import collections
import dataclasses

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.arithmetic import Count, Counts, nrbf_counts
from lwrl.agent.learner_contract import Learner, LearnerSettings, NoValues
from lwrl.agent.linear import (FeatureSettings, LinearAgents, action_value, describe_features,
                               feature_spec, features_from, features_into, nrbf_on_grid,
                               per_agent, scratch_width)
from lwrl.agent.nrbf import NRBF
from lwrl.agent.streams import gaussian, seed_streams
from lwrl.agent.traces import update_
from lwrl.settings import check_non_negative, check_positive, check_unit_interval, setting

ACTOR, CRITIC = 0, 1
"""The rows of an agent's `weights` `(2, N)`: the actor's w, the critic's v."""
CRITIC_TRACES = ("accumulating", "replacing")
"""The critic's trace rules (`agent.traces`, with one action)."""
_TRACE_INDEX = {"replacing": 0, "accumulating": 1}
"""`agent.traces`' index of each rule (REPLACING, ACCUMULATING)."""

Arrays = collections.namedtuple(
    "Arrays", "weights traces phi slot action streams diverged delta scratch "
              "alpha beta gamma lam sigma features trace")
"""One batch's learning state, scratch space and settings, each with a leading axis B:
`weights` `(B, 2, N)` (the actor's w, the critic's v), the critic's `traces` `(B, 1, N)`,
the features of the last two observations `phi` `(B, 2, N)` (the latest in
`phi[b, slot[b]]`), the latest action u in [-1, 1], the random streams, divergence flags,
the latest TD error `delta`
(NaN where no update was made); the step sizes, discount, trace decay, exploration and
trace rule per agent; the feature map as compiled code sees it."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class ActorCriticSettings(FeatureSettings, LearnerSettings):
    """CACLA with a TD(lambda) critic over the NRBF features (the module's docstring)."""

    r2: float = setting(0.0222, reading=True, only_with=("features", "nrbf"))
    """NRBF spread r^2 of eq. 8, in normalised units (the search's; the paper's agent: 0.01)."""
    trace: str = setting("accumulating", choices=CRITIC_TRACES, per_agent=True)
    """The critic's trace rule: `accumulating` (eq. 2) or `replacing` (eq. 6)."""
    alpha: float = setting(1.21, per_agent=True)
    """The critic's learning rate alpha > 0."""
    beta: float = setting(0.628, per_agent=True)
    """The actor's learning rate beta in (0, 1] (CACLA's step toward a better action)."""
    lam: float = setting(0.57, flags=("--lambda",), per_agent=True)
    """The critic's trace decay lambda in [0, 1]."""
    gamma: float = setting(0.95, per_agent=True)
    """Discount rate gamma in [0, 1]."""
    sigma: float = setting(0.232, per_agent=True)
    """Standard deviation sigma >= 0 of the Gaussian exploration, in action units ([-1, 1]
    spans the actuator's range)."""

    def check(self, task) -> None:
        check_positive("alpha", self.alpha)
        if not (isinstance(self.beta, (int, float)) and 0.0 < self.beta <= 1.0):
            raise ValueError(f"beta must be in (0, 1]; got {self.beta!r}")
        check_unit_interval("lambda", self.lam)
        check_unit_interval("gamma", self.gamma)
        check_non_negative("sigma", self.sigma)
        self.check_features(task)

    def label(self) -> str:
        return f"{self.features}-cacla-{self.trace}-a{self.alpha:g}-b{self.beta:g}-s{self.sigma:g}"

    def describe(self, dim: int) -> str:
        return (f"CACLA, {self.trace} critic traces, alpha {self.alpha:g}, beta {self.beta:g}, "
                f"lambda {self.lam:g}, gamma {self.gamma:g}, sigma {self.sigma:g}, "
                f"{self.network(dim)}")


def fits(task):
    """A task made with continuous actions, or one line saying so."""
    if task.actions == "continuous":
        return None
    return (f"actor_critic takes continuous actions; {task.name} was made with discrete ones: "
            "run it with actions='continuous' (--action-kind continuous)")


@register_jitable
def agent_step(b, first, reward, discount, observation, learn, greedy, arrays):
    """Agent b sees `observation`; returns its next action u in [-1, 1] (`Learner.step`).

    `first`: the observation starts an episode (traces reset, no update). Otherwise it ends
    the transition from the agent's previous (state, action) with `reward` and `discount`
    (0 at a terminal state, where no action is drawn and 0 is returned): the TD error, then
    CACLA's actor update where it is positive and the critic's TD(lambda) update.
    `learn=False` acts without updating; `greedy=True` acts on the mean."""
    phi_t = arrays.phi[b, 1 - arrays.slot[b]]
    features_into(arrays.features, observation, phi_t, arrays.scratch[b])
    w = arrays.weights[b]
    mu_t = action_value(w, phi_t, ACTOR)
    bootstrap = first or discount > 0.0
    arrays.delta[b] = np.nan
    if first:
        arrays.traces[b][:] = 0.0
    elif learn and not arrays.diverged[b]:
        phi_tm1 = arrays.phi[b, arrays.slot[b]]
        delta = reward - action_value(w, phi_tm1, CRITIC)
        if bootstrap:
            delta += arrays.gamma[b] * discount * action_value(w, phi_t, CRITIC)
        arrays.delta[b] = delta
        if not np.isfinite(delta):
            arrays.diverged[b] = True
        else:
            if delta > 0.0:
                step = arrays.beta[b] * (arrays.action[b] - action_value(w, phi_tm1, ACTOR))
                actor = w[ACTOR]
                for i in range(actor.shape[0]):
                    actor[i] += step * phi_tm1[i]
            update_(arrays.trace[b], arrays.traces[b], w[CRITIC:], phi_tm1, 0,
                    arrays.gamma[b] * arrays.lam[b], arrays.alpha[b] * delta)
    u = 0.0
    if bootstrap:
        u = mu_t if greedy else mu_t + arrays.sigma[b] * gaussian(arrays.streams, b)
        u = min(max(u, -1.0), 1.0)
    arrays.slot[b] = 1 - arrays.slot[b]
    arrays.action[b] = u
    return u


class ActorCriticAgents(LinearAgents):
    """B independent CACLA agents sharing one feature map; the settings are scalars or one
    per agent; `seeds` (one non-negative integer per agent) fixes B and each agent's stream."""

    def __init__(self, features, *, alpha, beta, lam, gamma, sigma, trace, seeds, settings=()):
        self.features = features
        self.dim = features.dim
        self.settings = tuple(settings)
        streams = seed_streams(seeds)
        batch, n = len(streams), features.num_features
        traces = [str(t) for t in np.broadcast_to(np.asarray(trace), (batch,))]
        unknown = [t for t in traces if t not in CRITIC_TRACES]
        if unknown:
            raise ValueError(f"unknown trace {unknown[0]!r}; allowed: {', '.join(CRITIC_TRACES)}")
        self.arrays = Arrays(
            weights=np.zeros((batch, 2, n)), traces=np.zeros((batch, 1, n)),
            phi=np.zeros((batch, 2, n)), slot=np.zeros(batch, dtype=np.int64),
            action=np.zeros(batch), streams=streams, diverged=np.zeros(batch, dtype=bool),
            delta=np.full(batch, np.nan),
            scratch=np.zeros((batch, features.dim, scratch_width(features))),
            alpha=per_agent("alpha", alpha, batch, 0.0, np.inf, closed_low=False)
            * features.alpha_scale,
            beta=per_agent("beta", beta, batch, 0.0, 1.0, closed_low=False),
            gamma=per_agent("gamma", gamma, batch, 0.0, 1.0),
            lam=per_agent("lambda", lam, batch, 0.0, 1.0),
            sigma=per_agent("sigma", sigma, batch, 0.0, np.inf),
            features=feature_spec(features),
            trace=np.array([_TRACE_INDEX[t] for t in traces], dtype=np.int64))

    def action_values(self, states, weights=None) -> np.ndarray:
        raise NoValues("actor_critic has no action values: its actor gives one action, "
                       "its critic the state's value")

    def action_values_on_grid(self, axes, weights) -> np.ndarray:
        return self.action_values(None, weights)

    def _row(self, states, weights, row) -> np.ndarray:
        phi = self.features.features(states)
        weights = self._weights(weights)
        if weights.ndim == 2:  # one agent's (2, N)
            return phi @ weights[row]
        return np.einsum("...n,bn->b...", phi, weights[:, row])

    def state_values(self, states, weights=None) -> np.ndarray:
        """The critic's V(s) = sum_i v_i phibar_i(s)."""
        return self._row(states, weights, CRITIC)

    def policy_means(self, states, weights=None) -> np.ndarray:
        """The actor's mean mu(s) = sum_i w_i phibar_i(s) in action units (a greedy agent
        acts on it, clipped to [-1, 1]), as `state_values` gives V."""
        return self._row(states, weights, ACTOR)

    def greedy_actions(self, states, weights=None) -> np.ndarray:
        """The actor's mean clipped to [-1, 1] (`policy_means`), the greedy action."""
        return np.clip(self.policy_means(states, weights), -1.0, 1.0)

    def state_values_on_grid(self, axes, weights) -> np.ndarray:
        """V over the grid, from the NRBF's factorisation where the features are an NRBF."""
        if isinstance(self.features, NRBF):
            return nrbf_on_grid(self.features, axes, np.asarray(weights)[CRITIC:])[..., 0]
        return super(LinearAgents, self).state_values_on_grid(axes, weights)

    @property
    def weights(self) -> np.ndarray:
        """The actor's and the critic's weights `(B, 2, N)`."""
        return self.arrays.weights

    def saved(self) -> tuple[dict, dict]:
        arrays = self.arrays
        document = {"features": describe_features(self.features),
                    "alpha": (arrays.alpha / self.features.alpha_scale).tolist(),
                    **{name: getattr(arrays, name).tolist()
                       for name in ("beta", "gamma", "lam", "sigma")},
                    "trace": [next(t for t, i in _TRACE_INDEX.items() if i == index)
                              for index in arrays.trace]}
        return document, {"weights": arrays.weights, "streams": arrays.streams,
                          "diverged": arrays.diverged}

    def controller_rows(self, b: int) -> np.ndarray:
        """`(1, N)` the actor's weights alone: the C controller (`export.c`, `lwrl_policy`
        for a continuous action) computes mu(s) over the NRBF features and clips it to
        [-1, 1], the greedy action; the critic is not needed to act."""
        return self.arrays.weights[b, ACTOR:ACTOR + 1]


def make(settings, task, seeds) -> ActorCriticAgents:
    """The agents of `settings` (one `ActorCriticSettings` per agent, equal but in the
    per-agent fields) on `task` (`TaskSpec`), with zero weights (mu = 0: the middle of the
    actuator's range; V = 0)."""
    base = settings[0]
    return ActorCriticAgents(base.feature_map(task.ranges.low, task.ranges.high), seeds=seeds,
                             settings=settings,
                             **{name: [getattr(s, name) for s in settings]
                                for name in ("alpha", "beta", "lam", "gamma", "sigma", "trace")})


def load(document, arrays) -> ActorCriticAgents:
    """The agents `ActorCriticAgents.saved` wrote (a ValueError if the parts do not fit)."""
    features = features_from(document["features"])
    weights, streams = arrays["weights"], arrays["streams"]
    if weights.shape != (len(streams), 2, features.num_features):
        raise ValueError(f"weights of shape {weights.shape} do not fit {len(streams)} agents "
                         f"of 2 x {features.num_features} features")
    agents = ActorCriticAgents(features, seeds=np.zeros(len(streams), dtype=np.uint64),
                               **{name: document[name] for name in
                                  ("alpha", "beta", "lam", "gamma", "sigma", "trace")})
    agents.arrays.weights[:] = weights
    agents.arrays.streams[:] = streams
    agents.arrays.diverged[:] = arrays.get("diverged", False)
    return agents


def memory(settings, task) -> int:
    """Bytes of one agent's arrays: the actor's and the critic's weights, the critic's traces,
    the last two feature vectors and the feature scratch."""
    features = settings.feature_map(task.ranges.low, task.ranges.high)
    n = features.num_features
    return 8 * (5 * n + features.dim * scratch_width(features) + 8)


def cacla_update(dim: int, n: int, actions: int) -> Count:
    """The arithmetic of one transition's update over N = n^d features: V(s) and V(s') and
    mu(s) (N each; mu(s) where delta > 0, counted always), the actor's update (N), the
    critic's trace rule and its weights' update (N each), and the exploration's Gaussian
    draw (a log and a cos)."""
    return Count(6 * n ** dim, 2)


def arithmetic(settings, task, steps=None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`): an NRBF grid's decision (the features
    and mu, one output) and, at every step, `cacla_update` (CMAC features not counted)."""
    return nrbf_counts(settings, len(task.state_names), 1, cacla_update)


LEARNER = Learner(
    name="actor_critic",
    title="continuous actor-critic (CACLA) over NRBF features, TD(lambda) critic",
    source="van Hasselt and Wiering (2007), IEEE ADPRL, CACLA; Sutton (1988) TD(lambda); "
           "Främling (2008) eq. 8 and 9 for the features",
    settings=ActorCriticSettings, make=make, load=load, memory=memory, step=agent_step,
    fits=fits, actions="continuous", arithmetic=arithmetic)
"""The `actor_critic` learner as the registry holds it (`agent.LEARNERS`)."""
ActorCriticAgents.learner = LEARNER
