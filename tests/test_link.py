"""The host's side of a session over the device link (`export.link`), against the device's C
side built for the host, with faults injected on the way: it never hangs, never takes an
answer to another step, and says what the link did."""

import math
import subprocess
import time

import pytest

from lwrl.export.frames import Observation
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


def test_a_device_of_another_protocol_version_is_one_line():
    """A device that answers in version 2 of the protocol: the host says so at once, in one
    line, rather than wait for answers it cannot read."""
    from lwrl.export import frames
    from lwrl.export.link import ProtocolMismatch

    answer = bytearray(frames.Action(0, 1).frame().encode())
    answer[1] = 2
    answer[-2:] = frames.CRC.pack(frames.crc16(bytes(answer[1:-2])))

    class OtherVersion:
        timeout = None

        def write(self, data):
            return len(data)

        def read(self, size):
            return bytes(answer)

    with pytest.raises(ProtocolMismatch) as error:
        HostLink(OtherVersion(), TIMEOUT).exchange(observations(1)[0])
    assert "version 2" in str(error.value) and "\n" not in str(error.value)
