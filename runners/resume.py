"""A population run's whole state kept on disk while it runs, so that a run of hours stopped
by a Ctrl-C, a kill or the end of a working session goes on from where it was kept, not
from its start, with the numbers it would have had (`runners.population.run_population`'s
`resume`).

The state is the program's carry between two chunks: every agent's learner (its weights,
optimiser and replay buffer or rollout), its environment, its random key, its clocks and the
episodes recorded so far; its leaves are written as one `.npz` archive, whole or not at all
(`lwrl.outputs.atomic_path`), every `EVERY_SECONDS` at most and when the run is
interrupted, and removed when the run ends. A later call goes on from it only where the
file is of the same run computed the same way: the run's key, a digest of the program
(its StableHLO text), the versions of JAX and jaxlib, and the CPU (`runners.store.cpu`: XLA
compiles for the CPU's features), and where none of the run's checkpoints is behind it
(each needs the carry before its budget is spent); otherwise the run starts again. The
kept carry's arrays are the program's own, so a run resumed on the same CPU computes what
the run without the stop computes, bit for bit (tested).

The archive also keeps the wall and CPU seconds the earlier processes spent on the run,
so that the ledger counts them (`EpisodeResults.earlier_compute`); what was computed after
the last save before a kill is computed again.
"""

import hashlib
import json
import pathlib
import time
from importlib import metadata

import numpy as np

from lwrl import outputs

EVERY_SECONDS = 600.0
"""The least wall time between two saves of a running run's state."""


def kept(path) -> dict:
    """What the state kept at `path` says of its run: `steps` (per agent, the most any agent
    has taken), and the `wall_s` and `cpu_s` spent to get there; `{}` where nothing is kept
    (an archive written before it said its steps says no `steps`)."""
    try:
        with np.load(path, allow_pickle=False) as archive:  # reads the document alone
            document = json.loads(str(archive["document"]))
    except (OSError, EOFError, ValueError, KeyError):
        return {}
    return {name: document[name] for name in ("steps", "wall_s", "cpu_s") if name in document}


class Resume:
    """The kept state of one run at `path` (see the module); `identity` names the run (its
    key), `program` is the jitted chunk and `arguments` its arguments after the carry."""

    def __init__(self, path, run: str, program, template: dict, arguments: tuple):
        import jax

        from lwrl.runners.store import cpu  # pandas, the sweep's: not needed to import this
        self.path = pathlib.Path(path)
        """The `.npz` archive the state is kept in."""
        text = program.lower(template, *arguments).as_text()
        self.identity = {"run": run, "program": hashlib.sha1(text.encode()).hexdigest(),
                         "jax": jax.__version__, "jaxlib": metadata.version("jaxlib"),
                         "cpu": cpu()}
        """What a kept state must match to be this run's: the run's key, the program's
        digest, JAX's and jaxlib's versions and the CPU."""
        self.earlier = (0.0, 0.0)
        """`(wall, CPU)` seconds the earlier processes spent on the run (read by `load`)."""
        self._started = (time.perf_counter(), time.process_time())
        self._saved = time.perf_counter()

    def load(self, template: dict, first_checkpoint=None):
        """The kept carry, shaped as `template`, where the file is this run's and is not past
        `first_checkpoint` (the smallest budget still to give); else None."""
        import jax
        import jax.numpy as jnp
        try:
            with np.load(self.path, allow_pickle=False) as archive:
                document = json.loads(str(archive["document"]))
                leaves = [archive[f"leaf{i}"] for i in range(document["leaves"])]
        except (OSError, EOFError, ValueError, KeyError):
            return None
        expected, structure = jax.tree.flatten(template)
        if document["identity"] != self.identity or len(leaves) != len(expected) or any(
                kept.shape != np.shape(leaf) or kept.dtype != np.asarray(leaf).dtype
                for kept, leaf in zip(leaves, expected)):
            return None
        carry = jax.tree.unflatten(structure, [jnp.asarray(leaf) for leaf in leaves])
        if first_checkpoint is not None and int(np.asarray(carry["spent"]).max()) >= first_checkpoint:
            return None
        self.earlier = (document["wall_s"], document["cpu_s"])
        return carry

    def due(self) -> bool:
        """Whether `EVERY_SECONDS` have passed since the last save (or the start)."""
        return time.perf_counter() - self._saved >= EVERY_SECONDS

    def spent(self) -> tuple:
        """`(wall, CPU)` seconds spent on the run so far, the earlier processes' included."""
        return (self.earlier[0] + time.perf_counter() - self._started[0],
                self.earlier[1] + time.process_time() - self._started[1])

    def keep(self, carry: dict) -> None:
        """Write `carry` (between two chunks) and the seconds spent so far."""
        import jax
        leaves = [np.asarray(leaf) for leaf in jax.tree.leaves(carry)]
        wall_s, cpu_s = self.spent()
        document = {"identity": self.identity, "leaves": len(leaves), "wall_s": wall_s,
                    "cpu_s": cpu_s, "steps": int(np.asarray(carry["spent"]).max())}
        with outputs.atomic_write(self.path, "wb") as file:
            np.savez(file, document=np.array(json.dumps(document)),
                     **{f"leaf{i}": leaf for i, leaf in enumerate(leaves)})
        self._saved = time.perf_counter()

    def remove(self) -> None:
        """Delete the kept state (the run has ended); nothing where there is none."""
        self.path.unlink(missing_ok=True)
