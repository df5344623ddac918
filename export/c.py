"""The embedded controller: a trained agent as a dependency-free C99 function.

Främling (2008) argues that the trained controller is cheap enough for embedded software.
`export_c` writes one saved agent (a file of `lwrl train --save`, read by `agent.io.load`)
whose learner has a C controller (`Agents.controller`: the template it fills and the values;
NRBF agents, below, and the Stable-Baselines3 learners' networks, template `mlp_policy`: a
plain forward pass over `const` weights, `tanhf`/`tanh` where the actor uses tanh; for ARS
and the streaming learners the forms of `agent.controller_forms`, the same template with
the state's normalisation, layer normalisation and leaky ReLU) as two
files in `out_dir`:

- `lwrl_policy.h`: the interface. For a learner of discrete actions (`Learner.actions`),
  `int lwrl_act(const lwrl_real *state)` returns the greedy action index and
  `void lwrl_q_values(const lwrl_real *state, lwrl_real *q)` writes Q(s, .); for one of
  continuous actions, `lwrl_real lwrl_act(const lwrl_real *state)` returns the greedy
  action u in [-1, 1] and `void lwrl_actor(const lwrl_real *state, lwrl_real *u)` the
  actor's output before the clip. `lwrl_real` is `float` (default) or `double`. Macros
  give the state dimension, the action count (`LWRL_NUM_ACTIONS`) or the actuator's range
  at the task's paper values (`LWRL_ACTION_LOW`, `LWRL_ACTION_HIGH`: u commands
  `(low + high) / 2 + u (high - low) / 2`, `tasks.commands`), the grid, r^2 and the
  ranges (`LWRL_LOW`, `LWRL_HIGH`, as initialiser lists).
- `lwrl_policy.c`: the weights as `static const` arrays, action-major (each action's row of
  N weights is contiguous), and the two functions. It includes only `<math.h>` (`expf`,
  `fabsf`; `exp`, `fabs` for double) and allocates nothing: its stack holds the d x n
  factors, one row of n features and the A sums, never all N features (RAM is scarcer
  than flash on a microcontroller).

The names are fixed (not per task) so firmware code does not change when the controller is
retrained; the comment header of both files says what task, features, grid, ranges and
source file (path, SHA-256, agent index) they were generated from. One template pair per
network serves both kinds of action: the lines between `%% discrete` (or `%% continuous`)
and `%% end` are kept for that kind only (`template`), the rest, the features' and the
network's code among it, is the same.

The C code computes what `agent/nrbf.py` computes, step for step, in `lwrl_real`: each
variable is mapped from [low, high] to [0, 1] (not clipped); per dimension, the factors
`exp(-((s_j - c_k)^2 - m^2) / r^2)` with centroids `c_k = (k + 0.5) / n` and `m` the
nearest-centroid distance (the underflow guard), normalised to sum 1; the features are the
outer product of the per-dimension factors in C order (last variable fastest), and
`Q(s, a) = sum_i w_ia phibar_i`, or the actor's mean `mu(s) = sum_i w_i phibar_i` of
`agent/actor_critic.py` (CACLA, van Hasselt and Wiering 2007), clipped to [-1, 1] as its
greedy action is. One addition: a normalised value is limited to
`[-M, 1 + M]` with `M = 400 n r^2` (`clamp_margin`). Beyond, every factor but the edge
centroid's is below `exp(-800)`, which is 0 in float and in double, so the features are
exactly those at the limit; the limit keeps the float arithmetic accurate (at a normalised
value of 1e7 a float cannot tell the centroids apart) and finite (no inf - inf = NaN).

Ties: `lwrl_act` returns the lowest index among equal Q values (the Python agent breaks
ties at random); with trained weights exact ties are rare. A NaN state gives action 0, or
for a continuous action 0, the middle of the actuator's range.

`measure(out_dir)` compiles the exported files with the system C compiler and reports the
flash they take (`.text` at `-Os` and the read-only data) and the time per decision.
"""

import hashlib
import os
import re
import shutil
import string
import subprocess
import tempfile
from importlib import resources

import numpy as np

from lwrl import outputs, tasks
from lwrl.agent import controller_forms
from lwrl.agent import io as agent_io
from lwrl.runners.config import as_written_now
from lwrl.runners.stepped import kind_of
from lwrl.tasks.task_definition import ACTIONS

SOURCE = "lwrl_policy.c"
"""The exported file names, fixed so that firmware does not change when the controller is
retrained; their templates are package data, `templates/<name>.in` (`string.Template`)."""
HEADER = "lwrl_policy.h"
DTYPES = {"float": np.float32, "double": np.float64}
_VALUES_PER_LINE = 6
INTERFACES = {
    "discrete": {"values": "lwrl_q_values", "outputs": "LWRL_NUM_ACTIONS", "row": "action {}"},
    "continuous": {"values": "lwrl_actor", "outputs": "1", "row": "the actor"},
}
"""Per kind of action (`Learner.actions`), what the controller templates' code names: the
function that writes the outputs (`values`: Q(s, .), or the actor's output), their count
(`outputs`) and the comment before row a of the weights (`row`, formatted with a)."""
PLAIN_MLP = {"title": "a Stable-Baselines3 network", "between": "", "output": "TANH",
             "inputs": "the state in task units, as the network was trained on it (no "
                       "normalisation)", "normalise": 0, "layer_norm": 0, "leaky_slope": "0",
             "layer_norm_eps": "0", "input_mean": "0", "input_scale": "1"}
"""The `mlp_policy` template's options at a plain network's values (Stable-Baselines3's:
`agent.dqn.mlp_form`), for the forms that leave them out: no normalisation of the state or
of the layers, tanh after a continuous actor's last layer."""
TEMPLATE_DEFAULTS = {"mlp_policy": PLAIN_MLP}
"""Per template, the values of the placeholders a form may leave out."""
SECTION = "%% "
"""A template's line `%% KIND` starts the lines kept for the kind of action KIND only,
`%% end` ends them."""


def template(name: str, actions: str = "discrete") -> string.Template:
    """The template of the exported file `name` (`lwrl_policy.c`, `lwrl_policy.h`, or a
    path below `templates/` such as `learner/lwrl_learner.c`) for a controller of the kind
    of action `actions`: its sections for the other kind left out (`SECTION`)."""
    text = resources.files(__package__).joinpath("templates", *f"{name}.in".split("/")).read_text()
    lines, kept = [], True
    for line in text.splitlines(keepends=True):
        if line.startswith(SECTION):
            section = line[len(SECTION):].strip()
            if section not in ("end", *ACTIONS):
                raise ValueError(f"templates/{name}.in: unknown section {section!r}")
            kept = section in ("end", actions)
        elif kept:
            lines.append(line)
    return string.Template("".join(lines))


def _literal(value, dtype: str) -> str:
    """A C literal that reads back as exactly `value` rounded to `dtype`."""
    if np.isinf(value):  # <math.h>'s INFINITY, a float that converts to double exactly
        return "INFINITY" if value > 0 else "-INFINITY"
    if dtype == "float":
        text = str(np.float32(value))  # shortest string that round-trips the float32
        suffix = "f"
    else:
        text = repr(float(value))
        suffix = ""
    if not re.search(r"[.eE]", text):
        text += ".0"
    return text + suffix


def _comment(text: str) -> str:
    """`text` made safe inside a C block comment."""
    return text.replace("*/", "* /").replace("\n", " ").replace("\r", " ")


def _check_dtype(dtype: str) -> str:
    """`dtype` if it is one of `DTYPES`' names, else a one-line error."""
    if dtype not in DTYPES:
        raise ValueError(f"dtype must be one of {', '.join(DTYPES)}; got {dtype!r}")
    return dtype


def _check_index(agent_index, batch: int) -> int:
    if (isinstance(agent_index, bool) or not isinstance(agent_index, (int, np.integer))
            or not 0 <= agent_index < batch):
        raise ValueError(f"agent_index must be an integer in 0..{batch - 1} (the file holds "
                         f"{batch} agent{'s' if batch != 1 else ''}); got {agent_index!r}")
    return int(agent_index)


def _task_description(metadata: dict, agents, source: str):
    """(task name, state names, task definition or None, config dict) from the file's
    metadata, the definition made with the agents' kind of action; a one-line error if
    the agents do not fit the task it names."""
    config = metadata.get("config") if isinstance(metadata, dict) else None
    config = as_written_now(config) if isinstance(config, dict) else {}
    task = config.get("task")
    names, definition = [f"state[{j}]" for j in range(agents.dim)], None
    if isinstance(task, str) and task.count(".") == 1:
        try:
            definition = tasks.definition(*task.split("."), actions=kind_of(agents)[1])
        except ValueError:
            definition = None
        if definition is not None:
            definition.check_fits(agents.dim, agents.action_space, source)
            names = list(definition.state_names)
    return (task if isinstance(task, str) else "unknown (no run configuration in the file)",
            names, definition, config)


def _action_fields(agents, definition, dtype: str) -> dict:
    """The header's `action_lines` (what an action is) and `action_macros` (the count of
    discrete actions, or the actuator's range) for `agent`'s controller on the task
    `definition` (None: unknown, which only a controller of discrete actions may be)."""
    if not agents.continuous:
        controls = None if definition is None else definition.controls
        line = ("" if controls is None else " (action i applies control " + ", ".join(
            f"{i}: {c:g}" for i, c in enumerate(controls)) + ")")
        actions = agents.action_space.n
        return {"action_lines": f" * Actions: {actions}{line}",
                "action_macros": f"#define LWRL_NUM_ACTIONS {actions}"}
    low, high = definition.control_range
    name = definition.control_name
    return {"action_lines": (
                f" * Action: a real u in [-1, 1] (lwrl_act); the actuator applies the {name}\n"
                " *   (LWRL_ACTION_LOW + LWRL_ACTION_HIGH) / 2 + u (LWRL_ACTION_HIGH - "
                "LWRL_ACTION_LOW) / 2\n"
                f" *   (lwrl.tasks.commands), in [{low:g}, {high:g}] at the task's paper values"),
            "action_macros": (
                f"#define LWRL_ACTION_LOW ({_literal(low, dtype)}) /* the actuator's range "
                f"({name}) at the task's paper values */\n"
                f"#define LWRL_ACTION_HIGH ({_literal(high, dtype)})")}



def _weights_block(rows: np.ndarray, dtype: str, row: str = "action {}") -> str:
    """The initialiser of a 2-D array (e.g. `WEIGHTS` (A, N)): one brace block per row,
    row a's headed by the comment `row` formatted with a."""
    width = len(str(rows.shape[1] - 1))
    blocks = []
    for a, values_of_row in enumerate(rows):
        lines = [f"    {{ /* {row.format(a)} */"]
        for start in range(0, len(values_of_row), _VALUES_PER_LINE):
            values = ", ".join(_literal(v, dtype)
                               for v in values_of_row[start:start + _VALUES_PER_LINE])
            lines.append(f"        /* {start:>{width}} */ {values},")
        lines.append("    },")
        blocks.append("\n".join(lines) + "\n")
    return "".join(blocks)


def _rendered(value, dtype: str, row: str = "action {}") -> str:
    """A controller value as C text (`ControllerForm.values`; `row` as `_weights_block`)."""
    if isinstance(value, np.ndarray) and value.ndim == 2:
        return _weights_block(value, dtype, row)
    if isinstance(value, np.ndarray):
        return ", ".join(_literal(v, dtype) for v in value)
    if isinstance(value, float):
        return _literal(value, dtype)
    return str(value)


def export_c(agent_path, out_dir, agent_index: int = 0, dtype: str = "float") -> dict:
    """Write agent `agent_index` of the saved agents at `agent_path` as C99 code in `out_dir`.

    `dtype`: `"float"` (default; single-precision FPUs) or `"double"`. Writes `lwrl_policy.c`
    and `lwrl_policy.h` (created or overwritten; `out_dir` is created if needed). Refuses
    (one-line ValueError) a file that is not an agent file, a learner or feature map with no
    C controller (CMAC features), a diverged agent (flagged, or non-finite weights), weights
    or constants that do not fit `dtype`, an index out of range, and agents of continuous
    actions from a file that names no task (their header states the actuator's range).
    Returns a dict: `source`, `header` (paths), `task`, `agent_index`, `dtype`,
    `state_dim`, `actions` (the discrete actions, or 1: one continuous action),
    `weight_bytes` (the weights), `constant_bytes` (the other values it stores: an NRBF's
    ranges and r^2) and `flash_bytes` (their sum; the compiled code comes on top, see
    `measure`), and the controller's own values that are sizes (an NRBF's `grid`, `neurons`).
    """
    _check_dtype(dtype)
    agent, metadata = agent_io.load(agent_path)
    b = _check_index(agent_index, agent.batch_size)
    try:
        form = controller_forms.controller(agent, b)
    except ValueError as error:
        raise ValueError(f"{agent_path}: {error}") from None
    weights = form.values["weights"]
    if agent.diverged[b] or not np.all(np.isfinite(weights)):
        raise ValueError(f"{agent_path}: agent {b} diverged (non-finite weights); "
                         f"there is no controller to export")
    numpy_type = DTYPES[dtype]
    with np.errstate(over="ignore", invalid="ignore"):
        rounded = {name: value.astype(numpy_type) if isinstance(value, np.ndarray) else value
                   for name, value in form.values.items()}
    if not np.all(np.isfinite(rounded["weights"])):
        raise ValueError(f"{agent_path}: agent {b} has weights beyond the range of {dtype} "
                         f"(largest |w| {np.abs(weights).max():.3g}); export with dtype='double'")
    reason = form.check(numpy_type)
    if reason is not None:
        raise ValueError(f"{agent_path}: {reason}")

    dim, num_actions = agent.dim, 1 if agent.continuous else agent.action_space.n
    task, names, definition, config = _task_description(metadata, agent, agent_path)
    if agent.continuous and definition is None:
        raise ValueError(f"{agent_path}: names no task, whose actuator's range a controller of "
                         "continuous actions states: save the agents with their run "
                         "configuration (lwrl train --save)")
    with open(agent_path, "rb") as file:
        sha256 = hashlib.sha256(file.read()).hexdigest()
    size = np.dtype(numpy_type).itemsize
    weight_bytes = weights.size * size
    constant_bytes = sum(np.size(form.values[name]) for name in form.stored
                         if name != "weights") * size
    run = ""
    if config:
        settings = config.get("settings") if isinstance(config.get("settings"), dict) else config
        keys = [("plant", "plant {}", config), ("trace", "{} traces", settings),
                ("alpha", "alpha {:g}", settings), ("lam", "lambda {:g}", settings),
                ("episodes", "{} episodes", config)]
        parts = [fmt.format(source[key]) for key, fmt, source in keys
                 if source.get(key) is not None]
        if isinstance(config.get("seed"), int):
            parts.append(f"seed {config['seed'] + b}")
        run = ("\n *   trained with " + _comment(", ".join(parts))) if parts else ""
    name_width = max(len(name) for name in names)
    low, high = form.ranges
    kind = kind_of(agent)[1]
    interface = INTERFACES[kind]
    fields = dict(
        {**TEMPLATE_DEFAULTS.get(form.template, {}),
         **{name: _rendered(value, dtype, interface["row"]) for name, value in rounded.items()}},
        header=HEADER, source=SOURCE, real=dtype, task=_comment(task), dim=dim,
        num_actions=num_actions, values=interface["values"], outputs=interface["outputs"],
        state_lines="\n".join(f" *   state[{j}] {_comment(name)}" for j, name in enumerate(names)),
        **_action_fields(agent, definition, dtype),
        path=_comment(os.path.abspath(os.fspath(agent_path))), sha256=sha256, index=b,
        batch=agent.batch_size, run=run,
        range_lines="\n".join(
            f" *   state[{j}] {_comment(name):<{name_width}}  [{lo:g}, {hi:g}]"
            for j, (name, lo, hi) in enumerate(zip(names, low, high))),
        weight_bytes=weight_bytes, flash_bytes=weight_bytes + constant_bytes,
        zero=_literal(0.0, dtype), one=_literal(1.0, dtype), half=_literal(0.5, dtype),
        exp="expf" if dtype == "float" else "exp", fabs="fabsf" if dtype == "float" else "fabs",
        tanh="tanhf" if dtype == "float" else "tanh", sqrt="sqrtf" if dtype == "float" else "sqrt",
    )
    paths = write_files(out_dir, {HEADER: template(f"{form.template}.h", kind).substitute(fields),
                                  SOURCE: template(f"{form.template}.c", kind).substitute(fields)})
    sizes = {name: value for name, value in form.values.items()
             if isinstance(value, int) and not isinstance(value, bool)}
    return {"source": paths[SOURCE], "header": paths[HEADER], "task": task, "agent_index": b,
            "dtype": dtype, "state_dim": dim, "actions": num_actions, **sizes,
            "weight_bytes": weight_bytes, "constant_bytes": constant_bytes,
            "flash_bytes": weight_bytes + constant_bytes}


def write_files(out_dir, texts: dict) -> dict:
    """Write `{file name: text}` into `out_dir` (created if needed), each file whole, in
    order; `{file name: path}`, or a one-line error if they cannot be written."""
    paths = {name: os.path.join(out_dir, name) for name in texts}
    try:
        os.makedirs(out_dir, exist_ok=True)
        for name, text in texts.items():
            with outputs.atomic_write(paths[name], encoding="utf-8") as file:
                file.write(text)
    except OSError as error:
        raise ValueError(f"{out_dir}: cannot write the C files ({error.strerror or error})") from None
    return paths


def find_compiler(compiler=None) -> str:
    """`compiler`, else `$CC`, else the first of cc, gcc, clang on the PATH; a ValueError
    if there is none."""
    for candidate in ([compiler] if compiler else [os.environ.get("CC"), "cc", "gcc", "clang"]):
        if candidate and shutil.which(candidate):
            return shutil.which(candidate)
    raise ValueError(f"no C compiler found ({'not found: ' + compiler if compiler else 'tried $CC, cc, gcc, clang'})")


def compile_in(command, cwd) -> None:
    """Run the compiler `command` (the compiler, then its arguments) in `cwd`; a one-line
    ValueError with its first words of complaint if it fails."""
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True)
    if result.returncode != 0:
        raise ValueError(f"{os.path.basename(command[0])} failed: "
                         + " ".join(result.stderr.strip().splitlines()[:2]))


def section_sizes(object_path) -> dict:
    """Bytes per section of an object file (`size -A`, else `objdump -h`)."""
    if shutil.which("size"):
        output = subprocess.run(["size", "-A", object_path], capture_output=True, text=True,
                                check=True).stdout
        pattern = re.compile(r"^(\.\S+)\s+(\d+)\s+\d+\s*$", re.M)
        return {name: int(value) for name, value in pattern.findall(output)}
    if shutil.which("objdump"):
        output = subprocess.run(["objdump", "-h", object_path], capture_output=True, text=True,
                                check=True).stdout
        pattern = re.compile(r"^\s*\d+\s+(\.\S+)\s+([0-9a-fA-F]+)\s", re.M)
        return {name: int(value, 16) for name, value in pattern.findall(output)}
    raise ValueError("neither size nor objdump is installed: cannot read section sizes")


_BENCH = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "lwrl_policy.h"

#define TABLE 4096 /* random states, within the ranges widened by a quarter on each side */

static lwrl_real states[TABLE][LWRL_STATE_DIM];

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double run(long count, double *checksum)
{
    long i;
    double start = now();
    for (i = 0; i < count; i++) /* an action index, or a continuous action */
        *checksum += (double)lwrl_act(states[i & (TABLE - 1)]);
    return now() - start;
}

int main(int argc, char **argv)
{
    const double low[LWRL_STATE_DIM] = {LWRL_LOW}, high[LWRL_STATE_DIM] = {LWRL_HIGH};
    double seconds = argc > 1 ? atof(argv[1]) : 0.2, best;
    unsigned long long x = 88172645463325252ULL;
    double checksum = 0.0;
    long count = 1024;
    int i, j;
    for (i = 0; i < TABLE; i++)
        for (j = 0; j < LWRL_STATE_DIM; j++) {
            double u;
            x ^= x << 13; x ^= x >> 7; x ^= x << 17;
            u = (double)(x >> 11) / 9007199254740992.0;
            states[i][j] = (lwrl_real)(low[j] + (high[j] - low[j]) * (1.5 * u - 0.25));
        }
    while (run(count, &checksum) < seconds / 4 && count < 1000000000L)
        count *= 2;
    best = run(count, &checksum);
    for (i = 0; i < 2; i++) {
        double t = run(count, &checksum);
        if (t < best)
            best = t;
    }
    printf("%.3f %ld %g\n", 1e9 * best / (double)count, count, checksum);
    return 0;
}
"""


def measure(out_dir, compiler=None, seconds: float = 0.2) -> dict:
    """Compile the C files `export_c` wrote in `out_dir`; return their flash and speed.

    `code_bytes`: `.text` of `cc -Os -std=c99 -c lwrl_policy.c` (the machine code of the host
    compiler's target); `rodata_bytes`: its read-only data (weights, ranges, float
    constants); `ns_per_decision`: one `lwrl_act` call, built with `-O2 -std=c99` and run
    on random states in and around the ranges (best of three runs of about `seconds / 4`
    each after calibration; a measurement, machine-dependent). Also `compiler` (its path
    and first `--version` line) and `decisions` (calls per timed run). Builds in a
    temporary directory; `out_dir` is not changed.
    """
    compiler = find_compiler(compiler)
    source = os.path.abspath(os.path.join(out_dir, SOURCE))
    if not (os.path.isfile(source) and os.path.isfile(os.path.join(out_dir, HEADER))):
        raise ValueError(f"{out_dir}: no {SOURCE} and {HEADER} (run export_c first)")
    version = subprocess.run([compiler, "--version"], capture_output=True, text=True).stdout
    with tempfile.TemporaryDirectory() as build:
        include = ["-I", os.path.abspath(out_dir)]
        compile_in([compiler, "-Os", "-std=c99", *include, "-c", source, "-o", "policy.o"], build)
        sections = section_sizes(os.path.join(build, "policy.o"))
        with open(os.path.join(build, "bench.c"), "w") as file:
            file.write(_BENCH)
        compile_in([compiler, "-O2", "-std=c99", *include, "bench.c", source, "-o", "bench",
                    "-lm"], build)
        output = subprocess.run([os.path.join(build, "bench"), repr(float(seconds))],
                                capture_output=True, text=True, check=True).stdout.split()
    return {"compiler": f"{compiler} ({version.splitlines()[0] if version else 'unknown version'})",
            "code_bytes": sum(v for k, v in sections.items() if k.startswith(".text")),
            "rodata_bytes": sum(v for k, v in sections.items() if k.startswith(".rodata")),
            "ns_per_decision": float(output[0]), "decisions": int(output[1])}
