"""What other installed packages add to lwrl's registries, through entry points.

A registry of lwrl (`agent.LEARNERS`, `tasks.DOMAINS`, and each part's facts about domains,
`DomainFacts`) is lwrl's own entries, then those of an entry-point group (`lwrl.learners`,
`lwrl.tasks`, ...): each entry point of an installed distribution, `NAME = module:attribute`,
names one value of the registry's kind called NAME (for `DomainFacts`, NAME is the domain's).
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

import importlib.metadata
import warnings
from typing import Any, Callable, Iterator, Mapping, Optional


def admitted(group: str, kind: type[Any], noun: str, registered: Mapping, entry_points,
             owner: Callable, check: Optional[Callable] = None, named: bool = True) -> dict:
    """`{name: value}` of `entry_points` (of `group`), each a `kind` called by its entry
    point's name (its `name`), in the order of their names (then of their distributions);
    `registered` is left as it was.

    `noun` says what an entry is in the messages (`learner`, `domain`), `owner(value)` the
    module a registered value comes from, and `check(value)`, where given, raises a
    ValueError saying what else is wrong with a loaded value; `named`: the value has a
    `name`, which must be its entry point's (a domain's facts are named by the entry point
    alone). The warnings are attributed to the caller of the registry's own function (which
    calls this one)."""
    found: dict = {}
    for entry_point in sorted(entry_points, key=lambda each: (each.name, each.dist.name)):
        try:
            found[entry_point.name] = _loaded(entry_point, {**registered, **found}, kind, noun,
                                              owner, check, named)
        except ValueError as problem:
            dist = entry_point.dist
            warnings.warn(f"{group} entry point '{entry_point.name} = {entry_point.value}' of "
                          f"{dist.name} {dist.version} {problem}; skipped", stacklevel=3)
    return found


def _loaded(entry_point, taken: Mapping, kind: type[Any], noun: str, owner: Callable,
            check: Optional[Callable], named: bool):
    """The value an entry point names, or a ValueError saying what is wrong with it."""
    if entry_point.name in taken:
        raise ValueError(f"takes the name of {owner(taken[entry_point.name])}'s {noun}: an "
                         f"added {noun} needs a name of its own")
    try:
        value = entry_point.load()
    except Exception as error:  # whatever the package raises, it is the package's fault
        raise ValueError(f"fails to import ({type(error).__name__}: "
                         f"{' '.join(str(error).split())})") from None
    if not isinstance(value, kind):
        raise ValueError(f"names a {type(value).__name__}, not a {kind.__name__} "
                         f"({kind.__module__})")
    if named and value.name != entry_point.name:
        raise ValueError(f"names the {noun} {value.name!r}: an entry point's name must be "
                         f"its {noun}'s")
    if check is not None:
        check(value)
    return value


class DomainFacts(Mapping):
    """One part's facts about domains, by domain name (DESIGN.md: a task is its spec and its
    physics; every other part keeps its own facts): `own`, the part's entries for lwrl's
    domains, then those of the entry points of `group` (`admitted`), each naming a `kind`
    for the domain of its name. Read on first use, so that importing a part reads no other
    package. `of(domain)` is a domain's entry, or one line naming the domains that have one
    and the group to register under."""

    def __init__(self, group: str, kind: type[Any], noun: str, own: Mapping):
        self.group, self.kind, self.noun = group, kind, noun
        self._own = dict(own)
        self._all: Optional[dict] = None

    def _entries(self) -> dict:
        if self._all is None:
            self._all = {**self._own, **admitted(
                self.group, self.kind, self.noun, self._own,
                importlib.metadata.entry_points(group=self.group),
                owner=lambda value: type(value).__module__, named=False)}
        return self._all

    def __getitem__(self, domain: str):
        return self._entries()[domain]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries())

    def __len__(self) -> int:
        return len(self._entries())

    def of(self, domain: str):
        """The entry of `domain`, or a one-line ValueError naming the domains that have one
        and the entry-point group through which a package adds one."""
        if domain not in self:
            raise ValueError(f"no {self.noun} for the domain {domain!r} (the domains with one: "
                              f"{', '.join(self) or 'none'}); an installed package adds one with "
                              f"an entry point '{domain} = module:attribute' of the group "
                              f"{self.group!r}")
        return self[domain]
