"""The third benchmark of the light-weight claim, by docs/FINDINGS.md's rule ("The light-weight
claim judged a third time: the third benchmark's rule"), in a directory of its own
(`docs/benchmark3`; the second benchmark, `studies.paper.benchmark`, kept as it is).

What it keeps of the second: the budgets, the normalised score, the measures and the
tasks' rows (`benchmark.protocol`). What it adds, a module each: `rule` (its edition, the
rows with the new rivals and their agents, the seeds, the variants as tasks), `clock` (20
greedy evaluations log-spaced over the budget), `halving` (every row's search by
successive halving around its own centre), `study` (the runs in order, resumable from their
tables alone), `progress` (what is left, `lwrl bench status`) and `report` (the report,
judged by the rule: `judging` the comparisons, curves and verdicts, `verdict_tables` their
tables, `disclosure` the rows' prior tuning and the runs' provenance). The verdicts'
statistics are `analysis`'.
"""
