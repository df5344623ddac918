"""What every subcommand shares: one-line parse errors, progress bars, the results table
printed after a run, and the files `--out` writes."""

import argparse
import os
import sys

import numpy as np
import tqdm

from lwrl.runners import summary


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line: `lwrl COMMAND: error: ...`."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def progress_bar(total: int, description: str):
    """A progress bar on standard error (off where it is not a terminal) and its update."""
    bar = tqdm.tqdm(total=total, desc=description, unit="episode", file=sys.stderr,
                    disable=None, leave=False)
    return bar, bar.update


def print_results(results, seeds, title: str, with_uptime: bool) -> None:
    """Print a run's block table, its divergences and any interruption."""
    if title:
        print(title)
    print(summary.format_rows(summary.block_rows(results), with_uptime))
    print(f"means ± standard errors over agents (seeds {seeds[0]}..{seeds[-1]})")
    print(summary.divergence_note(results, seeds))
    truncated, run_episodes = int(results.truncated.sum()), int(np.isfinite(results.steps).sum())
    if truncated:
        print(f"{truncated} of {run_episodes} episodes ended at the time limit (truncated)")
    if results.interrupted:
        print("interrupted: episodes not run are left empty", file=sys.stderr)


def write_run(out: str, config, results) -> None:
    """`--out DIR`: the run's config.json and episodes.csv."""
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "config.json"), "w") as file:
        file.write(config.to_json() + "\n")
    summary.write_csv(os.path.join(out, "episodes.csv"), results, config.seeds)
    print(f"wrote {out}/config.json and {out}/episodes.csv")


def paper_extra_missing(command: str, error: ImportError) -> ValueError:
    """The one-line error of a command whose 'paper' extra (pandas, matplotlib) is missing."""
    return ValueError(f"lwrl {command} needs the 'paper' extra ({error.name} is missing): "
                      "pip install -e '.[paper]'")
