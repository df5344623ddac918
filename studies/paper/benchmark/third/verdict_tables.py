"""The third benchmark's verdicts as its report's tables (`judging`'s results): the verdict
of every task at each budget point, and per task and point the light-weight row's
comparisons with each rival and every row's time to the level and success share; then the
aggregates across the four discrete tasks and the three variants by rliable
(`analysis.aggregates`), or the one line why not.
"""

import math

import numpy as np

from lwrl.analysis import aggregates, outcomes, plots, verdicts
from lwrl.analysis.graphical import HYPOTHESES
from lwrl.analysis.statistics import Estimate
from lwrl.studies.paper.benchmark import protocol
from lwrl.studies.paper.benchmark.third import clock, figures, judging, rule

EXPLAINED = [
    "Per task and point, the light-weight row (the paper's agent; the actor-critic on the "
    "continuous pendulum) against each rival: d = mean(light) − mean(rival) of the final "
    "normalised scores, with its 95 % bootstrap interval; the p values of \"not worse\", "
    "\"worse\" and \"better\" (adjusted across the family); the outcome; the smallest "
    "difference the rows could detect where undecided; TOST's p (equivalence within the "
    "margin, beside, not in the outcome); the area's d and outcome (a family of its own); the "
    "ratios of restricted mean steps, CPU and multiply-adds to the level 0.5 (light / rival, "
    "bootstrap intervals), the log-rank p of the steps and the pace. Then per row its agents "
    "at the level, the Kaplan-Meier medians of steps, CPU seconds and multiply-adds to it, "
    "where the task is reached or not the share of agents reaching it in every greedy "
    "episode (Clopper-Pearson interval), and the host CPUs its runs' records name. The rule "
    "reads the CPU; the multiply-adds (counted, `Learner.arithmetic`; transcendental "
    "functions apart, in the records) are a cost no host's speed or load moves, beside it "
    "for rows that ran on different hosts.", ""]
"""The report's words on the tables of every task and point."""
NOT_CONTINUED = (
    "The plan continues rows past the budget on the rule's four tasks only (docs/FINDINGS.md, "
    "\"Compute\"): here a row not rising at the budget stands at 4 times it with its score at 1, "
    "carried; a rising one is not run this far.")
"""The report's words at 4 times the budget on a task whose rows are not continued."""
PROFILE = (0.25, 0.5, 0.75, 1.0)
"""The normalised scores at which the report gives the performance profiles."""
AGGREGATED = (*rule.STAGE_1, *(t for t in rule.TASKS if rule.JOIN in t))
"""The tasks the aggregates run over: the four discrete tasks and the three variants."""


def two_digits(value: float) -> str:
    """A number (a p-value, a detectable difference) in two significant digits, a dash where
    there is none."""
    return f"{value:.2g}" if math.isfinite(value) else "—"


def family_line(name: str, size: int) -> str:
    """What the family is at the point `name`."""
    if not size:
        return f"- at {name} times the budget: no comparison is run yet."
    family = judging.family_size()
    return (f"- at {name} times the budget: {size} comparison{'s' * (size != 1)} run, of the "
            f"rule's family of {family}; \"not worse\" and \"worse\" start at "
            f"{outcomes.ALPHA} / {2 * family} each (the final scores' family; the areas' alike).")


def summary_lines(judged: dict) -> list:
    """The verdict of every task at every point, and each point's family."""
    names = list(judged)
    tasks = [t.task for t in judged[names[0]][0]]
    lines = ["## Verdicts", "",
             "| task | " + " | ".join(f"at {n} times the budget" for n in names) + " |",
             "|---|" + "---|" * len(names)]
    for i, task in enumerate(tasks):
        lines.append(f"| {task} | " + " | ".join(f"**{judged[n][0][i].verdict[0]}**"
                                                 for n in names) + " |")
    lines += ["", "The families of the graphical Holm procedure (Bretz et al. 2009; margin "
              f"{outcomes.MARGIN}), one per budget point over every task:", ""]
    return lines + [family_line(n, judged[n][1]) for n in names] + [""] + EXPLAINED


def significant(estimate: Estimate) -> str:
    """`estimate` with its interval in two significant digits (CPU seconds and their ratios
    span orders of magnitude)."""
    if not math.isfinite(estimate.low):
        return two_digits(estimate.value)
    return (f"{two_digits(estimate.value)} [{two_digits(estimate.low)}, "
            f"{two_digits(estimate.high)}]")


def comparison_row(c) -> str:
    """One comparison's cells (see `comparison_lines`)."""
    if not c.run:
        return f"| {c.rival} | not run |" + " — |" * 12
    f, a = c.final, c.area
    tests = ", ".join(f"{two_digits(f.p_values[h])} ({two_digits(f.adjusted[h])})"
                      for h in HYPOTHESES)
    return (f"| {c.rival} | {'passes' if c.gate.judged else c.gate.reason} | "
            f"{c.difference.text(2)} | {tests} | **{f.outcome}** | {two_digits(f.detectable)} | "
            f"{two_digits(f.equivalence)} | {c.area_difference.text(2)} | {a.outcome} | "
            f"{c.steps_ratio.text(2)} | {two_digits(c.logrank)} | {significant(c.cpu_ratio)} | "
            f"{significant(c.macs_ratio)} | {c.pace} |")


def comparison_lines(judged_task) -> list:
    """The light-weight row's comparisons on one task at one point (`EXPLAINED`)."""
    return ["| rival | gate | d | p not worse, worse, better (adjusted) | outcome | "
            "detectable | TOST p | area's d | area's outcome | steps ratio | log-rank p | "
            "CPU ratio | multiply-adds ratio | pace |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
            *map(comparison_row, judged_task.comparisons), ""]


def row_lines(judged_task, out_dir: str) -> list:
    """Every row's time to the level 0.5 (Kaplan-Meier medians), where the task is reached
    or not its success share, and its records' host CPUs, at one point."""
    shares = judging.reached_or_not(judged_task.task)
    lines = ["| row | agents at 0.5 | median steps to 0.5 | median CPU s to 0.5 | "
             "median multiply-adds to 0.5 | reach the task in every greedy episode | host CPU |",
             "|---|---|---|---|---|---|---|"]
    for label, pace in judged_task.paces.items():
        row_curve = judged_task.curves[label]
        if pace is None:
            lines.append(f"| {label} | not run | — | — | — | — | — |")
            continue
        share = (judging.success_share(judged_task.task, out_dir, row_curve.final).text(2)
                 if shares else "—")
        carried = " (carried)" if row_curve.carried else ""
        lines.append(f"| {label}{carried} | {int(pace.reached.sum())} of {len(pace.reached)} | "
                     f"{pace.median_steps.text(0)} | {significant(pace.median_cpu)} | "
                     f"{significant(pace.median_macs)} | {share} | "
                     f"{' + '.join(row_curve.hosts) or '—'} |")
    return lines + [""]


def task_lines(task: str, judged: dict, out_dir: str) -> list:
    """One task's verdict, comparisons and rows at every point."""
    lines = []
    for name, (tasks, _) in judged.items():
        judged_task = next(t for t in tasks if t.task == task)
        verdict, why = judged_task.verdict
        lines += [f"### At {name} times the budget", "", f"Verdict: **{verdict}** ({why}).", ""]
        if judging.POINTS[name] > clock.POINTS[-1] and task not in rule.STAGE_1:
            lines += [NOT_CONTINUED, ""]
        lines += comparison_lines(judged_task) + row_lines(judged_task, out_dir)
    return lines


def aggregate_lines(judged: dict, out_dir: str, name: str = "1") -> list:
    """The aggregates across `AGGREGATED` of the rows run on every one of them, at the point
    `name`, by rliable, with their figures (`figures.aggregate_figures`, in `out_dir`'s
    `figures.FIGURES`); the one line why not where they cannot be."""
    tasks = {t.task: t for t in judged[name][0]}
    lines = ["## Aggregates across tasks (rliable)", ""]
    missing = [task for task in AGGREGATED if task not in tasks]
    if missing:
        return lines + [f"Not run: the aggregates are over the four discrete tasks and the "
                        f"three variants; not run yet: {', '.join(missing)}.", ""]
    labels = [label for label in tasks[AGGREGATED[0]].curves
              if all(tasks[t].curves.get(label) is not None for t in AGGREGATED)]
    scores = {label: np.stack([tasks[t].curves[label].scores[:, -1] for t in AGGREGATED], axis=1)
              for label in labels}
    try:
        estimates = aggregates.aggregate_estimates(scores)
    except (RuntimeError, ValueError) as why:
        return lines + [f"Not computed: {why}", ""]
    lines += [f"Final normalised scores at {name} times the budget, over {len(AGGREGATED)} "
              "tasks, stratified bootstrap intervals:", "",
              "| row | " + " | ".join(verdicts.AGGREGATES) + " |",
              "|---|" + "---|" * len(verdicts.AGGREGATES)]
    lines += [f"| {label} | " + " | ".join(e.text(2) for e in estimates[label].values()) + " |"
              for label in labels]
    profiles = aggregates.performance_profiles(scores, PROFILE)
    lines += ["", "Performance profiles: the share of runs' final scores above each score:", "",
              "| row | " + " | ".join(f"above {tau}" for tau in PROFILE) + " |",
              "|---|" + "---|" * len(PROFILE)]
    lines += [f"| {label} | " + " | ".join(
        Estimate(*values).text(2) for values in zip(profile.fraction, profile.low, profile.high))
        + " |" for label, profile in profiles.items()]
    lines += ["", *plots.markdown_images(figures.aggregate_figures(
        estimates, profiles, figures.directory(out_dir), name), out_dir)]
    light = protocol.LIGHT["discrete"]
    if light in scores:
        lines += ["", f"P({light} > rival) over the tasks:", ""]
        lines += [f"- {label}: {aggregates.improvement(scores[light], scores[label]).text(2)}"
                  for label in labels if label != light]
    return lines + [""]
