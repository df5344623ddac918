"""Command-line flags generated from the configuration dataclasses (`runners.config`).

Each field becomes one flag: `--name-with-hyphens` unless its metadata names `flags`; its
help is the field's docstring; its parser follows its type (a finite number, an integer, a
comma-separated tuple of finite numbers, a word among the field's `choices`, a switch
for a bool, `--name` and `--no-name`, or repeated `NAME=VALUE` pairs for a dict,
`NAME=LOW:HIGH` where its values are ranges). Unset flags stay out of the configuration,
which then takes its defaults. So a field added to a dataclass is on the command line
without a second edit.

A bad value is one line: `lwrl train: error: argument --alpha: must be a finite number;
got 'inf'`.
"""

import argparse
import ast
import dataclasses
import functools
import inspect
import math
import textwrap
import types
import typing

from lwrl.settings import base_type


def finite_number(text: str) -> float:
    """A finite float, or an argparse error."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number; got {text!r}")
    return value


def integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer; got {text!r}") from None


def integer_at_least(minimum: int, meaning: str):
    """An argparse type for integers >= `minimum`, named `meaning` in its error."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be a {meaning} integer; got {text!r}")
        return value
    return parse


positive_int = integer_at_least(1, "positive")
non_negative_int = integer_at_least(0, "non-negative")


def numbers(text: str) -> tuple:
    """Comma-separated finite numbers, or an argparse error."""
    try:
        values = tuple(float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be comma-separated numbers; got {text!r}") from None
    if not all(map(math.isfinite, values)):
        raise argparse.ArgumentTypeError(f"must be finite numbers; got {text!r}")
    return values


def value_range(text: str) -> tuple:
    """`LOW:HIGH`, two finite numbers, or an argparse error."""
    low, colon, high = text.partition(":")
    if not colon:
        raise argparse.ArgumentTypeError(f"must be a range LOW:HIGH; got {text!r}")
    return finite_number(low), finite_number(high)


def pair(value):
    """An argparse type for `NAME=VALUE`, the value read by `value`: `(name, value)`."""
    def parse(text: str) -> tuple:
        name, equals, rest = text.partition("=")
        if not equals or not name:
            raise argparse.ArgumentTypeError(f"must be NAME=VALUE; got {text!r}")
        return name, value(rest)
    return parse


PAIR_VALUES = {float: (finite_number, "NAME=VALUE"), tuple: (value_range, "NAME=LOW:HIGH")}
"""How the values of a `dict[str, V]` field are read, and its metavar, by V."""


def pair_value(field: dataclasses.Field):
    """`(parser, metavar)` of the values of a `dict[str, V]` field, or None for another."""
    if typing.get_origin(field.type) is not dict:
        return None
    return PAIR_VALUES[typing.get_args(field.type)[1]]


def word(allowed):
    """An argparse type for one of `allowed` (its error names them)."""
    def parse(text: str) -> str:
        if text not in allowed:
            raise argparse.ArgumentTypeError(f"must be one of {', '.join(allowed)}; got {text!r}")
        return text
    return parse


@functools.lru_cache(maxsize=None)
def field_docs(cls) -> dict:
    """`{field: docstring}` of a dataclass and its bases: the string after each field."""
    docs = {}
    for klass in reversed(cls.__mro__):
        if not dataclasses.is_dataclass(klass):
            continue
        body = ast.parse(textwrap.dedent(inspect.getsource(klass))).body[0].body
        for statement, following in zip(body, body[1:]):
            if (isinstance(statement, ast.AnnAssign) and isinstance(following, ast.Expr)
                    and isinstance(following.value, ast.Constant)):
                docs[statement.target.id] = " ".join(following.value.value.split())
    return docs


def parser_of(field: dataclasses.Field):
    """The argparse type of a field's values, from its choices or its type (`NAME=VALUE`
    pairs for a dict)."""
    if field.metadata.get("choices"):
        return word(field.metadata["choices"])
    if pair_value(field):
        return pair(pair_value(field)[0])
    return {float: finite_number, int: integer, tuple: numbers}.get(base_type(field.type), str)


def cli_fields(*classes) -> list:
    """The fields of `classes` that go on the command line, each once, in order."""
    seen, fields = set(), []
    for cls in classes:
        for field in dataclasses.fields(cls):
            if field.metadata.get("cli", True) and field.name not in seen:
                seen.add(field.name)
                fields.append((cls, field))
    return fields


def flags_of(field: dataclasses.Field) -> tuple:
    return field.metadata.get("flags", (f"--{field.name.replace('_', '-')}",))


def _add_flag(group, field: dataclasses.Field, help_text: str, allowed=None) -> None:
    """The flag of one field: a switch for a bool (`--NAME` and `--no-NAME`), else a value
    read by its type."""
    if field.metadata.get("describe"):
        help_text = f"{help_text} Allowed: {field.metadata['describe']()}."
    help_text = help_text.replace("%", "%%")
    if pair_value(field):  # repeatable: the pairs make one dict
        group.add_argument(*flags_of(field), dest=field.name, type=parser_of(field),
                           action="append", default=None, metavar=pair_value(field)[1],
                           help=help_text)
        return
    if base_type(field.type) is bool:
        group.add_argument(*flags_of(field), dest=field.name,
                           action=argparse.BooleanOptionalAction, default=None, help=help_text)
        return
    allowed = allowed if allowed is not None else field.metadata.get("choices")
    metavar = ("{" + ",".join(allowed) + "}" if allowed else "V,V,..."
               if base_type(field.type) is tuple else flags_of(field)[0][2:].upper())
    kind = word(allowed) if allowed else parser_of(field)
    group.add_argument(*flags_of(field), dest=field.name, type=kind, default=None,
                       metavar=metavar, help=help_text)


def add_fields(parser: argparse.ArgumentParser, *classes, title: str | None = None) -> None:
    """One flag per command-line field of the dataclasses `classes`."""
    group = parser.add_argument_group(title) if title else parser
    for cls, field in cli_fields(*classes):
        _add_flag(group, field, field_docs(cls).get(field.name, ""))


def learner_fields(learners) -> dict:
    """`{name: [(learner, settings class, field), ...]}`: each command-line setting of the
    learners, with the learners that have it, in order."""
    found = {}
    for learner in learners:
        for cls, field in cli_fields(learner.settings):
            found.setdefault(field.name, []).append((learner, cls, field))
    return found


def add_learner_fields(parser: argparse.ArgumentParser, learners, title: str) -> None:
    """One flag per setting of any of `learners` (`agent.LEARNERS`' values): its help is the
    first learner's docstring of it, followed by the learners that take it; its choices
    are all of theirs (the chosen learner checks its own)."""
    group = parser.add_argument_group(title)
    for name, owners in learner_fields(learners).items():
        _, cls, field = owners[0]
        allowed = [value for _, _, f in owners for value in f.metadata.get("choices", ())]
        help_text = (f"{field_docs(cls).get(name, '')} [{', '.join(l.name for l, _, _ in owners)}]")
        _add_flag(group, field, help_text, tuple(dict.fromkeys(allowed)) or None)


def given(args: argparse.Namespace, *classes) -> dict:
    """`{field: value}` of the command-line fields of `classes` that were given (the
    pairs of a dict field as one dict; a name given twice is an error)."""
    values = {field.name: getattr(args, field.name) for _, field in cli_fields(*classes)
              if getattr(args, field.name, None) is not None}
    for _, field in cli_fields(*classes):
        if pair_value(field) and field.name in values:
            values[field.name] = pairs_dict(flags_of(field)[0], values[field.name])
    return values


def pairs_dict(flag: str, pairs) -> dict:
    """`{name: value}` of `(name, value)` pairs; a one-line ValueError for a name twice."""
    names = [name for name, _ in pairs]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise ValueError(f"{flag} {twice[0]} is given more than once")
    return dict(pairs)


def given_learner_settings(args: argparse.Namespace, learners) -> dict:
    """`{field: value}` of the learners' command-line settings that were given."""
    return {name: getattr(args, name) for name in learner_fields(learners)
            if getattr(args, name, None) is not None}


def parse_value(classes, name: str, text: str):
    """`text` read as the value of field `name` of the first of the dataclasses `classes`
    that has it (for `--set NAME=VALUE`); raises argparse.ArgumentTypeError naming the
    field."""
    field = next(f for cls in classes for f in dataclasses.fields(cls) if f.name == name)
    if base_type(field.type) is bool:
        if text.lower() not in ("true", "false"):
            raise argparse.ArgumentTypeError(f"{name} must be true or false; got {text!r}")
        return text.lower() == "true"
    if text.lower() == "none" and isinstance(field.type, types.UnionType):
        return None
    try:
        if pair_value(field):  # NAME=VALUE,NAME=VALUE
            return pairs_dict(name, [parser_of(field)(part) for part in text.split(",")])
        return parser_of(field)(text)
    except argparse.ArgumentTypeError as error:
        raise argparse.ArgumentTypeError(f"{name} {error}") from None
