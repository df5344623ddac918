"""Settings as frozen dataclasses: the field metadata every configuration shares.

A run's configuration (`runners.config`) and each learner's settings (`agent/<learner>.py`)
are frozen dataclasses whose fields say, in their `metadata`, everything other code derives
from them, so that no list of field names is kept by hand:

- `flags`: the command-line flags (default `--name-with-hyphens`); `cli=False` keeps a
  field off the command line. The help is the field's docstring (`cli.fields`).
- `choices`: the allowed values, checked for every configuration (`check_choices`).
- `per_task`: the field's own default where a task gives none: a field left None takes
  the task's setting of the same name (the paper agent's, `agent.paper_settings`) where
  the task has one, else this value (`runners.config.task_defaults`).
- `key`: how the field enters a run's key (`runners.config.RunConfig.key_json`): named
  always, in field order (the default); `WHEN_SET`: only where it departs from its
  default, so that results computed before the field existed keep their key; `LATE`: as
  `WHEN_SET`, after the protocol's fields (where these readings entered the key when they
  were introduced).
- `per_agent`: agents of one batch may differ in it (the learner takes it per agent), so
  runs that differ only in such fields share a batch (`runners.sweep.batches`).
- `reading`: an open point of SPEC.md that `lwrl reproduce --set NAME=VALUE` may change.
- `only_with`: `(field, value)`: the field matters only where that other field has that
  value (an NRBF's spread means nothing to a CMAC), so a reading leaves the others alone.
- `describe`: a function returning text that the flag's help adds to the docstring (what
  is allowed, generated from where it is declared, e.g. the domains' parameters).

This module imports no other part of lwrl: every room may use it.
"""

import dataclasses
import math
import types

import numpy as np

WHEN_SET = "when_set"
"""A field's `key`: in the run key only where it departs from its default."""
LATE = "late"
"""A field's `key`: as `WHEN_SET`, after the protocol's fields."""


def setting(default=None, *, choices=None, flags=None, cli=True, per_task=None,
            key=None, per_agent=False, reading=False, only_with=None, default_factory=None,
            describe=None):
    """A dataclass field with the metadata above."""
    metadata = {"cli": cli, "per_agent": per_agent, "reading": reading}
    if per_task is not None:
        metadata["per_task"] = per_task
    if describe is not None:
        metadata["describe"] = describe
    if choices is not None:
        metadata["choices"] = tuple(choices)
    if flags is not None:
        metadata["flags"] = tuple(flags)
    if key is not None:
        if key not in (WHEN_SET, LATE):
            raise ValueError(f"key must be {WHEN_SET!r} or {LATE!r}; got {key!r}")
        metadata["key"] = key
    if only_with is not None:
        metadata["only_with"] = tuple(only_with)
    if default_factory is not None:
        return dataclasses.field(default_factory=default_factory, metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def base_type(annotation):
    """`float` of `float | None`: a field's type without its None."""
    if isinstance(annotation, types.UnionType):
        kinds = [kind for kind in annotation.__args__ if kind is not type(None)]
        return kinds[0] if len(kinds) == 1 else str
    return annotation


SCALARS = (str, int, float, bool)
"""The types of settings that take one value (a column of a results table)."""


def default_of(field: dataclasses.Field):
    """The value a field takes when not given."""
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return field.default


def fields_with(cls, name: str) -> tuple:
    """The names of the fields of `cls` whose metadata `name` is true."""
    return tuple(field.name for field in dataclasses.fields(cls) if field.metadata.get(name))


def fill(instance, /, **values) -> None:
    """Set fields of a frozen dataclass while it is being made (`__post_init__` only)."""
    for name, value in values.items():
        object.__setattr__(instance, name, value)


def check_choices(settings) -> None:
    """Every field with `choices` holds one of them (or None)."""
    for field in dataclasses.fields(settings):
        allowed = field.metadata.get("choices")
        value = getattr(settings, field.name)
        if allowed and value is not None and value not in allowed:
            raise ValueError(f"unknown {field.name} {value!r}; allowed: {', '.join(allowed)}")


def check_count(name: str, value, minimum: int) -> int:
    """An integer parameter `>= minimum`, or a one-line error."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def _number(value) -> bool:
    return isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)


def check_flag(name: str, value) -> None:
    """True or False, or a one-line error."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be true or false; got {value!r}")


def check_unit_interval(name: str, value) -> None:
    """A number in [0, 1], or a one-line error."""
    if not (_number(value) and 0.0 <= value <= 1.0):
        raise ValueError(f"{name} must be a number in [0, 1]; got {value!r}")


def check_positive(name: str, value) -> None:
    """A finite number > 0, or a one-line error."""
    if not (_number(value) and 0 < value < math.inf):
        raise ValueError(f"{name} must be a finite number > 0; got {value!r}")


def check_non_negative(name: str, value) -> None:
    """A finite number >= 0, or a one-line error."""
    if not (_number(value) and 0 <= value < math.inf):
        raise ValueError(f"{name} must be a finite number >= 0; got {value!r}")


def applies(field: dataclasses.Field, settings) -> bool:
    """False where the field's `only_with` condition does not hold for `settings`."""
    condition = field.metadata.get("only_with")
    return condition is None or getattr(settings, condition[0], None) == condition[1]
