"""The paper's figures and table: one `Item` each, with its grid, its analysis and the
paper's numbers.

Each item lists the runs it needs (`configs`) and turns their results into figures and a
report section (`analyse`) that puts our numbers beside the paper's and says whether they
reproduce, by a rule written in the section. Grids follow the paper or, where it is silent,
SPEC.md's readings; `quick=True` gives a tiny grid for smoke tests.

How the items judge (the report says it again beside each):

- Each rule judges the quantity the paper plots or states, quoted in the section (`claim`,
  `measure`): Fig. 5's mean up-time over agents staying above 40 s, not an agent touching it
  once; Table 1's agents balancing for a run of episodes, not once. The first-touch numbers
  stay as secondary rows.
- Every mean has a 95 % bootstrap interval over agents (`lwrl.analysis.statistics`), and
  "trace A better than trace B" is the probability of improvement with its interval.
- A best alpha (or lambda) is chosen on one half of the seeds and judged on the other, and
  a confirmation run judges the chosen cells on fresh agents (`studies.paper.judging`).
"""

from lwrl import agent
from lwrl.studies.paper.items import fig2, fig3, fig5, table1, traces
from lwrl.studies.paper.judging import Item

ITEMS = {
    "fig2": Item("fig2", "Fig. 2 — Mountain-Car: average steps per episode against λ at the best α",
                 fig2.configs, fig2.analyse),
    "fig3": Item("fig3", "Fig. 3 — Mountain-Car: the best agent's learning curve",
                 fig3.configs, fig3.analyse),
    "fig5": Item("fig5", "Fig. 5 — Pendulum: up-time per episode of the best agent",
                 fig5.configs, fig5.analyse, fig5.confirm),
    "fig6": Item("fig6", "Fig. 6 — Pendulum: average up-time against λ at the best α",
                 traces.fig6_configs, traces.fig6_analyse, traces.confirm),
    "fig8": Item("fig8", "Fig. 8 — Cart-Pole: average up-time against λ at the best α",
                 traces.fig8_configs, traces.fig8_analyse, traces.confirm),
    "table1": Item("table1", "Table 1 — Cart-Pole: episode at which agents balance",
                   table1.configs, table1.analyse, table1.confirm),
}
"""Every reproduced item; Table 1 reads Fig. 8's runs and the ASE/ACE's."""

JUDGED_TASKS = {"pendulum.swingup": "fig5", "cartpole.balance": "table1"}
"""The item each task's learning runs are held to where the plants are compared."""


def judge(task: str, learner: str = agent.DEFAULT_LEARNER):
    """`judge(table, figure_dir) -> (item name, Section)`: the paper's item for `task`'s
    learning runs (Fig. 5, Table 1), for `lwrl compare`; None for a task no item judges, and
    for a learner other than the paper's (its claims are about its own agent)."""
    if task not in JUDGED_TASKS or learner != agent.DEFAULT_LEARNER:
        return None
    name = JUDGED_TASKS[task]
    return lambda table, figure_dir: (name, ITEMS[name].analyse(table, figure_dir))
