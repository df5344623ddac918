"""Learning on an emulated microcontroller: the C learner on a Cortex-M4 under QEMU.

`run_device(task)` writes a device program (the C learner of `export.learner`, a new agent
for the task with its settings, the task's plant in C (`export.c_plants`), and a loop over
episodes that prints each one's steps), builds it twice from the same sources:

- for the host, with the system C compiler and its C library (`io_host.c`: stdout);
- for a bare-metal Cortex-M4 with Debian's `gcc-arm-none-eabi` and newlib's libm
  (`libnewlib-arm-none-eabi`), hardware single-precision FPU, no C library start-up:
  `io_semihosting.c` holds the vector table, the reset handler and ARM semihosting output;
  `m4.ld` lays it out in the memory of QEMU's `mps2-an386` board (Cortex-M4),

runs the host build, and the device build under `qemu-system-arm -M mps2-an386` with
semihosting, and compares their steps per episode and final weights. Both builds draw the
episodes' starts from a SplitMix64 stream of their own (`agent.streams.SPLITMIX64`, its
state at the agent's seed + 2^63) computed in 64-bit integers, so the same code gives the
same starts on both; the plant runs in double on both (software double on the M4, which
has no double FPU).

The builds differ in one thing the code does not control: the C library's `exp` (`expf`)
and `cos`. glibc's and newlib's differ in the last bit for some arguments (`libm_agreement`
counts how often), so the two runs' weights may differ by some units in the last place;
the steps are equal as long as no action choice sits on such a difference.

`policy_costs(path)` measures an exported greedy controller (`export.c`) the same way: its
object's bytes, its stack, and instructions per decision (`lwrl_act`) on both machines;
`new_policy_costs(task, learner=...)` those of an agent of a learner without a C learner
(today's rivals) after some learning, with the learner's counted arithmetic and memory
beside them.

`costs(task)` measures what the learner costs: the learner object's bytes (flash: code and
constants; RAM: static data, with `arm-none-eabi-size`; stack with `-fstack-usage`), and
instructions per learning step (`lwrl_learn`) and per decision (`lwrl_greedy`) on a table
of observations drawn in the ranges: on the host with `valgrind --tool=callgrind`, on the
emulated M4 with a QEMU TCG plugin that counts executed instructions (`insn_count.c`,
built here). Each count is the difference of two runs of 200 and 1200 calls divided by
1000, so the program's set-up cancels and the bench loop's few instructions per call stay
in. Instructions are not cycles: a time at a clock rate is an estimate (`estimate_us`).
"""

import dataclasses
import os
import string
import re
import shutil
import subprocess
import tempfile
from importlib import resources

import numpy as np

from lwrl import tasks
from lwrl import agent as learners
from lwrl.agent import io as agent_io
from lwrl.agent.streams import SPLITMIX64
from lwrl.export import learner
from lwrl.export.c import (DTYPES, SOURCE, _literal, compile_in, export_c, find_compiler,
                           template)
from lwrl.export.c_plants import C_PLANTS
from lwrl.runners.config import RunConfig
from lwrl.runners.run import run

CROSS = {"arm-none-eabi-gcc": "gcc-arm-none-eabi", "arm-none-eabi-size": "binutils-arm-none-eabi",
         "qemu-system-arm": "qemu-system-arm"}
"""The cross tools and the Debian package of each."""
NEWLIB = "/usr/lib/arm-none-eabi/newlib"
"""Where libnewlib-arm-none-eabi installs newlib."""
BOARD = "mps2-an386"
M4_FLAGS = ["-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16"]
COMMON_FLAGS = ["-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra"]
"""Both builds: C99 at -O2, no fused multiply-adds (lwrl's Python learner has none)."""
M4_LINK = ["-nostartfiles", "-T", "m4.ld", "--specs=nano.specs", "--specs=nosys.specs"]
DEVICE_FILES = ("device_io.h", "io_common.c", "io_host.c", "io_semihosting.c", "m4.ld",
                "insn_count.c")
BENCH_CALLS = (200, 1200)
"""Calls of the two bench runs whose difference gives the cost of one call."""
TABLE = 64
"""Observations in the bench's table."""
QEMU_TIMEOUT = 600
SOURCES = ["program.c", "lwrl_learner.c", "io_common.c"]
"""A device program's own sources; the host adds io_host.c, the M4 io_semihosting.c."""
POLICY_SOURCES = ["program.c", SOURCE, "io_common.c"]
"""The sources of the bench of an exported greedy controller (`policy_costs`)."""


def device_file(name: str) -> str:
    """The text of a fixed file of `templates/device/`."""
    return resources.files(__package__).joinpath("templates", "device", name).read_text()


def missing_tools(needed=tuple(CROSS)) -> list:
    """'tool (Debian package)' for each needed cross tool not found, and newlib's libm."""
    missing = [f"{tool} (Debian package {CROSS[tool]})" for tool in needed if not shutil.which(tool)]
    if "arm-none-eabi-gcc" in needed and not os.path.isdir(NEWLIB):
        missing.append("newlib (Debian package libnewlib-arm-none-eabi)")
    return missing


def check_tools(needed=tuple(CROSS)) -> None:
    missing = missing_tools(needed)
    if missing:
        raise ValueError(f"missing {', '.join(missing)}: apt-get install "
                         + " ".join(sorted({m.split('package ')[1].rstrip(')') for m in missing})))


def plant_header(task: str, **options) -> str:
    """`lwrl_plant.h` for `task` (DOMAIN.TASK) with its `options` (`params`, ...): the
    domain's plant in C (`export.c_plants`) with the task's parameter values and the
    domain's constants, its controls and step limit, in the template
    `templates/device/plant.h.in`; a one-line error for a domain without one."""
    domain_name, task_name = tasks.split_name(task)
    domain = tasks.domain(domain_name)
    plant = C_PLANTS.of(domain_name)
    definition = tasks.definition(domain_name, task_name, **options)
    parameters = dict(zip((p.name for p in domain.parameters.items), definition.physical))
    values = {name: _literal(float(value), "double")
              for name, value in {**plant.constants, **parameters}.items()}
    return template("device/plant.h").substitute(
        domain=domain_name, task=task, dim=len(definition.state_names),
        parameter_text=", ".join(f"{name} {value:g}" for name, value in parameters.items()),
        step_limit=int(definition.step_limit),
        controls=", ".join(_literal(float(c), "double") for c in definition.controls),
        start=string.Template(plant.start).substitute(values),
        step=string.Template(plant.step).substitute(values))


def write_program(build, source, dtype, program: str, **fields) -> dict:
    """Write into `build` the C learner of `source` (`export.learner.LearnerSource`) in
    `dtype`, the fixed device files and `program.c` from `templates/device/<program>.in`
    with `fields` (and SplitMix64); what `write_learner` returns."""
    written = learner.write_learner(source, build, dtype)
    write_fixed_files(build)
    with open(os.path.join(build, "program.c"), "w") as file:
        file.write(template(f"device/{program}").substitute(
            fields, splitmix=learner.splitmix_c(SPLITMIX64)))
    return written


def write_fixed_files(build) -> None:
    """The device files every program uses (`DEVICE_FILES`), into `build`."""
    for name in DEVICE_FILES:
        with open(os.path.join(build, name), "w") as file:
            file.write(device_file(name))


def build_host(build, output="host", compiler=None, defines=(), sources=SOURCES) -> str:
    """The program of `sources` in `build` for this machine; the executable's path."""
    compile_in([find_compiler(compiler), *COMMON_FLAGS, *defines, *sources, "io_host.c", "-o",
                output, "-lm"], build)
    return os.path.join(build, output)


def build_m4(build, output="device.elf", defines=(), sources=SOURCES) -> str:
    """The program of `sources` in `build` for the bare-metal Cortex-M4; the ELF's path."""
    check_tools(("arm-none-eabi-gcc",))
    compile_in(["arm-none-eabi-gcc", *M4_FLAGS, *COMMON_FLAGS, *defines, *sources, "io_semihosting.c",
              *M4_LINK, "-o", output, "-lm"], build)
    return os.path.join(build, output)


def qemu(elf, plugin=None) -> tuple:
    """Run `elf` on the emulated board; (its semihosting output, instructions or None)."""
    check_tools(("qemu-system-arm",))
    with tempfile.TemporaryDirectory() as scratch:
        log = os.path.join(scratch, "plugin.log")
        command = ["qemu-system-arm", "-M", BOARD, "-display", "none", "-monitor", "none",
                   "-serial", "none", "-semihosting-config", "enable=on,target=native",
                   "-kernel", elf]
        if plugin:
            command += ["-plugin", plugin, "-d", "plugin", "-D", log]
        result = subprocess.run(command, capture_output=True, text=True, timeout=QEMU_TIMEOUT)
        if result.returncode != 0:
            raise ValueError(f"qemu-system-arm -M {BOARD} {os.path.basename(elf)} ended with "
                             f"status {result.returncode}: {result.stderr.strip()[-200:]}")
        instructions = read_instructions(log) if plugin else None
    return result.stderr, instructions  # semihosting writes to QEMU's standard error


def read_instructions(log) -> int:
    """The instruction count the plugin (`insn_count.c`) wrote to QEMU's log `log`."""
    with open(log) as file:
        return int(re.search(r"instructions (\d+)", file.read()).group(1))


def parse_run(text: str, dtype: str) -> dict:
    """Steps per episode, total, divergence and weights (as numbers) of a run's output."""
    steps = [int(s) for s in re.findall(r"^episode \d+ steps (\d+)$", text, re.M)]
    words = [int(w, 16) for w in re.findall(r"^w ([0-9a-f]{16})$", text, re.M)]
    kind = np.uint32 if dtype == "float" else np.uint64
    weights = np.array(words, dtype=np.uint64).astype(kind).view(DTYPES[dtype])
    return {"steps": steps, "diverged": "diverged 1" in text, "weights": weights}


def ulps(a: np.ndarray, b: np.ndarray) -> int:
    """The largest distance in units in the last place between same-signed weights, as the
    distance between their bit patterns (0 if equal)."""
    if a.shape != b.shape:
        return -1
    ints = np.int64 if a.dtype == np.float64 else np.int32
    return int(np.abs(a.view(ints).astype(np.int64) - b.view(ints).astype(np.int64)).max(initial=0))


def run_device(task: str, episodes: int = 40, seed: int = 0, dtype: str = "float", build=None,
               **settings) -> dict:
    """A new agent for the task (`export.learner.from_task` with `seed` and `settings`)
    learns on the emulated Cortex-M4 and in the host build of the same code for `episodes`
    episodes. Returns `summary` (the learner's), `ram` (its computed RAM), `host` and
    `device` (steps per episode, weights), `equal_steps`, `weight_ulps` (largest
    difference of the final weights in units in the last place), `sizes` (the firmware's
    text, data and bss) and `instructions` (the emulated run's, from start to exit)."""
    source = learner.from_task(task, seed=seed, **settings)
    plant = plant_header(task)
    check_tools()
    with tempfile.TemporaryDirectory() as scratch:
        build = build or scratch
        os.makedirs(build, exist_ok=True)
        written = write_program(build, source, dtype, "run.c", episodes=episodes, seed=seed)
        with open(os.path.join(build, "lwrl_plant.h"), "w") as file:
            file.write(plant)
        host_text = subprocess.run([build_host(build)], capture_output=True, text=True,
                                   check=True).stdout
        elf = build_m4(build)
        device_text, instructions = qemu(elf, plugin=build_plugin(build))
        sizes = size_of(elf)
    host, device = parse_run(host_text, dtype), parse_run(device_text, dtype)
    if len(device["steps"]) != episodes:
        raise ValueError(f"the emulated run printed {len(device['steps'])} of {episodes} episodes")
    return {"task": task, "dtype": dtype, "seed": seed, "episodes": episodes,
            "summary": written["summary"], "ram": written["ram"], "host": host, "device": device,
            "equal_steps": host["steps"] == device["steps"],
            "weight_ulps": ulps(host["weights"], device["weights"]), "sizes": sizes,
            "instructions": instructions}


def build_plugin(build) -> str:
    """The instruction-counting QEMU plugin, built with the host compiler into `build`."""
    compiler = find_compiler()
    source = os.path.join(build, "insn_count.c")
    if not os.path.exists(source):
        with open(source, "w") as file:
            file.write(device_file("insn_count.c"))
    compile_in([compiler, "-O2", "-shared", "-fPIC", "insn_count.c", "-o", "insn_count.so"], build)
    return os.path.join(build, "insn_count.so")


def size_of(path) -> dict:
    """`text`, `data`, `bss` of an ARM object or ELF (arm-none-eabi-size, Berkeley format:
    text holds code and read-only data)."""
    check_tools(("arm-none-eabi-size",))
    output = subprocess.run(["arm-none-eabi-size", path], capture_output=True, text=True,
                            check=True).stdout.splitlines()[1].split()
    return {"text": int(output[0]), "data": int(output[1]), "bss": int(output[2])}


def callgrind_instructions(executable) -> int:
    """Instructions the whole program executes under `valgrind --tool=callgrind`."""
    if not shutil.which("valgrind"):
        raise ValueError("missing valgrind (Debian package valgrind): apt-get install valgrind")
    with tempfile.TemporaryDirectory() as scratch:
        out = os.path.join(scratch, "callgrind.out")
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", executable],
                       capture_output=True, text=True, check=True)
        with open(out) as file:
            return int(re.search(r"^(?:summary|totals): (\d+)", file.read(), re.M).group(1))


def costs(task: str, dtype: str = "float", **settings) -> dict:
    """What a new agent for the task costs (`export.learner.from_task` with `settings`, its
    defaults for the others): `summary` (the learner's), `ram` (computed),
    `object` (the learner object for the M4 at -O2: `text` code and constants, `data`,
    `bss`), `firmware` (the whole learning bench for the M4: the learner with libm's expf,
    the start-up and the semihosting output), `stack` (an upper bound of lwrl_learn's stack
    within the learner, -fstack-usage),
    and instructions per `learn` step and per `decide` (greedy decision) on the `host`
    (callgrind) and on the emulated `m4` (the QEMU plugin); and what `learner_counts` gives."""
    source = learner.from_task(task, **settings)
    check_tools()
    result = {"task": task, "dtype": dtype, **learner_counts(task, **settings)}
    with tempfile.TemporaryDirectory() as build:
        written = write_program(build, source, dtype, "bench.c", steps="STEPS_FROM_BUILD",
                                table=TABLE, decisions="DECISIONS_FROM_BUILD")
        result.update(summary=written["summary"], ram=written["ram"])
        compile_in(["arm-none-eabi-gcc", *M4_FLAGS, *COMMON_FLAGS, "-fstack-usage", "-c",
                  "lwrl_learner.c", "-o", "lwrl_learner.o"], build)
        result["object"] = size_of(os.path.join(build, "lwrl_learner.o"))
        result["stack"] = stack_bytes(os.path.join(build, "lwrl_learner.su"))
        plugin = build_plugin(build)
        for kind, decisions in (("learn", 0), ("decide", 1)):
            counts, elf, texts = per_call(build, kind, [f"-DDECISIONS_FROM_BUILD={decisions}"],
                                          SOURCES, plugin)
            if kind == "learn":
                result["firmware"] = size_of(elf)
            if any("diverged 0" not in text for text in texts):
                raise ValueError(f"the {task} bench diverged: its count would not be a learning step's")
            result.update({f"{machine}_{kind}": count for machine, count in counts.items()})
    return result


def per_call(build, name: str, defines, sources, plugin) -> tuple:
    """Instructions per call of a bench program in `build` (`STEPS_FROM_BUILD` calls, with
    the other `defines`): `({"host": callgrind's, "m4": the QEMU plugin's}, the last M4
    build's ELF, each M4 run's output)`, each count the difference of the runs of
    `BENCH_CALLS` calls divided by the calls between them, so that the set-up cancels."""
    counts, texts = {"host": [], "m4": []}, []
    for calls in BENCH_CALLS:
        flags = [f"-DSTEPS_FROM_BUILD={calls}", *defines]
        output = f"{name}{calls}"
        counts["host"].append(callgrind_instructions(build_host(build, output, defines=flags,
                                                                sources=sources)))
        elf = build_m4(build, f"{output}.elf", defines=flags, sources=sources)
        text, instructions = qemu(elf, plugin)
        texts.append(text)
        counts["m4"].append(instructions)
    span = BENCH_CALLS[1] - BENCH_CALLS[0]
    return {machine: (high - low) / span for machine, (low, high) in counts.items()}, elf, texts


def learns_in_c(task: str, **settings) -> bool:
    """Whether a new agent for `task` with `settings` (`export.learner.from_task`) has a C
    learner (`Agents.learner_form`); bad settings are a one-line error of their own."""
    source = learner.from_task(task, **settings)
    try:
        source.form
    except ValueError:
        return False
    return True


def new_policy_costs(task: str, dtype: str = "float", train: int = 200_000, **settings) -> dict:
    """`policy_costs` of a new agent for `task` (a `RunConfig`'s `settings`: `learner`, its
    settings, `actions`; seed 0) after `train` environment steps of learning on the analytic
    plant: a controller's cost is set by its shapes, but a new agent's normalisation holds
    the mean 0 and the scale 1, which the compiler folds away (x - 0 = x, x / 1 = x), so the
    agent learns first. Adds `learner_counts`' and `trained` (the steps it learned)."""
    config = RunConfig(task=task, agents=1, seed=0, plant="analytic", budget=train,
                       episodes=train, **settings)
    agents, _ = run(config)
    with tempfile.TemporaryDirectory() as scratch:
        path = os.path.join(scratch, "agent.npz")
        agent_io.save(path, agents, {"config": dataclasses.asdict(config)})
        result = policy_costs(path, 0, dtype)
    return {**result, **learner_counts(task, **settings), "trained": train}


def learner_counts(task: str, **settings) -> dict:
    """What a new agent's learner says of itself for `task` (a `RunConfig`'s `settings`):
    `learner` (its `Learner`), `counts` (its counted arithmetic, `Learner.arithmetic`) and
    `memory` (the bytes one agent needs, `Learner.memory`)."""
    config = RunConfig(task=task, agents=1, seed=0, **settings)
    spec = learners.learner(config.learner)
    return {"learner": spec, "counts": spec.arithmetic(config.settings, config.task_spec),
            "memory": spec.memory(config.settings, config.task_spec)}


def policy_costs(agent_path, agent_index: int = 0, dtype: str = "float") -> dict:
    """What agent `agent_index` of a saved file costs as its greedy controller
    (`export.c.export_c`): `written` (the export's report: weights and constants in bytes),
    `object` (`lwrl_policy.o` for the M4 at -O2: `text` its code and `const` weights and
    constants, `data`, `bss`: no static RAM), `stack` (the frames of every function of the
    controller added up, -fstack-usage, an upper bound: a frozen controller's only RAM),
    `firmware` (the whole bench for the M4, libm and start-up with it) and instructions
    per decision (`lwrl_act`) on the `host` (callgrind) and the emulated `m4` (the QEMU
    plugin), on a table of `TABLE` observations drawn in the task's ranges."""
    check_tools()
    with tempfile.TemporaryDirectory() as build:
        written = export_c(agent_path, build, agent_index=agent_index, dtype=dtype)
        write_fixed_files(build)
        with open(os.path.join(build, "program.c"), "w") as file:
            file.write(template("device/policy_bench.c").substitute(
                steps="STEPS_FROM_BUILD", table=TABLE, splitmix=learner.splitmix_c(SPLITMIX64)))
        compile_in(["arm-none-eabi-gcc", *M4_FLAGS, *COMMON_FLAGS, "-fstack-usage", "-c",
                    SOURCE, "-o", "lwrl_policy.o"], build)
        result = {"written": written, "object": size_of(os.path.join(build, "lwrl_policy.o")),
                  "stack": sum(frames(os.path.join(build, "lwrl_policy.su")).values())}
        counts, elf, _ = per_call(build, "decide", [], POLICY_SOURCES, build_plugin(build))
        result.update(firmware=size_of(elf), host_decide=counts["host"], m4_decide=counts["m4"])
    return result


def stack_bytes(su_path) -> int:
    """Bytes of stack a learning step can take at most: the frames (-fstack-usage) of
    lwrl_learn and of every function of the learner object outside its interface (those
    it may have below it), added up (an upper bound: they are not all on the stack at
    once; libm's exp comes on top)."""
    return sum(size for name, size in frames(su_path).items()
               if name == "lwrl_learn" or name not in learner.INTERFACE)


def frames(su_path) -> dict:
    """`{function: bytes of its stack frame}` of an object's -fstack-usage file."""
    sizes = {}
    with open(su_path) as file:
        for line in file:
            where, size = line.split("\t")[:2]
            sizes[where.rsplit(":", 1)[-1]] = int(size)
    return sizes


def estimate_us(instructions: float, megahertz: float, cycles_per_instruction: float = 1.0) -> float:
    """An estimate, not a measurement: microseconds at `megahertz` if each instruction took
    `cycles_per_instruction` cycles (a Cortex-M4 retires at most one per cycle; loads,
    divisions and flash wait states take more)."""
    return instructions * cycles_per_instruction / megahertz


def libm_agreement(count: int = 20000) -> dict:
    """How often newlib's (emulated M4) and this host's libm differ, in the last bit or more,
    on `exp`, `expf` and `cos` over the arguments the learner and plant meet (exponents in
    [-60, 0), angles 3x for x in [-1.2, 0.5]): a count per function of `count` draws."""
    check_tools()
    with tempfile.TemporaryDirectory() as build:
        write_fixed_files(build)
        with open(os.path.join(build, "program.c"), "w") as file:
            file.write(template("device/libm.c").substitute(
                count=count, splitmix=learner.splitmix_c(SPLITMIX64)))
        sources = ["program.c", "io_common.c"]
        compile_in([find_compiler(), *COMMON_FLAGS, *sources, "io_host.c", "-o", "host", "-lm"], build)
        compile_in(["arm-none-eabi-gcc", *M4_FLAGS, *COMMON_FLAGS, *sources, "io_semihosting.c",
                  *M4_LINK, "-o", "device.elf", "-lm"], build)
        host_text = subprocess.run([os.path.join(build, "host")], capture_output=True,
                                   text=True, check=True).stdout
        device_text, _ = qemu(os.path.join(build, "device.elf"))
    host = np.array(host_text.split()).reshape(-1, 3)
    device = np.array(device_text.split()).reshape(-1, 3)
    differ = np.sum(host != device, axis=0)
    return {"count": count, "exp": int(differ[0]), "expf": int(differ[1]), "cos": int(differ[2])}
