"""analysis/task_verdict.py: a task's verdict by the third benchmark's rule on comparisons
whose verdict is read off the rule's words."""

import math

import pytest

from lwrl.analysis.statistics import Estimate
from lwrl.analysis.task_verdict import Against, verdict

CHEAP, SHORT, DEAR = Estimate(0.002, 0.001, 0.004), Estimate(0.02, 0.005, 0.03), Estimate(
    3.0, 1.5, 5.0)
STRADDLING = Estimate(0.009, 0.006, 0.012)  # its point below 1/100, its interval not
NONE = Estimate(math.nan, math.nan, math.nan)


@pytest.mark.parametrize("comparisons, expected", [
    ([("dqn", True, "not worse", CHEAP), ("ppo", True, "better", CHEAP)], "yes"),
    ([("dqn", True, "not worse", CHEAP), ("ppo", True, "not worse", STRADDLING)], "partly"),
    ([("dqn", True, "not worse", CHEAP), ("ppo", True, "better", NONE)], "partly"),
    ([("dqn", True, "not worse", CHEAP), ("ppo", True, "worse", CHEAP)], "no"),
    ([("dqn", True, "not worse", CHEAP), ("ppo", True, "better", DEAR)], "no"),
    ([("dqn", True, "undecided", CHEAP), ("ppo", True, "worse", CHEAP)], "no"),
    ([("dqn", True, "undecided", CHEAP), ("ppo", True, "better", CHEAP)], "undecided"),
    ([("dqn", True, "undecided", SHORT), ("ppo", True, "not worse", SHORT)], "undecided"),
    # a comparison that does not pass the gate does not count either way
    ([("dqn", False, "worse", DEAR), ("ppo", True, "not worse", CHEAP)], "yes"),
    ([("dqn", False, "not worse", CHEAP), ("ppo", False, "better", CHEAP)], "not judged"),
])
def test_the_rule_s_verdicts(comparisons, expected):
    judged, why = verdict([Against(*c) for c in comparisons])
    assert judged == expected
    if expected in ("no", "undecided", "partly"):
        assert any(rival in why for rival, *_ in comparisons)


def test_the_reason_names_the_rivals_that_decide():
    _, why = verdict([Against("dqn", True, "not worse", CHEAP),
                      Against("ppo", True, "not worse", STRADDLING)])
    assert "ppo" in why and "dqn" not in why
    _, why = verdict([Against("dqn", True, "worse", CHEAP), Against("ars", True, "better", DEAR),
                      Against("ppo", True, "undecided", CHEAP)])
    assert why == "shown worse than dqn; more CPU to the level than ars"
