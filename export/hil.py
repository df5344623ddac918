"""Hardware in the loop: the host steps a task's plant, the learner on the device acts, the
two talking over the device link (`export.frames`, `export.link`).

The device program (`link_main.c`, package data under `templates/link/`) is the C learner
(`export.learner`, from `lwrl learner`) behind the link's C side: for each observation
frame it calls `lwrl_begin` (a frame flagged START) or `lwrl_learn` with the frame's reward
and TERMINAL flag, and answers with the action of the frame's step; a frame of the step it
answered last (a duplicate) gets that answer again and teaches it nothing twice.
`build_host_program` builds it for this machine, whose standard input and output are its
link (`export.link.PipePort`); `build_emulated_program` for the bare-metal Cortex-M4 of
`export.device`, its link UART0 of QEMU's mps2-an386, which QEMU puts on its own standard
input and output: the same pipes reach the emulated board.

`run_session` is the host's side: a dm_env environment of the task (`tasks.load`, any
plant) seeded as lwrl's loops seed it, and every observation sent, the episode's first
flagged START, a terminal one TERMINAL, the last of an episode cut by its time limit
TRUNCATED; the device answers each, and the episode goes on with its action. A missed
deadline holds the previous action, as an actuator would, and is counted. The episodes are
recorded as every run records them (steps, return, up-time, truncated)."""

import dataclasses
import os
import subprocess
from importlib import resources

from lwrl import tasks
from lwrl.export import frames, learner
from lwrl.export.c import find_compiler
from lwrl.export.device import (BOARD, COMMON_FLAGS, M4_FLAGS, M4_LINK, check_tools,
                                write_fixed_files)
from lwrl.export.frames import Observation
from lwrl.tasks.batched import flatten_observation

PROGRAM = ("link_io.h", "link_main.c")
"""The device program's files beside the C learner's and the link's (`templates/link/`)."""
IO = {"host": "link_io_host.c", "emulated": "link_io_uart.c"}
"""Where each build's bytes go: standard input and output, or the emulated board's UART."""


def write_program(task: str, build, seed: int, dtype: str, target: str, **settings) -> None:
    """The device program's sources for `target` (`IO`) in `build`: the C learner of a new
    agent of `task` seeded with `seed` (`settings`: a `RunConfig`'s) in `dtype`, the link's
    C side, the program and its I/O."""
    source = learner.from_task(task, seed=seed, **settings)
    learner.write_learner(source, build, dtype)
    frames.write_c(build)
    for name in (*PROGRAM, IO[target]):
        with open(os.path.join(build, name), "w") as file:
            file.write(resources.files(__package__).joinpath("templates", "link", name).read_text())


def _compile(command, build) -> None:
    done = subprocess.run(command, cwd=build, capture_output=True, text=True)
    if done.returncode != 0:
        raise ValueError(f"{os.path.basename(command[0])} failed: "
                         + " ".join(done.stderr.strip().splitlines()[:2]))


SOURCES = ("lwrl_learner.c", "lwrl_link.c", "link_main.c")


def build_host_program(task: str, build, seed: int = 0, dtype: str = "double",
                       compiler=None, **settings) -> list:
    """The device program for a new agent of `task` (`write_program`) built in `build` for
    this machine; the command that runs it (its standard input and output are the link)."""
    write_program(task, build, seed, dtype, "host", **settings)
    output = os.path.join(build, "link")
    _compile([find_compiler(compiler), *COMMON_FLAGS, *SOURCES, IO["host"], "-o", output, "-lm"],
             build)
    return [output]


def build_emulated_program(task: str, build, seed: int = 0, dtype: str = "float",
                           **settings) -> list:
    """The same program built for the bare-metal Cortex-M4 (`export.device`'s flags and
    start-up), its bytes on UART0; the command that runs it on QEMU's mps2-an386 with that
    UART on QEMU's standard input and output."""
    check_tools()
    write_program(task, build, seed, dtype, "emulated", **settings)
    write_fixed_files(build)
    _compile(["arm-none-eabi-gcc", *M4_FLAGS, *COMMON_FLAGS, *SOURCES, IO["emulated"],
              "io_semihosting.c", "io_common.c", *M4_LINK, "-o", "link.elf", "-lm"], build)
    return ["qemu-system-arm", "-M", BOARD, "-display", "none", "-monitor", "none", "-serial",
            "stdio", "-semihosting-config", "enable=on,target=native", "-kernel",
            os.path.join(build, "link.elf")]


@dataclasses.dataclass
class Session:
    """The episodes of a session, one entry per episode, and the actions the plant took."""

    steps: list = dataclasses.field(default_factory=list)
    returns: list = dataclasses.field(default_factory=list)
    uptime: list = dataclasses.field(default_factory=list)
    truncated: list = dataclasses.field(default_factory=list)
    held: int = 0
    """Steps whose action was held from the step before (missed deadlines)."""


STARTUP = 30.0
"""Seconds the first answer may take: the device starting up (QEMU boots the emulated board
in about a second)."""


def run_session(link, task: str, episodes: int, seed: int = 0, plant=None,
                **task_options) -> Session:
    """`episodes` episodes of `task` on `plant` (the domain's first by default; seeded with
    `seed` as lwrl's loops seed environment b with its seed; `task_options` the task's,
    e.g. `time_limit`) with the device behind `link` (an `export.link.HostLink`) acting;
    the first answer may take `STARTUP` seconds, every later one the link's deadline; see
    the module."""
    domain, name = tasks.split_name(task)
    env = tasks.load(domain, name, plant=plant, seed=seed, task_kwargs=task_options)
    session, step = Session(), 0

    def exchange(observation: Observation, held):
        nonlocal step
        step += 1
        answer = link.exchange(observation, STARTUP if step == 1 else None)
        if answer is None:
            session.held += 1
            return held
        return answer.value

    for _ in range(episodes):
        ts = env.reset()
        action = exchange(Observation(step, tuple(flatten_observation(ts.observation)), 0.0,
                                      start=True), 0)
        count, total = 0, 0.0
        while True:
            ts = env.step(action)
            count, total = count + 1, total + float(ts.reward)
            terminal = ts.last() and ts.discount == 0.0
            action = exchange(Observation(step, tuple(flatten_observation(ts.observation)),
                                          float(ts.reward), terminal=terminal,
                                          truncated=ts.last() and not terminal), action)
            if ts.last():
                break
        session.steps.append(count)
        session.returns.append(total)
        session.uptime.append(float(env.task.uptime))
        session.truncated.append(not terminal)
    return session
