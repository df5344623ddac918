"""The greedy controllers of today's light-weight rivals as C (`export.c`, template
`mlp_policy`): ARS's linear policy and the streaming learners' networks as
`ControllerForm`s, read through the agents' public arrays (`Agents.arrays.weights`,
`PopulationAgents.unflatten`: what each agent has learned, as its learner's `weight_tree`
holds it). `controller(agents, b)` is what the export asks for any agent: these forms for
their learners (`FORMS`), the learner's own `Agents.controller` for the others.

- **ARS** (`ars`, `ars_continuous`; Mania, Guy & Recht 2018, Algorithm 1): the scores theta
  x of the linear policy, one layer of p = A outputs (or one continuous output) without
  bias (its biases are stored as 0: 0 + a = a, the same scores); V2 reads the state as
  (x - mu) / (sigma + 1e-8) (`agent.random_search.v2_state`), so `INPUT_SCALE` is sigma +
  1e-8 computed here in double as the learner computes it (an infinite sigma, a variable
  that never varied, stays infinite: that variable reads 0). A discrete action is the
  argmax of the scores, a continuous one the output clipped to [-1, 1]
  (`random_search.continuous_action`).
- **Stream Q(lambda)** (Elsayed, Vasan & Mahmood 2024): the observation normalised by the
  running statistics, (x - mu) / sqrt(var + 1e-8) (`agent.running_stats.normalised`: the
  scale is computed here by the learner's own `stats_variance`), then Q's network, every
  hidden layer linear, layer-normalised without learned parameters (eps 1e-5) and leaky
  ReLU (slope 0.01) (`streaming.forward`); the greedy action is the argmax of Q.
- **Stream AC(lambda)**: the same normalisation and the actor's network, of which only
  the mean's output is kept (the last layer's first row; the other output, sigma's, does
  not enter a greedy decision); the greedy action is the mean clipped to [-1, 1]
  (`StreamAcAgents.choose` where greedy); for discrete actions (`stream_ac_discrete`) the
  actor's every output, a preference per action, whose argmax is the greedy action.

The statistics are frozen as the agent was saved: a greedy controller does not update them
(`agent.stream_agents`: acting greedily leaves them as they are), so the square roots of
the normalisation are constants of the controller, not work of its decisions.
"""

import numpy as np

from lwrl.agent.learner_contract import ControllerForm


def controller(agents, b: int) -> ControllerForm:
    """Agent b's greedy controller: the export's form for its learner (`FORMS`), else the
    learner's own (`Agents.controller`, a one-line ValueError where it has none)."""
    form = FORMS.get(agents.learner.name)
    return form(agents, b) if form else agents.controller(b)


def _tree(agents, b: int):
    """Agent b's learned arrays as its learner's `weight_tree` holds them, as NumPy."""
    import jax
    return jax.tree.map(np.asarray, agents.unflatten(agents.arrays.weights[b]))


def _network(layers, outputs=None) -> tuple:
    """`(flat weights, sizes)` of `[(W (in, out), b (out,)), ...]` in the template's layout
    (each layer's W row-major out x in, then b), the last layer cut to its first `outputs`
    units (None: all)."""
    if outputs is not None:
        *hidden, (w, bias) = layers
        layers = [*hidden, (w[:, :outputs], bias[:outputs])]
    flat = np.concatenate([np.concatenate([np.asarray(w, np.float64).T.ravel(),
                                           np.asarray(bias, np.float64)]) for w, bias in layers])
    sizes = [layers[0][0].shape[0]] + [w.shape[1] for w, _ in layers]
    return flat, sizes


def _form(agents, flat, sizes, title: str, **options) -> ControllerForm:
    """A `mlp_policy` form of the network `flat` with layer widths `sizes` for `agents`'
    task, and the template's `options` (normalisation, activation, ...)."""
    task = agents.task
    stored = (("weights", "input_mean", "input_scale") if options["normalise"] == "1"
              else ("weights",))
    return ControllerForm(
        template="mlp_policy",
        values={"weights": flat, "sizes": ", ".join(map(str, sizes)), "layers": len(sizes) - 1,
                "widest": max(sizes), "parameters": len(flat), "shape": " -> ".join(map(str, sizes)),
                "low": np.array(task.ranges.low, dtype=np.float64),
                "high": np.array(task.ranges.high, dtype=np.float64), "title": title, **options},
        stored=stored, ranges=(task.ranges.low, task.ranges.high), check=lambda real: None)


def linear_form(agents, b: int) -> ControllerForm:
    """ARS's linear policy (see the module)."""
    from lwrl.agent import random_search
    tree = _tree(agents, b)
    theta = np.asarray(tree["theta"], np.float64)
    flat = np.concatenate([theta.ravel(), np.zeros(len(theta))])
    v2 = agents.settings[b].variant == "v2"
    options = {"activation": "IDENTITY", "output": "CLIP", "normalise": str(int(v2))}
    if v2:
        options.update(input_mean=np.asarray(tree["mean"], np.float64),
                       input_scale=np.asarray(tree["std"], np.float64) + random_search.STD_EPS,
                       inputs="the state in task units, read as V2 reads it: (s - mu) / (sigma "
                              "+ 1e-8), mu and sigma of the states seen in learning")
    else:
        options.update(inputs="the state in task units (V1: no normalisation)")
    return _form(agents, flat, [theta.shape[1], theta.shape[0]],
                 f"ARS {'V2' if v2 else 'V1'}'s linear policy, no hidden layer", **options)


def _stream_form(agents, b: int, layers, outputs, title: str) -> ControllerForm:
    """A streaming learner's network `layers` (see the module), its statistics agent b's,
    or none where its settings turn the normalisation off."""
    from lwrl.agent import running_stats, streaming
    flat, sizes = _network(layers, outputs)
    network = dict(activation="LEAKY_RELU", output="CLIP",
                   between=", each hidden layer normalised (N) before it", layer_norm="1",
                   leaky_slope=streaming.LEAKY_SLOPE, layer_norm_eps=streaming.LAYER_NORM_EPS)
    if not agents.settings[b].normalize_observations:
        return _form(agents, flat, sizes, title, normalise="0",
                     inputs="the state in task units (no normalisation)", **network)
    stats = _tree(agents, b)["observations"]
    scale = np.sqrt(np.asarray(running_stats.stats_variance(stats), np.float64)
                    + running_stats.STATS_EPS)
    return _form(agents, flat, sizes, title, normalise="1",
                 input_mean=np.asarray(stats["mean"], np.float64), input_scale=scale,
                 inputs="the state in task units, normalised by the running statistics of "
                        "the observations seen in learning: (s - mu) / sqrt(var + 1e-8)",
                 **network)


def stream_q_form(agents, b: int) -> ControllerForm:
    """Stream Q(lambda)'s Q-network (see the module)."""
    return _stream_form(agents, b, _tree(agents, b)["params"], None,
                        "Stream Q(lambda)'s Q-network")


def stream_ac_form(agents, b: int) -> ControllerForm:
    """Stream AC(lambda)'s actor, its mean's output (see the module)."""
    return _stream_form(agents, b, _tree(agents, b)["params"]["actor"], 1,
                        "Stream AC(lambda)'s actor, its mean")


def stream_ac_discrete_form(agents, b: int) -> ControllerForm:
    """Stream AC(lambda)'s actor of discrete actions: the argmax of its preferences."""
    return _stream_form(agents, b, _tree(agents, b)["params"]["actor"], None,
                        "Stream AC(lambda)'s actor, its preferences")


FORMS = {"ars": linear_form, "ars_continuous": linear_form, "stream_q": stream_q_form,
         "stream_ac": stream_ac_form, "stream_ac_discrete": stream_ac_discrete_form}
"""`{learner name: form(agents, b) -> ControllerForm}`: the learners whose controller form
the export holds."""
