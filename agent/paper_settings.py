"""The paper agent's settings per task: `PAPER_SETTINGS`, beside the learner they set.

The paper's agent is gradient-descent Sarsa(lambda) over the NRBF network (`agent.sarsa`,
`agent.nrbf`; Främling 2008, eq. 1, 6, 8, 9). For each of its tasks the paper (or the
author's script, SPEC.md) gives the settings it ran: the NRBF's centroids per dimension n,
the trace rule, alpha, lambda, epsilon, gamma, and the protocol's episodes and agents. They
are the learner's facts about a task, not the task's, so they live here, as MuJoCo
Playground keeps tuned settings beside its learners rather than inside its environments;
a task keeps its normalisation ranges (`TaskDefinition.ranges`, `TaskSpec.ranges`), which
are facts of its state.

`PAPER_SETTINGS` is `{domain: {task: PaperSettings}}`: lwrl's tasks', then those other
installed packages add with entry points of the group `lwrl.paper_settings`
(`DOMAIN = module:attribute`, the attribute a dict of `PaperSettings` by task;
`lwrl.outside.DomainFacts`). A run of a task without an entry takes its learner's own
defaults (`runners.config.task_defaults`); a part that needs the paper's settings of a task
(`paper_settings`) refuses one without them in one line naming the group.
"""

import dataclasses

from lwrl.outside import DomainFacts


@dataclasses.dataclass(frozen=True)
class PaperSettings:
    """The paper agent's settings on one task; the field names are those of the learner's
    settings (`agent.linear.LinearSettings`) and the protocol's (`ProtocolSettings`)."""

    n: int
    """NRBF centroids per dimension: the network has n^d neurons (eq. 8)."""
    trace: str
    """The trace rule (`agent.traces.TRACES`)."""
    alpha: float
    """The learning rate alpha (eq. 1)."""
    lam: float
    """The trace decay lambda."""
    epsilon: float
    """Exploration rate of the epsilon-greedy policy."""
    episodes: int
    """Episodes per agent of the protocol."""
    agents: int
    """Agents of the protocol."""
    gamma: float = 1.0
    """Discount rate (1 in all the paper's tasks)."""


PAPER_SETTINGS = DomainFacts("lwrl.paper_settings", dict, "paper agent's settings", {
    # the paper's best agent (Fig. 3) and SPEC.md's epsilon
    "mountain_car": {"cost_to_go": PaperSettings(
        n=8, trace="replacing", alpha=3.9, lam=0.9, epsilon=0.0, episodes=40, agents=30)},
    # the paper's best agent (Fig. 5); epsilon and the protocol of the author's script
    "pendulum": {"swingup": PaperSettings(
        n=10, trace="replacing", alpha=1.5, lam=0.4, epsilon=0.1, episodes=200, agents=10)},
    # the author's script's agent (SPEC.md's readings), the paper's epsilon
    "cartpole": {"balance": PaperSettings(
        n=6, trace="accumulating", alpha=0.5, lam=0.7, epsilon=0.1, episodes=200, agents=10)},
    # found for this suite (docs/acrobot/README.md): no paper gives an NRBF agent here
    "acrobot": {"swingup": PaperSettings(
        n=6, trace="replacing", alpha=1.0, lam=0.9, epsilon=0.0, episodes=200, agents=10)},
})
"""`{domain: {task: PaperSettings}}` (see the module)."""


def has_paper_settings(task: str) -> bool:
    """True where the task DOMAIN.TASK has the paper agent's settings."""
    domain, _, name = task.partition(".")
    return domain in PAPER_SETTINGS and name in PAPER_SETTINGS[domain]


def paper_settings(task: str) -> PaperSettings:
    """The paper agent's settings on `task` (DOMAIN.TASK), or a one-line ValueError naming
    the domains (or the domain's tasks) that have them and the entry-point group through
    which a package adds them."""
    domain, _, name = task.partition(".")
    per_task = PAPER_SETTINGS.of(domain)
    if name not in per_task:
        raise ValueError(f"no {PAPER_SETTINGS.noun} for the task {task!r} (the domain's tasks "
                         f"with them: {', '.join(per_task) or 'none'}); the entry point "
                         f"'{domain} = module:attribute' of the group {PAPER_SETTINGS.group!r} "
                         f"names them, a dict of PaperSettings by task")
    return per_task[name]
