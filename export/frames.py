"""The frames of the device link: a learner on a board and a plant on a host, over a byte
stream (a serial port, QEMU's UART), as MAVLink frames its messages.

Every frame, byte by byte (multi-byte numbers little-endian; docs/guide/device-link.md
draws it):

    offset  size  field
    0       1     MAGIC, 0xA5: where a frame starts
    1       1     VERSION of the protocol, 1
    2       1     kind: OBSERVATION (1, host to device) or ACTION (2, device to host)
    3       1     payload length L (at most MAX_PAYLOAD)
    4       4     step: the plant's step counter, uint32 (a frame's identity: an answer
                  carries the step of the observation it answers, so a duplicate or a late
                  answer is told from the awaited one)
    8       L     payload
    8 + L   2     CRC-16/CCITT-FALSE (polynomial 0x1021, initial 0xFFFF, no reflection, no
                  final XOR) over bytes 1 .. 7 + L: everything but MAGIC and the CRC

Payloads, every real an IEEE 754 binary64 (a double, so every value the plant computes
goes over exactly, NaN and infinities included):

- OBSERVATION: flags (uint8: bit 0 START, the observation starts an episode; bit 1
  TERMINAL, it is a terminal state; bit 2 TRUNCATED, the episode was cut there), the
  reward of the transition into it (double; 0 at a start), then the d observed variables
  (d doubles): L = 9 + 8 d.
- ACTION: a discrete action's index (kind byte 0, then int32: L = 5) or a continuous
  action in [-1, 1] (kind byte 1, then a double: L = 9), `tasks.commands`' convention.
- REQUEST (3, host to device, between episodes): the learned weights from index `offset`
  (uint32: L = 4).
- WEIGHTS (4, device to host, the answer with the request's step): the number of weights
  (uint32), the offset of the first one sent (uint32), the diverged flag (uint8: 1 once the
  learner froze its weights), then k of them (k doubles, 1 <= k <= WEIGHTS_PER_FRAME, in
  the learner's order, `lwrl_weights()`): L = 9 + 8 k. The host asks from offset 0 on
  until it has them all.

A reader (`FrameReader`) takes bytes as they come and gives back whole frames. A byte
that does not start a frame, or a frame whose CRC, version, kind or length is wrong, is
skipped, counted and named (`FrameReader.errors`), and the reader looks for the next
MAGIC from the byte after the bad frame's start: one corrupted frame costs that frame,
never the stream. A whole frame of another protocol version (its CRC right) is skipped
too, and its version kept (`FrameReader.foreign_version`): the device speaks another
protocol, which the host says in one line rather than wait for answers it cannot read. A frame cut short waits for its missing bytes; the host's timeout, not
the reader, decides when they are not coming; a length that no frame of its kind has is
refused at once.

The device's side is C99 with static memory only, `lwrl_link.h` and `lwrl_link.c`
(`write_c` copies them out; package data under `templates/link/`): the same layout, a
reader fed one byte at a time that takes observations of at most `LWRL_LINK_MAX_DIM`
variables (8 unless defined otherwise), and the action frames. Where resynchronising leaves
a whole frame behind the refused one, the C reader gives it with the next byte.
"""

import dataclasses
import os
import struct
from importlib import resources

MAGIC = 0xA5
VERSION = 1
OBSERVATION, ACTION, REQUEST, WEIGHTS = 1, 2, 3, 4
KINDS = {OBSERVATION: "observation", ACTION: "action", REQUEST: "request", WEIGHTS: "weights"}
WEIGHTS_PER_FRAME = 30
"""Weights a WEIGHTS frame carries at most (9 + 8 * 30 = 249 bytes of payload)."""
START, TERMINAL, TRUNCATED = 1, 2, 4
"""The OBSERVATION flags' bits."""
DISCRETE, CONTINUOUS = 0, 1
"""An ACTION's kind byte."""
HEADER = struct.Struct("<BBBBI")
"""MAGIC, VERSION, kind, payload length, step."""
CRC = struct.Struct("<H")
MAX_PAYLOAD = 255
MAX_STEP = 2 ** 32 - 1


def crc16(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of `data` (its check value: 0x29B1 for b"123456789")."""
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


@dataclasses.dataclass(frozen=True)
class Frame:
    """One frame: its kind, the step it belongs to and its payload's bytes."""

    kind: int
    step: int
    payload: bytes

    def encode(self) -> bytes:
        """The frame's bytes (the module's layout); a one-line ValueError for a kind, step
        or payload the layout cannot carry."""
        if self.kind not in KINDS:
            raise ValueError(f"frame kind must be one of {sorted(KINDS)}; got {self.kind!r}")
        if not (isinstance(self.step, int) and 0 <= self.step <= MAX_STEP):
            raise ValueError(f"step must be an integer in 0..{MAX_STEP}; got {self.step!r}")
        if len(self.payload) > MAX_PAYLOAD:
            raise ValueError(f"a payload holds at most {MAX_PAYLOAD} bytes; got {len(self.payload)}")
        body = HEADER.pack(MAGIC, VERSION, self.kind, len(self.payload), self.step)[1:] + self.payload
        return bytes([MAGIC]) + body + CRC.pack(crc16(body))


@dataclasses.dataclass(frozen=True)
class Observation:
    """What the host sends each step: the observation, the reward of the transition into
    it, and the episode's flags."""

    step: int
    observation: tuple
    reward: float = 0.0
    start: bool = False
    terminal: bool = False
    truncated: bool = False

    def frame(self) -> Frame:
        flags = START * self.start | TERMINAL * self.terminal | TRUNCATED * self.truncated
        values = tuple(float(x) for x in self.observation)
        payload = struct.pack(f"<Bd{len(values)}d", flags, float(self.reward), *values)
        return Frame(OBSERVATION, self.step, payload)

    @classmethod
    def read(cls, frame: Frame) -> "Observation":
        """The observation a frame carries; a one-line ValueError where it carries none."""
        size = len(frame.payload) - 9
        if frame.kind != OBSERVATION or size < 0 or size % 8:
            raise ValueError(f"not an observation frame (kind {frame.kind}, payload of "
                             f"{len(frame.payload)} bytes; an observation's is 9 + 8 d)")
        flags, reward, *values = struct.unpack(f"<Bd{size // 8}d", frame.payload)
        return cls(frame.step, tuple(values), reward, bool(flags & START),
                   bool(flags & TERMINAL), bool(flags & TRUNCATED))


@dataclasses.dataclass(frozen=True)
class Action:
    """What the device answers: a discrete action's index, or a continuous action."""

    step: int
    value: int | float

    def frame(self) -> Frame:
        if isinstance(self.value, bool) or not isinstance(self.value, (int, float)):
            raise ValueError(f"an action is an index or a number; got {self.value!r}")
        if isinstance(self.value, int):
            return Frame(ACTION, self.step, struct.pack("<Bi", DISCRETE, self.value))
        return Frame(ACTION, self.step, struct.pack("<Bd", CONTINUOUS, self.value))

    @classmethod
    def read(cls, frame: Frame) -> "Action":
        """The action a frame carries; a one-line ValueError where it carries none."""
        payload = frame.payload
        if frame.kind == ACTION and len(payload) == 5 and payload[0] == DISCRETE:
            return cls(frame.step, struct.unpack("<i", payload[1:])[0])
        if frame.kind == ACTION and len(payload) == 9 and payload[0] == CONTINUOUS:
            return cls(frame.step, struct.unpack("<d", payload[1:])[0])
        raise ValueError(f"not an action frame (kind {frame.kind}, payload of {len(payload)} "
                         "bytes; an action's is 5, an index, or 9, a number)")


def fits(kind: int, length: int) -> bool:
    """Whether a payload of `length` bytes can be a frame of `kind`'s: the reader refuses
    any other at once rather than wait for bytes a corrupted length promises."""
    if kind == ACTION:
        return length in (5, 9)
    if kind == REQUEST:
        return length == 4
    values = (length - 9) // 8
    return length >= 9 and (length - 9) % 8 == 0 and (kind == OBSERVATION
                                                      or 1 <= values <= WEIGHTS_PER_FRAME)


@dataclasses.dataclass(frozen=True)
class Request:
    """The host's request for the learned weights from index `offset` on."""

    step: int
    offset: int = 0

    def frame(self) -> Frame:
        return Frame(REQUEST, self.step, struct.pack("<I", self.offset))


@dataclasses.dataclass(frozen=True)
class Weights:
    """A piece of the device's learned weights: `values` from index `offset` of `total`."""

    step: int
    total: int
    offset: int
    diverged: bool
    values: tuple

    def frame(self) -> Frame:
        return Frame(WEIGHTS, self.step, struct.pack(
            f"<IIB{len(self.values)}d", self.total, self.offset, self.diverged, *self.values))

    @classmethod
    def read(cls, frame: Frame) -> "Weights":
        """The weights a frame carries; a one-line ValueError where it carries none."""
        if frame.kind != WEIGHTS or not fits(WEIGHTS, len(frame.payload)):
            raise ValueError(f"not a weights frame (kind {frame.kind}, payload of "
                             f"{len(frame.payload)} bytes; a weights frame's is 9 + 8 k, "
                             f"1 <= k <= {WEIGHTS_PER_FRAME})")
        total, offset, diverged, *values = struct.unpack(
            f"<IIB{(len(frame.payload) - 9) // 8}d", frame.payload)
        return cls(frame.step, total, offset, bool(diverged), tuple(values))


class FrameReader:
    """Whole frames out of a byte stream fed in pieces (the module's docstring)."""

    def __init__(self) -> None:
        self.buffer = bytearray()
        self.errors: list[str] = []
        """One line per byte run skipped or frame refused, in order."""
        self.skipped = 0
        """Bytes skipped so far."""
        self.foreign_version: int | None = None
        """The version of the last whole frame of another protocol version met, if any."""

    def feed(self, data: bytes) -> list[Frame]:
        """Take `data`; return the frames it completes, in order."""
        self.buffer += data
        frames = []
        while True:
            start = self.buffer.find(MAGIC)
            if start < 0:
                self._skip(len(self.buffer), "no frame start")
                return frames
            if start:
                self._skip(start, "bytes before a frame start")
            if len(self.buffer) < HEADER.size:
                return frames
            _, version, kind, length, step = HEADER.unpack_from(self.buffer)
            end = HEADER.size + length + CRC.size
            if version != VERSION and self._whole_frame(length):
                self.foreign_version = version
                self._skip(end, f"a whole frame of protocol version {version} (this side "
                                f"speaks version {VERSION})")
                continue
            plausible = kind in KINDS and fits(kind, length)
            if version != VERSION and plausible and len(self.buffer) < end:
                return frames  # perhaps another version's frame: its CRC will tell
            if version != VERSION or not plausible:
                self._skip(1, f"a frame start with version {version}, kind {kind} and "
                              f"length {length} (expected version {VERSION}, a kind of "
                              f"{sorted(KINDS)} and a length that kind has)")
                continue
            if len(self.buffer) < end:
                return frames
            body = bytes(self.buffer[1:HEADER.size + length])
            (crc,) = CRC.unpack_from(self.buffer, HEADER.size + length)
            if crc != crc16(body):
                self._skip(1, f"the {KINDS[kind]} frame of step {step}: CRC {crc:#06x}, its "
                              f"bytes give {crc16(body):#06x}")
                continue
            frames.append(Frame(kind, step, bytes(self.buffer[HEADER.size:HEADER.size + length])))
            del self.buffer[:end]

    def _whole_frame(self, length: int) -> bool:
        """Whether the buffer starts with a whole frame of payload `length` whose CRC is
        right, whatever its version and kind."""
        end = HEADER.size + length + CRC.size
        if len(self.buffer) < end:
            return False
        (crc,) = CRC.unpack_from(self.buffer, HEADER.size + length)
        return crc == crc16(bytes(self.buffer[1:HEADER.size + length]))

    def _skip(self, count: int, why: str) -> None:
        if count:
            self.errors.append(f"skipped {count} byte{'s' if count != 1 else ''}: {why}")
            self.skipped += count
            del self.buffer[:count]


C_FILES = ("lwrl_link.h", "lwrl_link.c")
"""The device's side of the link (the module's docstring)."""


def write_c(out_dir) -> list:
    """Copy the device's side of the link (`C_FILES`) into `out_dir` (created if needed);
    the paths written."""
    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for name in C_FILES:
        path = os.path.join(out_dir, name)
        with open(path, "w") as file:
            file.write(resources.files(__package__).joinpath("templates", "link", name).read_text())
        paths.append(path)
    return paths
