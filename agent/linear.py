"""What the linear learners share: Q(s, a) = sum_i w_ia x_i(s) over a feature map.

Sarsa(lambda) (`agent.sarsa`) and true online Sarsa(lambda) (`agent.true_online_sarsa`)
learn linear action values over the same features: the paper's NRBF network
(`agent.nrbf`, eq. 8 and 9) or the CMAC baseline's binary tile coding (`agent.cmac`).

- `FeatureSettings`: the settings of the feature map, shared by both learners' settings;
- `FeatureSpec` and `features_into`: a feature map as compiled code sees it, and its
  features of one state;
- `TraceSettings`: the trace rule and step sizes of the Sarsa(lambda) family, and
  `LinearSettings` both those and the features;
- `action_value`: Q(s, a) of one action, in a fixed order of additions; `choose` and
  `advance`: the part of a per-agent step that both learners share (the features of the new
  observation, its action values, the epsilon-greedy action, and the bookkeeping after);
- `LinearAgents`: the arrays both learners keep, and the contract's values, value box,
  centroids, C controller and saved form for agents whose `arrays` hold `weights`
  `(B, A, N)` over `features`.
"""

import collections
import dataclasses

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.cmac import CMAC, cmac_features_into
from lwrl.agent.lanes import lane_dot
from lwrl.agent.learner_contract import Agents, ControllerForm, LearnerSettings
from lwrl.agent.nrbf import DEFAULT_R2, NRBF, clamp_margin, nrbf_features_into
from lwrl.agent.policy import epsilon_greedy
from lwrl.agent.streams import seed_streams
from lwrl.agent.traces import TRACES
from lwrl.settings import (LATE, check_count, check_positive, check_unit_interval, fill,
                           setting)

FEATURE_MAPS = {"nrbf": NRBF, "cmac": CMAC}
"""The feature maps by name: the paper's network and the tile-coding baseline."""
CENTROID_PLACEMENTS = ("midpoints", "edges")
"""Where the NRBF centroids sit in each dimension (`LinearSettings.centroids`)."""
_NRBF, _CMAC = 0, 1

FeatureSpec = collections.namedtuple("FeatureSpec", "kind low high n r2 tilings")
"""A feature map as compiled code sees it (`n` is the CMAC's intervals)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class FeatureSettings:
    """The feature map of a linear learner (None: the task's setting, else the field's own,
    `per_task`: n 8)."""

    features: str = setting("nrbf", choices=FEATURE_MAPS)
    """`nrbf` (the paper's network) or `cmac` (the tile-coding baseline)."""
    n: int | None = setting(flags=("--n", "--centroids"), per_task=8)
    """NRBF centroids per dimension (>= 2), or CMAC intervals per dimension."""
    r2: float = setting(DEFAULT_R2, reading=True, only_with=("features", "nrbf"))
    """NRBF spread r^2 of eq. 8, in normalised units (the paper: 0.01)."""
    tilings: int = 5
    """CMAC tilings."""
    normalise_alpha: bool = False
    """CMAC only: divide alpha by the tilings (Sutton's code)."""
    low: tuple | None = setting(key=LATE, reading=True)
    """Lower end of each state variable's normalisation range, comma-separated (default:
    the task's)."""
    high: tuple | None = setting(key=LATE, reading=True)
    """Upper end of each state variable's normalisation range, comma-separated (default:
    the task's)."""
    centroids: str = setting("midpoints", choices=CENTROID_PLACEMENTS,
                             flags=("--centroid-placement",), key=LATE, reading=True,
                             only_with=("features", "nrbf"))
    """NRBF centroid placement: `midpoints` of n cells, `(i + 0.5) / n` (the author's code),
    or `edges`, `i / (n - 1)`, from one end of each range to the other (SPEC.md leaves it
    open: the paper says "regularly spaced")."""

    def check_features(self, task) -> None:
        """A one-line ValueError for the first feature setting out of its range on `task`
        (`TaskSpec`); the ranges set here become tuples of floats."""
        check_count("n (centroids per dimension)", self.n, 2 if self.features == "nrbf" else 1)
        check_count("tilings", self.tilings, 1)
        check_positive("r2 (the spread r^2)", self.r2)
        for name in ("low", "high"):
            value = getattr(self, name)
            if value is None:
                continue
            if len(value) != len(task.state_names):
                raise ValueError(f"{name} must have one value per state variable of {task.name} "
                                 f"({len(task.state_names)}); got {value!r}")
            fill(self, **{name: tuple(float(v) for v in value)})

    def network(self, dim: int) -> str:
        """`nrbf 8^2`: the feature map over `dim` state variables, for run headers."""
        return f"{self.features} {self.n}^{dim}"

    def feature_map(self, low, high):
        """The features over the normalisation ranges set here, else `low..high` (the task's).

        Centroids at the `edges` are the midpoint grid of `agent.nrbf` over ranges widened by
        half a spacing, `(high - low) / (2 (n - 1))`, at each end, with r^2 scaled by
        `((n - 1) / n)^2`: in those units the distances, and so the features, are the same."""
        low = self.low if self.low is not None else tuple(low)
        high = self.high if self.high is not None else tuple(high)
        if len(low) != len(high):
            raise ValueError(f"low and high must have one value per state variable; got "
                             f"{len(low)} and {len(high)}")
        if self.features == "cmac":
            return CMAC(low, high, intervals=self.n, tilings=self.tilings,
                        normalise_alpha=self.normalise_alpha)
        if self.centroids == "edges":
            low, high = np.array(low), np.array(high)
            half = (high - low) / (2 * (self.n - 1))
            return NRBF(tuple(low - half), tuple(high + half), self.n,
                        self.r2 * ((self.n - 1) / self.n) ** 2)
        return NRBF(low, high, self.n, self.r2)


@dataclasses.dataclass(frozen=True, kw_only=True)
class TraceSettings(LearnerSettings):
    """The trace rule and step sizes of Sarsa(lambda) (None: the task's setting, the paper
    agent's (`agent.paper_settings`), else the field's own, `per_task`: replacing traces,
    alpha 0.5, lambda 0.9, epsilon 0.1, gamma 1; starting values for a task nobody tuned,
    from the middle of the paper's settings, not tuned themselves)."""

    trace: str | None = setting(choices=TRACES, per_task="replacing", per_agent=True)
    """Trace rule: `replacing` (eq. 6), `accumulating` (eq. 2) or `replacing_reset` (eq. 5)."""
    alpha: float | None = setting(per_task=0.5, per_agent=True)
    """Learning rate alpha > 0 (eq. 1)."""
    lam: float | None = setting(flags=("--lambda",), per_task=0.9, per_agent=True)
    """Trace decay lambda in [0, 1]."""
    epsilon: float | None = setting(per_task=0.1, per_agent=True, reading=True)
    """Exploration rate in [0, 1] of the epsilon-greedy policy."""
    gamma: float | None = setting(per_task=1.0)
    """Discount rate in [0, 1] (1 in all the paper's tasks)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class LinearSettings(FeatureSettings, TraceSettings):
    """A linear learner of the Sarsa(lambda) family: its trace rule and step sizes, then its
    features."""

    def check(self, task) -> None:
        check_positive("alpha", self.alpha)
        check_unit_interval("lambda", self.lam)
        check_unit_interval("epsilon", self.epsilon)
        check_unit_interval("gamma", self.gamma)
        self.check_features(task)

    def label(self) -> str:
        return f"{self.features}-{self.trace}-a{self.alpha:g}-l{self.lam:g}"

    def describe(self, dim: int) -> str:
        gamma = f", gamma {self.gamma:g}" if self.gamma != 1 else ""
        return (f"{self.trace} traces, alpha {self.alpha:g}, lambda {self.lam:g}, epsilon "
                f"{self.epsilon:g}{gamma}, {self.network(dim)}")


def describe_features(features) -> dict:
    """A feature map as JSON (for agent files): its kind and its fields."""
    kind = next(name for name, cls in FEATURE_MAPS.items() if isinstance(features, cls))
    return {"kind": kind, **dataclasses.asdict(features)}


def features_from(description: dict):
    """The feature map `describe_features` described (a one-line error if unknown)."""
    description = dict(description)
    kind = description.pop("kind", None)
    if kind not in FEATURE_MAPS:
        raise ValueError(f"unknown feature kind {kind!r}; allowed: {', '.join(FEATURE_MAPS)}")
    return FEATURE_MAPS[kind](**description)


def feature_spec(features) -> FeatureSpec:
    """The compiled-code view of an `NRBF` or `CMAC`."""
    low, high = np.array(features.low), np.array(features.high)
    if isinstance(features, NRBF):
        return FeatureSpec(_NRBF, low, high, features.n, features.r2, 0)
    if isinstance(features, CMAC):
        return FeatureSpec(_CMAC, low, high, features.intervals, 0.0, features.tilings)
    raise ValueError(f"features must be an NRBF or a CMAC; got {type(features).__name__}")


def scratch_width(features) -> int:
    """Per-dimension scratch an agent needs to compute its features (the NRBF's factors)."""
    return features.n if isinstance(features, NRBF) else 1


@register_jitable
def features_into(spec, state, out, scratch):
    """The feature vector of one state, written into `out`."""
    if spec.kind == _NRBF:
        nrbf_features_into(state, spec.low, spec.high, spec.n, spec.r2, out, scratch)
    else:
        cmac_features_into(state, spec.low, spec.high, spec.n, spec.tilings, out)


@register_jitable
def action_value(w, phi, a):
    """Q(s, a) = sum_i w_ia phibar_i(s) (eq. 9), for weights `w` stored `(A, N)`, summed in
    the fixed order of `agent.lanes.lane_dot` (four interleaved partial sums)."""
    return lane_dot(w[a], phi)


@register_jitable(inline="always")
def choose(b, first, discount, observation, greedy, arrays):
    """The first half of a linear learner's step: agent b's features of `observation` (into
    the free slot of `arrays.phi`) and its action values there (into `arrays.q[b]`), and the
    epsilon-greedy action (epsilon 0 if `greedy`; none, 0, at a terminal state, discount 0).
    Returns `(phi_t, q_t, a_t, bootstrap)`, `bootstrap` False at a terminal state.

    Inlined into the learner's step by numba (`inline="always"`), as `advance` is: a call
    passes `arrays` flattened, every array's pointer, shape and strides, some 150 words per
    call, which on Mountain-Car's small network is a visible part of an agent-step."""
    phi_t = arrays.phi[b, 1 - arrays.slot[b]]
    features_into(arrays.features, observation, phi_t, arrays.scratch[b])
    w = arrays.weights[b]
    q_t = arrays.q[b]
    for a in range(q_t.shape[0]):
        q_t[a] = action_value(w, phi_t, a)
    bootstrap = first or discount > 0.0
    epsilon = 0.0 if greedy else arrays.epsilon[b]
    a_t = epsilon_greedy(q_t, epsilon, arrays.streams, b) if bootstrap else 0
    arrays.delta[b] = np.nan
    return phi_t, q_t, a_t, bootstrap


@register_jitable(inline="always")
def advance(b, a_t, arrays):
    """The last of a linear learner's step: the new features become the previous ones, and
    `a_t` the action taken."""
    arrays.slot[b] = 1 - arrays.slot[b]
    arrays.action[b] = a_t


def per_agent(name, value, batch_size, low, high, closed_low=True):
    """`value` broadcast to `(batch_size,)` float64, every entry checked against its range."""
    array = np.broadcast_to(np.asarray(value, dtype=np.float64), (batch_size,)).copy()
    above_low = array >= low if closed_low else array > low
    if not np.all(above_low & (array <= high)):
        bad = array[~(above_low & (array <= high))][0]
        interval = f"{'[' if closed_low else '('}{low}, {high}]"
        raise ValueError(f"{name} must be in {interval}; got {bad}")
    return array


def check_actions(num_actions) -> int:
    """An action count >= 1, or a one-line error."""
    if isinstance(num_actions, bool) or not isinstance(num_actions, (int, np.integer)) or num_actions < 1:
        raise ValueError(f"num_actions must be an integer >= 1; got {num_actions!r}")
    return int(num_actions)


def linear_arrays(features, num_actions, *, alpha, lam, epsilon, gamma, seeds) -> dict:
    """The arrays every linear learner keeps for B agents (see `agent.sarsa.Arrays`): zero
    weights and traces `(B, A, N)`, the last two feature vectors, the action values and TD
    error at the latest observation, each agent's random stream and divergence flag, and
    its step sizes (alpha scaled by the feature map's `alpha_scale`), checked."""
    streams = seed_streams(seeds)
    batch = len(streams)
    num_actions = check_actions(num_actions)
    alpha = per_agent("alpha", alpha, batch, 0.0, np.inf, closed_low=False)
    n_features = features.num_features
    return dict(
        weights=np.zeros((batch, num_actions, n_features)),
        traces=np.zeros((batch, num_actions, n_features)),
        phi=np.zeros((batch, 2, n_features)),
        slot=np.zeros(batch, dtype=np.int64),
        action=np.zeros(batch, dtype=np.int64),
        streams=streams,
        diverged=np.zeros(batch, dtype=bool),
        q=np.zeros((batch, num_actions)),
        delta=np.full(batch, np.nan),
        scratch=np.zeros((batch, features.dim, scratch_width(features))),
        alpha=alpha * features.alpha_scale,
        gamma=per_agent("gamma", gamma, batch, 0.0, 1.0),
        lam=per_agent("lambda", lam, batch, 0.0, 1.0),
        epsilon=per_agent("epsilon", epsilon, batch, 0.0, 1.0),
        features=feature_spec(features),
    )


def linear_memory(settings, task) -> int:
    """Bytes of one linear agent's arrays: weights and traces (A x N each), the last two
    feature vectors, the feature scratch and the action values."""
    features = settings.feature_map(task.ranges.low, task.ranges.high)
    n, actions = features.num_features, task.action.n
    return 8 * (2 * actions * n + 2 * n + features.dim * scratch_width(features) + 2 * actions)


def nrbf_factors(features: NRBF, dim: int, values) -> np.ndarray:
    """`(m, n)` the normalised per-dimension factors g_j / sum_k g_j[k] of an NRBF's features
    for `m` values of state variable `dim` (`agent.nrbf`: the features are their outer
    product over the dimensions), with the same guard against underflow."""
    low, high = features.low[dim], features.high[dim]
    centres = (np.arange(features.n) + 0.5) / features.n
    distance = np.abs((np.asarray(values, dtype=np.float64)[:, None] - low) / (high - low) - centres)
    nearest = distance.min(axis=1, keepdims=True)
    g = np.exp(-(distance - nearest) * (distance + nearest) / features.r2)
    return g / g.sum(axis=1, keepdims=True)


def nrbf_on_grid(features: NRBF, axes, weights) -> np.ndarray:
    """Q `(len(axes[0]), ..., A)` over a grid of states from the NRBF's factorisation: the
    weights `(n,) * d + (A,)` contracted with each variable's factors, with no
    `(cells, N)` feature matrix (cart-pole: 10 000 x 1296)."""
    dim = features.dim
    tensor = np.asarray(weights).T.reshape((features.n,) * dim + (len(weights),))
    letters = "ijklmnopqrstuvwxyz"[:dim]
    grid = "ABCDEFGHIJKLMNOPQR"[:dim]
    operands, terms = [tensor], [letters + "a"]
    for j in range(dim):
        operands.append(nrbf_factors(features, j, axes[j]))
        terms.append(grid[j] + letters[j])
    return np.einsum(",".join(terms) + "->" + grid + "a", *operands, optimize=True)


def nrbf_check(features: NRBF, real, **constants) -> str | None:
    """None, or one line saying why an NRBF's ranges, its r^2 and its clamp
    (`clamp_margin`), or the other `constants` `{name: value}` of code that computes it in
    the NumPy type `real` (`np.float32`), do not fit that type."""
    low, high = np.array(features.low), np.array(features.high)
    with np.errstate(over="ignore", invalid="ignore"):
        span = high.astype(real) - low.astype(real)
        r2, s_max = real(features.r2), real(1.0 + clamp_margin(features.n, features.r2))
        others = np.array(list(constants.values()), dtype=np.float64).astype(real)
    if not (np.all(np.isfinite(span)) and np.all(span > 0) and np.isfinite(s_max)
            and np.isfinite(r2) and r2 >= np.finfo(real).tiny and np.all(np.isfinite(others))):
        parts = ["the ranges", f"r^2 = {features.r2!r}",
                 *(f"{name} = {value!r}" for name, value in constants.items())]
        return f"{', '.join(parts[:-1])} or {parts[-1]} do not fit {np.dtype(real).name}"
    return None


class LinearAgents(Agents):
    """Agents whose `arrays.weights` `(B, A, N)` weigh the features of `features`."""

    features: NRBF | CMAC
    """The feature map."""

    def _weights(self, weights):
        return self.arrays.weights if weights is None else np.asarray(weights)

    def action_values(self, states, weights=None) -> np.ndarray:
        phi = self.features.features(states)
        weights = self._weights(weights)
        if weights.ndim == 2:  # one agent's (A, N)
            return phi @ weights.T
        return np.einsum("...n,ban->b...a", phi, weights)

    def action_values_on_grid(self, axes, weights) -> np.ndarray:
        if isinstance(self.features, NRBF):
            return nrbf_on_grid(self.features, axes, weights)
        return super().action_values_on_grid(axes, weights)

    def state_values_on_grid(self, axes, weights) -> np.ndarray:
        """max_a Q over the grid, from `action_values_on_grid` (the NRBF's factorisation)."""
        return self.action_values_on_grid(axes, weights).max(axis=-1)

    def value_box(self) -> tuple:
        return self.features.low, self.features.high

    def feature_points(self):
        if not isinstance(self.features, NRBF):
            return None
        low, high = np.asarray(self.features.low), np.asarray(self.features.high)
        return low + self.features.centroids * (high - low)

    @property
    def weights(self) -> np.ndarray:
        """The weights w_ia as `(B, N, A)` (a view: it follows the agents as they learn)."""
        return self.arrays.weights.transpose(0, 2, 1)

    def saved(self) -> tuple[dict, dict]:
        """The feature map, the actions and step sizes, and the weights, streams and
        divergence flags (a learner adds its own)."""
        arrays = self.arrays
        document = {
            "features": describe_features(self.features),
            "num_actions": self.action_space.n,
            "alpha": (arrays.alpha / self.features.alpha_scale).tolist(),
            "lambda": arrays.lam.tolist(),
            "epsilon": arrays.epsilon.tolist(),
            "gamma": arrays.gamma.tolist(),
        }
        return document, {"weights": self.weights, "streams": arrays.streams,
                          "diverged": arrays.diverged}

    @classmethod
    def loaded(cls, document, arrays, **extra):
        """The agents `saved` wrote, made with `cls(features, num_actions, alpha=..., lam=...,
        epsilon=..., gamma=..., seeds=..., **extra)` (a ValueError if the parts do not fit)."""
        features = features_from(document["features"])
        weights, streams = arrays["weights"], arrays["streams"]
        expected = (len(streams), features.num_features, document["num_actions"])
        if weights.shape != expected:
            raise ValueError(f"weights of shape {weights.shape} do not fit {len(streams)} agents "
                             f"of {features.num_features} features and {document['num_actions']} actions")
        agent = cls(features, document["num_actions"], alpha=document["alpha"],
                    lam=document["lambda"], epsilon=document["epsilon"], gamma=document["gamma"],
                    seeds=np.zeros(len(streams), dtype=np.uint64), **extra)
        agent.weights[:] = weights
        agent.arrays.streams[:] = streams
        return agent

    def controller(self, b: int) -> ControllerForm:
        """The greedy NRBF controller, `argmax_a sum_i w_ia phibar_i(s)`, for the export's
        template `lwrl_policy` (`export.c`), over the rows `controller_rows(b)`."""
        features = self.features
        if not isinstance(features, NRBF):
            raise ValueError(f"only NRBF agents can be exported to C; these have "
                             f"{type(features).__name__} features")
        margin = clamp_margin(features.n, features.r2)
        low, high = np.array(features.low), np.array(features.high)
        return ControllerForm(
            template="lwrl_policy",
            values={"weights": self.controller_rows(b), "low": low, "high": high,
                    "r2": features.r2, "s_min": -margin, "s_max": 1.0 + margin,
                    "n": features.n, "neurons": features.num_features,
                    "grid": " x ".join([str(features.n)] * features.dim),
                    "r2_text": f"{features.r2:g}"},
            stored=("weights", "low", "high", "r2"), ranges=(features.low, features.high),
            check=lambda real: nrbf_check(features, real))

    def controller_rows(self, b: int) -> np.ndarray:
        """`(A, N)` the rows of agent b's weights that its C controller sums over the
        features (`controller`): every action's."""
        return self.arrays.weights[b]
