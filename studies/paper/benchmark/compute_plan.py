"""The third benchmark's compute, planned before its runs (docs/FINDINGS.md, "The light-weight
claim judged a third time: the third benchmark's rule", "Compute") from what the second
benchmark's runs cost: its ledger (`compute.jsonl`, a line per computed batch with its CPU
seconds, `RunStore.record_compute`) over the agent-steps of the runs each line names, per
learner, training and greedy evaluation apart (`ledger_rates`); times the agent-steps the
third benchmark's design gives each row (`plan`): its search by successive halving
(`SEARCH_RUNGS`), its agents, its evaluations (`EVALUATIONS`) on each task and on the chosen
variants (`VARIANT_TASKS`, which run each row's configuration chosen on the task, without a
search of their own).

A learner the ledger does not count borrows another's rate (`STAND_INS`, stated in the
plan's table): the first runs' own records replace it.
"""

import pandas as pd

from lwrl import outputs
from lwrl.runners.store import RunStore, ledger_lines
from lwrl.studies.paper.benchmark import evaluation, protocol

SEARCH_RUNGS = ((32, 2, 0.125), (8, 4, 0.5), (2, 10, 1.0))
"""Successive halving: `(configurations, seeds, fraction of the budget)` per rung; the best
quarter of a rung's configurations goes on to the next, its seeds continuing their runs from
the rung's checkpoint and new seeds starting afresh."""
LIGHT_AGENTS = 100
"""Agents of each linear row (the paper's agent, its kin, the CMAC, ASE/ACE, the
actor-critic): their CPU is a few seconds a row."""
RIVAL_AGENTS = 20
"""Agents of each other row (the deep ones, ARS and the streaming learners): the count the
compute affords (the power analysis asks for more where a row spreads, `planning`)."""
EVALUATIONS = 20
"""Greedy evaluations of a row's run, log-spaced over the budget."""
FINE_EPISODES = 1
"""Greedy episodes at each evaluation but the verdicts' (at 1/4 and 1 times the budget): the
curve's area averages over the evaluations, so one episode each serves it."""
VERDICTS = 2
"""The evaluations the verdicts read, with `evaluation.EPISODES` episodes each."""
LONGER = 4
"""The longest budget a row still rising at 1 times it is continued to, in budgets."""
NEW_RIVALS = {"discrete": ("ars", "stream_q", "stream_ac"), "continuous": ("ars", "stream_ac")}
"""The rows the third benchmark adds (ARS, stream-Q(lambda), stream-AC(lambda)), by kind of
action."""
STAND_INS = {"cmac": "sarsa", "ase_ace": "sarsa", "ars": "ppo_jax", "ars_continuous": "ppo_jax",
             "stream_q": "ppo_jax", "stream_ac": "ppo_jax", "stream_ac_discrete": "ppo_jax"}
"""`{learner: learner whose ledger rate it borrows}` for learners the ledger does not count:
the linear ones the paper's agent's, the new rivals PPO's (one small network's update and
forward passes a step, no replay: not more than PPO's minibatch epochs a step)."""
VARIANT_TASKS = ("mountain_car.cost_to_go", "cartpole.balance", "acrobot.swingup")
"""The tasks whose chosen variant the third benchmark runs (`variants`, measured)."""


def ledger_rates(out_dir) -> pd.DataFrame:
    """Per task, learner and kind of run (training, or greedy evaluation) that the ledger of
    `out_dir` counts alone (its lines that name runs of that kind only): the lines, their CPU
    seconds, the agent-steps of their runs (the `steps` of every episode of their tables) and
    the CPU seconds per agent-step."""
    runs = RunStore(out_dir, make=False).directory
    counted = []
    for line in ledger_lines(out_dir):
        tables = [outputs.read_table(runs / f"{key}.csv.gz",
                                     usecols=["task", "actions", "learner", "greedy", "steps"])
                  for key in line["runs"]]
        kinds = {(t.task.iloc[0] + (protocol.CONTINUOUS if t.actions.iloc[0] == "continuous"
                                    else ""), t.learner.iloc[0], bool(t.greedy.iloc[0]))
                 for t in tables}
        if len(kinds) == 1:
            task, learner, greedy = kinds.pop()
            counted.append({"task": task, "learner": learner,
                            "run": "evaluation" if greedy else "training",
                            "cpu_s": line["cpu_s"],
                            "agent_steps": int(sum(t.steps.sum() for t in tables))})
    columns = ["task", "learner", "run", "lines", "cpu_s", "agent_steps", "cpu_s_per_agent_step"]
    if not counted:
        return pd.DataFrame(columns=columns)
    rates = (pd.DataFrame(counted).groupby(["task", "learner", "run"], sort=True)
             .agg(lines=("cpu_s", "size"), cpu_s=("cpu_s", "sum"),
                  agent_steps=("agent_steps", "sum")).reset_index())
    return rates.assign(cpu_s_per_agent_step=rates.cpu_s / rates.agent_steps)[columns]


def rates_table(rates: pd.DataFrame) -> str:
    """`ledger_rates` as a Markdown table."""
    lines = ["| task | learner | run | ledger lines | CPU h | agent-steps | CPU µs per agent-step |",
             "|---|---|---|---|---|---|---|"]
    lines += [f"| {r.task} | {r.learner} | {r.run} | {r.lines} | {r.cpu_s / 3600:.2f} | "
              f"{r.agent_steps:,} | {1e6 * r.cpu_s_per_agent_step:.1f} |"
              for r in rates.itertuples()]
    return "\n".join(lines)


def rate(rates: pd.DataFrame, learner: str, run: str) -> tuple:
    """`(CPU s per agent-step, the learner whose rate it is)`: `learner`'s over every task the
    ledger counts it on, else its stand-in's (`STAND_INS`), for `run` ("training" or
    "evaluation"); a ValueError where neither is counted."""
    for source in (learner, STAND_INS.get(learner)):
        part = rates[(rates.learner == source) & (rates.run == run)]
        if len(part):
            return float(part.cpu_s.sum() / part.agent_steps.sum()), source
    raise ValueError(f"the ledger counts no {run} of {learner!r} and it has no stand-in; "
                     f"stand-ins: {', '.join(STAND_INS)}")


def search_budgets() -> float:
    """The agent-budgets of one row's search (`SEARCH_RUNGS`): each rung's configurations
    continue their earlier seeds from the last rung's fraction and start the new ones."""
    total, seeds_before, fraction_before = 0.0, 0, 0.0
    for configurations, seeds, fraction in SEARCH_RUNGS:
        total += configurations * (seeds_before * (fraction - fraction_before)
                                   + (seeds - seeds_before) * fraction)
        seeds_before, fraction_before = seeds, fraction
    return total


def search_evaluations() -> int:
    """The agents evaluated at the ends of one row's search rungs."""
    return sum(configurations * seeds for configurations, seeds, _ in SEARCH_RUNGS)


def episode_steps(runs) -> dict:
    """`{label: mean steps of a greedy episode}` of each row's final evaluation in a finished
    task's `study.TaskRuns` (a diverged agent's episodes as long as the longest)."""
    final = protocol.FRACTIONS[-1]
    by_run = dict(iter(runs.tables.groupby("run")))
    return {label: float(by_run[evaluation.evaluation(config).key].steps.mean())
            for (label, fraction), config in runs.trainings.items() if fraction == final}


def plan(task_runs: dict, rates: pd.DataFrame, variants=VARIANT_TASKS) -> pd.DataFrame:
    """Per task (and variant) and row of the third benchmark: its learner, agents, the
    agent-steps of its training (search and row) and greedy evaluation, the rates' sources,
    its CPU hours, and the hours of continuing its agents to `LONGER` budgets (where it is
    still rising at 1). `task_runs`: `{task: study.TaskRuns}` of the second benchmark."""
    lines = []
    for task, runs in task_runs.items():
        steps = episode_steps(runs)
        learners = {label: config.learner for (label, fraction), config in runs.trainings.items()
                    if fraction == protocol.FRACTIONS[-1]}
        learners.update({label: label for label in NEW_RIVALS[protocol.variant(task)[1]]})
        placements = [(task, True)] + ([(f"{task} (variant)", False)] if task in variants else [])
        for place, searched in placements:
            for label, learner in learners.items():
                linear = label in steps and label not in protocol.deep(task)
                lines.append(row_plan(place, label, learner, protocol.BUDGETS[task], searched,
                                      LIGHT_AGENTS if linear else RIVAL_AGENTS,
                                      steps.get(label, max(steps.values())), rates))
    return pd.DataFrame(lines)


def row_plan(place: str, label: str, learner: str, budget: int, searched: bool, agents: int,
             episode: float, rates: pd.DataFrame) -> dict:
    """One line of `plan`: `agents` agents of `learner` for `budget` steps (after a search
    where `searched`), greedy episodes of `episode` steps."""
    train_rate, train_source = rate(rates, learner, "training")
    greedy_rate, greedy_source = rate(rates, learner, "evaluation")
    episodes = (EVALUATIONS - VERDICTS) * FINE_EPISODES + VERDICTS * evaluation.EPISODES
    training = budget * (agents + (search_budgets() if searched else 0.0))
    greedy = episode * (agents * episodes
                        + (search_evaluations() * evaluation.EPISODES if searched else 0))
    longer = ((LONGER - 1) * budget * train_rate + episode * evaluation.EPISODES * greedy_rate) * agents
    return {"task": place, "row": label, "learner": learner, "agents": agents,
            "training_agent_steps": training, "greedy_agent_steps": greedy,
            "rates_of": train_source if train_source == greedy_source
            else f"{train_source}, {greedy_source}",
            "cpu_h": (training * train_rate + greedy * greedy_rate) / 3600,
            "longer_cpu_h": longer / 3600}


def plan_table(planned: pd.DataFrame) -> str:
    """`plan` as a Markdown table, with the totals."""
    lines = [f"| task | row | rates of | agents | training agent-steps (M) | greedy agent-steps (M) "
             f"| CPU h | CPU h more to {LONGER} budgets |", "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r.task} | {r.row} | {r.rates_of} | {r.agents} | "
              f"{r.training_agent_steps / 1e6:.1f} | {r.greedy_agent_steps / 1e6:.1f} | "
              f"{r.cpu_h:.2f} | {r.longer_cpu_h:.2f} |" for r in planned.itertuples()]
    lines.append(f"| all | | | | {planned.training_agent_steps.sum() / 1e6:.0f} | "
                 f"{planned.greedy_agent_steps.sum() / 1e6:.0f} | {planned.cpu_h.sum():.1f} | "
                 f"{planned.longer_cpu_h.sum():.1f} |")
    return "\n".join(lines)
