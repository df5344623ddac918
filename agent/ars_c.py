"""Augmented Random Search as C99 that learns on a device: its `LearnerForm`.

The template `export/templates/learner/ars_learner.c.in` computes ARS's equations
(`agent.random_search`: the perturbed policies, the argmax of the linear scores, V2's
reading of the state and scale, the step over the top directions; `agent.running_stats`:
the statistics of the states) for one agent of `agent.ars`, with discrete actions. What it
cannot share with the JAX learner is the random stream: JAX's keys (threefry) are out of a
microcontroller's reach, so the C learner draws its directions from lwrl's SplitMix64
stream (`agent.streams.gaussian`, Box-Muller), seeded with the agent's seed. It starts an
iteration afresh from the agent's policy, V2's scale and the statistics of the states it
has seen (an iteration under way in Python is not carried over), and learns for as long as
it runs (the run's budget is the host's). `tests/test_ars_c.py` holds its iterations to the
equations on the directions it draws.

Continuous actions (`ars_continuous`) have no C learner: the device's programs exchange an
action index.
"""

import numpy as np

from lwrl.agent.learner_contract import LearnerForm
from lwrl.agent.random_search import STD_EPS, STD_FLOOR
from lwrl.agent.streams import SPLITMIX64

STATE_BYTES = 8 + 3 * 4
"""The C learner's integers: its stream's 64-bit state, the rollout, whether one is under
way and the divergence flag (ints)."""


def learner_form(agents, b: int) -> LearnerForm:
    """Agent b of `agents` (an `agent.ars.ArsAgents`) as the C learner's template takes it;
    a one-line ValueError for continuous actions."""
    if agents.continuous:
        raise ValueError(f"{agents.learner.name} agents cannot learn in C: the device's "
                         "programs exchange an action index, and these act continuously")
    settings = agents.settings[b]
    tree = agents.unflatten(agents.arrays.weights[b])
    weights = np.concatenate([np.ravel(tree[part]) for part in ("mean", "std", "theta")])
    seen = {part: np.asarray(values[b], dtype=np.float64)
            for part, values in agents.state["states"].items()}
    actions, dim = agents.action_space.n, agents.dim
    directions, top = settings.directions, settings.top_directions
    variant = settings.variant

    def values(real) -> dict:
        return {"weights": weights[None], "seed": int(agents.seeds[b]),
                "directions": directions, "top": top, "v2": int(variant == "v2"),
                "variant_text": ("V2, the state normalised by the running mean and standard "
                                 "deviation" if variant == "v2" else "V1, the state itself"),
                "alpha": float(settings.learning_rate), "nu": float(settings.delta_std),
                "std_floor": STD_FLOOR, "std_eps": STD_EPS, "count": float(seen["count"]),
                "states_mean": seen["mean"], "states_p": seen["p"],
                "sqrt": "sqrtf" if real == np.float32 else "sqrt"}

    return LearnerForm(
        template="learner/ars_learner", values=values,
        ram={"weights": (weights.size, 0), "directions": (directions * actions * dim, 0),
             "returns": (2 * directions, 0), "statistics": (1 + 2 * dim, 0),
             "scratch": (dim + 1, 0), "state": (0, STATE_BYTES)},
        ranges=(agents.task.ranges.low, agents.task.ranges.high), stream=SPLITMIX64,
        check=lambda real: None,
        summary=(f"ARS {variant.upper()}-t, linear policy {actions} x {dim}, {directions} "
                 f"directions, top {top}, step {settings.learning_rate:g}, noise "
                 f"{settings.delta_std:g}"),
        name=f"the {directions}-direction ARS learner", smaller="fewer directions (--directions)")
