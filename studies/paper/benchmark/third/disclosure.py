"""What the third benchmark's report discloses beside its verdicts (docs/FINDINGS.md, the
third benchmark's rule, "Prior tuning, disclosed", "Provenance and schemas" and "Compute"):
what tuned each row's centre before its search drew around it (`prior_tuning`), where the
runs were computed, read from their own records (`provenance`: `runners.records`' columns),
and what each of the rule's stages cost by the ledger (`stage_lines`).
"""

import glob
import os

import pandas as pd

from lwrl.runners import table_schema
from lwrl.runners.config import tuned_settings
from lwrl.runners.store import RunStore, compute_spent
from lwrl.runners.summary import plural
from lwrl.studies.paper.benchmark import protocol
from lwrl.studies.paper.benchmark.third import rule

AUTHORS = {"ars": "Mania, Guy & Recht 2018", "ars_continuous": "Mania, Guy & Recht 2018",
           "stream_q": "Elsayed, Vasan & Mahmood 2024",
           "stream_ac": "Elsayed, Vasan & Mahmood 2024"}
"""The sources of the new rivals' settings."""
OWN_ROWS = {"cmac": "the CMAC of the paper's Fig. 2 comparison (its tilings and step size)",
            "ase_ace": "ASE/ACE's settings of its source (Barto, Sutton & Anderson 1983), the "
                       "paper's Table 1 rival"}
"""What set the centre of a task's own linear rows (`protocol.TASK_ROWS`)."""


def prior_tuning(task: str, row: protocol.Row) -> str:
    """What tuned `row`'s centre on `task` before the third benchmark's search (the rule's
    list): the paper's Fig. 2 grids, the acrobot's defaults, the actor-critic's second
    search, the zoo's sets, the authors' settings."""
    base = rule.split(task)[0]
    name, actions = protocol.variant(base)
    deep = row.label in protocol.deep(base)
    # the deep rows take the zoo's set by their label (`protocol.rows`), the rivals by learner
    zoo = bool(tuned_settings(name, row.label if deep else row.learner))
    if row.learner == "actor_critic":
        return ("its defaults, chosen by the second benchmark's search on this task (seeds 1000 "
                "to 1002)")
    if zoo and (deep or row.label in rule.RIVALS[actions]):
        return "the zoo's set, tuned on Gymnasium's counterpart of the task"
    if row.learner in AUTHORS:
        return f"its authors' settings ({AUTHORS[row.learner]})"
    if deep and actions == "continuous":
        return ("its defaults: the zoo's set for Pendulum-v1, tuned on Gymnasium's counterpart "
                "of the task")
    if deep:
        return "the learner's defaults (the zoo has no set for this task)"
    if row.label in OWN_ROWS:
        return OWN_ROWS[row.label]
    if name == "acrobot.swingup":
        return ("the acrobot's defaults, tuned on seeds 0 to 19 (the second benchmark's "
                "evaluation seeds)")
    return "the paper's agent's alpha and lambda on this task, from the paper's Fig. 2 grids"


def prior_tuning_lines(tasks) -> list:
    """A table of every row's prior tuning on the first stage's tasks and the continuous
    pendulum among `tasks` (a variant's rows run their task's configurations)."""
    lines = ["## The rows' centres: their prior tuning", "",
             "Each row's search draws around its centre; what tuned that centre before "
             "(a variant runs the configurations chosen on its task):", "",
             "| task | row | its centre was tuned by |", "|---|---|---|"]
    for task in tasks:
        if rule.split(task)[0] == task:
            lines += [f"| {task} | {row.label} | {prior_tuning(task, row)} |"
                      for row in rule.rows(task)]
    return lines + [""]


PROVENANCE = ["run", "lwrl_version", "lwrl_commit", "host_cpu", "python", "libraries"]
"""The columns of a run's records (`runners.records`) that say where it was computed."""


def provenance(out_dir: str) -> pd.DataFrame:
    """The `PROVENANCE` of every record of the runs in `out_dir`, one row per agent of a
    run, as text (the records read as their schema reads them, those of one header at
    once: thousands of small files)."""
    paths = sorted(glob.glob(str(RunStore.records_file(out_dir, "*"))))
    if not paths:
        return pd.DataFrame(columns=PROVENANCE)
    schema = table_schema.load(table_schema.SCHEMAS / "records.json")
    return pd.concat([table[PROVENANCE] for _, table in table_schema.read_groups(paths, schema)],
                     ignore_index=True)


def provenance_lines(out_dir: str) -> list:
    """Where the runs were computed: per (commit, host, Python, libraries) the runs, from
    their records; how many of the runs whose tables are here have records, and how many
    recorded runs keep no table here (the rows' trainings, whose greedy evaluations and
    records are what the rule reads)."""
    table = provenance(out_dir)
    tables = {os.path.basename(path)[:-len(".csv.gz")]
              for path in glob.glob(os.path.join(out_dir, "runs", "*.csv.gz"))}
    runs = set(table.run)
    untabled = len(runs - tables)
    lines = ["## Provenance", "",
             f"{len(runs)} runs have records (`runs/records/`): {len(runs & tables)} of the "
             f"{len(tables)} runs whose tables are here"
             + (f", and {plural(untabled, 'training')} whose tables are not kept here (their greedy "
                "evaluations and records are what the rule reads)" if untabled else "")
             + "; per commit, host and libraries:", "",
             "| runs | lwrl | commit | host CPU | Python | libraries |",
             "|---|---|---|---|---|---|"]
    keys = ["lwrl_version", "lwrl_commit", "host_cpu", "python", "libraries"]
    if runs:
        for values, part in table.fillna("").astype({k: str for k in keys}).groupby(keys):
            lines.append(f"| {part.run.nunique()} | " + " | ".join(values) + " |")
    return lines + [""]


STAGES = ("1. the four discrete tasks: searches and rows", "2. the three variants: rows",
          "3. the rows still rising at the budget, continued to 4 times it",
          "4. the continuous pendulum: searches and rows")
"""The rule's stages, in the order they run (FINDINGS, "Compute")."""


def stage_keys(held) -> list:
    """Per stage (`STAGES`), the keys of the runs of the tasks `held` (`study.TaskRuns`) that
    it ran: a task's rows' and searches' runs, a continued row's (`RowRuns.continued`) in
    the third."""
    keys = [set() for _ in STAGES]
    for runs in held:
        stage = 0 if runs.task in rule.STAGE_1 else 3 if runs.task == rule.TASKS[-1] else 1
        for row in runs.rows.values():
            keys[stage] |= (set(row.own) - set(row.continued)) | set(row.searched)
            keys[2] |= set(row.continued)
    return keys


def stage_lines(held, out_dir: str) -> list:
    """What each stage cost, the ledger's CPU of its runs (`stage_keys`), and what the
    ledger counts beside them: the runs of rows not all written yet (the reference rows are
    computed outside it; where none are, the sums differ by rounding alone, and it is 0)."""
    spent = [compute_spent(out_dir, keys)["cpu_s"] / 3600 for keys in stage_keys(held)]
    total = compute_spent(out_dir)["cpu_s"] / 3600
    lines = ["## What each stage cost", "",
             "The ledger's CPU (`compute.jsonl`) of each stage's runs, against the plan in "
             "docs/FINDINGS.md's \"Compute\" (the second benchmark's rates).", "",
             "| stage | CPU h |", "|---|---|"]
    lines += [f"| {stage} | {hours:.2f} |" for stage, hours in zip(STAGES, spent)]
    return lines + [f"| the runs of rows not all written yet | "
                    f"{max(total - sum(spent), 0.0):.2f} |", f"| all | {total:.2f} |", ""]
