"""The second benchmark of the light-weight claim, by docs/FINDINGS.md's rule ("The
light-weight claim judged again: the second benchmark's rule"): one budget of environment
steps per task for every learner, greedy evaluations apart from training, a normalised score
between a random row (0) and the domain's classical controller (1), and the same search for
every learner.

Modules: `protocol` (the budgets, the rows and their training runs), `search` (the same
random search for every row), `references` (the random and classical rows as agents, in no
registry), `evaluation` (the greedy evaluation of a trained run, the reference rows' runs
and the per-agent measure), `study` (the runs in order, resumable from their tables alone), `judging` (the gate, the
tests, the compute to a level and the verdicts), `outside` (an outside learner's results,
checked against the protocol and scored), `report` (the verdicts across tasks, Holm's
family whole, and the document with the aggregates and figures).
The statistics are `analysis.verdicts`'.
"""
