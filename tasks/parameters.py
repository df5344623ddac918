"""A domain's physical parameters: declared in its module, carried as arrays.

Each domain module names its physical constants once, as `Parameters`: for each its name,
symbol, unit, the paper's value (the nominal one) and the range the plants accept. Its
physics reads them from a parameter vector `p`, laid out in the declared order, through the
indices `Parameters.index` (`p[P.pole_mass]`); nothing outside `tasks/` names a parameter.
As in gymnax, where a task's `EnvParams` travel apart from its state, and in CARL's
contexts, the values are data, not code:

- one environment or agent: `p` of shape `(P,)`;
- a batch: rows `(B, P)`, one per environment (so one batch can span a grid); the
  element-wise physics takes them as columns, `np.moveaxis(values, -1, 0)`, so that
  `p[i]` is a `(B,)` array broadcasting with the state's columns, as it is a float in
  compiled code.

`Parameters.values` turns the user's `{name: value}` (dm_control's `task_kwargs={"params":
...}`) into such an array, or raises one line naming what is allowed.
"""

import collections
import dataclasses
import math
import numbers
from typing import Mapping, Optional

import numpy as np


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One physical constant of a domain."""

    name: str
    """The key users give it by, e.g. `pole_mass`."""
    symbol: str
    """The paper's symbol, e.g. `m`."""
    unit: str
    """Its unit, e.g. `kg` (`1` where it has none)."""
    nominal: float
    """The paper's value: every result of the suite is at this value unless told otherwise."""
    low: float
    """The smallest value the plants accept."""
    high: float
    """The largest value the plants accept."""
    doc: str
    """What it is, in a few words."""

    def accepts(self, value: float) -> bool:
        """True where `value` lies in `[low, high]`."""
        return self.low <= value <= self.high

    def allowed(self) -> str:
        """`name (symbol, unit) in [low, high]`, for messages and tables."""
        return f"{self.name} ({self.symbol}, {self.unit}) in [{self.low:g}, {self.high:g}]"


class Parameters:
    """The physical parameters of a domain, in the order of its parameter vectors."""

    def __init__(self, *parameters: Parameter):
        names = [parameter.name for parameter in parameters]
        if len(set(names)) != len(names):
            raise ValueError(f"parameter names must be unique; got {names}")
        for parameter in parameters:
            if not (parameter.accepts(parameter.nominal) and math.isfinite(parameter.low)
                    and math.isfinite(parameter.high)):
                raise ValueError(f"{parameter.name}: the nominal value {parameter.nominal!r} must "
                                 f"lie in a finite range; got [{parameter.low}, {parameter.high}]")
        self.items = tuple(parameters)
        """The `Parameter`s, in the vectors' order."""
        self.index = collections.namedtuple("Index", names)(*range(len(names)))
        """Where each parameter sits in a vector: `p[index.pole_mass]` (numba-jitable: a
        global tuple of integers)."""
        self.nominal = collections.namedtuple("Values", names)(
            *(parameter.nominal for parameter in parameters))
        """The paper's values, by name (`nominal.pole_mass`) and in order
        (`np.asarray(nominal)` is the vector `(P,)`)."""

    @property
    def names(self) -> tuple:
        """The parameters' names, in the vectors' order."""
        return tuple(parameter.name for parameter in self.items)

    def position(self, name) -> int:
        """Where `name` sits in a vector, or a one-line ValueError naming the parameters."""
        if name not in self.names:
            allowed = ", ".join(parameter.allowed() for parameter in self.items) or "none"
            raise ValueError(f"unknown parameter {name!r}; allowed: {allowed}")
        return self.names.index(name)

    def values(self, given: Optional[Mapping] = None, batch_size: Optional[int] = None) -> np.ndarray:
        """The parameter vector `(P,)` with the values `given` (`{name: value}`) and the
        nominal ones for the others; with `batch_size` B, rows `(B, P)`, where each value
        is one number for every environment or one per environment (a sequence of B).

        A ValueError of one line names what is wrong and what is allowed: an unknown name,
        a value that is not a real number, not finite or outside the parameter's range.
        """
        if given is None:
            given = {}
        if not isinstance(given, Mapping):
            raise ValueError(f"params must be a mapping of parameter names to values; got {given!r}")
        shape = (len(self.items),) if batch_size is None else (batch_size, len(self.items))
        values = np.broadcast_to(np.asarray(self.nominal, dtype=np.float64), shape).copy()
        for name, value in given.items():
            parameter = self.items[self.position(name)]
            values[..., self.position(name)] = per_environment(
                f"{parameter.name} ({parameter.symbol})", value, parameter.low, parameter.high,
                parameter.unit, batch_size)
        return values

    def table(self) -> str:
        """The parameters as a Markdown table (docs/guide/tasks.md's, checked by a test)."""
        lines = ["| parameter | symbol | unit | nominal | accepted range | what it is |",
                 "|---|---|---|---|---|---|"]
        lines += [f"| `{p.name}` | {p.symbol} | {p.unit} | {p.nominal:g} | {p.low:g} to {p.high:g} "
                  f"| {p.doc} |" for p in self.items]
        return "\n".join(lines)


def per_environment(name: str, value, low: float, high: float, unit: str,
                    batch_size: Optional[int], integer: bool = False) -> np.ndarray:
    """`value` as float64: one real number (`batch_size` None), or with a batch one number
    for every environment or a sequence of `batch_size`, one per environment; finite and
    within `[low, high]` (and whole with `integer`). Otherwise a one-line ValueError that
    names `name`, what is allowed and what was given."""
    kind = "whole number" if integer else "number"
    one = f"one {kind}" if batch_size is None else f"one {kind} or {batch_size}, one per environment"
    given = np.ravel(np.asarray(value, dtype=object))
    if (not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in given)
            or np.ndim(value) > (0 if batch_size is None else 1)
            or (np.ndim(value) == 1 and len(given) != batch_size)):
        raise ValueError(f"{name} must be {one}, within [{low:g}, {high:g}] {unit}; got {value!r}")
    array = np.asarray(value, dtype=np.float64)
    bad = ~np.isfinite(array) | (array < low) | (array > high)
    if integer:
        bad |= np.isfinite(array) & (array != np.round(array))
    if np.any(bad):
        raise ValueError(f"{name} must be a finite {kind} within [{low:g}, {high:g}] {unit}; got "
                         f"{np.ravel(array)[np.flatnonzero(np.ravel(bad))[0]].item()!r}")
    return array


def columns(values: np.ndarray) -> np.ndarray:
    """Parameter rows `(..., P)` as the columns `(P, ...)` that element-wise physics reads
    (`p[i]` the i-th parameter of every row)."""
    return np.moveaxis(np.asarray(values, dtype=np.float64), -1, 0)
