"""ASE/ACE: the associative search element and adaptive critic element of Barto, Sutton and
Anderson (1983), "Neuronlike adaptive elements that can solve difficult learning control
problems", IEEE Transactions on Systems, Man, and Cybernetics 13(5), 834-846; as in
Sutton and Anderson's `pole.c` (Sutton and Barto's book code), for a batch of independent
agents. The learner Table 1 of Främling (2008) quotes at about 80 episodes.

The state (x, x_dot, theta, theta_dot) of the cart-pole falls in one of 162 boxes (x_i = 1
for that box, 0 for the others): x at -0.8 and 0.8 m (edges +-2.4), x_dot at -0.5 and
0.5 m/s, theta at -6, -1, 0, 1 and 6 degrees (edges +-12), theta_dot at -50 and 50 deg/s;
boxes are numbered as `pole.c`'s `get_box` numbers them.

- ASE, the actor (their eq. 1 to 3): y(t) = +1 (push right) if sum_i w_i x_i + noise >= 0,
  else -1, noise Gaussian with standard deviation sigma; e_i <- delta e_i + (1 - delta) y x_i;
  w_i <- w_i + alpha r_hat e_i.
- ACE, the critic (their eq. 4 to 7): p(t) = sum_i v_i x_i, with p = 0 at a failure;
  r_hat(t) = r(t) + gamma p(t) - p(t - 1); v_i <- v_i + beta r_hat x_bar_i;
  x_bar_i <- lambda x_bar_i + (1 - lambda) x_i.

Order within a step, as in `pole.c`: the traces take the current box's increment when the
action is chosen; after the next state, r_hat updates w and v with those traces, then the
traces decay. Traces reset at each trial (episode). Constants (their section V, and
`pole.c`): alpha = 1000, beta = 0.5, delta = 0.9, gamma = 0.95, lambda = 0.8, sigma = 0.01;
r = -1 on failure, 0 otherwise (lwrl's cart-pole reward).

Reading (SPEC.md): the action noise is the paper's Gaussian threshold unit (`policy =
"gaussian"`); `pole.c` draws y = +1 with probability 1 / (1 + exp(-s)), s = sum_i w_i x_i
limited to +-50, and increments the trace by (1 - delta)(y' - 1/2) with y' in {0, 1} (half
the paper's, absorbed by alpha): `policy = "logistic"` takes that.

In the contract's terms: the action values are the actor's preferences (-s, +s) for (left,
right), whose argmax is the greedy action; the state value is the critic's p; `weights` is
`(B, 2, 162)`, the actor's w and the critic's v; the TD error is r_hat.
"""

import collections
import dataclasses
import math

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.arithmetic import Count, Counts
from lwrl.agent.learner_contract import Agents, Learner, LearnerSettings
from lwrl.agent.linear import per_agent
from lwrl.agent.streams import gaussian, seed_streams, uniform
from lwrl.settings import check_non_negative, check_positive, check_unit_interval, setting
from lwrl.spaces import Discrete

STATE = ("cart_position", "cart_velocity", "pole_angle", "pole_angular_velocity")
"""The state the boxes read, in this order (x in m, x_dot in m/s, theta and theta_dot in rad
and rad/s, theta = 0 upright)."""
BOXES = 162
"""The boxes the cart-pole's state space is cut into (Barto et al. 1983)."""
POSITION_EDGES = (-0.8, 0.8)
"""m."""
VELOCITY_EDGES = (-0.5, 0.5)
"""m/s."""
ANGLE_EDGES = tuple(math.radians(a) for a in (-6.0, -1.0, 0.0, 1.0, 6.0))
"""rad."""
ANGULAR_VELOCITY_EDGES = tuple(math.radians(a) for a in (-50.0, 50.0))
"""rad/s."""
POLICIES = ("gaussian", "logistic")
"""The action noise's readings (see the module): the paper's Gaussian threshold unit, or
`pole.c`'s logistic draw."""

Arrays = collections.namedtuple(
    "Arrays", "weights e xbar box action p_old streams diverged q delta "
              "alpha beta delta_decay gamma lam sigma logistic edges")
"""One batch's state, each with a leading axis B: `weights` `(B, 2, 162)` (the actor's w,
the critic's v), the traces `e` and `xbar` `(B, 162)`, the box and action (+-1) of the latest
step, the critic's p there (`p_old`), the random streams, divergence flags, the preferences
`q` `(B, 2)` and r_hat in `delta`; the constants per agent; `logistic` per agent (the
policy), and the box edges (`edges`: a tuple of four arrays)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class AseAceSettings(LearnerSettings):
    """The ASE/ACE of Barto, Sutton and Anderson (1983), with their constants."""

    alpha: float = setting(1000.0, per_agent=True)
    """The actor's (ASE) learning rate alpha > 0."""
    beta: float = setting(0.5, per_agent=True)
    """The critic's (ACE) learning rate beta > 0."""
    delta: float = setting(0.9, per_agent=True)
    """The actor's trace decay delta in [0, 1]."""
    gamma: float = setting(0.95, per_agent=True)
    """The critic's discount gamma in [0, 1]."""
    lam: float = setting(0.8, flags=("--lambda",), per_agent=True)
    """The critic's trace decay lambda in [0, 1]."""
    sigma: float = setting(0.01, per_agent=True)
    """Standard deviation sigma >= 0 of the actor's Gaussian noise."""
    policy: str = setting("gaussian", choices=POLICIES)
    """`gaussian`: the paper's noisy threshold; `logistic`: `pole.c`'s."""

    def check(self, task) -> None:
        check_positive("alpha", self.alpha)
        check_positive("beta", self.beta)
        for name in ("delta", "gamma", "lam"):
            check_unit_interval("lambda" if name == "lam" else name, getattr(self, name))
        check_non_negative("sigma", self.sigma)

    def label(self) -> str:
        return f"ase_ace-{self.policy}-a{self.alpha:g}-b{self.beta:g}"

    def describe(self, dim: int) -> str:
        return (f"ASE/ACE, {self.policy} actor, alpha {self.alpha:g}, beta {self.beta:g}, "
                f"delta {self.delta:g}, gamma {self.gamma:g}, lambda {self.lam:g}, sigma "
                f"{self.sigma:g}, {BOXES} boxes")


def fits(task):
    """The cart-pole's state and two actions, or one line saying so."""
    if tuple(task.state_names) == STATE and task.action == Discrete(2):
        return None
    return (f"ase_ace fits the cart-pole (Barto et al. 1983): a state ({', '.join(STATE)}) and "
            f"two actions; {task.name} has ({', '.join(task.state_names)}) and "
            f"{'continuous actions' if task.continuous else f'{task.action.n} actions'}")


@register_jitable
def _interval(value, edges):
    """How many of `edges` (ascending) lie at or below `value`."""
    count = 0
    for edge in edges:
        if value >= edge:
            count += 1
    return count


@register_jitable
def box_of(state, edges):
    """The box (0..161) of a state `(4,)`, numbered as `pole.c` numbers it (x slowest...
    theta_dot fastest by 54s); states beyond the edges fall in the outer boxes."""
    x, x_dot, theta, theta_dot = edges
    return (_interval(state[0], x) + 3 * _interval(state[1], x_dot)
            + 9 * _interval(state[2], theta) + 54 * _interval(state[3], theta_dot))


@register_jitable
def act(b, box, greedy, arrays):
    """y in {-1, +1} for agent b in `box`: the actor's noisy threshold (or `pole.c`'s
    logistic), or its greedy action (push right where s >= 0)."""
    s = arrays.weights[b, 0, box]
    if greedy:
        return 1.0 if s >= 0.0 else -1.0
    if arrays.logistic[b]:
        limited = min(max(s, -50.0), 50.0)
        return 1.0 if uniform(arrays.streams, b) < 1.0 / (1.0 + math.exp(-limited)) else -1.0
    return 1.0 if s + arrays.sigma[b] * gaussian(arrays.streams, b) >= 0.0 else -1.0


@register_jitable
def agent_step(b, first, reward, discount, observation, learn, greedy, arrays):
    """Agent b sees `observation`; returns its next action, 0 (left) or 1 (right)
    (`Learner.step`): r_hat from the previous step's prediction, the updates of w and v
    and the traces' decay, then the next action and the traces' increment."""
    box = box_of(observation, arrays.edges)
    w, v = arrays.weights[b, 0], arrays.weights[b, 1]
    e, xbar = arrays.e[b], arrays.xbar[b]
    bootstrap = first or discount > 0.0
    arrays.delta[b] = np.nan
    if first:
        e[:] = 0.0
        xbar[:] = 0.0
    elif learn and not arrays.diverged[b]:
        p = v[box] if bootstrap else 0.0
        r_hat = reward + arrays.gamma[b] * p - arrays.p_old[b]
        arrays.delta[b] = r_hat
        if not np.isfinite(r_hat):
            arrays.diverged[b] = True
        else:
            actor, critic = arrays.alpha[b] * r_hat, arrays.beta[b] * r_hat
            for i in range(w.shape[0]):
                w[i] += actor * e[i]
                v[i] += critic * xbar[i]
                e[i] *= arrays.delta_decay[b]
                xbar[i] *= arrays.lam[b]
    s = w[box]
    arrays.q[b, 0], arrays.q[b, 1] = -s, s
    if not bootstrap:
        return 0
    y = act(b, box, greedy, arrays)
    if arrays.logistic[b]:
        e[box] += (1.0 - arrays.delta_decay[b]) * (0.5 if y > 0.0 else -0.5)
    else:
        e[box] += (1.0 - arrays.delta_decay[b]) * y
    xbar[box] += 1.0 - arrays.lam[b]
    arrays.p_old[b] = v[box]
    arrays.box[b] = box
    arrays.action[b] = 1 if y > 0.0 else 0
    return arrays.action[b]


class AseAceAgents(Agents):
    """B independent ASE/ACE agents on the cart-pole; the constants are scalars or one per
    agent, `policy` one for the batch."""

    def __init__(self, *, seeds, alpha=1000.0, beta=0.5, delta=0.9, gamma=0.95, lam=0.8,
                 sigma=0.01, policy="gaussian", box=None, settings=()):
        if policy not in POLICIES:
            raise ValueError(f"unknown policy {policy!r}; allowed: {', '.join(POLICIES)}")
        streams = seed_streams(seeds)
        batch = len(streams)
        self.dim = len(STATE)
        self.settings = tuple(settings)
        self.policy = policy
        """The action noise's reading, one of `POLICIES`, for the whole batch."""
        self.box = box
        """The task's normalisation ranges `(low, high)`, which `value_box` gives."""
        self.arrays = Arrays(
            weights=np.zeros((batch, 2, BOXES)), e=np.zeros((batch, BOXES)),
            xbar=np.zeros((batch, BOXES)), box=np.zeros(batch, dtype=np.int64),
            action=np.zeros(batch, dtype=np.int64), p_old=np.zeros(batch), streams=streams,
            diverged=np.zeros(batch, dtype=bool), q=np.zeros((batch, 2)),
            delta=np.full(batch, np.nan),
            alpha=per_agent("alpha", alpha, batch, 0.0, np.inf, closed_low=False),
            beta=per_agent("beta", beta, batch, 0.0, np.inf, closed_low=False),
            delta_decay=per_agent("delta", delta, batch, 0.0, 1.0),
            gamma=per_agent("gamma", gamma, batch, 0.0, 1.0),
            lam=per_agent("lambda", lam, batch, 0.0, 1.0),
            sigma=per_agent("sigma", sigma, batch, 0.0, np.inf),
            logistic=np.full(batch, policy == "logistic"),
            edges=tuple(np.array(edges) for edges in (POSITION_EDGES, VELOCITY_EDGES,
                                                     ANGLE_EDGES, ANGULAR_VELOCITY_EDGES)))

    def _weights(self, weights):
        return self.arrays.weights if weights is None else np.asarray(weights)

    def _boxes(self, states) -> np.ndarray:
        states = np.asarray(states, dtype=np.float64)
        flat = states.reshape(-1, self.dim)
        return np.array([box_of(state, self.arrays.edges) for state in flat],
                        dtype=np.int64).reshape(states.shape[:-1])

    def action_values(self, states, weights=None) -> np.ndarray:
        """The actor's preferences (-s, +s) for (left, right), s = w of the state's box."""
        weights, boxes = self._weights(weights), self._boxes(states)
        s = weights[..., 0, :][..., boxes] if weights.ndim == 3 else weights[0][boxes]
        return np.stack([-s, s], axis=-1)

    def state_values(self, states, weights=None) -> np.ndarray:
        """The critic's prediction p = v of the state's box."""
        weights, boxes = self._weights(weights), self._boxes(states)
        return weights[..., 1, :][..., boxes] if weights.ndim == 3 else weights[1][boxes]

    def value_box(self) -> tuple:
        """The task's normalisation ranges (the cart-pole's: where the boxes lie)."""
        return self.box

    def saved(self) -> tuple[dict, dict]:
        arrays = self.arrays
        document = {"policy": self.policy, "box": self.box,
                    **{name: getattr(arrays, field).tolist() for name, field in (
                        ("alpha", "alpha"), ("beta", "beta"), ("delta", "delta_decay"),
                        ("gamma", "gamma"), ("lambda", "lam"), ("sigma", "sigma"))}}
        return document, {"weights": arrays.weights, "streams": arrays.streams,
                          "diverged": arrays.diverged}


def make(settings, task, seeds) -> AseAceAgents:
    """The agents of `settings` (one `AseAceSettings` per agent) on the cart-pole `task`."""
    return AseAceAgents(seeds=seeds, **{name: [getattr(s, name) for s in settings] for name in
                                        ("alpha", "beta", "delta", "gamma", "lam", "sigma")},
                        policy=settings[0].policy, box=(task.ranges.low, task.ranges.high), settings=settings)


def load(document, arrays) -> AseAceAgents:
    """The agents `AseAceAgents.saved` wrote (a ValueError if the parts do not fit)."""
    weights, streams = arrays["weights"], arrays["streams"]
    if weights.shape != (len(streams), 2, BOXES):
        raise ValueError(f"weights of shape {weights.shape} do not fit {len(streams)} agents "
                         f"of 2 x {BOXES} boxes")
    agent = AseAceAgents(seeds=np.zeros(len(streams), dtype=np.uint64), alpha=document["alpha"],
                         beta=document["beta"], delta=document["delta"],
                         gamma=document["gamma"], lam=document["lambda"],
                         sigma=document["sigma"], policy=document["policy"],
                         box=tuple(map(tuple, document["box"])))
    agent.arrays.weights[:] = weights
    agent.arrays.streams[:] = streams
    return agent


def memory(settings, task) -> int:
    """Bytes of one agent's arrays: w, v and both traces over the boxes."""
    return 8 * (4 * BOXES + 8)


def arithmetic(settings, task, steps=None) -> Counts:
    """Its counted arithmetic (`Learner.arithmetic`; the same on every step): a greedy
    decision reads one weight of the state's box (no multiply-add); an agent-step of
    learning updates the actor's and the critic's weights and decays both traces over the
    162 boxes (4 x 162 multiply-adds) and draws its action's noise (Box-Muller, a log and a
    cos; `pole.c`'s logistic policy: one exp)."""
    noise = 1 if settings.policy == "logistic" else 2
    update = Count(4 * BOXES, 0)
    return Counts(Count(), update + Count(0, noise), update,
                  f"{BOXES} boxes, {settings.policy} policy ({__name__}.arithmetic)")


LEARNER = Learner(
    name="ase_ace", title="ASE/ACE actor-critic over 162 boxes (the cart-pole)",
    source="Barto, Sutton and Anderson (1983), IEEE SMC 13(5); Sutton and Anderson's pole.c",
    settings=AseAceSettings, make=make, load=load, memory=memory, step=agent_step, fits=fits,
    arithmetic=arithmetic)
"""The `ase_ace` learner as the registry holds it (`agent.LEARNERS`)."""
AseAceAgents.learner = LEARNER
