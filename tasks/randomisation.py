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


def _deviates(entropy, episode: int, count: int) -> np.ndarray:
    """`(count,)`: the uniform deviates of episode `episode` of the stream `entropy`
    (`_entropy`), one per randomised parameter in the domain's order."""
    stream = np.random.SeedSequence(entropy, spawn_key=(STREAM, int(episode)))
    return np.random.default_rng(stream).random(count)


KEPT_SEEDS = 512
"""How many seeds' deviates a process keeps (`kept_deviates`) before it starts again: a
benchmark row's training and evaluation seeds, 200, at 160 kB each for two parameters drawn
over 10 000 episodes."""

_kept: dict = {}


def kept_deviates(seed, episodes: int, count: int) -> np.ndarray:
    """`(episodes, count)`: the deviates (`_deviates`) of the first `episodes` episodes of
    the environment seeded with `seed`. For an integer seed they are kept for the process:
    every run of a benchmark's row, and each row of a variant, draws the same seeds'
    episodes, up to 10 000 each, at about 20 µs an episode."""
    def drawn(first: int) -> np.ndarray:  # episodes first.. up to `episodes`
        return np.array([_deviates(_entropy(seed), k, count) for k in range(first, episodes)]
                        ).reshape(-1, count)

    if not isinstance(seed, numbers.Integral):
        return drawn(0)
    key = (int(seed), count)
    kept = _kept.get(key, np.empty((0, count)))
    if len(kept) < episodes:
        kept = np.concatenate([kept, drawn(len(kept))])
        if len(_kept) >= KEPT_SEEDS:
            _kept.clear()
        _kept[key] = kept
    return kept[:episodes]


def _placed(parameters: Parameters, ranges: dict, values: np.ndarray,
           deviates: np.ndarray) -> np.ndarray:
    """`values` `(..., P)`, in place, with each parameter of `ranges` at `low + (high - low) * u`, u
    its column of `deviates` `(..., len(ranges))`."""
    for column, (name, (low, high)) in enumerate(ranges.items()):
        values[..., parameters.position(name)] = low + (high - low) * deviates[..., column]
    return values


def episode_values(parameters: Parameters, ranges: dict, row: np.ndarray, seed,
                   episode: int) -> np.ndarray:
    """The parameter vector `(P,)` of the episode `episode` (from 0) of the environment
    seeded with `seed`: `row` with each parameter of `ranges` (`check_ranges`) drawn."""
    values = np.array(row, dtype=np.float64)
    if not ranges:
        return values
    return _placed(parameters, ranges, values, _deviates(_entropy(seed), episode, len(ranges)))


def draws(parameters: Parameters, ranges: dict, rows: np.ndarray, seeds,
          episodes: int) -> np.ndarray:
    """`(B, K, P)`: the parameter vectors of every episode of B environments, environment b
    seeded with `seeds[b]` and at `rows[b]` `(B, P)` but for the drawn parameters."""
    rows = np.asarray(rows, dtype=np.float64)
    values = np.repeat(rows[:, None, :], episodes, axis=1)  # a new array, as the stack's
    for b, seed in enumerate(seeds if ranges else ()):
        _placed(parameters, ranges, values[b], kept_deviates(seed, episodes, len(ranges)))
    return values
