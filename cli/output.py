"""What every subcommand shares: one-line parse errors, Ctrl-C that stops the work but never
the writing, progress bars, the results table printed after a run, the files `--out`
writes, and a report of the outputs written."""

import argparse
import dataclasses
import contextlib
import importlib
import json
import os
import signal
import sys
import threading
import time

import numpy as np
import tqdm

from lwrl import outputs
from lwrl.agent import io as agent_io
from lwrl.runners import summary


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line: `lwrl COMMAND: error: ...`."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


SIGNALS = (signal.SIGINT, signal.SIGTERM)
"""What stops a command as Ctrl-C does: Ctrl-C itself, and `kill`'s default signal (which a
scheduler or the end of a session sends before it kills)."""


class Interrupts:
    """Ctrl-C (or SIGTERM) while a command runs (`main` installs it on the main thread): the
    first says at once that the work stops, and stops it (a KeyboardInterrupt, which the run
    loops turn into results marked interrupted, a population run keeping its state to go on
    from); later ones, and any while outputs are written (`writing()`), say so and are
    ignored, so that no output is left half-written. `signum`: the signal that stopped it."""

    def __init__(self, command: str):
        self.command = command
        self.stopping = False
        self.signum = None
        self.writing_depth = 0
        self._previous = {}

    def _handle(self, signum, frame):
        if self.stopping or self.writing_depth:
            print(f"lwrl {self.command}: still writing what finished; please wait",
                  file=sys.stderr, flush=True)
            return
        self.stopping, self.signum = True, signum
        print(f"lwrl {self.command}: stopping (the episodes in progress end, then what finished "
              "is written; Ctrl-C again is ignored)", file=sys.stderr, flush=True)
        raise KeyboardInterrupt

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self._previous = {signum: signal.signal(signum, self._handle) for signum in SIGNALS}
        return self

    def __exit__(self, *exc):
        for signum, previous in self._previous.items():
            # After a press the process is on its way out: a late press must not end it
            # with a traceback while it exits.
            signal.signal(signum, signal.SIG_IGN if self.stopping else previous)
        return False

    def status(self, status: int) -> int:
        """A command's exit status: an interrupted one's (130) as the shell gives a process
        ended by the signal that stopped it, 128 + its number (130 for Ctrl-C, 143 for
        SIGTERM)."""
        return 128 + self.signum if status == 130 and self.signum is not None else status

    @contextlib.contextmanager
    def writing(self):
        """A block during which Ctrl-C is ignored: outputs being written."""
        self.writing_depth += 1
        try:
            yield
        finally:
            self.writing_depth -= 1


INTERRUPTS = Interrupts("")
"""The running command's Ctrl-C handling (`main` replaces it for each command)."""


def writing():
    """Ctrl-C is ignored in this block, while outputs are written."""
    return INTERRUPTS.writing()


class Outputs:
    """The outputs of a command, each written on its own: one that fails does not keep the
    others from being written; `report()` says which were written and which failed."""

    def __init__(self, command: str):
        self.command = command
        self.written: list[str] = []
        self.failed: list[str] = []

    def write(self, what: str, write) -> bool:
        """Call `write()` for the output `what` (e.g. `--save agents.npz`), which returns
        what it wrote (a list of descriptions for `done`); note its failure."""
        with writing():
            try:
                self.written += write()
            except (OSError, ValueError) as error:
                self.failed.append(f"{what} ({error})")
                return False
        return True

    def report(self) -> int:
        """Print what was written and what failed; 1 if something failed, else 0."""
        for failure in self.failed:
            print(f"lwrl {self.command}: error: could not write {failure}", file=sys.stderr)
        return 1 if self.failed else 0


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


RUN_FILES = ("config.json", "episodes.csv")
"""What `--out DIR` holds."""


def write_run(out: str, config, results, extra=None) -> list:
    """`--out DIR`: the run's config.json and episodes.csv, and `NAME.json` for each record
    of `extra` (`{NAME: a JSON value}`), put in place together (`outputs.atomic_directory`);
    returns their paths."""
    names = [*RUN_FILES, *(f"{name}.json" for name in extra or {})]
    with outputs.atomic_directory(out) as staging:
        with outputs.atomic_write(staging / RUN_FILES[0]) as file:
            file.write(config.to_json() + "\n")
        summary.write_csv(staging / RUN_FILES[1], results, config.seeds)
        for name, value in (extra or {}).items():
            with outputs.atomic_write(staging / f"{name}.json") as file:
                file.write(json.dumps(value, indent=2) + "\n")
    return [os.path.join(out, name) for name in names]


def read_run(path: str) -> tuple:
    """`(configuration, episodes)` of a run directory that `write_run` wrote: its config.json
    as a dict and its episodes.csv as a table; a one-line ValueError for a directory that is
    not one."""
    files = [os.path.join(path, name) for name in RUN_FILES]
    if not all(os.path.isfile(file) for file in files):
        raise ValueError(f"{path}: not a run directory (lwrl train --out DIR writes "
                         f"{' and '.join(RUN_FILES)} there)")
    try:
        with open(files[0]) as file:
            configuration = json.load(file)
        episodes = outputs.read_table(files[1])
    except (OSError, ValueError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: unreadable run ({type(error).__name__})") from None
    missing = {"task", "learner"} - set(configuration)
    missing |= {"seed", "episode", "steps", "return", "uptime_s"} - set(episodes.columns)
    if missing:
        raise ValueError(f"{path}: not a run of lwrl train (missing {', '.join(sorted(missing))})")
    return configuration, episodes


def write_out_and_save(written, args, config, results, agents, what: str, extra=None) -> None:
    """`--out DIR` (`write_run`) and `--save PATH` (the agents, `what` in the report) of a
    run, each through `written` (an `Outputs`), so that one failing loses neither other;
    `extra`: further records of the run (`{NAME: a JSON value}`), NAME.json in DIR and in
    the saved agents' metadata."""
    if args.out:
        written.write(f"--out {args.out}", lambda: write_run(args.out, config, results, extra))
    if args.save:
        def save():
            agent_io.save(args.save, agents, {"config": dataclasses.asdict(config), **(extra or {})})
            return [f"{what} to {args.save}"]
        written.write(f"--save {args.save}", save)


def claim_outputs(args, *flags) -> None:
    """Claim the outputs that the options `flags` (e.g. `out`, `save`) of `args` name for
    this command (`outputs.claim_output`), before anything else is checked or done: a second
    command aimed at one of them stops at once, naming this one. `main` releases them."""
    for flag in flags:
        if getattr(args, flag, None):
            outputs.claim_output(getattr(args, flag), f"--{flag}")


def study_modules(command: str, *names) -> list:
    """The modules `names` of a command that needs the 'paper' extra (pandas, matplotlib, scipy,
    statsmodels);
    a one-line error naming the extra where it is missing."""
    try:
        return [importlib.import_module(name) for name in names]
    except ImportError as error:
        raise ValueError(f"lwrl {command} needs the 'paper' extra ({error.name} is missing): "
                         "pip install -e '.[paper]'") from None
