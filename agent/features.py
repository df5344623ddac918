"""What the agent's feature maps share: the state box, its normalisation, batch evaluation.

Both feature maps (`agent.nrbf.NRBF`, `agent.cmac.CMAC`) read states in task units through
an affine map of each variable from its range `[low, high]` to `[0, 1]`, not clipped.
"""

import numpy as np
from numba.extending import register_jitable


@register_jitable
def normalise(state, low, high):
    """The affine map of a state from `[low, high]` to `[0, 1]`, not clipped (element-wise)."""
    return (state - low) / (high - low)


def check_box(low, high):
    """`(low, high)` as tuples of floats, or a one-line error naming what is wrong."""
    low = np.asarray(low, dtype=np.float64)
    high = np.asarray(high, dtype=np.float64)
    if low.ndim != 1 or low.shape != high.shape or low.size == 0:
        raise ValueError(f"low and high must be 1-D of the same length d >= 1; "
                         f"got shapes {low.shape} and {high.shape}")
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and np.all(low < high)):
        raise ValueError(f"low must be finite and below a finite high in every dimension; "
                         f"got low={low.tolist()}, high={high.tolist()}")
    return tuple(low.tolist()), tuple(high.tolist())


class FeatureMap:
    """Base of the frozen feature-map dataclasses: the checked state box `low`, `high` and
    batch evaluation through the subclass's `num_features` and compiled
    `_features_rows(rows (B, d), out (B, N))`."""

    low: tuple
    """Lower end of each state variable's range (task units); maps to 0."""
    high: tuple
    """Upper end of each state variable's range (task units); maps to 1."""
    alpha_scale = 1.0
    """The factor the learner applies to alpha (the CMAC may divide it by its tilings)."""

    def __post_init__(self):
        low, high = check_box(self.low, self.high)
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)

    @property
    def dim(self) -> int:
        """d, the number of state variables."""
        return len(self.low)

    def features(self, states) -> np.ndarray:
        """The features `(..., N)` of states `(..., d)` in task units (`(d,)`, `(B, d)`)."""
        states = np.asarray(states, dtype=np.float64)
        if states.ndim == 0 or states.shape[-1] != self.dim:
            raise ValueError(f"states must have shape (..., {self.dim}); got {states.shape}")
        if not np.all(np.isfinite(states)):
            raise ValueError("states must be finite (out-of-range values are fine)")
        rows = np.ascontiguousarray(states.reshape(-1, self.dim))
        out = np.empty((rows.shape[0], self.num_features))
        self._features_rows(rows, out)
        return out.reshape(states.shape[:-1] + (self.num_features,))
