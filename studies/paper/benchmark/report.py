"""The second benchmark's report: the verdicts by docs/FINDINGS.md's rule across every task
(`judge`), and the document (`document`) with the aggregates across tasks and their figures,
a task with discrete and with continuous actions side by side (`torques`), per task the
reference rows, each row's normalised scores at each fraction of the budget, its compute to
the level, the comparisons with the paper's agent and every search configuration's score
beside the chosen one."""

import dataclasses
import glob
import os
import time

import matplotlib.pyplot as plt
import numpy as np

from lwrl import agent
from lwrl.agent.arithmetic import NotCounted
from lwrl.analysis import statistics, verdicts
from lwrl.analysis.plots import markdown_images, plot_estimates, save_figure
from lwrl.runners.store import compute_spent
from lwrl.studies.paper.benchmark import evaluation, judging, protocol, search, sensitivity, study, torques, twin_cost

THRESHOLDS = np.linspace(-0.25, 1.5, 71)
"""The performance profiles' normalised scores."""


@dataclasses.dataclass
class Judged:
    """One task's comparisons (Holm-corrected across every task), computes and verdict."""

    runs: study.TaskRuns
    """The task's `study.TaskRuns`."""
    comparisons: list
    computes: dict
    verdict: str
    cpu_s_per_step: dict = dataclasses.field(default_factory=dict)
    """`{label: CPU seconds of a learning step}` of the rows whose cost was measured."""


def judge(task_runs: list, cpu_s_per_step: dict) -> list:
    """`Judged` of every task of `task_runs` (`study.TaskRuns`), with the CPU seconds of a
    learning step `{(task, label): seconds}` (absent: not measured); Holm's correction runs
    across every task and rival."""
    comparisons = []
    for runs in task_runs:
        random_scores = _random_scores(runs)
        comparisons += [judging.compare(runs.task, runs.scores, random_scores, rival)
                        for rival in protocol.deep(runs.task) if (rival, 1.0) in runs.scores]
    comparisons = judging.holm_family(comparisons) if comparisons else []
    judged = []
    for runs in task_runs:
        mine = [c for c in comparisons if c.task == runs.task]
        computes = {label: judging.compute(runs.scores, label, protocol.BUDGETS[runs.task],
                                           cpu_s_per_step.get((runs.task, label)),
                                           macs_per_step(runs.trainings.get((label, 1.0))))
                    for label, fraction in runs.scores if fraction == protocol.FRACTIONS[-1]}
        cpu = {label: cpu_s_per_step[runs.task, label] for label in computes
               if cpu_s_per_step.get((runs.task, label)) is not None}
        judged.append(Judged(runs, mine, computes, judging.verdict(mine, runs.scores, computes), cpu))
    return judged


def macs_per_step(config):
    """`steps -> multiply-adds per agent-step` of a row's training `config` (its learner's
    `arithmetic`, updates amortised over the steps), or None: no configuration (an outside
    row), a learner without counts, or settings it does not count (CMAC features)."""
    if config is None:
        return None
    learner = agent.learner(config.learner)
    if learner.arithmetic is None:
        return None
    try:
        learner.arithmetic(config.settings, config.task_spec)
    except NotCounted:
        return None
    return lambda steps: learner.arithmetic(config.settings, config.task_spec, steps).step.macs


def _random_scores(runs) -> np.ndarray:
    """The random row's own agents' normalised scores (about 0)."""
    return study.normalised(runs.task, runs.references["random"], runs.references)


def rivals(judged: list) -> list:
    """The deep rows of the tasks of `judged`, in the order of their tasks (`protocol.deep`)."""
    return list(dict.fromkeys(rival for j in judged for rival in protocol.deep(j.runs.task)))


def aggregate_matrix(judged: list) -> dict:
    """`{label: agents x tasks}` final normalised scores of the rows every task has."""
    final = protocol.FRACTIONS[-1]
    labels = [label for label, fraction in judged[0].runs.scores if fraction == final
              and all((label, final) in j.runs.scores for j in judged)]
    return {label: np.stack([j.runs.scores[label, final] for j in judged], axis=1)
            for label in labels}


def document(judged: list, command: str, started: float, figure_dir: str, out_dir: str,
             unfinished=()) -> str:
    """The report's Markdown, its figures written to `figure_dir`: the call `command` began
    at `started` (`time.perf_counter()`), and the header states its wall time until the
    document is made; `unfinished` names the directory's tasks whose runs are not all
    written (a line each)."""
    columns = rivals(judged)
    lines = ["", *unfinished_lines(unfinished),
             cost_line(out_dir, [j.runs.task for j in judged],
                       set().union(*(j.runs.tables.get("run", ()) for j in judged))), "",
             "| task | verdict | " + " | ".join(f"against {rival}" for rival in columns) + " |",
             "|---|---|" + "---|" * len(columns)]
    for j in judged:
        against = {c.rival: c.gate.reason.split(":")[0] for c in j.comparisons}
        lines.append(f"| {j.runs.task} | **{j.verdict}** | "
                     + " | ".join(against.get(rival, "—") for rival in columns) + " |")
    lines += ["", *leaderboard(judged), *aggregates_section(judged, figure_dir, out_dir),
              *torques.section(judged, figure_dir, out_dir)]
    for j in judged:
        lines += task_section(j, markdown_images(curves(j, figure_dir), out_dir),
                              markdown_images(sensitivity.figure(j.runs, figure_dir), out_dir))
    seconds = time.perf_counter() - started  # the figures made: all but writing the file
    header = ["# The second benchmark: the light-weight claim by a reviewer's rule", "",
              f"Written by `{command}` in {duration(seconds)} of wall time from the runs in "
              "its directory, every task it holds (what computing the runs cost is the "
              "ledger's line below; `lwrl bench report DIR` rewrites this from them alone). "
              "The rule is docs/FINDINGS.md's (\"The light-weight claim judged again\"), "
              "written before the runs. " + plants_line(judged)]
    return "\n".join(header + lines) + "\n"


def duration(seconds: float) -> str:
    """Wall time in seconds, or in minutes from two minutes."""
    return f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def unfinished_lines(unfinished) -> list:
    """A paragraph naming the tasks the report leaves out, their runs not all written, or
    nothing."""
    if not unfinished:
        return []
    return ["Not reported, their runs not all written (`lwrl bench status` says what is left, "
            "`lwrl bench run` computes it): " + "; ".join(unfinished) + ".", ""]


def leaderboard(judged: list) -> list:
    """Every row of every task, the outside rows (`study.TaskRuns.outside`) marked, by its
    final normalised score (mean over its agents, best first, with its interval)."""
    final = protocol.FRACTIONS[-1]
    lines = ["## Leaderboard", "",
             f"Every row of every task by its normalised score after the whole budget (the "
             f"mean over its agents and its {statistics.CONFIDENCE:.0%} bootstrap interval; the random "
             "row scores 0 and the classical controller 1). A row marked *outside* is an "
             "outside learner's results (`lwrl bench score`), in no verdict or aggregate.", "",
             "| task | rank | row | normalised score |", "|---|---|---|---|"]
    for j in judged:
        rows = [(statistics.mean_interval(values), label + mark)
                for scores, mark in ((j.runs.scores, ""), (j.runs.outside, " *outside*"))
                for (label, fraction), values in scores.items() if fraction == final]
        rows.sort(key=lambda row: -row[0].value)
        lines += [f"| {j.runs.task} | {rank} | {label} | {estimate.text(2)} |"
                  for rank, (estimate, label) in enumerate(rows, 1)]
    return lines + [""]


def plants_line(judged: list) -> str:
    """On which plants the rows' trainings ran (`RunConfig.plant`): one, or each with its
    rows (MuJoCo's model: the deep rows on MJX, the others on MuJoCo)."""
    rows = {}
    for j in judged:
        for (label, _), config in j.runs.trainings.items():
            rows.setdefault(config.plant, {})[label] = None
    if len(rows) == 1:
        return f"Every run is on the {next(iter(rows))} plant."
    return "The runs are on " + "; ".join(f"the {plant} plant ({', '.join(labels)})"
                                         for plant, labels in rows.items()) + "."


def cost_line(out_dir: str, tasks=None, runs=None) -> str:
    """What the runs in `out_dir/runs` (those of the keys `runs` where given: the report's)
    cost, as far as its ledger counts them (`runners.store.compute_spent`: a line per
    computed batch, kept across interruptions), then what the deep rows (of `tasks` where
    given) would have cost with Stable-Baselines3 alone (`twin_cost`)."""
    spent = compute_spent(out_dir, runs)
    files = {os.path.basename(path)[:-len(".csv.gz")]
             for path in glob.glob(os.path.join(out_dir, "runs", "*.csv.gz"))}
    held = f"the {len(files)} runs" if runs is None else f"the report's {len(files & runs)} runs"
    counted = (f"{spent['wall_s'] / 3600:.2f} h of wall time and {spent['cpu_s'] / 3600:.2f} h "
               f"of CPU on {', '.join(spent['hosts'])}" if spent["runs"] else "nothing")
    return (f"What the runs cost, from `compute.jsonl` (a line per computed batch): "
            f"{spent['runs']} of {held} in `runs/`, {counted}; a run it does not name was "
            "computed before the ledger was kept, or on the way by a longer run of its "
            f"family, as that run's first steps. {twin_cost.sentence(out_dir, tasks)}")


def aggregates_section(judged: list, figure_dir: str, out_dir: str) -> list:
    """Across the tasks judged against the paper's agent (those of discrete actions, whose
    rows are the same): IQM, median, mean and optimality gap with stratified bootstrap
    intervals, and the performance profiles (Agarwal et al. 2021), of the rows every such
    task has. A task of continuous actions has other rows and stands alone."""
    judged = [j for j in judged if protocol.light(j.runs.task) == protocol.LIGHT["discrete"]]
    scores = aggregate_matrix(judged) if judged else {}
    if not scores or len(judged) < 2:
        return ["Across tasks: one task only, no aggregate.", ""]
    estimates = verdicts.aggregate_estimates(scores)
    profiles = verdicts.performance_profiles(scores, THRESHOLDS)
    paths = (verdicts.plot_aggregates(estimates, figure_dir, "aggregates")
             + verdicts.plot_profiles(profiles, figure_dir, "profiles"))
    lines = ["## Across tasks", "",
             "| row | " + " | ".join(verdicts.AGGREGATES) + " |",
             "|---|" + "---|" * len(verdicts.AGGREGATES)]
    for label, values in estimates.items():
        lines.append(f"| {label} | " + " | ".join(values[a].text(2) for a in verdicts.AGGREGATES) + " |")
    lines += ["", *markdown_images(paths, out_dir), ""]
    return lines


def task_section(j: Judged, curve_images=(), sensitivity_images=()) -> list:
    """One task's tables: the reference rows, the rows with their curves `curve_images`, the
    comparisons and the search with its figure `sensitivity_images` (Markdown lines)."""
    runs, measure = j.runs, evaluation.task_measure(j.runs.task)
    lines = [f"## {runs.task}", "", f"Budget: {protocol.BUDGETS[runs.task]:,} steps per agent. "
             f"Measure: {measure.label}; random row "
             f"{statistics.mean_interval(runs.references['random']).text(1)}, classical row "
             f"{statistics.mean_interval(runs.references['classical']).text(1)}.", "",
             "| row | " + " | ".join(f"score at {f:g}" for f in protocol.FRACTIONS)
             + f" | agents reaching {protocol.LEVEL:g} | steps to it | CPU s to it "
             "| multiply-adds to it |",
             "|---|" + "---|" * (len(protocol.FRACTIONS) + 4)]
    for label, compute in j.computes.items():
        cells = [statistics.mean_interval(runs.scores[label, f]).text(2) for f in protocol.FRACTIONS]
        cpu = compute.cpu_s.text(3) if compute.cpu_s else "not measured"
        macs = (f"{compute.macs.value:.3g} [{compute.macs.low:.3g}, {compute.macs.high:.3g}]"
                if compute.macs else "not counted")
        lines.append(f"| {label} | " + " | ".join(cells)
                     + f" | {compute.reached} of {compute.agents} | {compute.steps.text(0)} | {cpu} "
                     f"| {macs} |")
    lines += ["", diverged_line(runs), "", *curve_images, "", f"**Verdict: {j.verdict}.**", ""]
    for c in j.comparisons:
        light = protocol.light(c.task)
        who = "paper's agent" if light == protocol.LIGHT["discrete"] else light
        lines.append(f"- against {c.rival}: {c.gate.reason}; P({who} better) "
                     f"{c.improvement.text(2)}; permutation p {c.p_value:.3g}, Holm "
                     f"{c.adjusted:.3g}{' (significant)' if c.significant else ''}.")
    lines += ["", *search_lines(runs), "", *sensitivity_images, ""]
    return lines


def diverged_line(runs) -> str:
    """Which rows' agents diverged in training, each counted at the task's worst outcome
    (`study.TaskRuns.diverged`, `evaluation.worst`)."""
    counts = [f"{label} at {fraction:g}, {n} of {len(runs.scores[label, fraction])}"
              for (label, fraction), n in runs.diverged.items() if n]
    if not counts:
        return "No row's agent diverged in training."
    return ("Agents that diverged in training (weights no longer finite: they act no more) "
            f"count the worst outcome of every episode, {evaluation.worst(runs.task):g} "
            f"({evaluation.task_measure(runs.task).label}): " + "; ".join(counts) + ".")


def search_lines(runs) -> list:
    """Every configuration's score, with how many of its agents diverged, the chosen one
    marked (`search`)."""
    lines = [f"Search ({search.CONFIGURATIONS} configurations x {search.AGENTS} agents, seeds "
             f"{search.SEEDS[0]} to {search.SEEDS[-1]}; a configuration with an agent that "
             "diverged in training ranks last, its score the other agents' mean, — where "
             "every one diverged):", "",
             "| row | configuration | normalised score | chosen |", "|---|---|---|---|"]
    for (label, i), values in sorted(runs.search_scores.items()):
        mark = "**yes**" if runs.chosen.get(label) == i else ""
        diverged = int(np.isnan(values).sum())
        note = f" ({diverged} of {len(values)} diverged)" if diverged else ""
        lines.append(f"| {label} | {i} | {statistics.mean_interval(values).text(2)}{note} | {mark} |")
    return lines


def curves(j: Judged, figure_dir: str) -> list:
    """Each row of one task's greedy normalised score (mean and interval over agents) against
    the environment steps it trained for and against the CPU seconds they cost it (one
    agent, one thread, its fastest implementation; a row whose cost was not measured is
    left out there); the paths written."""
    figure, (by_steps, by_cpu) = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    steps = np.array(protocol.FRACTIONS) * protocol.BUDGETS[j.runs.task]
    for label in j.computes:
        estimates = [statistics.mean_interval(j.runs.scores[label, f]) for f in protocol.FRACTIONS]
        xs = [(by_steps, steps)]
        if label in j.cpu_s_per_step:
            xs.append((by_cpu, steps * j.cpu_s_per_step[label]))
        for axes, x in xs:
            plot_estimates(axes, x, estimates, label)
    for axes in (by_steps, by_cpu):
        axes.axhline(protocol.LEVEL, color="grey", linewidth=0.8, linestyle="--")
    by_steps.set_xlabel("environment steps of training")
    by_steps.set_ylabel("greedy normalised score")
    by_cpu.set_xscale("log")
    by_cpu.set_xlabel("CPU seconds of training (one agent, one thread)")
    by_steps.legend(fontsize="small")
    figure.suptitle(j.runs.task)
    figure.tight_layout()
    return save_figure(figure, figure_dir, f"{j.runs.task}-curves")
