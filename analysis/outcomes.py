"""A comparison's outcome by the third benchmark's rule (docs/FINDINGS.md, "The light-weight
claim judged a third time", the rule's "Tests"): better, not worse, worse or undecided, from
Welch's one-sided tests with a margin (`analysis.power`) judged together across the family
by the graphical procedure (`analysis.graphical.margin_graph`).

Per comparison of the light-weight row x against a rival y, d = mean(x) - mean(y), three
hypotheses (Chow, Shao & Wang 2008, Sec. 3.2):
- "not worse" (non-inferiority), H0: d <= -margin, `power.non_inferiority(x, y, margin)`;
- "worse", H0: d >= 0, `power.non_inferiority(y, x, 0)`;
- "better" (superiority), H0: d <= 0, `power.non_inferiority(x, y, 0)`.

The outcome: **better** where "better" is rejected; **not worse** where "not worse" is (also
where "worse" is too: a shortfall within the margin is what the margin allows); **worse**
where "worse" is and "not worse" is not; otherwise **undecided**, with the smallest
difference the rows could detect beside it (`power.detectable_difference` at the level the
procedure starts a hypothesis at, alpha / (2 C)). The two one-sided tests of equivalence
within the margin (Schuirmann 1987, `power.equivalence`) are reported beside, not in the
outcome.
"""

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from lwrl.analysis import graphical, power
from lwrl.analysis.graphical import BETTER, NOT_WORSE, WORSE

MARGIN = 0.1
"""The rule's non-inferiority margin on the normalised score."""
ALPHA = 0.05
"""The family-wise error rate of the rule's family."""
UNDECIDED = "undecided"
OUTCOMES = (BETTER, NOT_WORSE, WORSE, UNDECIDED)


@dataclasses.dataclass(frozen=True)
class Outcome:
    """One comparison's outcome: the difference of the means, each hypothesis's p-value,
    adjusted p-value (across the family) and whether it is rejected, keyed by
    `graphical.HYPOTHESES`; the equivalence p-value; the smallest shift the rows could
    detect with 80 % power (NaN but where the outcome is undecided)."""

    outcome: str
    difference: float
    p_values: dict
    adjusted: dict
    rejected: dict
    equivalence: float
    detectable: float


def hypothesis_p_values(x, y, margin: float = MARGIN) -> dict:
    """The three one-sided p-values of the light-weight row's scores `x` against the rival's
    `y`, keyed by `graphical.HYPOTHESES`."""
    return {NOT_WORSE: power.non_inferiority(x, y, margin).p_value,
            WORSE: power.non_inferiority(y, x, 0.0).p_value,
            BETTER: power.non_inferiority(x, y, 0.0).p_value}


def outcome(rejected: dict) -> str:
    """The rule's outcome from which of the three hypotheses are rejected."""
    if rejected[BETTER]:
        return BETTER
    if rejected[NOT_WORSE]:
        return NOT_WORSE
    if rejected[WORSE]:
        return WORSE
    return UNDECIDED


def _finite(values):
    """`values` as floats, or a one-line ValueError where one is NaN: the rule counts an agent
    whose learning diverged at the task's worst outcome, which its caller gives (the
    benchmark's `evaluation.measure(..., diverged_as_worst=True)`), not as a missing agent."""
    values = np.asarray(values, dtype=float)
    if np.isnan(values).any():
        raise ValueError("a comparison's score is NaN (a diverged agent's?): the rule counts a "
                         "diverged agent at the task's worst outcome, so give that score")
    return values


def judge(pairs: Sequence[tuple], margin: float = MARGIN, alpha: float = ALPHA,
          family: int | None = None) -> list:
    """The `Outcome` of each comparison of `pairs` (a sequence of (light-weight row's scores,
    rival's scores), one score per agent), its hypotheses judged together by the graphical
    procedure of `graphical.margin_graph` at family-wise `alpha`. `family`, the comparisons
    the family holds (`len(pairs)` where None), may be more than those run: the others'
    hypotheses are never shown (p 1), so their levels stay theirs and the family's levels do
    not depend on which runs are written."""
    if not pairs:
        raise ValueError("the family needs at least one comparison")
    comparisons = len(pairs) if family is None else family
    if isinstance(comparisons, bool) or not isinstance(comparisons, int) or comparisons < len(pairs):
        raise ValueError(f"family must be a whole number of comparisons at least the "
                         f"{len(pairs)} run; got {family!r}")
    pairs = [(_finite(x), _finite(y)) for x, y in pairs]
    p_values = [hypothesis_p_values(x, y, margin) for x, y in pairs]
    flat = [p[h] for p in p_values for h in graphical.HYPOTHESES]
    flat += [1.0] * (len(graphical.HYPOTHESES) * (comparisons - len(pairs)))
    weights, transitions = graphical.margin_graph(comparisons)
    adjusted = graphical.adjusted_p_values(flat, weights, transitions)
    family = 2 * comparisons
    outcomes = []
    for c, ((x, y), p) in enumerate(zip(pairs, p_values)):
        mine = dict(zip(graphical.HYPOTHESES, (float(a) for a in adjusted[3 * c:3 * c + 3])))
        shown = {h: mine[h] <= alpha for h in graphical.HYPOTHESES}
        result = outcome(shown)
        detectable = math.nan
        if result == UNDECIDED:
            detectable = power.detectable_difference(
                float(np.std(x, ddof=1)), float(np.std(y, ddof=1)), len(x), len(y), alpha,
                family)
        outcomes.append(Outcome(result, float(np.mean(x) - np.mean(y)), p, mine, shown,
                                power.equivalence(x, y, margin), detectable))
    return outcomes
