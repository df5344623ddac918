"""One random stream per agent, usable inside compiled loops.

Each agent draws from its own SplitMix64 stream (Steele, Lea and Flood 2014), a 64-bit state
that advances by a constant and is hashed on output. An agent's draws depend only on its own
seed, so its results are the same whether it runs alone or in any batch, in any order.
"""

import numpy as np
from numba.extending import register_jitable

_GOLDEN_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_MIX_1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX_2 = np.uint64(0x94D049BB133111EB)
_SHIFTS = (np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11))
_TO_UNIT = 2.0 ** -53


def seed_streams(seeds) -> np.ndarray:
    """Stream states (uint64) from integer seeds, one per agent; equal seeds give equal streams."""
    seeds = np.asarray(seeds)
    if seeds.ndim != 1 or seeds.dtype.kind not in "iu" or np.any(seeds < 0):
        raise ValueError(f"seeds must be a 1-D sequence of non-negative integers; got {seeds!r}")
    return seeds.astype(np.uint64)


@register_jitable
def uniform(streams, i):
    """Advance stream `i` of `streams` (uint64 array, updated in place); return a float in [0, 1)."""
    streams[i] += _GOLDEN_GAMMA
    z = streams[i]
    z = (z ^ (z >> _SHIFTS[0])) * _MIX_1
    z = (z ^ (z >> _SHIFTS[1])) * _MIX_2
    z = z ^ (z >> _SHIFTS[2])
    return (z >> _SHIFTS[3]) * _TO_UNIT
