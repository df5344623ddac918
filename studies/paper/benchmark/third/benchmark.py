"""`lwrl bench run|status|report` on a directory of the third benchmark (`rule.EDITION_FILE`):
its runs (`study`), what is left (`progress`) and its report (`report`).

Layout of the output directory (every table a gzip CSV, resumable by the same command):

    rule.json                    the rule's edition: the directory is the third benchmark's
    runs/<key>.csv.gz            one run's per-episode table (`benchmark.benchmark`'s layout)
    runs/<key>.agents.npz        a training's agents until its evaluation is written
    references/<task>-<plant>.csv.gz
                                 the random and classical rows' greedy episodes (`row`)
    compute.jsonl                what each computed batch of runs cost (`runners.store`)
    README.md                    the report
"""

import time

from lwrl.studies.paper.benchmark.third import progress, report, rule, study

PLANTS = ("analytic",)
"""The plants the third benchmark runs on (MuJoCo's follows only if time allows, FINDINGS)."""


def check(tasks, plant: str) -> list:
    """The tasks (`all`: every task, `rule.TASKS`), each checked; a one-line ValueError for a
    task or plant the third benchmark does not have."""
    if plant not in PLANTS:
        raise ValueError(f"the third benchmark runs on the {', '.join(PLANTS)} plant; "
                         f"got {plant!r}")
    return list(rule.TASKS) if list(tasks) == ["all"] else [rule.check_task(t) for t in tasks]


def benchmark(tasks, out_dir: str, command: str, plant: str = "analytic", sweep=None,
              with_report: bool = True) -> str | None:
    """Run (or resume) the third benchmark on `tasks` into `out_dir` (its edition recorded),
    then, where `with_report`, write the report of every task it holds; its path, or None
    where no report was asked for (`rebuild` writes it later)."""
    started = time.perf_counter()
    tasks = check(tasks, plant)
    rule.write_edition(out_dir)
    computed = {}
    for task, continued in rule.stages(tasks):
        computed[task] = (study.continue_task if continued else study.study_task)(
            task, out_dir, plant, sweep)
    if not with_report:
        return None
    return report.write(out_dir, command, plant, started, computed.values())


def rebuild(out_dir: str, command: str, plant: str = "analytic") -> str:
    """The report of what `out_dir` holds, computing nothing; its path."""
    started = time.perf_counter()
    check([], plant)
    rule.check_edition(out_dir)
    return report.write(out_dir, command, plant, started)


def status(tasks, out_dir: str, plant: str = "analytic") -> list:
    """`progress.lines` of `tasks` in `out_dir`."""
    return progress.lines(check(tasks, plant), out_dir, plant)
