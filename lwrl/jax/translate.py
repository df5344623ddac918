"""One physics, another array library: a domain's NumPy-written functions run on JAX arrays.

The suite writes each domain's physics once, element-wise, in NumPy's vocabulary (`np.sin`,
`np.minimum`, arithmetic and indexing: `tasks/<domain>.py`), so that NumPy batches, the
dm_env Physics and numba's compiled loops all call the same functions. `as_jax(f)` is that
function with its module's `np` bound to `jax.numpy` instead, and every function of lwrl
(or of the domain's own package, for a domain of another package) it calls bound in the same
way, recursively: the same code, traced by JAX. Nothing is ported,
so nothing can drift from the NumPy plant but the library's own arithmetic (the operations
are the same, in the same order; `tests/test_jax_tasks.py` holds the two to 1e-12).
"""

import functools
import types

import jax.numpy as jnp


class Vocabulary:
    """`jax.numpy` as a function's `np`, with `float64` standing for the environment's
    floating-point type (`float32` unless JAX runs in 64 bits)."""

    def __init__(self, dtype):
        self.float64 = dtype
        """The environment's floating-point type, which `np.float64` means here."""

    def __getattr__(self, name):
        return getattr(jnp, name)


def _translated_alike(value, function) -> bool:
    """True where `value`, called by `function`, is a function of lwrl or of `function`'s
    own package (a domain of another package, `tasks.ENTRY_POINT_GROUP`, calls its own)."""
    return isinstance(value, types.FunctionType) and value.__module__.split(".")[0] in (
        "lwrl", function.__module__.split(".")[0])


@functools.lru_cache(maxsize=None)
def as_jax(function, dtype=jnp.float64):
    """`function` (a NumPy-written function of a domain) with `np` bound to `jax.numpy` and
    the functions of lwrl and of its own package it calls translated alike; `dtype` is what
    its `np.float64` means."""
    vocabulary = Vocabulary(dtype)
    names = dict(function.__globals__)
    names["np"] = vocabulary
    for name in function.__code__.co_names:
        value = names.get(name)
        if _translated_alike(value, function) and value is not function:
            names[name] = as_jax(value, dtype)
    translated = types.FunctionType(function.__code__, names, function.__name__,
                                    function.__defaults__, function.__closure__)
    names[function.__name__] = translated  # a recursive call stays in JAX
    translated.__doc__ = function.__doc__
    return translated
