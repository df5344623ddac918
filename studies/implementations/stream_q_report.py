"""lwrl's stream-Q(lambda) (`agent.stream_q`, a JAX population) against the authors' PyTorch
code (`stream_q_torch`) on one task, at the same settings and budget: the report
docs/implementations/stream_q.md, recomputed from the runs kept beside it.

    python -m lwrl.studies.implementations.stream_q_report --dir docs/implementations/stream_q \\
        [--lwrl-run RUN_DIR] --out docs/implementations/stream_q.md

`--lwrl-run` first keeps what the report reads of an `lwrl train --out RUN_DIR` run
(its config.json as `lwrl.json`, its episodes' steps as `lwrl.csv.gz`) in `--dir`, which also
holds the authors' runs (`torch.json.gz`, `stream_q_torch`'s); docs/implementations/stream_q/
run.sh makes both and calls this.

The measure is the steps per episode (the cart-pole's up-time is the same count times its
20-ms step). Curves: at equal numbers of environment steps, each agent's last finished
episode (`analysis.plots.curve_by_steps`, as `lwrl plot --by-steps` draws them), the mean over
the agents with its 95 % bootstrap interval. The final window: each agent's mean, over
`WINDOW_POINTS` numbers of steps evenly spaced over the budget's last `WINDOW` part, of its
last finished episode's steps; its mean over the agents with a 95 % bootstrap interval, the
difference of the two means with its interval, P(an agent of lwrl's does better) with its
interval (Agarwal et al. 2021; `report.verdict`), and the smallest difference of the means a
two-sided Welch test at 0.05 detects with 80 % power at the measured spreads
(`analysis.power.detectable_difference`): with 10 agents a side, a difference smaller than
that is not shown to be absent.
"""

import argparse
import json
import os
import shutil
import sys

import numpy as np
import pandas as pd

from lwrl import outputs, tasks
from lwrl.analysis import plots, power
from lwrl.analysis import statistics as st
from lwrl.studies.implementations import stream_q_torch
from lwrl.studies.implementations.report import verdict

WINDOW = 0.2
"""The final window: the last fifth of the budget of environment steps."""
WINDOW_POINTS = 11
"""Numbers of steps over the final window at which each agent's last episode is read."""
LWRL = "lwrl stream_q (JAX)"
AUTHORS = "authors' stream_q (PyTorch)"


def authors_table(document: dict) -> pd.DataFrame:
    """The authors' runs (`stream_q_torch`'s document) as episodes.csv's columns: a row per
    agent and finished episode, `seed`, `episode` (from 1), `steps`, `return`."""
    rows = [{"seed": agent["seed"], "episode": episode + 1, "steps": length, "return": value}
            for agent in document["agents"]
            for episode, (length, value) in enumerate(zip(agent["lengths"], agent["returns"]))]
    return pd.DataFrame(rows, columns=["seed", "episode", "steps", "return"])


def lwrl_table(episodes: pd.DataFrame, task: str) -> pd.DataFrame:
    """An `lwrl train` run's episodes without the one the budget cut short in each agent
    (`plots.without_cut_episodes`), as `lwrl plot` reads them."""
    return plots.without_cut_episodes(episodes, float(tasks.spec(task).step_limit))


def final_window(table: pd.DataFrame, budget: int) -> np.ndarray:
    """Each agent's (by seed) mean steps of its last finished episode at `WINDOW_POINTS`
    numbers of steps evenly spaced from (1 - `WINDOW`) `budget` to `budget`."""
    finished, values = plots.finished_episodes(table, "steps")
    steps = np.linspace((1.0 - WINDOW) * budget, budget, WINDOW_POINTS)
    return plots.values_at_steps(finished, values, steps).mean(axis=1)


def difference_of_means(x, y, axis=-1):
    """mean(x) - mean(y) (vectorised for `statistics.interval`)."""
    return np.mean(x, axis=axis) - np.mean(y, axis=axis)


def finished_counts(table: pd.DataFrame) -> np.ndarray:
    """Each agent's (by seed) number of episodes finished within the budget."""
    return table.groupby("seed", sort=True)["episode"].count().to_numpy(dtype=float)


def comparison(lwrl_values, authors_values, higher_is_better: bool = True) -> dict:
    """One measure's statistics (see the module)."""
    sd = [float(np.std(v, ddof=1)) for v in (lwrl_values, authors_values)]
    return {"lwrl": st.mean_interval(lwrl_values),
            "authors": st.mean_interval(authors_values),
            "difference": st.interval(difference_of_means, lwrl_values, authors_values),
            "improvement": st.improvement_interval(lwrl_values, authors_values,
                                                   higher_is_better),
            "detectable": power.detectable_difference(sd[0], sd[1], len(lwrl_values),
                                                      len(authors_values), family=2),
            "sd": sd}


def read(directory: str) -> tuple:
    """`(lwrl's configuration, lwrl's episodes, the authors' document)` kept in `directory`."""
    with open(os.path.join(directory, "lwrl.json")) as file:
        configuration = json.load(file)
    episodes = outputs.read_table(os.path.join(directory, "lwrl.csv.gz"))
    return configuration, episodes, stream_q_torch.load(os.path.join(directory, "torch.json.gz"))


def keep_lwrl_run(run_dir: str, directory: str) -> None:
    """What the report reads of an `lwrl train --out` run, kept in `directory`."""
    shutil.copyfile(os.path.join(run_dir, "config.json"), os.path.join(directory, "lwrl.json"))
    episodes = outputs.read_table(os.path.join(run_dir, "episodes.csv"))
    ran = episodes[episodes["steps"].notna()]
    ran[["seed", "episode", "steps", "truncated", "return"]].to_csv(
        os.path.join(directory, "lwrl.csv.gz"), index=False)


def check_same_settings(configuration: dict, episodes: pd.DataFrame, document: dict) -> int:
    """The budget both ran, or a one-line ValueError where their budgets, horizons,
    settings or seeds differ, or where an agent of lwrl's stopped short of the budget."""
    budget = configuration["budget"]
    horizons = (budget, configuration["settings"]["timesteps"], document["timesteps"])
    if len(set(horizons)) > 1:
        raise ValueError(f"the runs differ: lwrl's budget {horizons[0]} and timesteps "
                         f"{horizons[1]}, the authors' total_steps {horizons[2]}")
    differing = [name for name, value in stream_q_torch.SETTINGS.items()
                 if configuration["settings"][name] != value]
    if differing:
        raise ValueError(f"lwrl's run has other settings than the authors' defaults: "
                         f"{', '.join(differing)}")
    seeds = sorted(configuration["seed"] + b for b in range(configuration["agents"]))
    if seeds != document_seeds(document):
        raise ValueError(f"the runs' seeds differ: lwrl's {seeds}, the authors' "
                         f"{document_seeds(document)}")
    steps = episodes.groupby("seed")["steps"].sum()
    if (steps < budget).any():
        raise ValueError(f"lwrl's agents of seeds {list(steps.index[steps < budget])} ran out "
                         f"of episodes before the budget of {budget} steps: give more --episodes")
    return int(budget)


MEASURES = (("final window: steps per episode (more is better)", True),
            ("episodes finished within the budget (fewer is better: longer episodes)", False))
"""The report's measures and whether more is better: the final window's, which the verdict is
on, and the episodes finished, a whole-budget count."""


def write(directory: str, out: str, command: str) -> dict:
    """The report and its figure from the runs kept in `directory`; its numbers, the final
    window's, with `measures`' of both measures and each implementation's per-agent
    `values`."""
    configuration, episodes, document = read(directory)
    budget = check_same_settings(configuration, episodes, document)
    task = configuration["task"]
    limit = int(tasks.spec(task).step_limit)
    tables = {LWRL: lwrl_table(episodes, task), AUTHORS: authors_table(document)}
    per_agent = {name: (final_window(table, budget), finished_counts(table))
                 for name, table in tables.items()}
    results = [comparison(per_agent[LWRL][k], per_agent[AUTHORS][k], higher)
               for k, (_, higher) in enumerate(MEASURES)]
    result = results[0]
    figure = plots.plot_runs(list(tables.items()), "steps", "steps per episode", by_steps=True)
    agents = {name: len(values[0]) for name, values in per_agent.items()}
    figure.axes[0].set_title(f"{task}, {agents[LWRL]} and {agents[AUTHORS]} agents")
    paths = plots.save_figure(figure, os.path.join(os.path.dirname(out) or ".", "figures"),
                              os.path.splitext(os.path.basename(out))[0])
    seconds = sum(agent["seconds"] for agent in document["agents"])
    authors_steps = budget * len(document["agents"])
    seeds = document_seeds(document)
    lines = [
        "# lwrl's stream-Q(λ) against the authors' PyTorch code",
        "",
        "Written by",
        "",
        "```",
        command,
        "```",
        "",
        f"from the runs that `bash docs/implementations/stream_q/run.sh "
        f"PATH/streaming-drl` made (it runs both, then this report).",
        "",
        f"| measure (mean over agents, 95 % interval) | {LWRL}, {agents[LWRL]} agents | "
        f"{AUTHORS}, {agents[AUTHORS]} agents | difference (lwrl − authors) | smallest "
        f"difference detectable | P(lwrl better) |",
        "|---|---|---|---|---|---|",
        *[f"| {name} | {r['lwrl'].text(1)} | {r['authors'].text(1)} | "
          f"{r['difference'].text(1)} | {r['detectable']:.1f} | {r['improvement'].text(2)} |"
          for (name, _), r in zip(MEASURES, results)],
        "",
        f"**Final window: {lowered(verdict(result['improvement'], AUTHORS, LWRL, agents))}** "
        f"The agents spread (standard deviations {result['sd'][0]:.0f} and "
        f"{result['sd'][1]:.0f} steps per episode): {above_half(per_agent, limit)}. With "
        f"these spreads and {agents[LWRL]} agents a side, the smallest difference of the means "
        f"a two-sided Welch test at 0.05 detects with 80 % power is about "
        f"{result['detectable']:.0f} steps per episode: a smaller true difference is missed "
        f"more than one time in five, so that finding no difference does not show the two "
        f"equal. Episodes finished: "
        f"{lowered(verdict(results[1]['improvement'], AUTHORS, LWRL, agents))}",
        "",
        "The curves: at equal numbers of environment steps, each agent's last finished episode "
        "(as `lwrl plot --by-steps` draws them), from the step by which every agent had "
        "finished an episode to the step by which every agent had finished its last; the mean "
        "over the agents with its 95 % interval.",
        "",
        *plots.markdown_images(paths, os.path.dirname(out)),
        "",
        "## Protocol",
        "",
        f"- Task: `{task}` on the `{configuration.get('plant')}` plant; lwrl's "
        f"`{configuration['learner']}` through `lwrl train`, the authors' code through lwrl's "
        f"Gymnasium face (`gymnasium.make(\"{document['env_id']}\")`).",
        f"- Budget: {spaced(budget)} environment steps per agent, the horizon of both (lwrl's "
        f"`--timesteps` and `--budget`, the authors' `total_steps`: ε falls from 1 to 0.01 "
        f"over its first 5 %), less than the benchmark's (docs/guide/learners.md, \"First "
        f"results\"), so that the authors' code, {1000 * seconds / authors_steps:.1f} ms per "
        f"step here on one thread of a shared machine, ran its agents within the time there "
        f"was.",
        f"- Agents: {agents[LWRL]} of each, seeds {seeds[0]} to {seeds[-1]}; each "
        f"implementation draws its own random numbers (JAX's streams; PyTorch's and NumPy's), "
        f"so the comparison is between the two sets of agents, not agent by agent.",
        "- Settings: the authors' defaults for both: ObGD with α 1, γ 0.99, λ 0.8, κ 2; two "
        "hidden layers of 32 with layer normalisation without learned parameters and leaky "
        "ReLU; sparse initialisation at 0.9; observations normalised and rewards scaled by "
        "running statistics; ε-greedy, the trace cleared after an exploratory action.",
        f"- The authors' code: `mohmdelsayed/streaming-drl` at `{document['authors'][-40:]}` "
        f"(CC BY-NC 4.0: imported from a checkout, not copied), run as it is (their `StreamQ`, "
        f"`ObGD`, `sparse_init` and normalisation wrappers) by "
        f"`studies/implementations/stream_q_torch.py` (torch {document['torch']}, Python "
        f"{document['python']}), whose glue follows their script's `main`. Adapted there: the "
        f"environment keeps the task's own time limit, {spaced(limit)} steps (their `main` "
        "sets 10 000), and has no `AddTimeInfo` feature (the episode's elapsed time in the "
        "observation), as lwrl's `stream_q` has none.",
        "- Where lwrl's `stream_q` departs from the authors' algorithm (docs/guide/learners.md): "
        "a time limit is not a terminal state (lwrl bootstraps from it; the authors' "
        "`update_params` takes `terminated or truncated` as the end), which touches one "
        f"transition of each episode that reaches the {spaced(limit)}-step limit.",
        f"- Final window: the last {WINDOW * 100:.0f} % of the budget; each agent's steps of "
        f"its last finished episode at {WINDOW_POINTS} evenly spaced numbers of steps there, "
        "averaged. Episodes finished: those that ended within the budget (lwrl's last "
        "episode, cut by the budget, not counted, as `lwrl plot` leaves it out). Intervals: "
        "95 % percentile bootstrap over agents; P(lwrl better): the probability that an agent "
        "of lwrl's does better than one of the authors' (Agarwal et al. 2021), ties half; the "
        "smallest difference detectable: Welch's test at the measured standard deviations, "
        "80 % power, two-sided 0.05 (`analysis.power.detectable_difference`, one side at "
        "0.025).",
        "",
        "## Per agent",
        "",
        "| seed | lwrl: final window | authors': final window | lwrl: episodes | "
        "authors': episodes |",
        "|---|---|---|---|---|",
        *[f"| {seed} | {a:.1f} | {b:.1f} | {c:.0f} | {d:.0f} |" for seed, a, b, c, d in
          zip(seeds, *per_agent[LWRL][:1], *per_agent[AUTHORS][:1], per_agent[LWRL][1],
              per_agent[AUTHORS][1])],
        "",
    ]
    with open(out, "w") as file:
        file.write("\n".join(lines))
    return {**result, "measures": results,
            "values": {name: values[0] for name, values in per_agent.items()}}


def lowered(sentence: str) -> str:
    """`sentence` to follow a colon: its first letter lower-case."""
    return sentence[:1].lower() + sentence[1:]


def above_half(per_agent: dict, limit: int) -> str:
    """How many agents of each implementation averaged more than half the episode's step
    `limit` in the final window."""
    counts = [int(np.sum(values[0] > limit / 2)) for values in per_agent.values()]
    total = [len(values[0]) for values in per_agent.values()]
    return (f"{counts[0]} of lwrl's {total[0]} agents and {counts[1]} of the authors' "
            f"{total[1]} averaged more than half the {spaced(limit)}-step limit in the final "
            f"window, the others less")


def spaced(number: int) -> str:
    """50 000, as the documentation writes numbers."""
    return f"{number:,}".replace(",", " ")


def document_seeds(document: dict) -> list:
    return sorted(agent["seed"] for agent in document["agents"])


def command_line(directory: str, out: str) -> str:
    """The command that writes the report from the runs kept in `directory` (its first line)."""
    return f"python -m lwrl.studies.implementations.stream_q_report --dir {directory} --out {out}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dir", default="docs/implementations/stream_q",
                        help="where the runs are kept")
    parser.add_argument("--lwrl-run", help="an `lwrl train --out` run to keep in --dir first")
    parser.add_argument("--out", default="docs/implementations/stream_q.md",
                        help="the report; its figure goes beside it, figures/<its name>.png")
    args = parser.parse_args(argv)
    if args.lwrl_run:
        keep_lwrl_run(args.lwrl_run, args.dir)
    try:
        result = write(args.dir, args.out, command_line(args.dir, args.out))
    except (OSError, ValueError, KeyError) as error:
        print(f"stream_q_report: {error}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}: lwrl {result['lwrl'].text(1)}, the authors' "
          f"{result['authors'].text(1)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
