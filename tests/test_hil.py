"""Hardware in the loop over the device link (`export.hil`): the C learner, built for the
host in double and answering over the link, learns what lwrl's own learner learns, step
for step, on the analytic plant and on MuJoCo's; its weights come back by frames and load
as an agent; real time holds the plant to its period; the command writes what a run writes."""

import contextlib
import subprocess
import time

import numpy as np
import pytest

from lwrl import tasks
from lwrl.export.hil import build_host_program, run_session
from lwrl.export.link import HostLink, PipePort
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents, run_dm_env


@contextlib.contextmanager
def device_link(command, wrap=lambda port: port, timeout=5.0):
    """A `HostLink` to the device program `command` run as a child process."""
    device = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL)
    try:
        yield HostLink(wrap(PipePort(device)), timeout)
    finally:
        device.kill()
        device.wait()


def own_run(task, episodes, plant=None, **options):
    """lwrl's learner (agent seed 3) on the episodes of environment seed 11."""
    domain, name = tasks.split_name(task)
    agent = make_agents(RunConfig(task=task, agents=1, seed=3, task_options=options))
    results = run_dm_env(tasks.load(domain, name, plant=plant, seed=11, task_kwargs=options),
                         agent, episodes)
    return agent, results


def assert_same_episodes(results, own):
    for field in ("steps", "returns", "uptime", "truncated"):  # up-time NaN where a task has none
        np.testing.assert_array_equal(getattr(results, field), getattr(own, field), err_msg=field)


@pytest.mark.parametrize("task, plant, episodes", [("mountain_car.cost_to_go", "analytic", 3),
                                                   ("pendulum.swingup", "mujoco", 2)])
def test_the_device_learns_over_the_link_what_lwrl_learns(task, plant, episodes, tmp_path):
    """The same agent (seed 3) on the same episodes (environment seed 11): every episode's
    steps, return, up-time and truncation equal lwrl's learner's in its own loop
    (`run_dm_env`), and the weights fetched by frames at the end equal its weights to the
    bit; no deadline was missed and every byte is counted."""
    with device_link(build_host_program(task, tmp_path, seed=3)) as link:
        results, device, twin = run_session(link, task, episodes, seed=3, plant=plant,
                                            env_seed=11)
    agent, own = own_run(task, episodes, plant)
    assert_same_episodes(results, own)
    np.testing.assert_array_equal(twin.arrays.weights, agent.arrays.weights)
    assert device.held == 0 and link.counts.missed == 0 and not device.diverged[0]
    assert link.counts.answered == results.steps.sum() + episodes
    assert link.counts.bytes_fetched > 8 * twin.arrays.weights.size * episodes


def test_duplicated_observations_teach_the_device_nothing_twice(tmp_path):
    """Observations written twice on the link: the device answers the copy with the same
    action and learns from it nothing, so the session is still lwrl's learner's, step for
    step; the copies' answers are counted as duplicates."""
    from tests.test_link import FaultyPort

    task = "mountain_car.cost_to_go"
    faults = {write: "duplicate" for write in (1, 5, 77)}  # write 0 is the handshake's hello
    with device_link(build_host_program(task, tmp_path, seed=3),
                     lambda port: FaultyPort(port, faults)) as link:
        results, _, _ = run_session(link, task, 2, seed=3, env_seed=11)
    assert_same_episodes(results, own_run(task, 2)[1])
    assert link.counts.exchanges > 78 and link.counts.duplicates == 3


def test_in_real_time_the_plant_keeps_its_period_and_the_episodes_stay(tmp_path):
    """Paced at the pendulum's 20 ms, two episodes of 0.3 s (15 steps) take at least their
    14 periods each after the first step, and are lwrl's learner's, step for step."""
    task, options = "pendulum.swingup", {"time_limit": 0.3}
    with device_link(build_host_program(task, tmp_path, seed=3)) as link:
        started = time.monotonic()
        results, device, _ = run_session(link, task, 2, seed=3, plant="analytic", env_seed=11,
                                         realtime=True, **options)
        took = time.monotonic() - started
    assert device.period == 0.02 and took >= 2 * 14 * 0.02
    assert device.held == link.counts.missed
    if device.held == 0:  # a loaded machine may miss a deadline: then the episodes may differ
        assert_same_episodes(results, own_run(task, 2, "analytic", **options)[1])


class SlowPort:
    """A port whose bytes arrive `delay` seconds after they could be read."""

    def __init__(self, port, delay):
        self.port, self.delay, self.timeout = port, delay, None

    def write(self, data):
        return self.port.write(data)

    def read(self, size):
        self.port.timeout = self.timeout
        data = self.port.read(size)
        if data:
            time.sleep(self.delay)
        return data


def test_late_answers_in_real_time_hold_the_action_and_are_counted(tmp_path):
    """Every answer 30 ms late at a 20 ms period: after the first (the start-up's), each
    step misses its deadline and holds the action before, the late answers are counted and
    never taken, and every episode still ends and is recorded."""
    task, options = "pendulum.swingup", {"time_limit": 0.2}
    with device_link(build_host_program(task, tmp_path, seed=3),
                     lambda port: SlowPort(port, 0.03)) as link:
        results, device, _ = run_session(link, task, 2, seed=3, plant="analytic", env_seed=11,
                                         realtime=True, **options)
    assert list(results.steps[0]) == [10, 10] and results.truncated.all()
    assert device.held == link.counts.missed >= 15 and link.counts.late >= 5


def test_lwrl_device_hil_writes_a_runs_files_and_an_agent_lwrl_eval_runs(capsys, tmp_path):
    """--out, --save and --rrd: config.json and episodes.csv as `lwrl train` writes them,
    the device's weights as an agent that `lwrl eval` runs, and a recording."""
    import csv

    from lwrl.agent import io as agent_io
    from lwrl.cli.main import main

    out, saved, rrd = tmp_path / "run", tmp_path / "agent.npz", tmp_path / "run.rrd"
    assert main(["device", "hil", "mountain_car.cost_to_go", "--episodes", "2", "--seed", "3",
                 "--env-seed", "11", "--time-limit", "300", "--out", str(out), "--save",
                 str(saved), "--rrd", str(rrd), "--log-episodes", "all"]) == 0
    printed = capsys.readouterr().out
    assert "0 missed deadlines" in printed and "baud at one step per" in printed
    with open(out / "episodes.csv") as file:
        rows = list(csv.DictReader(file))
    agent, own = own_run("mountain_car.cost_to_go", 2, time_limit=300)
    assert [int(row["steps"]) for row in rows] == list(own.steps[0])
    loaded, metadata = agent_io.load(saved)
    np.testing.assert_array_equal(loaded.arrays.weights, agent.arrays.weights)
    assert metadata["config"]["seed"] == 3 and rrd.stat().st_size > 0
    assert main(["eval", str(saved), "--episodes", "1"]) == 0


def test_lwrl_device_hil_says_in_one_line_what_it_cannot_do(capsys):
    from lwrl.cli.main import main

    for argv, words in ((["--timeout", "0"], "--timeout must be a positive number"),
                        (["--link-timeout", "-1"], "--link-timeout must be a positive number"),
                        (["--port", "/dev/no-such-port", "--emulated"], "give one"),
                        (["--port", "/dev/no-such-port", "--baud", "300"],
                         "need at least 500 baud"),
                        (["--log-episodes", "best", "--rrd", "x.rrd"], "the device learns once")):
        assert main(["device", "hil", "mountain_car.cost_to_go", *argv]) == 2, argv
        error = capsys.readouterr().err.strip().splitlines()
        assert len(error) == 1 and words in error[0], (argv, error)


def test_a_port_that_does_not_exist_is_one_line(capsys):
    pytest.importorskip("serial", reason="--port needs pyserial (the serial extra)")
    from lwrl.cli.main import main

    assert main(["device", "hil", "pendulum.swingup", "--port", "/dev/no-such-port"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "--port /dev/no-such-port: cannot open it" in error[0]


@pytest.mark.skipif(bool(__import__("lwrl.export.device", fromlist=["missing_tools"]).missing_tools()),
                    reason="needs gcc-arm-none-eabi, libnewlib-arm-none-eabi and qemu-system-arm")
def test_the_emulated_board_learns_over_its_uart_what_the_host_build_learns(tmp_path):
    """The float learner on the emulated Cortex-M4, its UART the link, against the same
    program built for the host, on MuJoCo's pendulum (2 episodes of 4 s: the emulated UART
    takes about 10 ms a round trip): the same steps, returns and up-times in every episode
    (the device's expf is newlib's, the host's glibc's; they agree on these episodes), and
    the weights fetched at the end within a float's rounding of each other; the board's
    instructions per step counted without its waits for bytes."""
    from functools import partial

    from lwrl.export.hil import build_emulated_program, counted_instructions

    task, plant, options, sessions = "pendulum.swingup", "mujoco", {"time_limit": 4.0}, []
    for build, target in ((tmp_path / "host", build_host_program),
                          (tmp_path / "m4", partial(build_emulated_program, count=True))):
        build.mkdir()
        with device_link(target(task, build, seed=3, dtype="float")) as link:
            results, _, twin = run_session(link, task, 2, seed=3, plant=plant, env_seed=11,
                                           dtype="float", **options)
            if target is not build_host_program:
                instructions = counted_instructions(link.port.process, build)
        assert link.counts.missed == 0 and link.counts.late == 0
        sessions.append((results, twin.arrays.weights))
    # the pendulum's learning step is about 7 800 instructions (docs/FINDINGS.md), the
    # frames' CRCs and doubles add to it; a count with the polling waits in would be millions
    assert 5_000 < instructions / link.counts.exchanges < 50_000
    (host, host_weights), (emulated, emulated_weights) = sessions
    assert_same_episodes(emulated, host)
    scale = np.abs(host_weights).max()  # measured: 1.9e-7 of it apart, a float's last bits
    np.testing.assert_allclose(emulated_weights, host_weights, rtol=0, atol=1e-5 * scale)


class RestartingPort:
    """A port to a device program that is killed and started again after `after` writes,
    as a board that resets mid-episode."""

    def __init__(self, command, after):
        self.command, self.after, self.writes, self.timeout = command, after, 0, None
        self.process = self._start()

    def _start(self):
        return subprocess.Popen(self.command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL)

    def write(self, data):
        self.writes += 1
        if self.writes == self.after:
            self.process.kill()
            self.process.wait()
            self.process = self._start()
        return PipePort(self.process).write(data)

    def read(self, size):
        return PipePort(self.process, self.timeout).read(size)


def test_a_device_that_restarts_mid_episode_begins_anew_and_the_session_goes_on(tmp_path):
    """The device program restarted at the 40th observation of Mountain-Car's first
    episode: it starts learning afresh from that observation, as from an episode's start,
    and the session ends every episode; the weights it sends at the end are not those of a
    device that never restarted: what it learned before is lost, as on a board that keeps
    nothing over a reset."""
    task = "mountain_car.cost_to_go"
    command = build_host_program(task, tmp_path, seed=3)
    port = RestartingPort(command, after=40)
    try:
        results, device, twin = run_session(HostLink(port, 5.0), task, 2, seed=3, env_seed=11)
    finally:
        port.process.kill()
        port.process.wait()
    agent, own = own_run(task, 2)
    assert results.steps.shape == (1, 2) and np.all(results.steps > 0)
    assert not np.array_equal(twin.arrays.weights, agent.arrays.weights)
    assert device.held == 0


def test_the_device_program_and_the_host_refuse_each_other_when_they_are_other_programs(tmp_path):
    """The device program of seed 3's learner, and a host that expects seed 4's: the host
    refuses it in one line naming both builds; the device, told another program's hello,
    acts on no observation, and acts again once told its own."""
    from lwrl.export.frames import Observation
    from lwrl.export.hil import identity
    from lwrl.export.link import IdentityMismatch

    task = "mountain_car.cost_to_go"
    own, other = identity(task, 3, "double"), identity(task, 4, "double")
    assert own.build != other.build and own.task == other.task
    with device_link(build_host_program(task, tmp_path, seed=3), timeout=0.5) as link:
        with pytest.raises(IdentityMismatch) as error:
            run_session(link, task, 1, seed=4, env_seed=11)
        assert f"runs {own.describe()}; this host expects {other.describe()}" in str(error.value)
        assert link.exchange(Observation(1, (-0.5, 0.0), start=True)) is None
        assert link.handshake(own, step=2) == own
        assert link.exchange(Observation(3, (-0.5, 0.0), start=True)) is not None


def test_the_baud_rate_needed_counts_the_programs_own_action_frames():
    """The check of --baud reads the frames' sizes from their layout and the program's kind
    of action: Mountain-Car's 2 variables at a step a second need 500 baud with an index
    (35 + 15 bytes), 540 with a continuous action (35 + 19)."""
    from lwrl.cli.device import needed_baud
    from lwrl.export.frames import CONTINUOUS, DISCRETE, Identity

    discrete = Identity("mountain_car.cost_to_go", 2, DISCRETE, 3, "float", 0)
    continuous = Identity("mountain_car.cost_to_go", 2, CONTINUOUS, 1, "float", 0)
    assert needed_baud(discrete, 1.0) == 500 and needed_baud(continuous, 1.0) == 540


class PtyDevice:
    """A pseudo-terminal (`os.openpty`) whose far end plays a device, `serve(master, stop)`
    in a thread; its near end (`name`) is the serial port `lwrl device hil --port` opens."""

    def __init__(self, serve):
        import os
        import threading
        import tty

        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no line editing, before pyserial sets it so too
        self.name = os.ttyname(self.slave)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=serve, args=(self.master, self.stop), daemon=True)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        import os

        self.stop.set()
        self.thread.join(10)
        os.close(self.master)
        os.close(self.slave)


def host_bytes(master, wait=0.01) -> bytes:
    """What the host wrote to the pseudo-terminal, within `wait` seconds (b"" if nothing)."""
    import os
    import select

    ready, _, _ = select.select([master], [], [], wait)
    return os.read(master, 4096) if ready else b""


def silent(master, stop):
    while not stop.is_set():
        host_bytes(master, 0.05)


def noisy(master, stop):
    import os
    import random

    noise = random.Random(5)
    while not stop.is_set():
        host_bytes(master)
        os.write(master, bytes(noise.getrandbits(8) for _ in range(40)))


def another_task(master, stop):
    """Answers each hello with the identity of the pendulum's program."""
    import os

    from lwrl.export.frames import HELLO, IDENTITY, Frame, FrameReader
    from lwrl.export.hil import identity

    other, reader = identity("pendulum.swingup", 0, "float"), FrameReader()
    while not stop.is_set():
        for frame in reader.feed(host_bytes(master)):
            if frame.kind == HELLO:
                os.write(master, Frame(IDENTITY, frame.step, other.payload()).encode())


def relay(command, stall_at, stall):
    """A device that forwards the link to the device program `command` and back, and at
    the `stall_at`-th observation goes silent, forwarding nothing either way, for `stall`
    seconds (None: for good)."""
    def serve(master, stop):
        import os
        import select

        from lwrl.export.frames import OBSERVATION, FrameReader

        process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                   stderr=subprocess.DEVNULL)
        reader, seen, stalled = FrameReader(), 0, False
        try:
            while not stop.is_set():
                data = host_bytes(master)
                seen += sum(f.kind == OBSERVATION for f in reader.feed(data))
                if seen >= stall_at and not stalled:
                    stop.wait(stall)  # silent: the host's bytes wait in the terminal
                    stalled = True
                process.stdin.write(data)
                process.stdin.flush()
                ready, _, _ = select.select([process.stdout], [], [], 0.0)
                if ready:
                    os.write(master, os.read(process.stdout.fileno(), 4096))
        finally:
            process.kill()
            process.wait()
    return serve


def hil_on(pty, capsys, *flags, within=120.0):
    """`lwrl device hil mountain_car.cost_to_go --port PTY` with short deadlines and
    `flags`, run in a thread that must end within `within` seconds (a bound on its ending,
    far above the times it is given); its exit status and standard error's lines."""
    import threading

    from lwrl.cli.main import main

    done = {}
    argv = ["device", "hil", "mountain_car.cost_to_go", "--port", pty.name, "--timeout", "0.2",
            "--link-timeout", "1", *flags]
    worker = threading.Thread(target=lambda: done.update(status=main(argv)), daemon=True)
    worker.start()
    worker.join(within)
    assert not worker.is_alive(), "lwrl device hil did not end"
    return done["status"], capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("serve, words", [
    (silent, "has sent no valid frame for"),
    (noisy, "heard: noise ("),
    (another_task, "runs pendulum.swingup (")])
def test_against_a_silent_noisy_or_wrong_device_the_session_ends_in_one_line(serve, words,
                                                                             capsys):
    """A pseudo-terminal that is silent, that sends only noise, or whose program is the
    pendulum's: the handshake never takes it, the command ends (within the watchdog's 1 s,
    or at once for the wrong program) with one line naming the port and its baud, and exit
    status 2; nothing is written."""
    pytest.importorskip("serial", reason="--port needs pyserial (the serial extra)")
    with PtyDevice(serve) as pty:
        status, error = hil_on(pty, capsys)
    assert status == 2 and len(error) == 1, error
    assert f"the board at {pty.name} (115200 baud)" in error[0] and words in error[0]


def test_a_device_that_stalls_mid_episode_and_returns_within_the_window_goes_on(tmp_path,
                                                                                capsys):
    """The device program behind a pseudo-terminal goes silent for 0.6 s in the first
    episode (two or three deadlines of 0.2 s, the watchdog's misses, but less than its
    1 s): the session goes on, every episode runs, the missed deadlines are counted."""
    pytest.importorskip("serial", reason="--port needs pyserial (the serial extra)")
    import csv
    import json

    program = build_host_program("mountain_car.cost_to_go", tmp_path / "build", dtype="float")
    with PtyDevice(relay(program, 20, 0.6)) as pty:
        status, error = hil_on(pty, capsys, "--episodes", "2", "--time-limit", "40",
                               "--link-misses", "2", "--out", str(tmp_path / "run"))
    assert status == 0, error
    session = json.loads((tmp_path / "run" / "session.json").read_text())
    with open(tmp_path / "run" / "episodes.csv") as file:
        steps = [int(row["steps"]) for row in csv.DictReader(file)]
    assert session["complete"] and session["episodes_finished"] == 2 and len(steps) == 2
    # the stall's deadlines missed, and only those: every other answer is taken as it comes
    assert 2 <= session["link"]["missed"] <= 10
    assert session["link"]["exchanges"] == sum(steps) + 2


def test_a_device_that_stalls_for_good_cuts_the_session_short_and_what_finished_is_kept(
        tmp_path, capsys):
    """The device goes silent for good in the second episode: the watchdog ends the session
    with one line naming the port, its baud and the last frame heard; the first episode is
    written whole, the second left empty, the session marked cut short, the weights those
    of the first episode's end, and the exit status 1."""
    pytest.importorskip("serial", reason="--port needs pyserial (the serial extra)")
    import csv
    import json

    from lwrl.agent import io as agent_io

    program = build_host_program("mountain_car.cost_to_go", tmp_path / "build", dtype="float")
    out, saved = tmp_path / "run", tmp_path / "agent.npz"
    with PtyDevice(relay(program, 50, None)) as pty:
        status, error = hil_on(pty, capsys, "--episodes", "2", "--time-limit", "40",
                               "--out", str(out), "--save", str(saved))
    assert status == 1
    assert f"the board at {pty.name} (115200 baud) has sent no valid frame" in error[-1]
    assert "last heard: an action frame of step" in error[-1] and "cut short" in error[-1]
    with open(out / "episodes.csv") as file:
        steps = [row["steps"] for row in csv.DictReader(file)]
    assert steps[0] == "40" and steps[1] == ""
    session = json.loads((out / "session.json").read_text())
    assert not session["complete"] and session["episodes_finished"] == 1
    assert "no valid frame" in session["ended"]
    assert agent_io.load(saved)[1]["session"] == session
