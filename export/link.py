"""The host's side of a session over the device link (`export.frames`): one observation out,
its answer back, within a deadline, whatever the link does to the bytes in between.

`HostLink(port, timeout)` works over any port with pyserial's interface: `write(bytes)`,
`read(size)` that returns what came within `port.timeout` seconds (fewer bytes, or none, at
the timeout), and a settable `timeout`. `serial.Serial` is one (a real board, or QEMU's
UART on a pty); `PipePort` is another, over a child process's standard input and output
(a device program built for the host).

`exchange(observation)` sends the observation's frame and waits for the action frame of the
same step until the deadline (`timeout` seconds after sending). What it meets on the way is
counted, not taken (`LinkCounts`): an answer to an earlier step (late: its deadline had
passed), a second answer to the awaited step (a duplicate), frames and bytes the reader
refused. At the deadline it returns None: a missed deadline, which the caller handles as an
actuator would, holding the previous action. It never waits longer than the deadline and
never returns an answer to another step.
"""

import dataclasses
import os
import select
import time

from lwrl.export.frames import ACTION, Action, FrameReader, Observation


@dataclasses.dataclass
class LinkCounts:
    """What a session's link did, step by step summed."""

    exchanges: int = 0
    answered: int = 0
    missed: int = 0
    """Deadlines passed with no answer."""
    late: int = 0
    """Answers to an earlier step, arrived after its deadline."""
    duplicates: int = 0
    """Second answers to a step already answered."""
    bytes_sent: int = 0
    bytes_received: int = 0
    round_trips: list = dataclasses.field(default_factory=list)
    """Seconds from sending each answered observation to its answer."""


class HostLink:
    """The host's side of the link over `port` (the module's docstring); `timeout`: seconds
    an answer may take."""

    def __init__(self, port, timeout: float):
        if not timeout > 0:
            raise ValueError(f"timeout must be a positive number of seconds; got {timeout!r}")
        self.port, self.timeout = port, float(timeout)
        self.reader = FrameReader()
        self.counts = LinkCounts()
        self._answered: set = set()
        self._frames: list = []

    def exchange(self, observation: Observation, timeout: float | None = None) -> Action | None:
        """Send `observation`; its answer, or None at the deadline, `timeout` seconds (the
        link's unless given: a device that is still starting up) after sending (see the
        module)."""
        data = observation.frame().encode()
        sent = time.monotonic()
        self.port.write(data)
        self.counts.exchanges += 1
        self.counts.bytes_sent += len(data)
        deadline = sent + (self.timeout if timeout is None else timeout)
        while True:
            answer = self._take(observation.step)
            if answer is not None:
                self.counts.answered += 1
                self.counts.round_trips.append(time.monotonic() - sent)
                return answer
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self.counts.missed += 1
                return None
            self.port.timeout = remaining
            chunk = self.port.read(256)
            self.counts.bytes_received += len(chunk)
            self._frames += self.reader.feed(chunk)

    def _take(self, step: int) -> Action | None:
        """The answer to `step` among the frames read, the others counted and dropped."""
        while self._frames:
            frame = self._frames.pop(0)
            if frame.kind != ACTION:
                continue
            if frame.step in self._answered:
                self.counts.duplicates += 1
            elif frame.step != step:
                self.counts.late += 1
            else:
                self._answered.add(step)
                return Action.read(frame)
        return None


class PipePort:
    """A port over a child process's standard input and output (`subprocess.Popen` with
    `stdin=PIPE, stdout=PIPE`), with pyserial's `write`, `read` and `timeout`."""

    def __init__(self, process, timeout: float | None = None):
        self.process, self.timeout = process, timeout

    def write(self, data: bytes) -> int:
        self.process.stdin.write(data)
        self.process.stdin.flush()
        return len(data)

    def read(self, size: int) -> bytes:
        """Up to `size` bytes that are there within `timeout` seconds (b"" at the timeout)."""
        out = self.process.stdout.fileno()
        ready, _, _ = select.select([out], [], [], self.timeout)
        return os.read(out, size) if ready else b""
