"""The runs directory of a sweep, `OUT/runs/`: finished runs, damaged ones set aside, claims.

- A finished run is `<key>.csv.gz`, written whole or not at all (`lwrl.outputs`), after
  its records `records/<key>.csv.gz` (what its training cost and where it ran,
  `runners.records`; in a folder of their own, so that `runs/*.csv.gz` are the runs' tables).
- A file there that cannot be read (truncated, empty, not gzip, not the run's table) is
  reported by name, moved aside to `<key>.csv.gz.damaged`, and its run computed again.
- A batch of runs being computed is claimed (`lwrl.outputs.claim`) by a file `<batch>.claim`
  naming the host and process that computes it, so that two processes sweeping into one
  directory share the work: each computes the batches it could claim and waits for the
  others' runs. A claim whose process is gone is taken over.
- What computing each batch cost is a line of `OUT/compute.jsonl` (`record_compute`,
  `compute_spent`): a study that runs over several working sessions, interrupted at each
  end, still says what all its runs cost.
"""

import hashlib
import json
import os
import pathlib
import platform
import time
import zlib

import pandas as pd

from lwrl import outputs


LEDGER = "compute.jsonl"
"""The ledger's file name in a sweep's directory: a line per computed batch."""


def compute_spent(out_dir, runs=None) -> dict:
    """What the ledger of `out_dir` (`RunStore.record_compute`) counts, of its lines that name
    runs of the keys `runs` only where given: `runs` (the computed runs they name, each once:
    a run stopped and resumed has a line for the processes before the one that ended it,
    `runners.resume`), `wall_s` and `cpu_s` (summed over the lines), `hosts`; zeros where
    there are none."""
    entries = ledger_lines(out_dir, runs)
    return {"runs": len(ledger_runs(entries)),
            "wall_s": float(sum(entry["wall_s"] for entry in entries)),
            "cpu_s": float(sum(entry["cpu_s"] for entry in entries)),
            "hosts": list(dict.fromkeys(entry["host"] for entry in entries))}


def ledger_lines(out_dir, runs=None) -> list:
    """The ledger of `out_dir` (`RunStore.record_compute`), a dict per computed batch; where
    `runs` (run keys) is given, only the lines that name none but those runs."""
    path = pathlib.Path(out_dir) / LEDGER
    lines = [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []
    return [line for line in lines if runs is None or set(line["runs"]) <= runs]


def ledger_runs(lines) -> list:
    """The keys of the runs that ledger `lines` name, each once, in the order they first
    appear."""
    return list(dict.fromkeys(key for line in lines for key in line["runs"]))


SIMD = {"avx512f": "AVX-512", "avx2": "AVX2", "fma": "FMA", "asimd": "NEON"}
"""The CPU features `cpu` names (Linux's flags: names): those that change how compiled code
(XLA's, NumPy's) rounds."""


def cpu() -> str:
    """The CPU a run was computed on: its model and which of `SIMD` it has (Linux's
    `/proc/cpuinfo`; elsewhere the platform's word alone). A JAX population's numbers are the
    same on the same CPU, not on another one (XLA compiles for the CPU's features)."""
    fields = {}
    try:
        with open("/proc/cpuinfo") as file:
            for line in file:
                name, _, value = line.partition(":")
                fields.setdefault(name.strip(), value.strip())
    except OSError:
        pass
    model = fields.get("model name") or platform.processor() or platform.machine()
    flags = set((fields.get("flags") or fields.get("Features") or "").split())
    return f"{model}; {' '.join(word for flag, word in SIMD.items() if flag in flags)}"


class RunStore:
    """The runs of a sweep in `out_dir/runs`; with `keep_agents`, each run's agents too,
    `<key>.agents.npz` (`agent.io`), written before its table. `make=False`: a store that is
    only read, whose directory is not made where it does not exist."""

    def __init__(self, out_dir, keep_agents: bool = False, make: bool = True):
        self.directory = pathlib.Path(out_dir) / "runs"
        """`out_dir/runs`, which holds a table per run."""
        if make:
            self.directory.mkdir(parents=True, exist_ok=True)
        self.keep_agents = keep_agents
        """Whether each run's agents are kept beside its table (`agents_file`)."""
        self._claims = {}

    def path(self, config) -> pathlib.Path:
        """The table of the run `config`: `runs/KEY.csv.gz`."""
        return self.directory / f"{config.key}.csv.gz"

    @staticmethod
    def agents_file(out_dir, key: str) -> pathlib.Path:
        """Where the agents of the run `key` of the sweep in `out_dir` are kept."""
        return pathlib.Path(out_dir) / "runs" / f"{key}.agents.npz"

    @staticmethod
    def records_file(out_dir, key: str) -> pathlib.Path:
        """Where the records of the run `key` of the sweep in `out_dir` are kept
        (`runners.records`)."""
        return pathlib.Path(out_dir) / "runs" / "records" / f"{key}.csv.gz"

    @staticmethod
    def resume_file(out_dir, key: str) -> pathlib.Path:
        """Where the run `key` (or the batch `batch_name`) of the sweep in `out_dir` keeps its
        state while it runs (`runners.resume`: population runs)."""
        return pathlib.Path(out_dir) / "runs" / f"{key}.resume.npz"

    def finished(self, config) -> bool:
        """Whether the run `config` is written: its table, and its agents where kept."""
        return self.path(config).exists() and (
            not self.keep_agents or self.agents_file(self.directory.parent, config.key).exists())

    def repair(self, configs) -> list[str]:
        """Set aside every unreadable run file of `configs` (return one line per file), and
        remove the files a process killed mid-write left half-written
        (`outputs.remove_abandoned`), the records' among them."""
        for directory in (self.directory, self.directory / "records"):
            outputs.remove_abandoned(directory)
        lines = []
        for config in configs:
            path = self.path(config)
            if not path.exists():
                continue
            try:
                table = outputs.read_table(path)
                if table.empty or "episode" not in table.columns:
                    raise ValueError("no rows of episodes")
            except (OSError, EOFError, zlib.error, ValueError, pd.errors.ParserError) as error:
                aside = path.with_name(path.name + ".damaged")
                os.replace(path, aside)
                lines.append(f"{path} is damaged ({' '.join(str(error).split()) or type(error).__name__}); "
                             f"moved to {aside.name}, its run is computed again")
        return lines

    @property
    def ledger(self) -> pathlib.Path:
        """`out_dir/compute.jsonl`: what each computed batch cost (`record_compute`)."""
        return self.directory.parent / LEDGER

    def record_compute(self, batch, wall_s: float, cpu_s: float) -> None:
        """Add one line to the ledger for a finished batch: its runs' keys, its wall and CPU
        seconds, the host, its CPU (`cpu`), the time. Each line is appended whole by one `write` in append
        mode, so processes sharing the directory do not mix their lines, and nothing is
        rewritten: what a call that is interrupted later computed stays counted."""
        line = json.dumps({"runs": [config.key for config in batch], "wall_s": round(wall_s, 3),
                           "cpu_s": round(cpu_s, 3), "host": platform.node(), "cpu": cpu(),
                           "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")}) + "\n"
        with open(self.ledger, "a") as file:
            file.write(line)

    def write(self, config, table: pd.DataFrame, records: pd.DataFrame | None = None) -> None:
        """Write the run's table whole (`lwrl.outputs.write_table`), after its `records`
        (`runners.records`) where given: a run's table is never there without them."""
        if records is not None:
            outputs.write_table(records, self.records_file(self.directory.parent, config.key))
        outputs.write_table(table, self.path(config))

    def read(self, configs) -> pd.DataFrame:
        """The runs' tables, one after the other; a table written before one of its run's
        settings was a column (`RunConfig.columns`) gets that column from the run."""
        tables = []
        for config in configs:
            table = outputs.read_table(self.path(config))
            missing = {name: value for name, value in config.columns().items()
                       if name not in table.columns}
            tables.append(table.assign(**missing) if missing else table)
        return pd.concat(tables, ignore_index=True)

    @staticmethod
    def batch_name(batch) -> str:
        """A name of the runs of `batch` together: its claim's, and the state of a batch of
        several runs as one population (`resume_file`)."""
        digest = hashlib.sha1("\n".join(sorted(config.key for config in batch)).encode())
        return f"batch-{digest.hexdigest()[:12]}"

    def _claim_path(self, batch) -> pathlib.Path:
        return self.directory / f"{self.batch_name(batch)}.claim"

    def claim(self, batch) -> bool:
        """Claim `batch` for this process (`lwrl.outputs.claim`): True if it is ours to compute
        now, False while another process computes it."""
        held = outputs.claim(self._claim_path(batch))
        if held is not None:
            self._claims[held.path] = held
        return held is not None

    def release(self, batch) -> None:
        """Release this process's claim of `batch`, where it holds one."""
        held = self._claims.pop(self._claim_path(batch), None)
        if held is not None:
            held.release()

    def release_all(self) -> None:
        """Release every claim this process holds."""
        for held in self._claims.values():
            held.release()
        self._claims.clear()
