"""The third benchmark's report, as far as its runs go, judged by its rule (docs/FINDINGS.md,
"The light-weight claim judged a third time"): first every task's verdict at 1/4, 1 and 4
times the budget and the families of the multiple-test procedure (`verdict_tables`); per
task and row the final normalised score with its 95 % interval (`analysis.statistics.
mean_interval`), at 1/4 of the budget too, its agents, the configuration its search chose,
how many programs its search's configurations make (`halving.programs`: what training each
program's configurations as one population could share) and what the ledger counts of its CPU (the row's runs and its search's apart,
`runners.store.compute_spent`) and the rows' curves on the fine clock (`figures`); per task and budget point the light-weight row's comparisons
with each rival, the rows' times to the level and success shares (`judging`); the rivals the
rule names that no learner runs and the rows whose observation normalisation is not
searched, named; a row whose runs are not all written named as such (`study.read_task`'s
partial reading), and a task whose reference rows are not; then the rows' prior tuning,
what each of the rule's stages cost and the runs' provenance (`disclosure`), and the
aggregates across tasks with their figures.

`lwrl bench report DIR` writes it from the directory alone, computing nothing.
"""

import os
import time

from lwrl import outputs
from lwrl.analysis.plots import markdown_images
from lwrl.analysis.statistics import mean_interval
from lwrl.runners.store import compute_spent
from lwrl.studies.paper.benchmark.third import (clock, disclosure, figures, halving, judging,
                                                rule, study, verdict_tables)

QUARTER = 12
"""The clock's point at 1/4 of the budget."""


def write(out_dir: str, command: str, plant: str, started: float, computed=()) -> str:
    """Write `out_dir/README.md` from every task it holds: `computed`'s (`study.TaskRuns`) as
    they are, the others read; its path."""
    given = {runs.task: runs for runs in computed}
    held, unfinished = [], []
    for task in study.held(out_dir, plant):
        try:
            runs = given[task] if task in given else study.read_task(task, out_dir, plant,
                                                                     partial=True)
            if task not in rule.STAGE_1:
                runs = study.carried(runs)
            elif task not in given:
                runs = study.read_longer(runs, out_dir)
        except study.Unfinished as missing:
            unfinished.append(str(missing))
            continue
        held.append(runs)
    judged = judging.judge(held, out_dir)
    sections = [task_section(runs, out_dir) + verdict_tables.task_lines(runs.task, judged, out_dir)
                for runs in held]
    spent = compute_spent(out_dir)
    text = [f"# The third benchmark ({rule.EDITION})", "",
            f"Written by `{command}` ({plant} plant) in {time.perf_counter() - started:.0f} s; "
            "the rule is docs/FINDINGS.md's \"The light-weight claim judged a third time\". "
            f"The ledger counts {spent['runs']} runs, {spent['cpu_s'] / 3600:.2f} h of CPU.", ""]
    text += verdict_tables.summary_lines(judged) if held else []
    text += [line for section in sections for line in section]
    if unfinished:
        text += ["## Not all run yet", ""] + [f"- {line}" for line in unfinished] + [""]
    text += disclosure.prior_tuning_lines([runs.task for runs in held])
    text += disclosure.stage_lines(held, out_dir)
    text += disclosure.provenance_lines(out_dir)
    text += verdict_tables.aggregate_lines(judged, out_dir) if held else []
    path = os.path.join(out_dir, "README.md")
    with outputs.atomic_write(path) as file:
        file.write("\n".join(text))
    return path


def at_four(task: str, row: "study.RowRuns") -> str:
    """A row's normalised score at 4 times the budget: continued, carried from 1 (not rising
    there), or not run (a variant's, or the stage not run yet)."""
    if row.longer is None:
        return "not run"
    if not row.longer:
        return f"{mean_interval(row.scores[clock.POINTS[-1]]).text(2)} (carried)"
    return mean_interval(row.longer[clock.LONGER[-1]]).text(2)


def task_section(runs: "study.TaskRuns", out_dir: str) -> list:
    """The lines of one task: a table of its rows and their curves on the fine clock
    (`figures.clock_curves`)."""
    lines = [f"## {runs.task}", "",
             "| row | agents | configuration | search's final score | search's programs "
             f"(of {halving.CONFIGURATIONS}; most in one) | normalised score at 1/4 "
             "| final normalised score | at 4 times the budget | CPU h (row) | CPU h (search) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    rows = {row.label: row for row in rule.rows(runs.task)}
    for label, row in runs.rows.items():
        final = row.scores[clock.POINTS[-1]]
        search = (f"{mean_interval(row.rungs[-1][row.chosen]).text(2)}" if row.rungs
                  else "(its task's)")
        shared = "{} ({})".format(*halving.programs(runs.task, rows[label])) if row.rungs else "—"
        lines.append(f"| {label} | {len(final)} | {row.chosen} | {search} | {shared} | "
                     f"{mean_interval(row.scores[QUARTER]).text(2)} | "
                     f"{mean_interval(final).text(2)} | {at_four(runs.task, row)} | "
                     f"{compute_spent(out_dir, set(row.own))['cpu_s'] / 3600:.3f} | "
                     f"{compute_spent(out_dir, set(row.searched))['cpu_s'] / 3600:.3f} |")
    lines += ["", *markdown_images(figures.clock_curves(runs, figures.directory(out_dir)),
                                   out_dir), ""]
    lines += [f"- not all run yet: {why}" for why in runs.unfinished.values()]
    lines += [""] if runs.unfinished else []
    plain = halving.unsearched(runs.task)
    if plain:
        lines += [f"Observation normalisation not searched (no setting of the learner's): "
                  f"{', '.join(plain)}.", ""]
    return lines
