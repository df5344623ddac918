"""Stream Q(lambda) as C99 that learns on a device: its `LearnerForm`.

The template `export/templates/learner/stream_q_learner.c.in` computes Stream Q(lambda)'s
equations (Elsayed, Vasan & Mahmood 2024, arXiv:2410.14606; the authors' `stream_q.py`,
`optim.py`, `normalization_wrappers.py`) as `agent.streaming` and `agent.running_stats`
write them: the network's forward pass and the gradient of Q(x, a) through its layer norms,
the TD error, ObGD's bounded step along the accumulating trace, the scaled reward and
epsilon's schedule, for one agent of `agent.stream_q`, in the order of `agent.stream_agents`'
plumbing (act, record, update: the traces cleared at an episode's start, after a terminal
step and after an exploratory action other than the greedy one). Its first `timesteps`
steps learn; then it acts greedily and changes nothing, as the JAX agent does after its
`learning_steps`. The network is in the build's floating-point type, the statistics, the TD
error, epsilon and the step size in double, as the JAX learner keeps them in float64.

What it cannot share with the JAX learner is the random stream: JAX's keys (threefry) are out
of a microcontroller's reach, so the C learner draws from lwrl's SplitMix64 stream
(`agent.streams.uniform`) seeded with the agent's seed: at each step of learning one draw
against epsilon and, where it explores, a second whose floor(u A) is the action. It takes
stream-Q's steps on its own draws, not the JAX agent's numbers; `tests/test_stream_q_c.py`
holds the double build to the equations on those draws.

Where the interface makes it depart from the JAX learner: the last step of an episode cut by
a time limit is learned as the JAX learner learns it (bootstrapping from its observation),
but the return trace u of the reward scaling becomes gamma u + r there, not r (the JAX
learner knows of the cut: the authors' `terminated or truncated`), so that one sample of
the return's statistics and that step's scaled reward differ; the next episode starts from
u = r as the JAX learner's does, and the action returned at the cut observation, never
taken, is not counted as a step (`lwrl_begin`), so epsilon's schedule and the end of
learning follow the steps taken. An agent carried over from Python keeps its network, its
observation and return statistics, its return trace and its steps of learning; its traces
and a transition under way are not carried over (the C learner starts a new episode).
"""

import numpy as np

from lwrl.agent.learner_contract import LearnerForm
from lwrl.agent.streaming import LAYER_NORM_EPS, LEAKY_SLOPE
from lwrl.agent.streams import SPLITMIX64

STATE_BYTES = 2 * 8 + 4 * 4
"""The C learner's integers: its stream's 64-bit state and its steps of learning, and the
action, the learning and Watkins flags and the divergence flag (ints)."""


def layout(sizes) -> dict:
    """Where each layer's parameters and units lie in the C learner's arrays for layer
    widths `sizes` (the input's, the hidden layers', Q's): `weights_at`, `biases_at` (in the
    parameters, lwrl's order W_0, b_0, W_1, ...), `units_at` (the hidden layers' in a pass),
    `parameters`, `hidden` (units) and `widest` (the most units of a layer but the input)."""
    weights_at, biases_at, at = [], [], 0
    for fan_in, fan_out in zip(sizes[:-1], sizes[1:]):
        weights_at.append(at)
        biases_at.append(at + fan_in * fan_out)
        at += fan_in * fan_out + fan_out
    hidden = sizes[1:-1]
    return {"weights_at": weights_at, "biases_at": biases_at,
            "units_at": list(np.cumsum([0, *hidden[:-1]])), "parameters": at,
            "hidden": sum(hidden), "widest": max(sizes[1:])}


def doubles(values) -> str:
    """Numbers as C double literals that read back exactly, comma-separated (constants that
    stay double in a float build)."""
    return ", ".join(repr(float(value)) for value in np.ravel(values))


def learner_form(agents, b: int) -> LearnerForm:
    """Agent b of `agents` (an `agent.stream_q.StreamQAgents`) as the C learner's template
    takes it."""
    settings = agents.settings[b]
    dim, actions = agents.dim, agents.action_space.n
    sizes = [dim, *settings.layers(), actions]
    places = layout(sizes)
    weights = np.asarray(agents.arrays.weights[b], dtype=np.float64)
    rewards = {part: float(values[b]) for part, values in agents.state["rewards"].items()}
    duration = settings.exploration_fraction * settings.timesteps
    normalise = bool(settings.normalize_observations)

    def values(real) -> dict:
        return {"weights": weights[None], "seed": int(agents.seeds[b]),
                "layers": len(sizes) - 1, "widths": ", ".join(map(str, sizes)),
                **{name: ", ".join(map(str, places[name]))
                   for name in ("weights_at", "biases_at", "units_at")},
                "parameters": places["parameters"], "hidden": places["hidden"],
                "widest": places["widest"], "normalise": int(normalise),
                "normalise_text": "" if normalise else (
                    "; with the normalisation off (normalize_observations False) x is the "
                    "observation itself, the statistics kept all the same"),
                "alpha": doubles([settings.learning_rate]), "kappa": doubles([settings.kappa]),
                "gamma": doubles([settings.gamma]),
                "epsilon_start": doubles([settings.exploration_initial_eps]),
                "epsilon_end": doubles([settings.exploration_final_eps]),
                "epsilon_steps": doubles([duration]), "timesteps": int(settings.timesteps),
                "decay": float(np.float64(settings.gamma) * np.float64(settings.lam)),
                "slope": LEAKY_SLOPE, "norm_eps": LAYER_NORM_EPS,
                "count": doubles(weights[:1]), "states_mean": doubles(weights[1:1 + dim]),
                "states_p": doubles(weights[1 + dim:1 + 2 * dim]),
                "rewards": doubles([rewards["count"], rewards["mean"], rewards["p"]]),
                "return_trace": doubles([agents.state["return_trace"][b]]),
                "steps": int(min(agents.clocks[b], settings.timesteps)),
                "sqrt": "sqrtf" if real == np.float32 else "sqrt"}

    passes = 2 * (dim + 2 * places["hidden"] + len(sizes) - 2 + actions)
    return LearnerForm(
        template="learner/stream_q_learner", values=values,
        ram={"weights": (weights.size, 0), "traces": (places["parameters"], 0),
             "statistics": (0, 8 * (1 + 2 * dim + 5)), "passes": (passes, 0),
             "gradients": (2 * places["widest"], 0), "state": (0, STATE_BYTES)},
        ranges=(agents.task.ranges.low, agents.task.ranges.high), stream=SPLITMIX64,
        check=lambda real: None,
        summary=(f"Stream Q(lambda), Q {'-'.join(map(str, sizes))} ({places['parameters']} "
                 f"parameters), layer norm, leaky ReLU, ObGD alpha {settings.learning_rate:g} "
                 f"kappa {settings.kappa:g}, gamma {settings.gamma:g}, lambda {settings.lam:g}, "
                 f"epsilon {settings.exploration_initial_eps:g} -> "
                 f"{settings.exploration_final_eps:g} over {duration:g} of "
                 f"{settings.timesteps} steps"),
        name=f"the {'-'.join(map(str, sizes))} Stream Q(lambda) learner",
        smaller="a smaller network (--net-arch)")
