"""Learning curves of runs written by `lwrl train ... --out DIR`, made for other suites'
environments (`dmc:...`, `gym:...`) and read alike for lwrl's own tasks: per run, a figure of the return per episode (mean over agents with a band of one
standard error) and a line with the first and the final tenth of the episodes, each as the
mean ± standard error over agents of the agents' mean return.

    python -m lwrl.studies.other_suites FIGURE_DIR RUN_DIR...

Needs the 'paper' extra (pandas, matplotlib).
"""

import argparse
import json
import os

import pandas as pd

from lwrl import outputs
from lwrl.analysis.plots import plot_learning_curve, save_figure
from lwrl.runners.summary import mean_and_error


def block_return(episodes: pd.DataFrame, first: int, last: int) -> tuple[float, float]:
    """Mean ± standard error over agents of each agent's mean return in episodes
    `first..last`."""
    block = episodes[(episodes["episode"] >= first) & (episodes["episode"] <= last)]
    return mean_and_error(block.groupby("agent")["return"].mean().to_numpy())


def plot_run(run_dir: str, figure_dir: str) -> str:
    """Write `run_dir`'s learning curve to `figure_dir` (PNG and SVG, named after the run's
    directory); return its line of numbers."""
    with open(os.path.join(run_dir, "config.json")) as file:
        config = json.load(file)
    episodes = outputs.read_table(os.path.join(run_dir, "episodes.csv"))
    seeds = sorted(episodes["seed"].unique())
    count = int(episodes["episode"].max())
    tenth = max(1, count // 10)
    figure, _ = plot_learning_curve(
        episodes, "return", "return per episode",
        f"{config.get('env', config.get('task'))}: {len(seeds)} agents (seeds {seeds[0]}..{seeds[-1]})")
    os.makedirs(figure_dir, exist_ok=True)
    save_figure(figure, figure_dir, os.path.basename(os.path.normpath(run_dir)))
    first = block_return(episodes, 1, tenth)
    final = block_return(episodes, count - tenth + 1, count)
    return (f"{config.get('env', config.get('task'))}: return {first[0]:.1f} ± {first[1]:.1f} in episodes 1-{tenth}, "
            f"{final[0]:.1f} ± {final[1]:.1f} in episodes {count - tenth + 1}-{count} "
            f"({len(seeds)} agents, seeds {seeds[0]}..{seeds[-1]})")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("figures", metavar="FIGURE_DIR")
    parser.add_argument("runs", metavar="RUN_DIR", nargs="+")
    args = parser.parse_args(argv)
    for run_dir in args.runs:
        print(plot_run(run_dir, args.figures))


if __name__ == "__main__":
    main()
