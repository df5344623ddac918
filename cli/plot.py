"""`lwrl plot RUN_DIR...`: the learning curves of runs that `lwrl train --out` wrote, each the
mean over its agents per episode with a 95 % bootstrap interval over agents, on one figure
(PNG and SVG); each run's last point printed with its interval. An episode that a budget of
steps (`--budget`) cut short is left out (`analysis.plots.without_cut_episodes`)."""

import os

from lwrl import tasks
from lwrl.cli import output

MEASURES = {"steps": "steps per episode", "return": "return per episode",
            "uptime_s": "up-time per episode (s)"}
"""The per-episode columns a curve can show, and their axis labels."""


def add_parser(commands) -> None:
    plot = commands.add_parser(
        "plot", help="learning curves of runs (lwrl train --out DIR), with 95 %% intervals",
        description="Plot the learning curves of runs written by `lwrl train --out DIR` (or "
                    "`lwrl device run --out DIR`): per run, the mean over its agents of each "
                    "episode's measure with its 95 % bootstrap interval over agents, every run "
                    "on one figure, written as PNG and SVG.")
    plot.add_argument("runs", metavar="RUN_DIR", nargs="+", help="run directories")
    plot.add_argument("--measure", choices=tuple(MEASURES),
                      help="the per-episode column (default: the up-time on tasks that keep "
                           "one, else the steps)")
    plot.add_argument("--out", metavar="PNG", default="curves.png",
                      help="the figure's path; an SVG is written beside it (default: curves.png)")
    plot.add_argument("--log", action="store_true", help="a logarithmic y axis")
    plot.add_argument("--by-steps", action="store_true",
                      help="against the environment steps of training, not the episodes "
                           "(learners whose episodes differ in length compared at equal steps)")
    plot.set_defaults(run=plot_runs)


def plot_runs(args) -> int:
    """Read each run, draw their curves, write the figure."""
    plots, = output.study_modules("plot", "lwrl.analysis.plots")
    if not args.out.endswith(".png"):
        raise ValueError(f"--out must name a .png file; got {args.out!r}")
    runs = [(path, config, plots.without_cut_episodes(episodes, step_limit(config)))
            for path, (config, episodes) in ((path, output.read_run(path)) for path in args.runs)]
    measure = args.measure or default_measure([config["task"] for _, config, _ in runs])
    figure = plots.plot_runs([(f"{os.path.basename(os.path.normpath(path))}: "
                               f"{config['learner']} on {config['task']}", episodes)
                              for path, config, episodes in runs],
                             measure, MEASURES[measure], log=args.log, by_steps=args.by_steps)
    for path, _, episodes in runs:
        where, estimate = plots.curve_end(episodes, measure, args.by_steps)
        at = f"{where:,} steps" if args.by_steps else f"episode {where}"
        print(f"{path}: {MEASURES[measure]} at {at}, mean over agents {estimate.text(1)}")
    directory, name = os.path.split(os.path.abspath(args.out))
    for path in plots.save_figure(figure, directory, name[:-len(".png")]):
        print(f"wrote {path}")
    return 0


def step_limit(config: dict) -> float:
    """The step limit of a run's task with its options (`config.json`'s)."""
    return tasks.definition(*tasks.split_name(config["task"]),
                            **config.get("task_options", {})).step_limit


def default_measure(task_names: list) -> str:
    """The up-time where every run's task keeps one, else the steps."""
    kept = all(tasks.definition(*tasks.split_name(name)).has_uptime for name in task_names)
    return "uptime_s" if kept else "steps"
