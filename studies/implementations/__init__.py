"""`lwrl implementations`: the JAX population learners against the learners whose settings
they take, one pair at a time, under the same settings, seeds, starts and episodes.

The pairs come from the registry (`plan.pairs`): each population learner (`Learner.population`)
of the kind of action asked (discrete, the paper's, by default; continuous with
`--action-kind continuous`, on the tasks made with it) and the registry learner whose
settings class its own subclasses (the Stable-Baselines3 learner it re-implements). Every
pair runs on every task asked for with the settings tuned for the reference learner on the
task's domain (`runners.config.tuned_settings`; the learners' defaults where it has none),
the same for both implementations; the report lists them field by field (the translation).

Modules: `plan` (the pairs, the runs, the measures, the translation), `costs` (CPU and wall
time per agent-step of each implementation), `report` (the statistics, the figures and
`report.md`), `study` (the runs through `runners.sweep`, resumable, and the report).
Beside them, one comparison with a reference outside the registry: `stream_q_torch` (the
authors' PyTorch stream-Q(lambda), imported from a checkout, on a task through the Gymnasium
face) and `stream_q_report` (it against lwrl's `stream_q`: `stream_q.md`, its runs in
`stream_q/`).

Layout of the output directory:

    runs/<key>.csv.gz     one finished run (the sweep's store: resumable)
    configs.jsonl         every run's full configuration
    costs.json            CPU and wall time per agent-step of each implementation (kept)
    timings.json          the wall time of each call that finished, and of its phases
    figures/              learning curves per task and pair (PNG and SVG)
    notes.md              investigation notes, written by hand; the report includes them
    report.md             the report
"""
