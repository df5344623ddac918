"""Save and load a batch of agents of any learner: one `.npz` file, no pickle.

The file holds the learner's arrays (`Agents.saved`: its weights, each agent's random
stream and divergence flag, ...) and one JSON document (stored as a string array) naming the
learner and the state count, the learner's own description (what it has: its feature map,
actions and hyper-parameters; the task's spec where it keeps one) and any metadata the caller adds (e.g. the run's configuration). The file
appears whole or not at all. `load` refuses a file that is not such a file, or whose parts
do not fit together, with one line saying what is wrong; an agent whose weights are not
finite is loaded as diverged, whatever its flag says.

Format `lwrl-agent/2` names its learner; files of format `lwrl-agent/1`, written before
learners other than Sarsa(lambda) existed, hold Sarsa(lambda) agents and load as such.
Files written before learners said what they have carry `num_actions` in every document,
and the task as a list or dict of (name, state names, actions, ranges) where a learner kept
one (`lwrl.spaces.spec_of_document` reads both); they load as they are.
"""

import json
import os
import zipfile

import numpy as np

from lwrl import agent as learners
from lwrl.outputs import atomic_write

FORMAT = "lwrl-agent/2"
"""The format `save` writes, named in the saved document."""
FORMATS = (FORMAT, "lwrl-agent/1")
"""The formats `load` reads: this one, and the first (Sarsa(lambda) agents only)."""


def save(path, agents, metadata: dict | None = None) -> None:
    """Write `agents` (any learner's `Agents`) and JSON-serialisable `metadata` to `path`."""
    own, arrays = agents.saved()
    document = {"format": FORMAT, "learner": agents.learner.name, "dim": agents.dim, **own,
                "metadata": metadata or {}}
    with atomic_write(path, "wb") as file:  # whole or not at all
        np.savez_compressed(file, **arrays, document=np.array(json.dumps(document)))


def load(path) -> tuple:
    """Read agents saved by `save`; return them (the learner's `Agents`) and their metadata."""
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such agent file")
    not_npz = ValueError(f"{path} is not an lwrl agent file (not a NumPy .npz archive of plain arrays)")
    try:
        archive = np.load(path, allow_pickle=False)
    except (OSError, EOFError, ValueError, zipfile.BadZipFile):
        raise not_npz from None
    if not isinstance(archive, np.lib.npyio.NpzFile):  # a .npy file: one array
        raise not_npz
    try:
        with archive:
            arrays = {name: archive[name] for name in archive.files}
    except (OSError, EOFError, ValueError, zipfile.BadZipFile):
        raise not_npz from None
    missing = {"diverged", "document"} - set(arrays)
    if missing:
        raise ValueError(f"{path} is not an lwrl agent file (missing {', '.join(sorted(missing))})")
    try:
        document = json.loads(str(arrays.pop("document")))
    except json.JSONDecodeError:
        raise ValueError(f"{path} is not an lwrl agent file (unreadable description)") from None
    if not isinstance(document, dict) or document.get("format") not in FORMATS:
        raise ValueError(f"{path} is not an lwrl agent file (format {document.get('format')!r}, "
                         f"expected {FORMAT!r})" if isinstance(document, dict) else
                         f"{path} is not an lwrl agent file")
    try:
        learner = learners.learner(document.get("learner", "sarsa"))
        agent = learner.load(document, arrays)
        diverged = arrays["diverged"]
        if diverged.shape != (agent.batch_size,):
            raise ValueError(f"{diverged.size} divergence flags for {agent.batch_size} agents")
        # An agent with non-finite weights diverged, whatever its flag says.
        weights = agent.arrays.weights
        agent.arrays.diverged[:] = diverged.astype(bool) | ~np.isfinite(
            weights.reshape(len(weights), -1)).all(axis=1)
    except KeyError as error:
        raise ValueError(f"{path} is not an lwrl agent file (missing {error.args[0]})") from None
    except (TypeError, ValueError) as error:
        raise ValueError(f"{path}: malformed agent file ({error})") from None
    return agent, document["metadata"]
