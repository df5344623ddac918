"""The host's side of a session over the device link (`export.link`), against the device's C
side built for the host, with faults injected on the way: it never hangs, never takes an
answer to another step, and says what the link did; its handshake refuses another
program and its watchdog ends a session whose device is gone, in one line."""

import math
import subprocess
import time

import pytest

from lwrl.export.frames import DISCRETE, IDENTITY, Frame, Identity, Observation
from lwrl.export.link import HostLink, PipePort
from tests.test_frames import c_echo

TIMEOUT = 1.0
"""Seconds an answer may take: far above a round trip through a pipe (tens of microseconds),
so that a loaded machine misses no deadline the test does not inject."""


class FaultyPort:
    """A port whose writes of the steps in `faults` go wrong: `corrupt` (a byte of the
    payload changed), `truncate` (the frame's first half only), `duplicate` (written twice)
    or `drop` (not written)."""

    def __init__(self, port, faults: dict):
        self.port, self.faults, self.writes = port, faults, 0

    @property
    def timeout(self):
        return self.port.timeout

    @timeout.setter
    def timeout(self, value):
        self.port.timeout = value

    def read(self, size):
        return self.port.read(size)

    def write(self, data: bytes) -> int:
        fault = self.faults.get(self.writes)
        self.writes += 1
        if fault == "corrupt":
            data = data[:10] + bytes([data[10] ^ 0x10]) + data[11:]
        elif fault == "truncate":
            data = data[:len(data) // 2]
        elif fault == "duplicate":
            data = data * 2
        elif fault == "drop":
            data = b""
        return self.port.write(data)


@pytest.fixture
def device(tmp_path):
    process = subprocess.Popen([str(c_echo(tmp_path))], stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    yield process
    process.kill()
    process.wait()


def observations(count):
    return [Observation(step, (0.25 * step, -1.0), reward=-1.0, start=step == 0)
            for step in range(count)]


def test_a_clean_session_answers_every_step_exactly(device):
    link = HostLink(PipePort(device), TIMEOUT)
    answers = [link.exchange(o) for o in observations(20)]
    assert [a.step for a in answers] == list(range(20))
    assert [a.value for a in answers] == [0.25 * step for step in range(20)]
    counts = link.counts
    assert (counts.answered, counts.missed, counts.late, counts.duplicates) == (20, 0, 0, 0)
    assert counts.bytes_sent == 20 * 35 and counts.bytes_received == 20 * 19
    assert len(counts.round_trips) == 20 and max(counts.round_trips) < TIMEOUT


def test_faults_cost_their_step_only_and_are_counted(device):
    """A corrupted, truncated or dropped observation gets no answer by its deadline (a
    missed deadline: None); a duplicated one gets its answer, and the second answer is
    counted, not taken, at the next step; every other step is answered with its own value."""
    faults = {3: "corrupt", 6: "duplicate", 9: "truncate", 12: "drop"}
    link = HostLink(FaultyPort(PipePort(device), faults), TIMEOUT)
    answers = [link.exchange(o) for o in observations(16)]
    for step, answer in enumerate(answers):
        if step in (3, 9, 12):
            assert answer is None, step
        else:
            assert answer is not None and answer.step == step and answer.value == 0.25 * step
    counts = link.counts
    assert (counts.missed, counts.duplicates, counts.answered) == (3, 1, 13)


def test_a_stalled_device_costs_each_step_its_deadline_and_no_more(tmp_path):
    silent = subprocess.Popen(["sleep", "30"], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        link = HostLink(PipePort(silent), 0.1)
        started = time.monotonic()
        assert [link.exchange(o) for o in observations(4)] == [None] * 4
        assert time.monotonic() - started < 4 * 0.1 + 0.5
        assert link.counts.missed == 4
    finally:
        silent.kill()
        silent.wait()


def test_a_restarted_device_and_a_restarted_host_go_on(device, tmp_path):
    """The device restarts between steps (a new process, its reader empty): the host goes
    on with it. The host restarts (a new link on the same device): the device goes on."""
    link = HostLink(PipePort(device), TIMEOUT)
    assert link.exchange(observations(2)[1]).step == 1
    again = subprocess.Popen([str(tmp_path / "echo")], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    try:
        link.port = PipePort(again)
        assert link.exchange(Observation(2, (math.pi,))).value == math.pi
    finally:
        again.kill()
        again.wait()
    fresh = HostLink(PipePort(device), TIMEOUT)
    assert fresh.exchange(Observation(0, (1.5,), start=True)).value == 1.5


def test_a_bad_timeout_is_one_line(device):
    with pytest.raises(ValueError, match="timeout must be a positive number"):
        HostLink(PipePort(device), 0)
    with pytest.raises(ValueError, match="window must be a positive number"):
        HostLink(PipePort(device), 1.0, window=-1.0)
    with pytest.raises(ValueError, match="a whole number, at least 1"):
        HostLink(PipePort(device), 1.0, misses=0)


EXPECTED = Identity("mountain_car.cost_to_go", 2, DISCRETE, 3, "double", 12345)


def test_the_handshake_takes_the_device_that_is_the_expected_program(device):
    """The C side (a program that says back the identity it is told) answers the hello;
    the handshake's bytes are counted apart from the steps'."""
    link = HostLink(PipePort(device), TIMEOUT)
    assert link.handshake(EXPECTED) == EXPECTED
    assert link.counts.bytes_handshake > 0 and link.counts.bytes_sent == 0


class ScriptedPort:
    """A port whose device writes what `answer(data)` returns for each write (silence,
    noise, frames), then sleeps through the read's timeout when it has nothing left."""

    def __init__(self, answer):
        self.answer, self.timeout, self.pending = answer, None, b""

    def write(self, data):
        self.pending += self.answer(data)
        return len(data)

    def read(self, size):
        if not self.pending:
            time.sleep(self.timeout or 0.0)
        data, self.pending = self.pending[:size], self.pending[size:]
        return data


def test_a_device_of_another_program_is_refused_in_one_line_naming_both():
    """A device that answers the hello with another task's identity: refused at once, the
    line naming what the device runs and what the host expects."""
    from lwrl.export.link import IdentityMismatch

    other = Identity("pendulum.swingup", 3, DISCRETE, 3, "float", 999)
    port = ScriptedPort(lambda data: Frame(IDENTITY, 0, other.payload()).encode())
    link = HostLink(port, TIMEOUT)
    with pytest.raises(IdentityMismatch) as error:
        link.handshake(EXPECTED)
    line = str(error.value)
    assert "\n" not in line and line == link.lost
    assert "runs pendulum.swingup (3 observed variables" in line
    assert "expects mountain_car.cost_to_go (2 observed variables" in line


@pytest.mark.parametrize("answer, heard", [(lambda data: b"", "heard: nothing"),
                                           (lambda data: bytes(range(7)) * 9, "heard: noise (")])
def test_the_watchdog_ends_a_session_whose_device_sends_nothing_valid(answer, heard):
    """A silent device, and one that sends only noise: each exchange misses its deadline and
    returns None until the device has sent no valid frame for the window and missed as many
    deadlines in a row, then the session ends with one line saying what was heard; the
    handshake's wait ends so too."""
    from lwrl.export.link import LinkLost
    from lwrl.runners.stepped import CutShort

    link = HostLink(ScriptedPort(answer), 0.05, window=0.3, misses=3, name="the board at X")
    with pytest.raises(LinkLost) as error:
        for step in range(10_000):  # ends by the watchdog, long before
            assert link.exchange(Observation(step, (0.0, 0.0))) is None
    line = str(error.value)
    assert isinstance(error.value, CutShort) and isinstance(error.value, ValueError)
    assert line == link.lost and "\n" not in line and heard in line
    assert line.startswith("the board at X has sent no valid frame for")
    assert 3 <= link.counts.missed < 10_000
    with pytest.raises(LinkLost, match="no valid frame"):
        HostLink(ScriptedPort(answer), 0.05, window=0.3, misses=3).handshake(EXPECTED)


def test_a_device_that_comes_back_within_the_window_goes_on_and_one_that_does_not_ends(device):
    """The device's link drops five observations (0.5 s without a frame, more deadlines in a
    row than `misses`, less than the window): the session goes on. Then it drops every one:
    the watchdog ends the session, naming the last frame heard."""
    from lwrl.export.link import LinkLost

    faults = {step: "drop" for step in range(3, 8)}
    port = FaultyPort(PipePort(device), faults)
    link = HostLink(port, 0.1, window=1.5, misses=3)
    answers = [link.exchange(o) for o in observations(12)]
    assert [a is None for a in answers] == [3 <= step < 8 for step in range(12)]
    assert link.counts.missed == 5 and link.lost is None
    port.faults = {step: "drop" for step in range(12, 10_000)}
    with pytest.raises(LinkLost) as error:
        for step in range(12, 10_000):
            link.exchange(Observation(step, (1.0,)))
    assert "last heard: an action frame of step 11, then nothing" in str(error.value)


def test_a_device_of_another_protocol_version_is_one_line():
    """A device that answers in version 1 of the protocol (this host speaks 2): the host
    says so at once, in one line, rather than wait for answers it cannot read."""
    from lwrl.export import frames
    from lwrl.export.link import ProtocolMismatch

    answer = bytearray(frames.Action(0, 1).frame().encode())
    answer[1] = 1
    answer[-2:] = frames.CRC.pack(frames.crc16(bytes(answer[1:-2])))

    class OtherVersion:
        timeout = None

        def write(self, data):
            return len(data)

        def read(self, size):
            return bytes(answer)

    with pytest.raises(ProtocolMismatch) as error:
        HostLink(OtherVersion(), TIMEOUT).exchange(observations(1)[0])
    assert "version 1" in str(error.value) and "\n" not in str(error.value)
