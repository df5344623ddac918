"""The host's side of a session over the device link (`export.frames`): one observation out,
its answer back, within a deadline, whatever the link does to the bytes in between.

`HostLink(port, timeout)` works over any port with pyserial's interface: `write(bytes)`,
`read(size)` that returns what came within `port.timeout` seconds (fewer bytes, or none, at
the timeout), and a settable `timeout`. `serial.Serial` is one (a real board, or QEMU's
UART on a pty); `PipePort` is another, over a child process's standard input and output
(a device program built for the host).

`exchange(observation)` sends the observation's frame and waits for the action frame of the
same step until the deadline (`timeout` seconds after sending); `exchange(request)` (a
`Request` for the learned weights) waits so for the WEIGHTS frame of its step, and
`fetch_weights` asks for them all, piece by piece. What it meets on the way is
counted, not taken (`LinkCounts`): an answer to an earlier step (late: its deadline had
passed), a second answer to the awaited step (a duplicate), frames and bytes the reader
refused. At the deadline it returns None: a missed deadline, which the caller handles as an
actuator would, holding the previous action. It never waits longer than the deadline and
never returns an answer to another step. A whole frame of another protocol version
(`FrameReader.foreign_version`) ends the session with a one-line `ProtocolMismatch`: the
device would never understand this host.
"""

import dataclasses
import os
import select
import time

import numpy as np

from lwrl.export.frames import (ACTION, VERSION, WEIGHTS, Action, FrameReader, Observation,
                                Request, Weights)

ANSWERS = {Observation: (ACTION, Action.read), Request: (WEIGHTS, Weights.read)}
"""What answers each message: the kind of its frame and how it is read."""


class ProtocolMismatch(ValueError):
    """The device answers in another version of the link's protocol."""


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
    """Bytes of the observations and their answers (`bytes_fetched` apart)."""
    bytes_fetched: int = 0
    """Bytes sent and received fetching the weights."""
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

    def exchange(self, message: Observation | Request, timeout: float | None = None):
        """Send `message`; its answer (an `Action`, or `Weights` for a `Request`), or None
        at the deadline, `timeout` seconds (the link's unless given: a device that is still
        starting up) after sending (see the module)."""
        control = isinstance(message, Observation)
        data = message.frame().encode()
        sent = time.monotonic()
        self.port.write(data)
        received = 0
        deadline = sent + (self.timeout if timeout is None else timeout)
        try:
            answer = self._take(message)
            while answer is None and time.monotonic() < deadline:
                self.port.timeout = deadline - time.monotonic()
                chunk = self.port.read(256)
                received += len(chunk)
                self._frames += self.reader.feed(chunk)
                if self.reader.foreign_version is not None:
                    raise ProtocolMismatch(
                        f"the device answers in version {self.reader.foreign_version} of the "
                        f"link's protocol; this host speaks version {VERSION}")
                if time.monotonic() >= deadline:
                    break  # what came after the deadline is late, counted when met
                answer = self._take(message)
        finally:
            counts = self.counts
            if control:
                counts.bytes_sent, counts.bytes_received = (counts.bytes_sent + len(data),
                                                            counts.bytes_received + received)
            else:
                counts.bytes_fetched += len(data) + received
        if control:
            counts.exchanges += 1
            if answer is None:
                counts.missed += 1
            else:
                counts.answered += 1
                counts.round_trips.append(time.monotonic() - sent)
        return answer

    def fetch_weights(self, step: int, timeout: float | None = None):
        """The device's learned weights, asked for piece by piece with requests of steps
        `step`, `step + 1`, ... (each within `timeout`, the link's unless given): `(weights
        as a float64 array, diverged, the next unused step)`; a one-line TimeoutError where a
        piece does not come."""
        values: list = []
        total, diverged = None, False
        while total is None or len(values) < total:
            piece = self.exchange(Request(step, len(values)), timeout)
            if piece is None or piece.offset != len(values):
                raise TimeoutError(f"the device did not send its weights from index "
                                   f"{len(values)} (request of step {step})")
            total, diverged = piece.total, piece.diverged
            values += piece.values
            step += 1
        return np.array(values, dtype=np.float64), diverged, step

    def _take(self, message):
        """The answer to `message` among the frames read, the others counted and dropped."""
        kind, read = ANSWERS[type(message)]
        while self._frames:
            frame = self._frames.pop(0)
            if frame.kind != kind:
                continue
            if frame.step in self._answered:
                self.counts.duplicates += 1
            elif frame.step != message.step:
                self.counts.late += 1
            else:
                self._answered.add(frame.step)
                return read(frame)
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
