"""What other installed packages add to lwrl's registries, through entry points.

A registry of lwrl (`agent.LEARNERS`, `tasks.DOMAINS`) is lwrl's own entries, then those of
an entry-point group (`lwrl.learners`, `lwrl.tasks`): each entry point of an installed
distribution, `NAME = module:attribute`, names one value of the registry's kind called NAME.
`admitted` reads them, in the order of their names (then of their distributions), and
admits each beside those registered and those before it. One that is bad is skipped with a
one-line warning naming it, its distribution and what is wrong: its name taken, an import
that fails, a value not of the registry's kind or not of its own name, or what the
registry's own `check` refuses.

A warning, not an error (pytest stops at a plugin that fails to import, as a plugin changes
how every test runs; Gymnasium warned of a failing environment plugin and went on): a
registry is made once, as its room is imported, and every command imports it, so one broken
package must not stop the runs of everything else. Nothing passes unnoticed for that: every
run, results table and saved agent names its learner and its task, so a skipped one cannot
stand in for another (asking for it names an unknown one), and a taken name keeps what had
it. `python -W "error:lwrl.tasks entry point"` (or `lwrl.learners`) makes each an error.
"""

import warnings
from typing import Any, Callable, Mapping, Optional


def admitted(group: str, kind: type[Any], noun: str, registered: Mapping, entry_points,
             owner: Callable, check: Optional[Callable] = None) -> dict:
    """`{name: value}` of `entry_points` (of `group`), each a `kind` called by its entry
    point's name (its `name`), in the order of their names (then of their distributions);
    `registered` is left as it was.

    `noun` says what an entry is in the messages (`learner`, `domain`), `owner(value)` the
    module a registered value comes from, and `check(value)`, where given, raises a
    ValueError saying what else is wrong with a loaded value. The warnings are attributed
    to the caller of the registry's own function (which calls this one)."""
    found: dict = {}
    for entry_point in sorted(entry_points, key=lambda each: (each.name, each.dist.name)):
        try:
            found[entry_point.name] = _loaded(entry_point, {**registered, **found}, kind, noun,
                                              owner, check)
        except ValueError as problem:
            dist = entry_point.dist
            warnings.warn(f"{group} entry point '{entry_point.name} = {entry_point.value}' of "
                          f"{dist.name} {dist.version} {problem}; skipped", stacklevel=3)
    return found


def _loaded(entry_point, taken: Mapping, kind: type[Any], noun: str, owner: Callable,
            check: Optional[Callable]):
    """The value an entry point names, or a ValueError saying what is wrong with it."""
    if entry_point.name in taken:
        raise ValueError(f"takes the name of {owner(taken[entry_point.name])}'s {noun}: an "
                         f"added {noun} needs a name of its own")
    try:
        named = entry_point.load()
    except Exception as error:  # whatever the package raises, it is the package's fault
        raise ValueError(f"fails to import ({type(error).__name__}: "
                         f"{' '.join(str(error).split())})") from None
    if not isinstance(named, kind):
        raise ValueError(f"names a {type(named).__name__}, not a {kind.__name__} "
                         f"({kind.__module__})")
    if named.name != entry_point.name:
        raise ValueError(f"names the {noun} {named.name!r}: an entry point's name must be "
                         f"its {noun}'s")
    if check is not None:
        check(named)
    return named
