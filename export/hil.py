"""Hardware in the loop: the host steps a task's plant, the learner on the device acts, the
two talking over the device link (`export.frames`, `export.link`).

The device program (`link_main.c`, package data under `templates/link/`) is the C learner
(`export.learner`, from `lwrl learner`) behind the link's C side: for each observation
frame it calls `lwrl_begin` (a frame flagged START) or `lwrl_learn` with the frame's reward
and TERMINAL flag, and answers with the action of the frame's step; a frame of the step it
answered last (a duplicate) gets that answer again and teaches it nothing twice. A hello
gets its identity (`identity`: the task, the learner's dimensions, arithmetic and build,
`link_identity.h` written beside it), and a hello for another program leaves it acting on
nothing until one for it comes.
`build_host_program` builds it for this machine, whose standard input and output are its
link (`export.link.PipePort`); `build_emulated_program` for the bare-metal Cortex-M4 of
`export.device`, its link UART0 of QEMU's mps2-an386, which QEMU puts on its own standard
input and output: the same pipes reach the emulated board.

`run_session` is the host's side: a handshake first (`export.link.HostLink.handshake`: the
device's identity must be the one the host expects of the program it would build for the
task, seed and arithmetic, or the session is refused in one line naming both), then lwrl's
stepped loop (`runners.stepped.run_batched`) on the task's plant, the device in it as the
agent (`DeviceAgent`): every observation sent, the episode's first flagged START, a
terminal one TERMINAL, the last of an episode cut by its time limit TRUNCATED; the device
answers each, and the episode goes on with its action. A missed deadline holds the
previous action, as an actuator would, and is counted; the link's watchdog ends the
session when the device has sent no valid frame for its window and as many deadlines in a
row have passed (`export.link.LinkLost`, a `runners.stepped.CutShort`): the episodes that
finished are kept, the one under way left out. At each episode's end the host fetches the
device's weights by frames. The episodes are what every run records (`EpisodeResults`:
steps, return, up-time, truncated, diverged; recordings of the episodes asked for), and
the weights load in `lwrl eval` as a saved agent's."""

import os
import string
import subprocess
import time
import types
from importlib import resources

import numpy as np

from lwrl import tasks
from lwrl.agent.learner_contract import NoValues
from lwrl.export import frames, learner
from lwrl.export.c import compile_in, find_compiler
from lwrl.export.device import (BOARD, COMMON_FLAGS, M4_FLAGS, M4_LINK, build_plugin,
                                check_tools, read_instructions, write_fixed_files)
from lwrl.export.frames import CONTINUOUS, DISCRETE, Identity, Observation
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents
from lwrl.runners.stepped import run_batched
from lwrl.tasks.batched import BatchedEnv

PROGRAM = ("link_io.h", "link_main.c")
"""The device program's files beside the C learner's and the link's (`templates/link/`)."""
IO = {"host": "link_io_host.c", "emulated": "link_io_uart.c"}
"""Where each build's bytes go: standard input and output, or the emulated board's UART."""


IDENTITY_HEADER = string.Template("""\
/* The device program's identity at the handshake (lwrl.export.hil.write_program):
 * $described. */
#ifndef LWRL_LINK_IDENTITY_H
#define LWRL_LINK_IDENTITY_H

#include <stdint.h>

#define LWRL_LINK_TASK "$task"
#define LWRL_LINK_BUILD UINT64_C(0x$build) /* the learner's build: its C source's digest */

#endif /* LWRL_LINK_IDENTITY_H */
""")
"""`link_identity.h`: what `link_main.c` says of itself beside the learner's own macros."""


def write_program(task: str, build, seed: int, dtype: str, target: str, **settings) -> Identity:
    """The device program's sources for `target` (`IO`) in `build`: the C learner of a new
    agent of `task` seeded with `seed` (`settings`: a `RunConfig`'s) in `dtype`, the link's
    C side, the program, its identity (`IDENTITY_HEADER`) and its I/O; the identity."""
    source = learner.from_task(task, seed=seed, **settings)
    program = identity_of(source, learner.write_learner(source, build, dtype))
    program.payload()  # a task's name an identity cannot carry: one line
    frames.write_c(build)
    for name in (*PROGRAM, IO[target]):
        with open(os.path.join(build, name), "w") as file:
            file.write(resources.files(__package__).joinpath("templates", "link", name).read_text())
    with open(os.path.join(build, "link_identity.h"), "w") as file:
        file.write(IDENTITY_HEADER.substitute(described=program.describe(), task=program.task,
                                              build=f"{program.build:016X}"))
    return program


def identity_of(source, written: dict) -> Identity:
    """The identity of the device program around the C learner of `source` (a
    `learner.LearnerSource`), as `learner.render_learner` or `write_learner` gave it
    (`written`)."""
    agents = source.agents
    return Identity(source.task, len(source.state_names),
                    CONTINUOUS if agents.continuous else DISCRETE,
                    1 if agents.continuous else agents.action_space.n, written["dtype"],
                    written["build"])


def identity(task: str, seed: int = 0, dtype: str = "double", **settings) -> Identity:
    """The identity the device program `write_program` writes for `task`, `seed`, `dtype`
    and `settings` says at the handshake: what the host expects of it."""
    source = learner.from_task(task, seed=seed, **settings)
    return identity_of(source, learner.render_learner(source, dtype)[1])


SOURCES = ("lwrl_learner.c", "lwrl_link.c", "link_main.c")


def build_host_program(task: str, build, seed: int = 0, dtype: str = "double",
                       compiler=None, **settings) -> list:
    """The device program for a new agent of `task` (`write_program`) built in `build` for
    this machine; the command that runs it (its standard input and output are the link)."""
    write_program(task, build, seed, dtype, "host", **settings)
    output = os.path.join(build, "link")
    compile_in([find_compiler(compiler), *COMMON_FLAGS, *SOURCES, IO["host"], "-o", output, "-lm"],
             build)
    return [output]


WAIT = "lwrl_link_getc"
"""The function in which the device waits for the link's next byte (`link_io_uart.c`)."""
PLUGIN_LOG = "plugin.log"


def build_emulated_program(task: str, build, seed: int = 0, dtype: str = "float",
                           count: bool = False, **settings) -> list:
    """The same program built for the bare-metal Cortex-M4 (`export.device`'s flags and
    start-up), its bytes on UART0; the command that runs it on QEMU's mps2-an386 with that
    UART on QEMU's standard input and output. `count`: with the instruction-counting plugin
    (`export.device.build_plugin`), which leaves out the polling loop of `WAIT`, so that
    the count is the program's work; QEMU writes it to `PLUGIN_LOG` in `build` as it ends
    (on SIGTERM too: `counted_instructions`)."""
    check_tools()
    write_program(task, build, seed, dtype, "emulated", **settings)
    write_fixed_files(build)
    elf = os.path.join(build, "link.elf")
    compile_in(["arm-none-eabi-gcc", *M4_FLAGS, *COMMON_FLAGS, *SOURCES, IO["emulated"],
                "io_semihosting.c", "io_common.c", *M4_LINK, "-o", elf, "-lm"], build)
    command = ["qemu-system-arm", "-M", BOARD, "-display", "none", "-monitor", "none",
               "-serial", "stdio", "-semihosting-config", "enable=on,target=native",
               "-kernel", elf]
    if count:
        start, end = symbol_range(elf, WAIT)
        command += ["-plugin", f"{build_plugin(build)},skip={start:#x}:{end:#x}", "-d", "plugin",
                    "-D", os.path.join(build, PLUGIN_LOG)]
    return command


def symbol_range(elf, name: str) -> tuple:
    """`(start, end)` addresses of the function `name` in `elf` (arm-none-eabi-nm)."""
    listing = subprocess.run(["arm-none-eabi-nm", "-S", elf], capture_output=True, text=True,
                             check=True).stdout
    for line in listing.splitlines():
        fields = line.split()
        if len(fields) == 4 and fields[3] == name:
            start = int(fields[0], 16) & ~1  # a Thumb function's address without its bit 0
            return start, start + int(fields[1], 16)
    raise ValueError(f"{name} is not in {os.path.basename(elf)}")


def counted_instructions(process, build) -> int:
    """End the emulated board `process` of a program built with `count` (SIGTERM: QEMU shuts
    down and the plugin writes its count); the instructions it executed, its waits for
    bytes left out."""
    process.terminate()
    process.wait()
    return read_instructions(os.path.join(build, PLUGIN_LOG))


class DeviceAgent:
    """The learner on the device as the stepped loop's agent, a batch of one
    (`runners.stepped.run_batched`'s interface): each `step` sends the time step's
    observation frame over `link` (an `export.link.HostLink`) and returns the device's
    answer. `twin`: a one-agent `Agents` of the learner the device runs, made from the same
    settings, whose shapes and value functions read the device's weights (`arrays.weights`,
    fetched by frames at each episode's end, with the diverged flag); Q and the TD error
    stay on the device: these agents keep no action values (`latest_values` says so) and
    no TD error (NaN). `env`: the batched environment stepped, which says when
    an episode is cut by its time limit (the TRUNCATED flag). `period`: with a number of
    seconds, real time: observations go out one `period` apart, and an answer that has not
    come by the next one is a missed deadline (`missed`), the previous action held, as an
    actuator would hold it; `overruns` counts the periods the host itself could not keep."""

    batch_size = 1

    def __init__(self, link, twin, env, period: float | None = None):
        self.link, self.twin, self.env, self.period = link, twin, env, period
        self.learner, self.continuous = twin.learner, twin.continuous
        self.action_space = twin.action_space
        self.arrays = types.SimpleNamespace(
            delta=np.full(1, np.nan),
            diverged=np.zeros(1, dtype=bool), weights=twin.arrays.weights.copy())
        self.frame_step, self.held, self.overruns = 0, 0, 0
        self.action = np.zeros(1, dtype=np.float64 if self.continuous else np.int64)
        self._tick = None

    @property
    def diverged(self) -> np.ndarray:
        return self.arrays.diverged

    def latest_values(self):
        """A `NoValues` error (`Agents.latest_values`): see the class."""
        raise NoValues("the learner on the device keeps its action values there: the link "
                       "carries actions, not values")

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=False) -> np.ndarray:
        """One exchange with the device (see the class)."""
        if not learn or greedy:
            raise ValueError("the learner on the device learns as it acts; it has no greedy "
                             "or frozen mode over the link")
        if active is not None and not np.asarray(active)[0]:
            return np.zeros_like(self.action)
        first, discount = bool(np.asarray(first)[0]), float(np.asarray(discount)[0])
        terminal = not first and discount == 0.0
        truncated = (not first and not terminal
                     and self.env.steps[0] >= self.env.definition.step_limit)
        self.frame_step += 1
        message = Observation(self.frame_step, tuple(map(float, np.asarray(observation)[0])),
                              0.0 if first else float(np.asarray(reward)[0]), start=first,
                              terminal=terminal, truncated=truncated)
        answer = self.link.exchange(message, self._deadline(first))
        if answer is None:
            self.held += 1
        else:
            self.action[0] = answer.value
        if terminal or truncated:
            self.fetch_weights()
        return self.action.copy()

    def _deadline(self, first: bool) -> float | None:
        """Seconds the answer may take: the link's timeout, or in real time what is left of
        the control period, after waiting for its start (the handshake waited for the
        device to start up)."""
        if self.period is None:
            return None
        now = time.monotonic()
        if first or self._tick is None:
            self._tick = now
        else:
            self._tick += self.period
            if now > self._tick:  # the host is late itself: start the period now
                self.overruns += 1
                self._tick = now
            time.sleep(self._tick - now if self._tick > now else 0.0)
        return max(self._tick + self.period - time.monotonic(), 0.0)

    def fetch_weights(self) -> None:
        """The device's weights and diverged flag into `arrays` (frames of their own)."""
        values, diverged, self.frame_step = self.link.fetch_weights(self.frame_step + 1)
        weights = self.arrays.weights
        if values.size != weights[0].size:
            raise ValueError(f"the device sent {values.size} weights; its learner has "
                             f"{weights[0].size}")
        weights[0] = values.reshape(weights.shape[1:])
        self.arrays.diverged[0] = diverged
        self.frame_step -= 1


def session_config(task: str, seed: int, plant, learner: str | None = None,
                   **task_options) -> RunConfig:
    """The one-agent `RunConfig` of the learner the device program of `task` runs
    (`write_program` with `seed` and `learner`, the task's default where None), lwrl's
    loops' defaults."""
    return RunConfig(task=task, agents=1, seed=seed, plant=plant,
                     task_options=dict(task_options), **learner_setting(learner))


def twin_of(task: str, seed: int, plant, learner: str | None = None, **task_options):
    """`session_config` and a new `Agents` of it: the device's twin."""
    config = session_config(task, seed, plant, learner, **task_options)
    return config, make_agents(config)


def learner_setting(learner: str | None) -> dict:
    """`{"learner": learner}`, the `RunConfig` setting of a learner named on the command
    line, or nothing for the task's default."""
    return {"learner": learner} if learner else {}


def run_session(link, task: str, episodes: int, seed: int = 0, plant=None, env_seed: int = 0,
                realtime: bool = False, record=(), dtype: str = "double",
                learner: str | None = None, **task_options):
    """`episodes` episodes of `task` on `plant` (the domain's first by default; the plant
    seeded with `env_seed` as lwrl's loops seed an environment; `task_options` the task's,
    e.g. `time_limit`) with the device behind `link` acting, a `DeviceAgent` of `learner`
    (the task's default where None) seeded with `seed` in `dtype`, after a handshake that
    refuses any other program;
    real time at the task's control period with `realtime`; `record`: the `(0, episode)`
    pairs recorded, as `run_batched` records them. Returns the episodes (`EpisodeResults`,
    marked interrupted where the link's watchdog cut the session short: `link.lost` says
    why), the `DeviceAgent` (its counts) and the twin `Agents` holding the device's last
    weights, those of the last episode that finished (saved, it loads in `lwrl eval`)."""
    domain, name = tasks.split_name(task)
    link.handshake(identity(task, seed, dtype, **learner_setting(learner)))
    config, twin = twin_of(task, seed, plant, learner, **task_options)
    env = BatchedEnv(domain, name, config.plant_name, [env_seed], **task_options)
    device = DeviceAgent(link, twin, env, env.definition.control_timestep if realtime else None)
    results = run_batched(env, device, episodes, record=record)
    twin.take_weights(device.arrays.weights)
    return results, device, twin
