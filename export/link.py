"""The host's side of a session over the device link (`export.frames`): a handshake, then one
observation out, its answer back, within a deadline, whatever the link does to the bytes in
between, and a watchdog that ends the session when the device is gone.

`HostLink(port, timeout)` works over any port with pyserial's interface: `write(bytes)`,
`read(size)` that returns what came within `port.timeout` seconds (fewer bytes, or none, at
the timeout), a settable `timeout` and, where the port has it, `in_waiting` (pyserial's
`read` waits for all `size` bytes until the timeout: the host asks for the bytes waiting,
or for one, so that an answer is taken when it comes, not at the deadline).
`serial.Serial` is one (a real board, or QEMU's UART on a pty); `PipePort` is another,
over a child process's standard input and output (a device program built for the host).

`handshake(identity)` opens a session: it says hello with the identity the host expects
(`frames.Hello`), again at each deadline while the device starts up, and takes the
device's answer, its own identity; a device that is another program (another task, other
dimensions, arithmetic or learner build) is refused with a one-line `IdentityMismatch`
naming both sides. `exchange(observation)` sends the observation's frame and waits for the
action frame of the same step until the deadline (`timeout` seconds after sending);
`exchange(request)` (a `Request` for the learned weights) waits so for the WEIGHTS frame
of its step, and `fetch_weights` asks for them all, piece by piece. What it meets on the
way is counted, not taken (`LinkCounts`): an answer to an earlier step (late: its deadline
had passed), a second answer to the awaited step (a duplicate), frames and bytes the
reader refused. At the deadline it returns None: a missed deadline, which the caller
handles as an actuator would, holding the previous action. It never waits longer than the
deadline and never returns an answer to another step.

The watchdog: when the device has sent no valid frame for `window` seconds and `misses`
deadlines in a row have passed, the next missed deadline ends the session with a one-line
`LinkLost` naming the device (`name`: its port and baud) and what was last heard from it
(nothing, noise, or its last valid frame and what came after). A device that answers
again within the window goes on as before. A whole frame of another protocol version
(`FrameReader.foreign_version`) ends the session at once (`ProtocolMismatch`): the device
would never understand this host. Each of these is a `runners.stepped.CutShort`, so that a
session's loop keeps the episodes that finished, and a ValueError, a one-line refusal
where nothing had begun; `lost` keeps its line.
"""

import dataclasses
import os
import select
import time

import numpy as np

from lwrl.export.frames import (ACTION, IDENTITY, VERSION, WEIGHTS, Action, FrameReader, Hello,
                                Identity, Observation, Request, Weights)
from lwrl.runners.stepped import CutShort

ANSWERS = {Observation: (ACTION, Action.read), Request: (WEIGHTS, Weights.read),
           Hello: (IDENTITY, Identity.read)}
"""What answers each message: the kind of its frame and how it is read."""
WINDOW = 5.0
"""Seconds without a valid frame after which the watchdog may end a session, by default."""
MISSES = 3
"""Missed deadlines in a row after which the watchdog may end a session, by default."""
READ = 256
"""Bytes asked of a port without `in_waiting` at a time (it returns those there)."""


class LinkLost(CutShort, ValueError):
    """The session cannot go on with this device (the module's docstring)."""


class ProtocolMismatch(LinkLost):
    """The device answers in another version of the link's protocol."""


class IdentityMismatch(LinkLost):
    """The device is another program than the one the host expects."""


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
    bytes_handshake: int = 0
    """Bytes sent and received in the handshake."""
    round_trips: list = dataclasses.field(default_factory=list)
    """Seconds from sending each answered observation to its answer."""


class HostLink:
    """The host's side of the link over `port` (the module's docstring); `timeout`: seconds
    an answer may take; `window` and `misses`: the watchdog's; `name`: the device as the
    watchdog's line names it."""

    def __init__(self, port, timeout: float, window: float = WINDOW, misses: int = MISSES,
                 name: str = "the device"):
        for what, value in (("timeout", timeout), ("the watchdog's window", window)):
            if not value > 0:
                raise ValueError(f"{what} must be a positive number of seconds; got {value!r}")
        if isinstance(misses, bool) or not isinstance(misses, int) or misses < 1:
            raise ValueError(f"the watchdog's missed deadlines must be a whole number, at "
                             f"least 1; got {misses!r}")
        self.port, self.timeout, self.window, self.misses = port, float(timeout), window, misses
        self.name = name
        self.reader = FrameReader()
        self.counts = LinkCounts()
        self.lost: str | None = None
        """The line that ended the session, if one did."""
        self._answered: set = set()
        self._frames: list = []
        self._heard_at = time.monotonic()  # the window opens with the link
        self._in_row = 0  # missed deadlines in a row
        self._since = 0  # bytes since the last valid frame
        self._last = None  # the last valid frame

    def handshake(self, expected: Identity, step: int = 0) -> Identity:
        """Say hello with the identity this host expects (step `step`), again at each
        deadline, until the device answers with its own or the watchdog ends the wait;
        the device's identity, or a one-line `IdentityMismatch` naming both sides."""
        answer = None
        while answer is None:
            answer = self.exchange(Hello(step, expected))
        if answer != expected:
            raise self._lose(IdentityMismatch, f"{self.name} runs {answer.describe()}; this "
                                               f"host expects {expected.describe()}")
        return answer

    def exchange(self, message: Observation | Request | Hello, timeout: float | None = None):
        """Send `message`; its answer (an `Action`, `Weights` for a `Request`, an
        `Identity` for a `Hello`), or None at the deadline, `timeout` seconds (the link's
        unless given) after sending (see the module); the watchdog's `LinkLost` where the
        device is gone."""
        data = message.frame().encode()
        sent = time.monotonic()
        self.port.write(data)
        received = 0
        deadline = sent + (self.timeout if timeout is None else timeout)
        try:
            answer = self._take(message)
            while answer is None and time.monotonic() < deadline:
                self.port.timeout = max(deadline - time.monotonic(), 0.0)
                chunk = self.port.read(getattr(self.port, "in_waiting", READ) or 1)
                received += len(chunk)
                self._hear(chunk)
                if time.monotonic() >= deadline:
                    break  # what came after the deadline is late, counted when met
                answer = self._take(message)
        finally:
            self._count(message, len(data), received)
        if isinstance(message, Observation):
            self.counts.exchanges += 1
            if answer is None:
                self.counts.missed += 1
            else:
                self.counts.answered += 1
                self.counts.round_trips.append(time.monotonic() - sent)
        self._in_row = 0 if answer is not None else self._in_row + 1
        if answer is None:
            self._watch()
        return answer

    def fetch_weights(self, step: int, timeout: float | None = None):
        """The device's learned weights, asked for piece by piece with requests of steps
        `step`, `step + 1`, ... (each within `timeout`, the link's unless given; a piece
        that has not come by then asked for again with the same step, so that it is taken
        whenever it comes, until the watchdog ends the wait): `(weights as a float64 array,
        diverged, the next unused step)`."""
        values: list = []
        total, diverged = None, False
        while total is None or len(values) < total:
            piece = self.exchange(Request(step, len(values)), timeout)
            if piece is None:
                continue
            step += 1
            if piece.offset != len(values):
                raise self._lose(LinkLost, f"{self.name} sent weights from index {piece.offset} "
                                           f"when asked for them from {len(values)}")
            total, diverged = piece.total, piece.diverged
            values += piece.values
        return np.array(values, dtype=np.float64), diverged, step

    def _hear(self, chunk: bytes) -> None:
        """Feed what came to the reader; note when a valid frame came, and the bytes since."""
        frames = self.reader.feed(chunk)
        if self.reader.foreign_version is not None:
            raise self._lose(ProtocolMismatch, f"{self.name} answers in version "
                                               f"{self.reader.foreign_version} of the link's "
                                               f"protocol; this host speaks version {VERSION}")
        if frames:
            self._heard_at, self._last = time.monotonic(), frames[-1]
            self._since = len(self.reader.buffer)
        else:
            self._since += len(chunk)
        self._frames += frames

    def _watch(self) -> None:
        """After a missed deadline: end the session if the watchdog's both limits are met."""
        silent = time.monotonic() - self._heard_at
        if self._in_row >= self.misses and silent >= self.window:
            raise self._lose(LinkLost, f"{self.name} has sent no valid frame for {silent:.1f} s "
                                       f"and missed {self._in_row} deadlines in a row (the "
                                       f"watchdog ends a session after {self.window:g} s and "
                                       f"{self.misses}); {self._heard()}")

    def _heard(self) -> str:
        """What was last heard from the device, for the watchdog's line."""
        noise = (f"noise ({self._since} bytes, no valid frame among them)" if self._since
                 else "nothing")
        if self._last is None:
            return f"heard: {noise}"
        return f"last heard: {self._last.describe()}, then {noise}"

    def _lose(self, kind, line: str) -> LinkLost:
        """The `kind` of `LinkLost` that ends the session with `line`, kept in `lost`."""
        self.lost = line
        return kind(line)

    def _count(self, message, sent: int, received: int) -> None:
        """The bytes of an exchange, in the counts of its kind of message."""
        counts = self.counts
        if isinstance(message, Observation):
            counts.bytes_sent, counts.bytes_received = (counts.bytes_sent + sent,
                                                        counts.bytes_received + received)
        elif isinstance(message, Request):
            counts.bytes_fetched += sent + received
        else:
            counts.bytes_handshake += sent + received

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
