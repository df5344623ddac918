"""Save and load a batch of agents: one `.npz` file, no pickle.

The file holds the weights `(B, N, A)`, each agent's random stream and divergence flag, and
one JSON document (stored as a string array) with the feature map, the hyper-parameters and
any metadata the caller adds (e.g. the run's configuration). The file appears whole or not
at all. `load` refuses a file that is not such a file, or whose parts do not fit together,
with one line saying what is wrong; an agent whose weights are not finite is loaded as
diverged, whatever its flag says.
"""

import json
import os
import zipfile

import numpy as np

from lwrl.agent.cmac import CMAC
from lwrl.agent.nrbf import NRBF
from lwrl.agent.sarsa import BatchedSarsa
from lwrl.agent.traces import TRACES
from lwrl.outputs import atomic_write

FORMAT = "lwrl-agent/1"


def _feature_description(features) -> dict:
    if isinstance(features, NRBF):
        return {"kind": "nrbf", "low": features.low, "high": features.high, "n": features.n,
                "r2": features.r2}
    return {"kind": "cmac", "low": features.low, "high": features.high,
            "intervals": features.intervals, "tilings": features.tilings,
            "normalise_alpha": features.normalise_alpha}


def _feature_map(description: dict):
    kind = description.pop("kind")
    if kind == "nrbf":
        return NRBF(**description)
    if kind == "cmac":
        return CMAC(**description)
    raise ValueError(f"unknown feature kind {kind!r}")


def save(path, agent: BatchedSarsa, metadata: dict | None = None) -> None:
    """Write `agent` (and JSON-serialisable `metadata`) to `path` (a `.npz` file)."""
    hyper = agent.hyper
    document = {
        "format": FORMAT,
        "features": _feature_description(agent.features),
        "num_actions": agent.num_actions,
        "alpha": (hyper.alpha / agent.features.alpha_scale).tolist(),
        "lambda": hyper.lam.tolist(),
        "epsilon": hyper.epsilon.tolist(),
        "gamma": hyper.gamma.tolist(),
        "trace": [TRACES[t] for t in hyper.trace],
        "metadata": metadata or {},
    }
    with atomic_write(path, "wb") as file:  # whole or not at all
        np.savez_compressed(file, weights=agent.weights, streams=agent.memory.streams,
                            diverged=agent.diverged, document=np.array(json.dumps(document)))


def load(path) -> tuple[BatchedSarsa, dict]:
    """Read agents saved by `save`; return them and their metadata."""
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
    missing = {"weights", "streams", "diverged", "document"} - set(arrays)
    if missing:
        raise ValueError(f"{path} is not an lwrl agent file (missing {', '.join(sorted(missing))})")
    try:
        document = json.loads(str(arrays["document"]))
    except json.JSONDecodeError:
        raise ValueError(f"{path} is not an lwrl agent file (unreadable description)") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise ValueError(f"{path} is not an lwrl agent file (format {document.get('format')!r}, "
                         f"expected {FORMAT!r})" if isinstance(document, dict) else
                         f"{path} is not an lwrl agent file")
    try:
        features = _feature_map(dict(document["features"]))
        weights, streams, diverged = arrays["weights"], arrays["streams"], arrays["diverged"]
        expected = (len(streams), features.num_features, document["num_actions"])
        if weights.shape != expected or diverged.shape != (len(streams),):
            raise ValueError(f"weights of shape {weights.shape} do not fit {len(streams)} agents "
                             f"of {features.num_features} features and {document['num_actions']} actions")
        # An agent with non-finite weights diverged, whatever its flag says.
        diverged = diverged.astype(bool) | ~np.isfinite(weights).all(axis=(1, 2))
        agent = BatchedSarsa(features, document["num_actions"], alpha=document["alpha"],
                             lam=document["lambda"], epsilon=document["epsilon"],
                             gamma=document["gamma"], trace=document["trace"],
                             seeds=np.zeros(len(streams), dtype=np.uint64))
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{path}: malformed agent file ({error})") from None
    agent.weights[:] = weights
    agent.memory.streams[:] = streams
    agent.memory.diverged[:] = diverged
    return agent, document["metadata"]
