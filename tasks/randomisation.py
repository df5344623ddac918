"""Physical parameters drawn anew for every episode: domain randomisation.

`randomise={name: (low, high)}` is an option of a run and of an environment (`tasks.load`,
`tasks.batched.BatchedEnv`, the compiled loop): at the start of each episode the named
parameters (`tasks.parameters`) take values drawn uniformly from their ranges, the others
keep theirs. This is domain randomisation (Tobin et al. 2017, "Domain randomization for
transferring deep neural networks from simulation to the real world"; Peng et al. 2018 for
dynamics) as CARL (Benjamins et al. 2023, "Contextually adaptive reinforcement learning")
samples its contexts: one context per episode, the agent not told which.

The values of environment b's episode k depend on its seed and k alone: a NumPy generator
of the seed's own stream (`STREAM`) and the episode, one uniform deviate per randomised
parameter in the domain's order. A batch, a single environment and a compiled loop (which
draws every episode's values before it starts) therefore give the same episodes.
"""

import math
import numbers
from typing import Mapping, Optional

import numpy as np

from lwrl.tasks.parameters import Parameters

STREAM = 0x7261  # a spawn key: the draws' streams apart from any other use of a seed
"""The spawn key of the per-episode parameter draws' streams."""


def check_ranges(parameters: Parameters, randomise: Optional[Mapping]) -> dict:
    """`{name: (low, high)}` in the domain's order, checked: each name a parameter, each
    range two finite numbers `low <= high` within the parameter's accepted range; a
    one-line ValueError naming what is allowed otherwise. None or `{}`: nothing drawn."""
    if not randomise:
        return {}
    if not isinstance(randomise, Mapping):
        raise ValueError(f"randomise must map parameter names to (low, high) ranges; got "
                         f"{randomise!r}")
    ranges = {}
    for name in randomise:
        parameter = parameters.items[parameters.position(name)]
        bounds = randomise[name]
        if (isinstance(bounds, (str, bytes)) or not hasattr(bounds, "__len__") or len(bounds) != 2
                or not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in bounds)
                or not all(math.isfinite(v) for v in bounds) or not bounds[0] <= bounds[1]
                or not (parameter.accepts(bounds[0]) and parameter.accepts(bounds[1]))):
            raise ValueError(f"randomise[{name!r}] must be a range (low, high), low <= high, "
                             f"within {parameter.allowed()}; got {bounds!r}")
        ranges[name] = (float(bounds[0]), float(bounds[1]))
    return {name: ranges[name] for name in parameters.names if name in ranges}


def _entropy(seed) -> int | None:
    """An integer seed for the draws' stream: the seed, a number taken from a NumPy
    Generator (not advancing it), or None (fresh entropy)."""
    if isinstance(seed, np.random.Generator):
        return int(seed.spawn(1)[0].integers(2 ** 63))
    return None if seed is None else int(seed)


def episode_values(parameters: Parameters, ranges: dict, row: np.ndarray, seed,
                   episode: int) -> np.ndarray:
    """The parameter vector `(P,)` of the episode `episode` (from 0) of the environment
    seeded with `seed`: `row` with each parameter of `ranges` (`check_ranges`) drawn."""
    values = np.array(row, dtype=np.float64)
    if ranges:
        rng = np.random.default_rng(np.random.SeedSequence(_entropy(seed),
                                                           spawn_key=(STREAM, int(episode))))
        for name, (low, high) in ranges.items():
            values[parameters.names.index(name)] = low + (high - low) * rng.random()
    return values


def draws(parameters: Parameters, ranges: dict, rows: np.ndarray, seeds,
          episodes: int) -> np.ndarray:
    """`(B, K, P)`: the parameter vectors of every episode of B environments, environment b
    seeded with `seeds[b]` and at `rows[b]` `(B, P)` but for the drawn parameters."""
    rows = np.asarray(rows, dtype=np.float64)
    if not ranges:
        return np.repeat(rows[:, None, :], episodes, axis=1)  # a new array, as the stack's
    return np.stack([[episode_values(parameters, ranges, row, seed, k) for k in range(episodes)]
                     for row, seed in zip(rows, seeds)])
