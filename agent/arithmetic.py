"""Counted arithmetic: the multiply-adds and exponentials of a learner's greedy decision and
of one agent-step of its learning, from its settings and the task's sizes.

Each learner declares its own counts (`Learner.arithmetic`,
`arithmetic(settings, task, steps=None) -> Counts`, in its module); this module holds what
they share: `Count` and `Counts`, the MLPs' forward passes and parameters, the optimiser's
and the backward pass's share, and the NRBF grid's greedy decision. The counts are what the
second benchmark's rule "Compute to a level" (docs/FINDINGS.md) multiplies by the steps an
agent takes, and what `benchmarks.deep_speed` sets beside the time it measures.

What is counted: multiply-adds (MACs: a multiplication and the addition it feeds; the
biases' additions, comparisons and the random draws' integer arithmetic are not counted)
and exponentials (exp, tanh, log and cos count one each), from the shapes alone: the work a
learner's equations ask for, not the time an implementation takes over it.
"""

import dataclasses

OPTIMISER_MACS = 10
"""Arithmetic per parameter of one gradient step beside the gradient, counted as
multiply-adds: the global norm (1) and the clipping's scale (1), Adam's first moment (2),
second moment (3) and step (3, with a square root and a division)
(`agent.jax_population.clip_by_norm`, `adam`; PyTorch's `clip_grad_norm_` and Adam)."""
BACKWARD_MACS = 2
"""A backward pass in forward passes' multiply-adds (the gradients with respect to each
layer's input and to its weights): forward and backward cost 3 forward passes."""


@dataclasses.dataclass(frozen=True)
class Count:
    """Multiply-adds and exponentials (exp, tanh, log, cos: one each)."""

    macs: float = 0.0
    """Multiply-adds."""
    exps: float = 0.0
    """Exponentials and the other transcendental functions, one each."""

    def __add__(self, other: "Count") -> "Count":
        return Count(self.macs + other.macs, self.exps + other.exps)

    def __mul__(self, factor: float) -> "Count":
        return Count(self.macs * factor, self.exps * factor)

    __rmul__ = __mul__


@dataclasses.dataclass(frozen=True)
class Counts:
    """A learner's counts: one greedy decision, and one agent-step of learning (its action
    and `update`, its share of the updates), with where they come from."""

    decision: Count
    """One greedy decision."""
    step: Count
    """One agent-step of learning: its action and its share of the updates."""
    update: Count
    """One update of the learner (of one transition, or the learner's unit of update)."""
    source: str
    """The sizes counted and the function that counted them, in one line."""


class NotCounted(ValueError):
    """A learner's `arithmetic` has no count for these settings (e.g. CMAC features); the
    message says which, in a few words."""


def mlp_forward(sizes, exponential_activation: bool) -> Count:
    """One forward pass of an MLP with layer widths `sizes` (input, hidden..., output), SB3's
    `create_mlp`: in x out multiply-adds per layer (the biases' additions not counted) and
    one activation per hidden unit, an exponential where it is tanh (ReLU: none)."""
    macs = sum(a * b for a, b in zip(sizes[:-1], sizes[1:]))
    return Count(macs, sum(sizes[1:-1]) if exponential_activation else 0)


def mlp_parameters(sizes) -> int:
    """Weights and biases of an MLP with layer widths `sizes`."""
    return sum(a * b + b for a, b in zip(sizes[:-1], sizes[1:]))


def nrbf_decision(dim: int, n: int, actions: int) -> Count:
    """One greedy decision over NRBF features (Främling 2008, eq. 8, 9) as `agent/nrbf.py`
    computes them: d n exponentials (eq. 8 factorised per dimension; as written it takes one
    per feature, n^d), n + n^2 + ... + n^d multiply-adds for the outer product of the
    factors (`outer_product_into`), and A N for Q(s, .) over the A actions (N = n^d)."""
    return Count(sum(n ** m for m in range(1, dim + 1)) + actions * n ** dim, dim * n)


def nrbf_counts(settings, dim: int, actions: int, update) -> Counts:
    """A linear learner over an NRBF grid (`agent.linear`) of `dim` state variables with
    `actions` outputs (its action values; the actor-critic's one mean): its greedy decision
    (`nrbf_decision`), and at every agent-step of learning that decision for its action
    (epsilon-greedy on Q(s', .)) and its update of one transition,
    `update(dim, n, actions) -> Count`: the counts do not depend on the steps. `NotCounted`
    for other feature maps."""
    if settings.features != "nrbf":
        raise NotCounted(f"{settings.features} features")
    n = settings.n
    decision = nrbf_decision(dim, n, actions)
    learning = update(dim, n, actions)
    return Counts(decision, decision + learning, learning,
                  f"NRBF {' x '.join([str(n)] * dim)} grid (N = {n ** dim}, d n = {dim * n} "
                  f"exponentials), {actions} actions ({update.__module__}.{update.__name__}, "
                  f"{__name__}.nrbf_decision)")
