"""A task's (or variant's) verdict by the third benchmark's rule (docs/FINDINGS.md, "The
light-weight claim judged a third time", the rule's "Verdict per task and variant"), from the
light-weight row's comparisons against its judged rivals: each one's outcome
(`analysis.outcomes`), whether it passes the gate (`verdicts.above_random_gate`), and the
ratio of the light-weight row's CPU to the level to the rival's, with its interval
(thresholds on the interval, `analysis.thresholds`):

- **yes** where the light-weight row is shown not worse than every one of them and reaches the
  level with at most 1/100 of each one's CPU (the interval's upper end below 1/100);
- **no** where its outcome against one of them is "worse", or it needs more CPU than one of
  them to the level (the interval's lower end above 1);
- **partly** where it is shown not worse than every one, short of the compute threshold
  against one;
- **undecided** where against one of them neither "not worse" nor "worse" is shown;
- **not judged** where no comparison passes the gate.

As the second benchmark's verdict did, the verdict is over the comparisons that pass the gate;
"no" is decided first (one shown shortfall settles it), then "undecided". "Better" is shown
only after "not worse" (`graphical.margin_graph`), so it counts as not worse.
"""

import dataclasses

from lwrl.analysis import thresholds
from lwrl.analysis.graphical import WORSE
from lwrl.analysis.outcomes import UNDECIDED
from lwrl.analysis.statistics import Estimate

COMPUTE_FRACTION = 0.01
"""The share of a rival's CPU to the level the light-weight row must be shown below."""
YES, NO, PARTLY, NOT_JUDGED = "yes", "no", "partly", "not judged"
VERDICTS = (YES, NO, PARTLY, UNDECIDED, NOT_JUDGED)


@dataclasses.dataclass(frozen=True)
class Against:
    """The light-weight row against one rival: whether the comparison passes the gate, its
    outcome (`outcomes.OUTCOMES`) and the CPU ratio light / rival to the level."""

    rival: str
    judged: bool
    outcome: str
    cpu_ratio: Estimate


def verdict(comparisons: list) -> tuple:
    """`(verdict, why)`: the task's verdict (`VERDICTS`) from its `Against` comparisons, and
    the rivals that decide it."""
    judged = [c for c in comparisons if c.judged]
    if not judged:
        return NOT_JUDGED, "no comparison passes the gate"
    worse = [c.rival for c in judged if c.outcome == WORSE]
    dearer = [c.rival for c in judged if thresholds.wholly_above(c.cpu_ratio, 1.0)]
    if worse or dearer:
        return NO, "; ".join(part for part in (
            worse and "shown worse than " + ", ".join(worse),
            dearer and "more CPU to the level than " + ", ".join(dearer)) if part)
    undecided = [c.rival for c in judged if c.outcome == UNDECIDED]
    if undecided:
        return UNDECIDED, "neither not worse nor worse shown against " + ", ".join(undecided)
    short = [c.rival for c in judged
             if not thresholds.wholly_below(c.cpu_ratio, COMPUTE_FRACTION)]
    if short:
        return PARTLY, "not shown below 1/100 of the CPU of " + ", ".join(short)
    return YES, "not worse than every judged rival, with under 1/100 of each one's CPU"
