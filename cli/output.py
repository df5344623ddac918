"""What every subcommand shares: one-line parse errors, progress bars, the results table
printed after a run, and the files `--out` writes."""

import argparse
import os
import sys
import time

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
    """Print a run's block table with its notes, its divergences and any interruption."""
    if title:
        print(title)
    rows = summary.block_rows(results)
    print(summary.format_rows(rows, with_uptime))
    for note in summary.table_notes(rows, results, seeds, with_uptime):
        print(note)
    print(summary.divergence_note(results, seeds))
    truncated, run_episodes = int(results.truncated.sum()), int(np.isfinite(results.steps).sum())
    if truncated:
        print(f"{truncated} of {summary.plural(run_episodes, 'episode')} ended at the time limit "
              "(truncated)")
    if results.interrupted:
        print("interrupted: episodes not run are left empty", file=sys.stderr)


def duration(seconds: float) -> str:
    """`8.4 s`, `9 min 38 s`, `1 h 16 min`."""
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, seconds = divmod(round(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {seconds} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes} min"


def and_list(items) -> str:
    """`a`, `a and b`, `a, b and c`."""
    items = list(items)
    return items[0] if len(items) == 1 else f"{', '.join(items[:-1])} and {items[-1]}"


def done(started: float, written=(), interrupted: bool = False, detail: str = "") -> None:
    """The line a long command ends with: how long it took (from `started`, a
    `time.perf_counter()`), `detail` in brackets, and what it wrote where."""
    took = duration(time.perf_counter() - started) + (f" ({detail})" if detail else "")
    head = f"interrupted after {took}" if interrupted else f"done in {took}"
    print(f"{head}: wrote {and_list(written)}" if written else f"{head}; nothing written")


def write_run(out: str, config, results) -> list:
    """`--out DIR`: the run's config.json and episodes.csv; returns their paths."""
    os.makedirs(out, exist_ok=True)
    paths = [os.path.join(out, "config.json"), os.path.join(out, "episodes.csv")]
    with open(paths[0], "w") as file:
        file.write(config.to_json() + "\n")
    summary.write_csv(paths[1], results, config.seeds)
    return paths


def paper_extra_missing(command: str, error: ImportError) -> ValueError:
    """The one-line error of a command whose 'paper' extra (pandas, matplotlib) is missing."""
    return ValueError(f"lwrl {command} needs the 'paper' extra ({error.name} is missing): "
                      "pip install -e '.[paper]'")
