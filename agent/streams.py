"""One random stream per agent, usable inside compiled loops.

Each agent draws from its own SplitMix64 stream (Steele, Lea and Flood 2014), a 64-bit state
that advances by a constant and is hashed on output. An agent's draws depend only on its own
seed, so its results are the same whether it runs alone or in any batch, in any order.
"""

import collections
import math

import numpy as np
from numba.extending import register_jitable

SplitMix64 = collections.namedtuple("SplitMix64", "increment multipliers shifts unit")
"""A SplitMix64 stream's constants (see `SPLITMIX64`)."""
SPLITMIX64 = SplitMix64(increment=0x9E3779B97F4A7C15,
                        multipliers=(0xBF58476D1CE4E5B9, 0x94D049BB133111EB),
                        shifts=(30, 27, 31, 11), unit=2.0 ** -53)
"""The stream `uniform` draws from, in plain numbers, for code that draws lwrl's numbers
elsewhere (the C learner, `export.learner`): the state's increment (the golden gamma), the
hash's two multipliers, its three shifts and then the one that keeps 53 bits, and 2^-53,
which makes those bits a float in [0, 1)."""
_GOLDEN_GAMMA = np.uint64(SPLITMIX64.increment)
_MIX_1, _MIX_2 = (np.uint64(m) for m in SPLITMIX64.multipliers)
_SHIFTS = tuple(np.uint64(s) for s in SPLITMIX64.shifts)
_TO_UNIT = SPLITMIX64.unit


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


@register_jitable
def gaussian(streams, i):
    """A standard normal draw from stream `i` (Box-Muller: two uniforms)."""
    u1 = 1.0 - uniform(streams, i)  # in (0, 1]
    u2 = uniform(streams, i)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)
