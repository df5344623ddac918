"""The learner on the device: NRBF Sarsa(lambda) itself as dependency-free C99.

Främling (2008) argues that the methods "remain computationally feasible to implement even
as embedded software" and could let "embedded systems ... adapt to their environment":
adapting means learning on the device. `write_learner` writes the learner for a task's grid
and settings (`settings_for_task`), or resumed from a saved agent (`settings_from_agent`, a
file of `lwrl train --save`), as two files in `out_dir`:

- `lwrl_learner.h`: the interface (six functions; `lwrl_reset`, then per episode
  `lwrl_begin` and one `lwrl_learn(observation, reward, terminal)` per control step, each
  returning the next action) and the settings as macros and comments;
- `lwrl_learner.c`: static arrays only (no heap), `<math.h>`'s `exp` (`expf` in float) and
  `fabs` and nothing else. Its arithmetic is `agent/`'s operation for operation (the
  template says which), so a double build takes the Python learner's actions at every step
  and ends with its weights, given the same `exp` (`tests/test_learner_c.py`).

`lwrl_real` is `float` (single-precision FPUs; the default) or `double`. In float the
traces' flush threshold 1e-100 is below float's range; float's smallest normal number,
1.2e-38, takes its place (it keeps the traces out of subnormal arithmetic, the threshold's
purpose). The random draws are lwrl's SplitMix64 in both: 53-bit doubles, compared in double.

The RAM the learner takes is computed (`ram_bytes`: weights and traces `A N`, the features
of the last two observations `2 N`, the per-variable factors `d n` and Q `A` values, and
20 bytes of stream, slot, action and divergence flag) and `write_learner(ram=...)` refuses
a grid that does not fit, in one line. A resumed learner also keeps the saved weights in
flash, as the values `lwrl_reset` restores.
"""

import dataclasses
import hashlib
import os

import numpy as np

from lwrl import outputs, tasks
from lwrl.export import reference
from lwrl.export.c import DTYPES, _check_index, _comment, _literal, _task_description, \
    _weights_block, template

SOURCE = "lwrl_learner.c"
"""The written file names (fixed, as the controller's are); templates `templates/learner/`."""
HEADER = "lwrl_learner.h"
STATE_BYTES = 8 + 3 * 4
"""The stream's 64-bit state and three ints (slot, action, divergence flag)."""
FLOAT_FLUSH = float(np.finfo(np.float32).tiny)
"""Float's smallest normal number: the float build's flush threshold."""


@dataclasses.dataclass(frozen=True)
class LearnerSettings:
    """What the generated learner is: its features, actions, hyper-parameters, the random
    stream's state, and where it came from."""

    features: reference.NRBF
    num_actions: int
    trace: str
    alpha: float
    lam: float
    epsilon: float
    gamma: float
    seed: int
    """The stream's initial 64-bit state (`LWRL_SEED`): lwrl's agent seeded with s starts at s."""
    task: str = "unknown"
    state_names: tuple = ()
    controls: tuple | None = None
    initial_weights: np.ndarray | None = None
    """`(A, N)` action-major weights to start from, or None for zeros."""
    origin: str = "new: zero weights"

    def __post_init__(self):
        if self.trace not in reference.TRACES:
            raise ValueError(f"the C learner has {' and '.join(reference.TRACES)} traces; "
                             f"got {self.trace!r}")
        for name, value, low, high in (("alpha", self.alpha, 0.0, np.inf),
                                       ("lambda", self.lam, 0.0, 1.0),
                                       ("epsilon", self.epsilon, 0.0, 1.0),
                                       ("gamma", self.gamma, 0.0, 1.0)):
            if not (isinstance(value, (int, float)) and low <= value <= high
                    and not (name == "alpha" and value == 0)):
                raise ValueError(f"{name} must be in {'(' if name == 'alpha' else '['}{low}, "
                                 f"{high}]; got {value!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or not 0 <= self.seed < 2 ** 64:
            raise ValueError(f"seed must be an integer in [0, 2^64); got {self.seed!r}")
        if not self.state_names:
            object.__setattr__(self, "state_names",
                               tuple(f"state[{j}]" for j in range(self.features.dim)))


def settings_for_task(task: str, *, n=None, r2=None, trace=None, alpha=None, lam=None,
                      epsilon=None, gamma=None, seed: int = 0) -> LearnerSettings:
    """A new learner for `task` (DOMAIN.TASK): the task's grid, ranges and best settings
    (`TaskDefinition.defaults`, the paper's), each overridable; zero weights."""
    if task not in tasks.TASK_NAMES:
        raise ValueError(f"unknown task {task!r}; available: {', '.join(tasks.TASK_NAMES)}")
    definition = tasks.definition(*tasks.split_name(task))
    defaults = definition.defaults
    pick = lambda value, default: default if value is None else value  # noqa: E731
    features = reference.NRBF(defaults.low, defaults.high, pick(n, defaults.n),
                              pick(r2, reference.DEFAULT_R2))
    return LearnerSettings(
        features=features, num_actions=definition.num_actions, trace=pick(trace, defaults.trace),
        alpha=float(pick(alpha, defaults.alpha)), lam=float(pick(lam, defaults.lam)),
        epsilon=float(pick(epsilon, defaults.epsilon)), gamma=float(pick(gamma, defaults.gamma)),
        seed=seed, task=task, state_names=tuple(definition.state_names),
        controls=tuple(definition.controls))


def settings_from_agent(path, agent_index: int = 0) -> LearnerSettings:
    """Agent `agent_index` of a saved batch (`lwrl train --save`), resumed: its features,
    hyper-parameters, weights and random stream's state, so that the C learner goes on as
    the Python agent would."""
    agent, metadata = reference.load_agents(path)
    if not isinstance(agent.features, reference.NRBF):
        raise ValueError(f"{path}: only NRBF agents can learn in C; this file holds "
                         f"{type(agent.features).__name__} features")
    b = _check_index(agent_index, agent.batch_size)
    weights = np.array(agent.memory.weights[b])
    if agent.diverged[b] or not np.all(np.isfinite(weights)):
        raise ValueError(f"{path}: agent {b} diverged (non-finite weights); there is nothing to resume")
    task, names, controls, _ = _task_description(metadata, agent.features.dim,
                                                 agent.num_actions, path)
    hyper = agent.hyper
    with open(path, "rb") as file:
        sha256 = hashlib.sha256(file.read()).hexdigest()
    return LearnerSettings(
        features=agent.features, num_actions=agent.num_actions,
        trace=reference.TRACE_NAMES[int(hyper.trace[b])],
        alpha=float(hyper.alpha[b]), lam=float(hyper.lam[b]), epsilon=float(hyper.epsilon[b]),
        gamma=float(hyper.gamma[b]), seed=int(agent.memory.streams[b]), task=task,
        state_names=tuple(names), controls=controls, initial_weights=weights,
        origin=f"resumed from agent {b} of {os.path.abspath(os.fspath(path))} (SHA-256 {sha256})")


def ram_bytes(settings: LearnerSettings, dtype: str = "float") -> dict:
    """Bytes of RAM per part of the learner in `dtype`, and their `total`."""
    size = np.dtype(DTYPES[_check_dtype(dtype)]).itemsize
    features, actions = settings.features, settings.num_actions
    parts = {"weights": actions * features.num_features * size,
             "traces": actions * features.num_features * size,
             "features": 2 * features.num_features * size,
             "scratch": (features.dim * features.n + actions) * size,
             "state": STATE_BYTES}
    parts["total"] = sum(parts.values())
    return parts


def check_fits(settings: LearnerSettings, dtype: str, ram) -> dict:
    """`ram_bytes`, or a one-line ValueError if they exceed `ram` bytes (None: no limit)."""
    parts = ram_bytes(settings, dtype)
    if ram is not None and parts["total"] > ram:
        grid = " x ".join([str(settings.features.n)] * settings.features.dim)
        raise ValueError(f"the {grid} grid's learner needs {parts['total']} bytes of RAM in "
                         f"{dtype} ({describe_ram(parts)}), more than the {ram} allowed; "
                         f"use a coarser grid (--n){' or float' if dtype == 'double' else ''}")
    return parts


def describe_ram(parts: dict) -> str:
    """The RAM parts as one phrase."""
    return ", ".join(f"{name} {parts[name]}" for name in ("weights", "traces", "features",
                                                          "scratch", "state"))


def _check_dtype(dtype: str) -> str:
    if dtype not in DTYPES:
        raise ValueError(f"dtype must be one of {', '.join(DTYPES)}; got {dtype!r}")
    return dtype


def _fields(settings: LearnerSettings, dtype: str, parts: dict) -> dict:
    """The templates' fields."""
    features = settings.features
    numpy_type = DTYPES[dtype]
    lit = lambda value: _literal(numpy_type(value), dtype)  # noqa: E731
    margin = reference.clamp_margin(features.n, features.r2)
    if settings.initial_weights is None:
        initial_weights, initial_value = "", lit(0.0)
        initial_text, initial_flash = "zero", ""
    else:
        rounded = settings.initial_weights.astype(numpy_type)
        if not np.all(np.isfinite(rounded)):
            raise ValueError(f"the saved weights are beyond the range of {dtype} (largest |w| "
                             f"{np.abs(settings.initial_weights).max():.3g}); use double")
        initial_weights = ("static const lwrl_real INITIAL[ACTIONS][NEURONS] = {\n"
                           + _weights_block(rounded, dtype) + "};\n")
        initial_value, initial_text = "INITIAL[a][i]", "the saved agent's"
        initial_flash = f", and the {rounded.nbytes} bytes of saved weights lwrl_reset restores"
    names = settings.state_names
    width = max(len(name) for name in names)
    flush = reference.FLUSH_THRESHOLD if dtype == "double" else FLOAT_FLUSH
    settings_line = (f"{settings.trace} traces, alpha {settings.alpha:g}, lambda {settings.lam:g}, "
                     f"epsilon {settings.epsilon:g}, gamma {settings.gamma:g}, r^2 {features.r2:g}, "
                     f"{dtype}")
    return dict(
        task=_comment(settings.task), settings=_comment(settings_line),
        grid=" x ".join([str(features.n)] * features.dim), neurons=features.num_features,
        num_actions=settings.num_actions, dim=features.dim, n=features.n, real=dtype,
        range_lines="\n".join(f" *   state[{j}] {_comment(name):<{width}}  [{lo:g}, {hi:g}]"
                              for j, (name, lo, hi) in enumerate(zip(names, features.low, features.high))),
        origin=_comment(settings.origin), ram_bytes=parts["total"],
        ram_lines=_comment(describe_ram(parts)), initial_flash=initial_flash,
        action_line=("" if settings.controls is None else "; action i applies control "
                     + ", ".join(f"{i}: {c:g}" for i, c in enumerate(settings.controls))),
        seed=settings.seed, seed_text=("the saved agent's stream" if settings.initial_weights is not None
                                       else f"lwrl's seed {settings.seed}"),
        low=", ".join(lit(v) for v in features.low), high=", ".join(lit(v) for v in features.high),
        initial_text=initial_text, flush_text=f"{flush:g}",
        trace_text=("replacing (eq. 6), e = max(gamma lambda e, phibar) for the taken action; "
                    "the other actions' traces only decay" if settings.trace == "replacing" else
                    "accumulating (eq. 2), e = gamma lambda e + phibar for the taken action; "
                    "the other actions' traces decay"),
        exp="expf" if dtype == "float" else "exp", fabs="fabsf" if dtype == "float" else "fabs",
        centroids=", ".join(lit((k + 0.5) / features.n) for k in range(features.n)),
        r2=lit(features.r2), s_min=lit(-margin), s_max=lit(1.0 + margin), alpha=lit(settings.alpha),
        gamma=lit(settings.gamma), gamma_lambda=lit(settings.gamma * settings.lam), flush=lit(flush),
        epsilon=_literal(settings.epsilon, "double"), initial_weights=initial_weights,
        initial_value=initial_value, zero=lit(0.0), one=lit(1.0),
        splitmix=splitmix_c(),
        trace_rule=("decayed > phi[i] ? decayed : phi[i]" if settings.trace == "replacing"
                    else "decayed + phi[i]"),
    )


def splitmix_c() -> str:
    """SplitMix64 in C as `agent/streams.py` draws (its constants from `reference.STREAM`):
    `static double draw(uint64_t *state)`, for the learner and the device programs."""
    stream = reference.STREAM
    shifts = stream["shifts"]
    return (
        "/* SplitMix64 (Steele, Lea and Flood 2014), as lwrl's agent/streams.py: advance the\n"
        " * state, hash it, keep 53 bits: a draw in [0, 1). */\n"
        "static double draw(uint64_t *state)\n{\n    uint64_t z;\n"
        f"    *state += UINT64_C(0x{stream['golden_gamma']:016X});\n    z = *state;\n"
        f"    z = (z ^ (z >> {shifts[0]})) * UINT64_C(0x{stream['mix_1']:016X});\n"
        f"    z = (z ^ (z >> {shifts[1]})) * UINT64_C(0x{stream['mix_2']:016X});\n"
        f"    z = z ^ (z >> {shifts[2]});\n"
        f"    return (double)(z >> {shifts[3]}) * {_literal(stream['to_unit'], 'double')};\n}}")


def write_learner(settings: LearnerSettings, out_dir, dtype: str = "float", ram=None) -> dict:
    """Write `lwrl_learner.c` and `lwrl_learner.h` for `settings` in `dtype` into `out_dir`
    (created if needed; the files replaced). Refuses, in one line, a learner whose RAM
    exceeds `ram` bytes (None: no limit), ranges or constants that do not fit `dtype`.
    Returns `source`, `header` (paths), `dtype`, `task`, `neurons`, `actions` and `ram`
    (`ram_bytes`)."""
    _check_dtype(dtype)
    parts = check_fits(settings, dtype, ram)
    features = settings.features
    numpy_type = DTYPES[dtype]
    with np.errstate(over="ignore", invalid="ignore"):
        low, high = np.array(features.low, numpy_type), np.array(features.high, numpy_type)
        constants = np.array([features.r2, 1.0 + reference.clamp_margin(features.n, features.r2),
                              settings.alpha], numpy_type)
        fits = (np.all(np.isfinite(high - low)) and np.all(high - low > 0)
                and np.all(np.isfinite(constants)) and constants[0] >= np.finfo(numpy_type).tiny)
    if not fits:
        raise ValueError(f"the ranges, r^2 = {features.r2!r} or alpha = {settings.alpha!r} do not fit {dtype}")
    fields = _fields(settings, dtype, parts)
    source_path, header_path = os.path.join(out_dir, SOURCE), os.path.join(out_dir, HEADER)
    try:
        os.makedirs(out_dir, exist_ok=True)
        for path, name in ((header_path, HEADER), (source_path, SOURCE)):
            with outputs.atomic_write(path, encoding="utf-8") as file:
                file.write(template(f"learner/{name}").substitute(fields))
    except OSError as error:
        raise ValueError(f"{out_dir}: cannot write the C files ({error.strerror or error})") from None
    return {"source": source_path, "header": header_path, "dtype": dtype, "task": settings.task,
            "neurons": features.num_features, "actions": settings.num_actions, "ram": parts}
