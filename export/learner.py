"""The learner on the device: an agent's learner itself as dependency-free C99.

Främling (2008) argues that the methods "remain computationally feasible to implement even
as embedded software" and could let "embedded systems ... adapt to their environment":
adapting means learning on the device. `write_learner` writes one agent whose learner has
a C form (`Agents.learner_form`: the template it fills, its values and the parts of its
RAM; NRBF Sarsa(lambda) with replacing or accumulating traces, `agent.sarsa_c`, ARS with
discrete actions, `agent.ars_c`, and Stream Q(lambda), `agent.stream_q_c`) as two files in
`out_dir`:

- `lwrl_learner.h`: the interface, six functions: `lwrl_reset(seed)` once, then per
  episode `lwrl_begin(observation)` and one `lwrl_learn(observation, reward, terminal)` per
  control step, each returning the next action; `lwrl_greedy`, `lwrl_weights` and
  `lwrl_diverged`. The macros `LWRL_STATE_DIM`, `LWRL_NUM_ACTIONS`, `LWRL_NUM_WEIGHTS`,
  `LWRL_SEED`, `LWRL_LOW` and `LWRL_HIGH` are there for the firmware around it;
- `lwrl_learner.c`: static arrays only (no heap), `<math.h>` and `<stdint.h>`. Its
  arithmetic is the Python learner's operation for operation, so that a double build takes
  the Python learner's actions at every step and ends with its weights, given the same
  `exp` (`tests/test_learner_c.py`).

The agent is a new one for a task (`from_task`: the run configuration's learner and
settings, the task's defaults for those not given, untrained, its stream at its seed),
or one of a file of `lwrl train --save` (`from_file`), which goes on from its weights and
its stream's state; non-zero weights are kept in flash, as the values `lwrl_reset`
restores. `lwrl_real` is `float` (single-precision FPUs; the default) or `double`; the
random draws are lwrl's (`agent/streams.py`), 53-bit doubles in both.

The RAM the learner takes is computed from its form (`ram_bytes`) and `write_learner(ram=
...)` refuses a learner that does not fit, in one line.
"""

import dataclasses
import hashlib
import os

import numpy as np

from lwrl import tasks
from lwrl.agent import io as agent_io
from lwrl.agent.learner_contract import Agents, LearnerForm
from lwrl.export.c import (DTYPES, _check_dtype, _check_index, _comment, _literal, _rendered,
                           _task_description, _weights_block, template, write_files)
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents

SOURCE = "lwrl_learner.c"
"""The written file names (fixed, as the controller's are)."""
HEADER = "lwrl_learner.h"
INTERFACE = ("lwrl_reset", "lwrl_begin", "lwrl_learn", "lwrl_greedy", "lwrl_weights",
             "lwrl_diverged")
"""The functions every C learner has (its form's template declares them in the header)."""


@dataclasses.dataclass(frozen=True)
class LearnerSource:
    """An agent to write as the C learner, and what the files say of it."""

    agents: Agents
    index: int
    """Which agent of `agents`."""
    task: str
    state_names: tuple
    controls: tuple | None
    """Each action's control, or None where the task is unknown."""
    origin: str
    """Where the agent came from, for the header."""
    stream: str
    """What the stream's state `LWRL_SEED` is, for the header."""

    @property
    def form(self) -> LearnerForm:
        """The agent's `LearnerForm` (a one-line ValueError where its learner has none)."""
        return self.agents.learner_form(self.index)


def from_task(task: str, seed: int = 0, **settings) -> LearnerSource:
    """A new agent for `task` (DOMAIN.TASK) seeded with `seed`: `settings` are those of a
    `RunConfig` (`learner` and the learner's settings), the task's defaults for the rest."""
    config = RunConfig(task=task, agents=1, seed=seed, **settings)
    definition = tasks.definition(config.domain, config.task_name, **config.task_options)
    return LearnerSource(make_agents(config), 0, task, tuple(definition.state_names),
                         definition.controls, origin=f"new {config.learner} agent, untrained",
                         stream=f"lwrl's seed {seed}")


def from_file(path, agent_index: int = 0) -> LearnerSource:
    """Agent `agent_index` of a saved batch (`lwrl train --save`), resumed: it goes on from
    its weights and its random stream's state, as the Python agent would."""
    agents, metadata = agent_io.load(path)
    b = _check_index(agent_index, agents.batch_size)
    if agents.diverged[b]:
        raise ValueError(f"{path}: agent {b} diverged (non-finite weights); there is nothing to resume")
    task, names, definition, _ = _task_description(metadata, agents, path)
    with open(path, "rb") as file:
        sha256 = hashlib.sha256(file.read()).hexdigest()
    return LearnerSource(agents, b, task, tuple(names),
                         None if definition is None or agents.continuous else definition.controls,
                         origin=f"resumed from agent {b} of {os.path.abspath(os.fspath(path))} "
                                f"(SHA-256 {sha256})",
                         stream=f"agent {b}'s stream as saved")


def ram_bytes(form: LearnerForm, dtype: str = "float") -> dict:
    """Bytes of RAM per part of the learner in `dtype` (`LearnerForm.ram`), and their `total`."""
    size = np.dtype(DTYPES[_check_dtype(dtype)]).itemsize
    parts = {name: reals * size + other for name, (reals, other) in form.ram.items()}
    parts["total"] = sum(parts.values())
    return parts


def describe_ram(parts: dict) -> str:
    """The RAM parts as one phrase: `weights 768, traces 768, ...`."""
    return ", ".join(f"{name} {value}" for name, value in parts.items() if name != "total")


def check_fits(form: LearnerForm, dtype: str, ram) -> dict:
    """`ram_bytes`, or a one-line ValueError if they exceed `ram` bytes (None: no limit)."""
    parts = ram_bytes(form, dtype)
    if ram is not None and parts["total"] > ram:
        raise ValueError(f"{form.name} needs {parts['total']} bytes of RAM in {dtype} "
                         f"({describe_ram(parts)}), more than the {ram} allowed; use "
                         f"{form.smaller}{' or float' if dtype == 'double' else ''}")
    return parts


def splitmix_c(stream) -> str:
    """`static double draw(uint64_t *state)`: a SplitMix64 stream (`agent.streams.SplitMix64`)
    in C, drawing what `agent.streams.uniform` draws; for the learner and the device
    programs."""
    shifts = stream.shifts
    return (
        "/* SplitMix64 (Steele, Lea and Flood 2014), as lwrl's agent/streams.py: advance the\n"
        " * state, hash it, keep 53 bits: a draw in [0, 1). */\n"
        "static double draw(uint64_t *state)\n{\n    uint64_t z;\n"
        f"    *state += UINT64_C(0x{stream.increment:016X});\n    z = *state;\n"
        f"    z = (z ^ (z >> {shifts[0]})) * UINT64_C(0x{stream.multipliers[0]:016X});\n"
        f"    z = (z ^ (z >> {shifts[1]})) * UINT64_C(0x{stream.multipliers[1]:016X});\n"
        f"    z = z ^ (z >> {shifts[2]});\n"
        f"    return (double)(z >> {shifts[3]}) * {_literal(stream.unit, 'double')};\n}}")


def _fields(source: LearnerSource, form: LearnerForm, dtype: str, parts: dict) -> dict:
    """The templates' fields: the form's values, and those every learner has."""
    numpy_type = DTYPES[dtype]
    values = form.values(numpy_type)
    weights = np.asarray(values.pop("weights"))
    with np.errstate(over="ignore", invalid="ignore"):
        rounded = weights.astype(numpy_type)
    if not np.all(np.isfinite(rounded)):
        raise ValueError(f"the agent's weights are beyond the range of {dtype} (largest |w| "
                         f"{np.abs(weights).max():.3g}); use double")
    reason = form.check(numpy_type)
    if reason is not None:
        raise ValueError(reason)
    if np.any(weights != 0):  # kept in flash, restored by lwrl_reset
        initial = dict(initial_weights=(f"static const lwrl_real INITIAL[{len(weights)}]"
                                        f"[{weights[0].size}] = {{\n"
                                        + _weights_block(rounded, dtype) + "};\n"),
                       initial_value="INITIAL[a][i]", initial_text="the saved agent's",
                       initial_flash=f", and the {rounded.nbytes} bytes of saved weights "
                                     f"lwrl_reset restores")
    else:
        initial = dict(initial_weights="", initial_value=_literal(0.0, dtype),
                       initial_text="zero", initial_flash="")
    names = source.state_names
    width = max(len(name) for name in names)
    low, high = form.ranges
    return dict(
        {name: _rendered(value, dtype) for name, value in values.items()}, **initial,
        task=_comment(source.task), summary=_comment(form.summary), origin=_comment(source.origin),
        stream_text=_comment(source.stream), real=dtype, dim=len(names),
        num_actions=source.agents.action_space.n, num_weights=weights.size,
        range_lines="\n".join(f" *   state[{j}] {_comment(name):<{width}}  [{lo:g}, {hi:g}]"
                              for j, (name, lo, hi) in enumerate(zip(names, low, high))),
        low=_rendered(np.asarray(low, dtype=np.float64), dtype),
        high=_rendered(np.asarray(high, dtype=np.float64), dtype),
        ram_bytes=parts["total"], ram_lines=_comment(describe_ram(parts)),
        action_line=("" if source.controls is None else "; action i applies control "
                     + ", ".join(f"{i}: {c:g}" for i, c in enumerate(source.controls))),
        exp="expf" if dtype == "float" else "exp", fabs="fabsf" if dtype == "float" else "fabs",
        zero=_literal(0.0, dtype), one=_literal(1.0, dtype), splitmix=splitmix_c(form.stream))


def build_digest(texts: dict) -> int:
    """A learner's build: the first 8 bytes of the SHA-256 of its header's and source's
    texts (`render_learner`), as an unsigned big-endian integer; the same agent, settings
    and arithmetic give the same build, any other a different one (but with odds of 2^-64)."""
    digest = hashlib.sha256("".join(texts[name] for name in (HEADER, SOURCE)).encode())
    return int.from_bytes(digest.digest()[:8], "big")


def render_learner(source: LearnerSource, dtype: str = "float", ram=None) -> tuple:
    """`({file name: text}, what write_learner returns but the paths)` for `source`'s agent
    in `dtype` (see `write_learner`)."""
    _check_dtype(dtype)
    form = source.form
    parts = check_fits(form, dtype, ram)
    fields = _fields(source, form, dtype, parts)
    texts = {HEADER: template(f"{form.template}.h").substitute(fields),
             SOURCE: template(f"{form.template}.c").substitute(fields)}
    return texts, {"dtype": dtype, "task": source.task, "summary": form.summary,
                   "seed": int(fields["seed"]), "weights": fields["num_weights"], "ram": parts,
                   "build": build_digest(texts)}


def write_learner(source: LearnerSource, out_dir, dtype: str = "float", ram=None) -> dict:
    """Write `lwrl_learner.c` and `lwrl_learner.h` for `source`'s agent in `dtype` into
    `out_dir` (created if needed; the files replaced). Refuses, in one line, a learner with
    no C form, one whose RAM exceeds `ram` bytes (None: no limit), and weights or constants
    that do not fit `dtype`. Returns `source`, `header` (paths), `dtype`, `task`,
    `summary`, `seed` (`LWRL_SEED`), `weights` (their count), `ram` (`ram_bytes`) and
    `build` (`build_digest`)."""
    texts, written = render_learner(source, dtype, ram)
    paths = write_files(out_dir, texts)
    return {"source": paths[SOURCE], "header": paths[HEADER], **written}
