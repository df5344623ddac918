"""The frames of the device link: a learner on a board and a plant on a host, over a byte
stream (a serial port, QEMU's UART), as MAVLink frames its messages.

Every frame, byte by byte (multi-byte numbers little-endian; docs/guide/device-link.md
draws it):

    offset  size  field
    0       1     MAGIC, 0xA5: where a frame starts
    1       1     VERSION of the protocol, 2
    2       1     kind: OBSERVATION (1, host to device), ACTION (2, device to host),
                  REQUEST (3), WEIGHTS (4), HELLO (5, host to device), IDENTITY (6,
                  device to host)
    3       1     payload length L (at most MAX_PAYLOAD)
    4       4     step: the plant's step counter, uint32 (a frame's identity: an answer
                  carries the step of the message it answers, so a duplicate or a late
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
- REQUEST (host to device, between episodes): the learned weights from index `offset`
  (uint32: L = 4).
- WEIGHTS (device to host, the answer with the request's step): the number of weights
  (uint32), the offset of the first one sent (uint32), the diverged flag (uint8: 1 once the
  learner froze its weights), then k of them (k doubles, 1 <= k <= WEIGHTS_PER_FRAME, in
  the learner's order, `lwrl_weights()`): L = 9 + 8 k. The host asks from offset 0 on
  until it has them all.
- HELLO (host to device, a session's first message) and IDENTITY (device to host, the
  answer with the hello's step) carry an `Identity`, the one what the host expects, the
  other what the device is: the observed variables (uint8), the action's kind (uint8,
  DISCRETE or CONTINUOUS) and count (uint16: discrete actions, or a continuous action's
  dimension), the learner's arithmetic (uint8, `ARITHMETICS`: 0 double, 1 float), the
  learner's build (uint64: `export.learner.build_digest` of its C source), then the task's
  name (ASCII, at most MAX_TASK bytes): L = 13 + its length. The protocol's version is the
  frame's own. A device whose identity is not the host's expectation is refused
  (`export.link`); a device given a hello that is not its identity acts on no observation
  until a hello that is.

The layout is written once, here: each fixed run of fields is a `Layout` (its fields'
names and `struct` codes), from which the host packs and reads its frames and `c_layout`
writes the C header's constants (`LWRL_LINK_<LAYOUT>_SIZE` and each field's offset), so
that the C side's sizes and offsets are these.

A reader (`FrameReader`) takes bytes as they come and gives back whole frames. A byte
that does not start a frame, or a frame whose CRC, version, kind or length is wrong, is
skipped, counted and named (`FrameReader.errors`), and the reader looks for the next
MAGIC from the byte after the bad frame's start: one corrupted frame costs that frame,
never the stream. A whole frame of another protocol version (its CRC right) is skipped
too, and its version kept (`FrameReader.foreign_version`): the device speaks another
protocol, which the host says in one line rather than wait for answers it cannot read. A
frame cut short waits for its missing bytes; the host's watchdog, not the reader, decides
when they are not coming; a length that no frame of its kind has is refused at once.

The device's side is C99 with static memory only, `lwrl_link.h` and `lwrl_link.c`
(`write_c` writes them out; package data under `templates/link/`, the header's layout
filled in from this module): the same layout, a reader fed one byte at a time that takes
observations of at most `LWRL_LINK_MAX_DIM` variables (8 unless defined otherwise),
requests and hellos, and the action, weights and identity frames. Where resynchronising
leaves a whole frame behind the refused one, the C reader gives it with the next byte.
"""

import dataclasses
import os
import string
import struct
from importlib import resources

MAGIC = 0xA5
VERSION = 2
OBSERVATION, ACTION, REQUEST, WEIGHTS, HELLO, IDENTITY = 1, 2, 3, 4, 5, 6
KINDS = {OBSERVATION: "observation", ACTION: "action", REQUEST: "request", WEIGHTS: "weights",
         HELLO: "hello", IDENTITY: "identity"}
WEIGHTS_PER_FRAME = 30
"""Weights a WEIGHTS frame carries at most (9 + 8 * 30 = 249 bytes of payload)."""
MAX_TASK = 64
"""Bytes of a task's name an identity carries at most."""
START, TERMINAL, TRUNCATED = 1, 2, 4
"""The OBSERVATION flags' bits."""
DISCRETE, CONTINUOUS = 0, 1
"""An ACTION's kind byte, and an identity's kind of action."""
ARITHMETICS = ("double", "float")
"""An identity's arithmetic byte: the learner's reals (`lwrl_real`), by index."""
MAX_PAYLOAD = 255
MAX_STEP = 2 ** 32 - 1


class Layout(struct.Struct):
    """A fixed run of little-endian fields, `(name, struct code)` each: packed and read as a
    `struct.Struct`, and written into the C header as its size and its fields' offsets."""

    def __init__(self, name: str, *fields: tuple):
        super().__init__("<" + "".join(code for _, code in fields))
        self.name, self.fields = name, fields

    def offsets(self) -> dict:
        """Each field's offset from the layout's start."""
        found, offset = {}, 0
        for field, code in self.fields:
            found[field] = offset
            offset += struct.calcsize("<" + code)
        return found


HEADER = Layout("HEADER", ("magic", "B"), ("version", "B"), ("kind", "B"),
                ("payload_length", "B"), ("step", "I"))
OBSERVATION_PART = Layout("OBSERVATION", ("flags", "B"), ("reward", "d"))
"""An observation's payload before its d observed variables."""
ACTION_INDEX = Layout("ACTION_INDEX", ("kind", "B"), ("action", "i"))
ACTION_VALUE = Layout("ACTION_VALUE", ("kind", "B"), ("action", "d"))
REQUEST_PART = Layout("REQUEST", ("offset", "I"))
WEIGHTS_PART = Layout("WEIGHTS", ("total", "I"), ("offset", "I"), ("diverged", "B"))
"""A weights frame's payload before its k weights."""
IDENTITY_PART = Layout("IDENTITY", ("observations", "B"), ("action_kind", "B"),
                       ("actions", "H"), ("arithmetic", "B"), ("build", "Q"))
"""A hello's or an identity's payload before the task's name."""
REAL = Layout("REAL", ("value", "d"))
CRC = Layout("CRC", ("value", "H"))
LAYOUTS = (HEADER, OBSERVATION_PART, ACTION_INDEX, ACTION_VALUE, REQUEST_PART, WEIGHTS_PART,
           IDENTITY_PART, REAL, CRC)


def frame_size(payload: int) -> int:
    """Bytes of a frame whose payload has `payload` bytes."""
    return HEADER.size + payload + CRC.size


def action_payload(continuous: bool) -> int:
    """Bytes of an action frame's payload: a continuous action's, or an index's."""
    return (ACTION_VALUE if continuous else ACTION_INDEX).size


def step_bytes(observed: int, continuous: bool) -> int:
    """Bytes one control step puts on the link: the observation of `observed` variables
    out, its action back."""
    return (frame_size(OBSERVATION_PART.size + REAL.size * observed)
            + frame_size(action_payload(continuous)))


def reals(data: bytes) -> tuple:
    """The doubles of `data` (a multiple of 8 bytes)."""
    return struct.unpack(f"<{len(data) // REAL.size}d", data)


def packed_reals(values) -> bytes:
    """`values` as doubles, little-endian."""
    return struct.pack(f"<{len(values)}d", *values)


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

    def describe(self) -> str:
        """`an action frame of step 7`."""
        kind = KINDS[self.kind]
        return f"{'an' if kind[0] in 'aeiou' else 'a'} {kind} frame of step {self.step}"


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
        payload = (OBSERVATION_PART.pack(flags, float(self.reward))
                   + packed_reals(tuple(float(x) for x in self.observation)))
        return Frame(OBSERVATION, self.step, payload)

    @classmethod
    def read(cls, frame: Frame) -> "Observation":
        """The observation a frame carries; a one-line ValueError where it carries none."""
        if frame.kind != OBSERVATION or not fits(OBSERVATION, len(frame.payload)):
            raise ValueError(f"not an observation frame (kind {frame.kind}, payload of "
                             f"{len(frame.payload)} bytes; an observation's is 9 + 8 d)")
        flags, reward = OBSERVATION_PART.unpack_from(frame.payload)
        return cls(frame.step, reals(frame.payload[OBSERVATION_PART.size:]), reward,
                   bool(flags & START), bool(flags & TERMINAL), bool(flags & TRUNCATED))


@dataclasses.dataclass(frozen=True)
class Action:
    """What the device answers: a discrete action's index, or a continuous action."""

    step: int
    value: int | float

    def frame(self) -> Frame:
        if isinstance(self.value, bool) or not isinstance(self.value, (int, float)):
            raise ValueError(f"an action is an index or a number; got {self.value!r}")
        if isinstance(self.value, int):
            return Frame(ACTION, self.step, ACTION_INDEX.pack(DISCRETE, self.value))
        return Frame(ACTION, self.step, ACTION_VALUE.pack(CONTINUOUS, self.value))

    @classmethod
    def read(cls, frame: Frame) -> "Action":
        """The action a frame carries; a one-line ValueError where it carries none."""
        payload = frame.payload
        for kind, layout in ((DISCRETE, ACTION_INDEX), (CONTINUOUS, ACTION_VALUE)):
            if frame.kind == ACTION and len(payload) == layout.size and payload[0] == kind:
                return cls(frame.step, layout.unpack(payload)[1])
        raise ValueError(f"not an action frame (kind {frame.kind}, payload of {len(payload)} "
                         f"bytes; an action's is {ACTION_INDEX.size}, an index, or "
                         f"{ACTION_VALUE.size}, a number)")


def fits(kind: int, length: int) -> bool:
    """Whether a payload of `length` bytes can be a frame of `kind`'s: the reader refuses
    any other at once rather than wait for bytes a corrupted length promises."""
    if kind == ACTION:
        return length in (ACTION_INDEX.size, ACTION_VALUE.size)
    if kind == REQUEST:
        return length == REQUEST_PART.size
    if kind in (HELLO, IDENTITY):
        return IDENTITY_PART.size <= length <= IDENTITY_PART.size + MAX_TASK
    fixed = OBSERVATION_PART.size if kind == OBSERVATION else WEIGHTS_PART.size
    values, rest = divmod(length - fixed, REAL.size)
    return length >= fixed and rest == 0 and (kind == OBSERVATION
                                              or 1 <= values <= WEIGHTS_PER_FRAME)


@dataclasses.dataclass(frozen=True)
class Request:
    """The host's request for the learned weights from index `offset` on."""

    step: int
    offset: int = 0

    def frame(self) -> Frame:
        return Frame(REQUEST, self.step, REQUEST_PART.pack(self.offset))


@dataclasses.dataclass(frozen=True)
class Weights:
    """A piece of the device's learned weights: `values` from index `offset` of `total`."""

    step: int
    total: int
    offset: int
    diverged: bool
    values: tuple

    def frame(self) -> Frame:
        return Frame(WEIGHTS, self.step, WEIGHTS_PART.pack(self.total, self.offset, self.diverged)
                     + packed_reals(self.values))

    @classmethod
    def read(cls, frame: Frame) -> "Weights":
        """The weights a frame carries; a one-line ValueError where it carries none."""
        if frame.kind != WEIGHTS or not fits(WEIGHTS, len(frame.payload)):
            raise ValueError(f"not a weights frame (kind {frame.kind}, payload of "
                             f"{len(frame.payload)} bytes; a weights frame's is 9 + 8 k, "
                             f"1 <= k <= {WEIGHTS_PER_FRAME})")
        total, offset, diverged = WEIGHTS_PART.unpack_from(frame.payload)
        return cls(frame.step, total, offset, bool(diverged),
                   reals(frame.payload[WEIGHTS_PART.size:]))


@dataclasses.dataclass(frozen=True)
class Identity:
    """What a device program is, as the handshake says it (the module's HELLO and
    IDENTITY): the task, its observed variables, the action's kind and count, the
    learner's arithmetic (a name of `ARITHMETICS`) and build."""

    task: str
    observations: int
    action_kind: int
    actions: int
    arithmetic: str
    build: int

    def payload(self) -> bytes:
        """The payload of a HELLO or IDENTITY frame; a one-line ValueError for a field the
        layout cannot carry."""
        name = self.task.encode("ascii", "replace")
        if len(name) > MAX_TASK:
            raise ValueError(f"an identity's task name holds at most {MAX_TASK} bytes; got "
                             f"{self.task!r}")
        if self.arithmetic not in ARITHMETICS:
            raise ValueError(f"an identity's arithmetic is one of {', '.join(ARITHMETICS)}; "
                             f"got {self.arithmetic!r}")
        return IDENTITY_PART.pack(self.observations, self.action_kind, self.actions,
                                  ARITHMETICS.index(self.arithmetic), self.build) + name

    @classmethod
    def read(cls, frame: Frame) -> "Identity":
        """The identity a HELLO or IDENTITY frame carries; a one-line ValueError where it
        carries none. An arithmetic code this side does not know is named by its number."""
        if frame.kind not in (HELLO, IDENTITY) or not fits(frame.kind, len(frame.payload)):
            raise ValueError(f"not a hello or identity frame (kind {frame.kind}, payload of "
                             f"{len(frame.payload)} bytes)")
        observations, action_kind, actions, code, build = IDENTITY_PART.unpack_from(frame.payload)
        arithmetic = ARITHMETICS[code] if code < len(ARITHMETICS) else f"arithmetic {code}"
        task = frame.payload[IDENTITY_PART.size:].decode("ascii", "replace")
        return cls(task, observations, action_kind, actions, arithmetic, build)

    def describe(self) -> str:
        """`pendulum.swingup (3 observed variables, 3 discrete actions, double, learner
        build 0123456789abcdef)`."""
        actions = (f"{self.actions} discrete actions" if self.action_kind == DISCRETE
                   else f"a continuous action of {self.actions} dimensions"
                   if self.action_kind == CONTINUOUS else f"action kind {self.action_kind}")
        return (f"{self.task} ({self.observations} observed variables, {actions}, "
                f"{self.arithmetic}, learner build {self.build:016x})")


@dataclasses.dataclass(frozen=True)
class Hello:
    """The host's first message of a session: the identity it expects of the device."""

    step: int
    identity: Identity

    def frame(self) -> Frame:
        return Frame(HELLO, self.step, self.identity.payload())


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
            end = frame_size(length)
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
        end = frame_size(length)
        if len(self.buffer) < end:
            return False
        (crc,) = CRC.unpack_from(self.buffer, HEADER.size + length)
        return crc == crc16(bytes(self.buffer[1:HEADER.size + length]))

    def _skip(self, count: int, why: str) -> None:
        if count:
            self.errors.append(f"skipped {count} byte{'s' if count != 1 else ''}: {why}")
            self.skipped += count
            del self.buffer[:count]


def c_constants() -> dict:
    """The C header's constants (`LWRL_LINK_` + each name): the protocol's numbers, and each
    `Layout`'s size (`<LAYOUT>_SIZE`) and, where it has several fields, their offsets
    (`<LAYOUT>_<FIELD>`)."""
    constants = {"MAGIC": MAGIC, "VERSION": VERSION,
                 **{name.upper(): kind for kind, name in KINDS.items()},
                 "START": START, "TERMINAL": TERMINAL, "TRUNCATED": TRUNCATED,
                 "DISCRETE": DISCRETE, "CONTINUOUS": CONTINUOUS,
                 **{name.upper(): code for code, name in enumerate(ARITHMETICS)},
                 "WEIGHTS_PER_FRAME": WEIGHTS_PER_FRAME, "MAX_TASK": MAX_TASK}
    for layout in LAYOUTS:
        constants[f"{layout.name}_SIZE"] = layout.size
        if len(layout.fields) > 1:
            constants.update({f"{layout.name}_{field.upper()}": offset
                              for field, offset in layout.offsets().items()})
    return constants


def c_layout() -> str:
    """The C header's constants (`c_constants`) as `#define` lines."""
    return "\n".join(f"#define LWRL_LINK_{name} {value}" for name, value in c_constants().items())


C_FILES = ("lwrl_link.h", "lwrl_link.c")
"""The device's side of the link (the module's docstring)."""


def c_text(name: str) -> str:
    """The text of the device's file `name` (`C_FILES`), the header's layout filled in."""
    folder = resources.files(__package__).joinpath("templates", "link")
    if name.endswith(".h"):
        return string.Template(folder.joinpath(f"{name}.in").read_text()).substitute(
            layout=c_layout())
    return folder.joinpath(name).read_text()


def write_c(out_dir) -> list:
    """Write the device's side of the link (`C_FILES`) into `out_dir` (created if needed);
    the paths written."""
    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for name in C_FILES:
        path = os.path.join(out_dir, name)
        with open(path, "w") as file:
            file.write(c_text(name))
        paths.append(path)
    return paths
