"""Sending to Rerun without its stateful clock: time columns and one-row sends.

Every temporal send here goes through `rr.send_columns`, which takes its timelines from the
columns given (it adds none of its own and ignores `set_time`), so logging never reads or
changes the time state of the caller's recording stream.
"""

import numpy as np
import rerun as rr

from lwrl.viz import names


def episode_indexes(steps, timestep: float, episode: int) -> list:
    """The `step`, `sim_time` and `episode` columns of rows at the given steps of an episode."""
    steps = np.asarray(steps, dtype=np.int64)
    return [
        rr.TimeColumn(names.STEP, sequence=steps),
        rr.TimeColumn(names.SIM_TIME, duration=steps * float(timestep)),
        rr.TimeColumn(names.EPISODE, sequence=np.full(len(steps), int(episode), dtype=np.int64)),
    ]


def one_row(archetype) -> list:
    """An archetype instance as component columns of one row (its whole batches in it)."""
    return [batch.partition([len(batch.as_arrow_array())])
            for batch in archetype.as_component_batches()]


def send(rec: rr.RecordingStream, path: str, indexes: list, columns) -> None:
    """`rr.send_columns` on `rec`, raising on errors instead of only warning."""
    rr.send_columns(path, indexes=indexes, columns=columns, recording=rec, strict=True)


def log_static(rec: rr.RecordingStream, path: str, archetype) -> None:
    """Log timeless data (shown on every timeline)."""
    rr.log(path, archetype, static=True, recording=rec, strict=True)
