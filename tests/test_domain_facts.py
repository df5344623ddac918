"""Each part's facts about the domains (`lwrl.outside.DomainFacts`): every entry fits the
domain it is about, lwrl's own domains have every part's, and a part asked for a domain it
has no entry for says so in one line, naming the entry-point group to register under."""

import pytest

from lwrl import tasks
from lwrl.agent.zoo import TUNED_AS
from lwrl.export.c_plants import C_PLANTS
from lwrl.outside import DomainFacts
from lwrl.studies.compare.domains import COMPARISONS
from lwrl.studies.paper.benchmark.classical import CLASSICAL
from lwrl.studies.paper.benchmark.variants import RANDOMISED
from lwrl.studies.robustness.domains import ROBUSTNESS
from lwrl.viz import scenes

LWRLS = ("mountain_car", "pendulum", "cartpole", "acrobot")


def state_names(domain: str) -> set:
    return {name for task in tasks.domain(domain).tasks
            for name in tasks.definition(domain, task).state_names}


@pytest.mark.parametrize("domain", LWRLS)
def test_lwrls_domains_have_every_parts_facts(domain):
    has_model = tasks.domain(domain).model is not None
    assert (scenes.SCENES.of(domain).drawing is None) == has_model, "a model or a drawing"
    assert (domain in COMPARISONS) == has_model, "compared where it has a model"
    assert domain in ROBUSTNESS and domain in CLASSICAL and domain in TUNED_AS
    assert domain in RANDOMISED


@pytest.mark.parametrize("domain", list(tasks.DOMAINS))
def test_every_entry_fits_its_domain(domain):
    names, parameters = state_names(domain), set(tasks.domain(domain).parameters.names)
    for task in tasks.domain(domain).tasks:
        axes = scenes.value_axes(domain, tasks.definition(domain, task).state_names)
        assert len(axes) == 2 and set(axes) <= names
    if domain in COMPARISONS:
        assert tasks.domain(domain).model is not None
        assert set(COMPARISONS[domain].tolerances) <= names
    if domain in ROBUSTNESS:
        assert 1 <= len(ROBUSTNESS[domain].axes) <= 2
        assert set(ROBUSTNESS[domain].axes) <= parameters
    if domain in RANDOMISED:
        assert set(RANDOMISED[domain]) <= parameters
    if domain in CLASSICAL:
        assert CLASSICAL[domain].summary.strip() and "\n" not in CLASSICAL[domain].summary


@pytest.mark.parametrize("facts", [scenes.SCENES, C_PLANTS, COMPARISONS, ROBUSTNESS, CLASSICAL,
                                   RANDOMISED, TUNED_AS], ids=lambda facts: facts.group)
def test_a_domain_without_an_entry_is_refused_in_one_line_naming_the_group(facts):
    with pytest.raises(ValueError) as error:
        facts.of("no_such_domain")
    message = str(error.value)
    assert "\n" not in message and f"'{facts.group}'" in message
    assert "no_such_domain = module:attribute" in message


def test_an_entry_point_adds_a_domains_fact(monkeypatch):
    """An installed package's entry point of a part's group adds its domain's entry, and one
    that names a value of another kind is skipped with one warning."""
    class Point:
        """An installed package's entry point, as importlib.metadata gives it."""

        dist = type("Distribution", (), {"name": "pkg", "version": "1"})

        def __init__(self, name, value, text):
            self.name, self.value, self._loaded = name, text, value

        def load(self):
            return self._loaded

    points = [Point("toy", ("mass",), "pkg:AXES"), Point("bad", 3, "pkg:BAD")]
    monkeypatch.setattr("importlib.metadata.entry_points", lambda group: points)
    facts = DomainFacts("lwrl.example", tuple, "example", {"own": ("x",)})
    with pytest.warns(UserWarning, match="lwrl.example entry point 'bad = pkg:BAD' of pkg 1 "
                                         "names a int, not a tuple"):
        assert dict(facts) == {"own": ("x",), "toy": ("mass",)}
    assert facts.of("toy") == ("mass",)
