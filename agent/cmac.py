"""CMAC (binary tile coding) features, the baseline of Främling (2008), Figure 2.

SPEC.md, "Baseline": `tilings` offset tilings over the [0, 1]-normalised state, each a grid
of `intervals + 1` tiles per dimension (`intervals` tiles span [0, 1] and one more takes
the offset), one weight per tile and action. Tiling `t` is shifted by `t / tilings` of a
tile in every dimension. A state activates exactly one tile per tiling: `tilings` features
equal to 1, all others 0. States outside [0, 1] fall in the edge tiles. The default
(5 tilings of a 9 x 9 grid, i.e. 8 intervals) is the author's; Sutton's Mountain-Car code
uses 10 tilings and divides alpha by the tiling count (`normalise_alpha`).

Feature index: tiling-major, then the tile's grid indices in C order:
`t * (intervals + 1)^d + ravel_multi_index(tile, (intervals + 1,) * d)`.
"""

import dataclasses

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.features import FeatureMap, normalise
from lwrl.kernels import kernel
from lwrl.settings import check_count


@register_jitable
def cmac_features_into(state, low, high, intervals, tilings, out):
    """Write the binary tile-coding features of one state into `out` (`tilings * (intervals
    + 1)^d`,); returns None. Allocates nothing; runs in Python and in numba code."""
    d = state.shape[0]
    side = intervals + 1
    per_tiling = side ** d
    if out.shape[0] != tilings * per_tiling:
        raise ValueError("out must have shape (tilings * (intervals + 1)^d,)")
    out[:] = 0.0
    for t in range(tilings):
        index = 0
        for j in range(d):
            position = normalise(state[j], low[j], high[j]) * intervals + t / tilings
            tile = min(max(int(np.floor(position)), 0), intervals)
            index = index * side + tile
        out[t * per_tiling + index] = 1.0


def _cmac_features_batch(states, low, high, intervals, tilings, out):
    """`cmac_features_into` for each row of `states` (B, d) into the rows of `out` (B, N)."""
    for b in range(states.shape[0]):
        cmac_features_into(states[b], low, high, intervals, tilings, out[b])


FEATURES_BATCH = kernel("cmac_features_batch", _cmac_features_batch)
"""`_cmac_features_batch` compiled: the CMAC features of a batch of states."""


@dataclasses.dataclass(frozen=True)
class CMAC(FeatureMap):
    """Binary tile coding over the state box `[low, high]`."""

    low: tuple
    """Lower end of each state variable's range (task units); maps to 0."""
    high: tuple
    """Upper end of each state variable's range (task units); maps to 1."""
    intervals: int = 8
    """Tiles spanning [0, 1] per dimension (>= 1); each tiling has one more for its offset."""
    tilings: int = 5
    """Offset tilings (>= 1)."""
    normalise_alpha: bool = False
    """Divide alpha by the number of tilings (Sutton's code) when true."""

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "intervals", check_count("intervals", self.intervals, 1))
        object.__setattr__(self, "tilings", check_count("tilings", self.tilings, 1))

    @property
    def num_features(self) -> int:
        """N = tilings (intervals + 1)^d, the tiles of every tiling."""
        return self.tilings * (self.intervals + 1) ** self.dim

    @property
    def alpha_scale(self) -> float:
        """The factor applied to alpha: 1 / tilings when `normalise_alpha`, else 1."""
        return 1.0 / self.tilings if self.normalise_alpha else 1.0

    def _features_rows(self, rows, out):
        FEATURES_BATCH(rows, np.array(self.low), np.array(self.high), self.intervals,
                             self.tilings, out)
