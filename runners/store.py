"""The runs directory of a sweep, `OUT/runs/`: finished runs, damaged ones set aside, claims.

- A finished run is `<key>.csv.gz`, written whole or not at all (`lwrl.outputs`).
- A file there that cannot be read (truncated, empty, not gzip, not the run's table) is
  reported by name, moved aside to `<key>.csv.gz.damaged`, and its run computed again.
- A batch of runs being computed is claimed by a file `<batch>.claim` holding the host and
  process that computes it, so that two processes sweeping into one directory share the
  work: each computes the batches it could claim and waits for the others' runs. A claim
  whose process is gone (on this host) is stale and is taken over.
"""

import hashlib
import os
import pathlib
import socket

import pandas as pd

from lwrl import outputs


class RunStore:
    """The runs of a sweep in `out_dir/runs`."""

    def __init__(self, out_dir):
        self.directory = pathlib.Path(out_dir) / "runs"
        self.directory.mkdir(parents=True, exist_ok=True)
        self._host = socket.gethostname()
        self._claims = set()

    def path(self, config) -> pathlib.Path:
        return self.directory / f"{config.key}.csv.gz"

    def finished(self, config) -> bool:
        return self.path(config).exists()

    def repair(self, configs) -> list[str]:
        """Set aside every unreadable run file of `configs`; return one line per file."""
        lines = []
        for config in configs:
            path = self.path(config)
            if not path.exists():
                continue
            try:
                table = pd.read_csv(path)
                if table.empty or "episode" not in table.columns:
                    raise ValueError("no rows of episodes")
            except (OSError, EOFError, ValueError, pd.errors.ParserError) as error:
                aside = path.with_name(path.name + ".damaged")
                os.replace(path, aside)
                lines.append(f"{path} is damaged ({' '.join(str(error).split()) or type(error).__name__}); "
                             f"moved to {aside.name}, its run is computed again")
        return lines

    def write(self, config, table: pd.DataFrame) -> None:
        with outputs.atomic_path(self.path(config)) as temporary:
            table.to_csv(temporary, index=False, compression="gzip")

    def read(self, configs) -> pd.DataFrame:
        """The runs' tables, one after the other; a table written before one of its run's
        settings was a column (`RunConfig.columns`) gets that column from the run."""
        tables = []
        for config in configs:
            table = pd.read_csv(self.path(config))
            missing = {name: value for name, value in config.columns().items()
                       if name not in table.columns}
            tables.append(table.assign(**missing) if missing else table)
        return pd.concat(tables, ignore_index=True)

    def _claim_path(self, batch) -> pathlib.Path:
        digest = hashlib.sha1("\n".join(sorted(config.key for config in batch)).encode())
        return self.directory / f"batch-{digest.hexdigest()[:12]}.claim"

    def _stale(self, path: pathlib.Path) -> bool:
        """True for a claim by a process of this host that is gone (or an unreadable claim)."""
        try:
            host, pid = path.read_text().split()
            pid = int(pid)
        except (OSError, ValueError):
            return True
        if host != self._host:
            return False  # another machine's: it cannot be checked from here
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        except PermissionError:
            return False
        return False

    def claim(self, batch) -> bool:
        """Claim `batch` for this process: True if it is ours to compute now."""
        path = self._claim_path(batch)
        for _ in range(2):
            try:
                descriptor = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                if not self._stale(path):
                    return False
                try:  # take over a stale claim: whoever removes it first may claim it
                    path.unlink()
                except FileNotFoundError:
                    pass
                continue
            with os.fdopen(descriptor, "w") as file:
                file.write(f"{self._host} {os.getpid()}\n")
            self._claims.add(path)
            return True
        return False

    def release(self, batch) -> None:
        path = self._claim_path(batch)
        if path in self._claims:
            self._claims.discard(path)
            path.unlink(missing_ok=True)

    def release_all(self) -> None:
        for path in list(self._claims):
            self._claims.discard(path)
            path.unlink(missing_ok=True)
