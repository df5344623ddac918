"""The device link's frames (`export.frames`): the layout byte by byte, exact doubles, and a
reader that loses no more than a bad frame."""

import math
import struct

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from lwrl.export import frames as layout
from lwrl.export.frames import (ACTION, CONTINUOUS, DISCRETE, HELLO, IDENTITY, MAGIC,
                                OBSERVATION, Action, Frame, FrameReader, Hello, Identity,
                                Observation, Request, Weights, crc16)

DOUBLES = st.floats(allow_nan=True, allow_infinity=True, width=64)


def same_double(a: float, b: float) -> bool:
    return struct.pack("<d", a) == struct.pack("<d", b)


def test_the_crc_is_ccitt_false():
    assert crc16(b"123456789") == 0x29B1  # the catalogue's check value


def test_an_action_frame_byte_by_byte():
    data = Action(7, 1).frame().encode()
    assert data[:8] == bytes([MAGIC, 2, ACTION, 5, 7, 0, 0, 0])
    assert data[8:13] == bytes([0, 1, 0, 0, 0])  # discrete, index 1 (int32)
    assert data[13:] == struct.pack("<H", crc16(data[1:13])) and len(data) == 15
    continuous = Action(2 ** 32 - 1, -0.25).frame().encode()
    assert continuous[:8] == bytes([MAGIC, 2, ACTION, 9, 255, 255, 255, 255])
    assert continuous[8:17] == bytes([1]) + struct.pack("<d", -0.25)


def test_an_observation_frame_byte_by_byte():
    data = Observation(3, (0.5, -2.0), reward=-1.0, start=False, terminal=True).frame().encode()
    assert data[:8] == bytes([MAGIC, 2, OBSERVATION, 25, 3, 0, 0, 0])
    assert data[8] == 2 and data[9:33] == struct.pack("<3d", -1.0, 0.5, -2.0)
    assert len(data) == 35


@given(st.integers(0, 2 ** 32 - 1), st.lists(DOUBLES, min_size=1, max_size=8), DOUBLES,
       st.booleans(), st.booleans(), st.booleans())
def test_observations_go_over_exactly(step, values, reward, start, terminal, truncated):
    sent = Observation(step, tuple(values), reward, start, terminal, truncated)
    frames = FrameReader().feed(sent.frame().encode())
    got = Observation.read(frames[0])
    assert len(frames) == 1 and (got.step, got.start, got.terminal, got.truncated) == (
        step, start, terminal, truncated)
    assert same_double(got.reward, reward)
    assert all(same_double(a, b) for a, b in zip(got.observation, values))


@given(st.integers(0, 2 ** 32 - 1), st.one_of(st.integers(-2 ** 31, 2 ** 31 - 1), DOUBLES))
def test_actions_go_over_exactly(step, value):
    got = Action.read(FrameReader().feed(Action(step, value).frame().encode())[0])
    assert got.step == step and type(got.value) is type(value)
    assert got.value == value or same_double(got.value, value)


def test_an_identity_frame_byte_by_byte():
    """A hello and an identity carry the same payload: observed variables, the action's kind
    and count, the arithmetic, the learner's build, then the task's name."""
    identity = Identity("pendulum.swingup", 3, DISCRETE, 5, "float", 0x0102030405060708)
    data = Hello(0, identity).frame().encode()
    assert data[:8] == bytes([MAGIC, 2, HELLO, 13 + 16, 0, 0, 0, 0])
    assert data[8:13] == bytes([3, DISCRETE, 5, 0, 1])  # 3, discrete, 5 (uint16), float
    assert data[13:21] == bytes([8, 7, 6, 5, 4, 3, 2, 1]) and data[21:37] == b"pendulum.swingup"
    answer = Frame(IDENTITY, 0, identity.payload())
    assert Identity.read(FrameReader().feed(answer.encode())[0]) == identity
    other = Identity("cartpole.balance", 5, CONTINUOUS, 1, "double", 2)
    assert other.describe() == ("cartpole.balance (5 observed variables, a continuous action "
                                "of 1 dimensions, double, learner build 0000000000000002)")


def test_an_identity_that_the_layout_cannot_carry_is_one_line():
    for identity, words in ((Identity("x" * 65, 1, DISCRETE, 2, "float", 0), "at most 64"),
                            (Identity("x", 1, DISCRETE, 2, "half", 0), "arithmetic is one of")):
        try:
            identity.payload()
        except ValueError as error:
            assert words in str(error) and "\n" not in str(error)
        else:
            raise AssertionError(f"no error for {words}")


def test_sizes_come_from_the_layout():
    """A control step's bytes, the baud rate's base: the pendulum's 3 variables take 43 + 15
    bytes with an index, 43 + 19 with a continuous action (docs/guide/device-link.md)."""
    assert layout.step_bytes(3, False) == 58 and layout.step_bytes(3, True) == 62
    assert layout.step_bytes(2, False) == 50


def stream():
    return [Observation(0, (0.1, 0.2), start=True).frame(), Action(0, 1).frame(),
            Observation(1, (0.3, 0.4), reward=-1.0).frame(), Action(1, 0.5).frame()]


def test_bytes_fed_one_at_a_time_give_the_same_frames():
    frames = stream()
    data = b"".join(frame.encode() for frame in frames)
    reader = FrameReader()
    got = [frame for i in range(len(data)) for frame in reader.feed(data[i:i + 1])]
    assert got == frames and not reader.errors


def test_a_corrupted_frame_costs_that_frame_only():
    """Every byte of each frame changed three ways (its lowest bit, its highest, all of
    them), the link then going on: the reader names what it skipped and gives back every
    other frame, in order. A changed length that another frame could have makes the reader
    wait for bytes that belong to the frames after it; when they are in, the CRC refuses the
    bogus frame and the reader finds them again."""
    frames = stream()
    after = [Action(step, 1).frame() for step in range(2, 30)]  # the link going on
    tail = b"".join(frame.encode() for frame in after)
    for which, frame in enumerate(frames):
        for position in range(len(frame.encode())):
            for flip in (0x01, 0x80, 0xFF):
                encoded = [bytearray(f.encode()) for f in frames]
                encoded[which][position] ^= flip
                reader = FrameReader()
                got = reader.feed(b"".join(encoded) + tail)
                assert got == [f for i, f in enumerate(frames) if i != which] + after, (
                    which, position, flip)
                assert reader.errors and all("\n" not in line for line in reader.errors)


def test_a_frame_cut_short_waits_and_noise_before_a_frame_is_skipped():
    reader = FrameReader()
    data = Action(4, 2).frame().encode()
    assert reader.feed(b"\x00\x17" + data[:6]) == [] and reader.skipped == 2
    assert reader.feed(data[6:]) == [Frame(ACTION, 4, data[8:13])]


def test_a_duplicated_frame_is_told_by_its_step():
    frame = Action(9, 1).frame()
    got = FrameReader().feed(frame.encode() * 2 + Action(10, 0).frame().encode())
    assert [f.step for f in got] == [9, 9, 10]


def test_bad_frames_are_refused_in_one_line():
    for make, words in ((lambda: Frame(9, 0, b"").encode(), "kind"),
                        (lambda: Frame(ACTION, -1, b"").encode(), "step"),
                        (lambda: Frame(OBSERVATION, 0, bytes(300)).encode(), "at most 255"),
                        (lambda: Action(0, "left").frame(), "index or a number"),
                        (lambda: Action.read(Observation(0, (1.0,)).frame()), "not an action"),
                        (lambda: Observation.read(Action(0, 1).frame()), "not an observation")):
        try:
            make()
        except ValueError as error:
            assert words in str(error) and "\n" not in str(error)
        else:
            raise AssertionError(f"no error for {words}")
    assert math.isnan(Action.read(Action(0, math.nan).frame()).value)
    assert np.isinf(Observation.read(Observation(0, (math.inf,)).frame()).observation[0])


ECHO = r"""
#include <stdio.h>
#include "lwrl_link.h"
/* Answers each observation: its first variable back as a continuous action, or with no
 * variable its flags as an index; each hello: its identity back; then prints nothing else. */
int main(void)
{
    static lwrl_link_reader reader;
    static lwrl_link_message message;
    uint8_t frame[LWRL_LINK_IDENTITY_FRAME];
    int c, kind, length;
    lwrl_link_reader_init(&reader);
    while ((c = getchar()) != EOF) {
        kind = lwrl_link_feed(&reader, (uint8_t)c, &message);
        if (kind == LWRL_LINK_HELLO)
            length = lwrl_link_identity_frame(message.step, &message.identity, frame);
        else if (kind == LWRL_LINK_OBSERVATION)
            length = message.dim ? lwrl_link_action_value(message.step, message.observation[0], frame)
                                 : lwrl_link_action_index(message.step, message.flags, frame);
        else
            continue;
        fwrite(frame, 1, (size_t)length, stdout);
        fflush(stdout);
    }
    fprintf(stderr, "%lu\n", (unsigned long)reader.skipped);
    return 0;
}
"""


def c_echo(tmp_path):
    """The C side of the link built on the host with a program that answers each frame."""
    import subprocess

    from lwrl.export.c import find_compiler
    from lwrl.export.frames import write_c

    write_c(tmp_path)
    (tmp_path / "echo.c").write_text(ECHO)
    subprocess.run([find_compiler(), "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-o",
                    str(tmp_path / "echo"), "echo.c", "lwrl_link.c"], cwd=tmp_path, check=True)
    return tmp_path / "echo"


def test_the_c_side_reads_and_answers_the_same_frames(tmp_path):
    """The device's C reader, fed the host's frames with noise and a corrupted frame among
    them, answers every intact observation, with its step and its first value to the bit;
    its frames are the Python side's, byte for byte."""
    import subprocess

    program = c_echo(tmp_path)
    values = [0.1, -0.0, math.inf, 5e-324, -1.7976931348623157e308, math.nan]
    sent = [Observation(step, (value, 1.0), reward=0.5, start=step == 0) for step, value in
            enumerate(values)] + [Observation(99, (), terminal=True)]
    corrupted = bytearray(Observation(50, (7.0,)).frame().encode())
    corrupted[12] ^= 0x40
    stream = (b"\x00\xa5\x01" + sent[0].frame().encode() + bytes(corrupted)
              + b"".join(o.frame().encode() for o in sent[1:]))
    done = subprocess.run([str(program)], input=stream, capture_output=True, check=True)
    answers = FrameReader().feed(done.stdout)
    assert [a.step for a in answers] == [o.step for o in sent]
    for answer, observation in zip(answers[:-1], sent):
        assert same_double(Action.read(answer).value, observation.observation[0])
        assert answer.encode() == Action(observation.step, observation.observation[0]).frame().encode()
    assert Action.read(answers[-1]).value == 2  # the terminal flag, as an index
    assert int(done.stderr) > 3  # the noise and the corrupted frame, skipped


def test_the_c_side_reads_hellos_and_writes_identities_as_the_host_does(tmp_path):
    """The C reader takes a hello among noise, and the C side's identity frame of what it
    read is the host's, byte for byte."""
    import subprocess

    program = c_echo(tmp_path)
    identity = Identity("mountain_car.cost_to_go", 2, DISCRETE, 3, "double", 2 ** 64 - 3)
    done = subprocess.run([str(program)], input=b"\xa5\x00" + Hello(41, identity).frame().encode(),
                          capture_output=True, check=True)
    assert done.stdout == Frame(IDENTITY, 41, identity.payload()).encode()


C_CONSTANTS = r"""
#include <stdio.h>
#include "lwrl_link.h"
int main(void)
{
%s
    printf("ACTION_FRAME %%d\n", (int)LWRL_LINK_ACTION_FRAME);
    printf("WEIGHTS_FRAME %%d\n", (int)LWRL_LINK_WEIGHTS_FRAME);
    printf("OBSERVATION_FRAME %%d\n", (int)LWRL_LINK_OBSERVATION_FRAME);
    printf("HELLO_FRAME %%d\n", (int)LWRL_LINK_HELLO_FRAME);
    return 0;
}
"""


def test_the_c_header_holds_the_layout_the_host_reads(tmp_path):
    """One layout: the C header's constants, compiled, are `export.frames`' (its Layouts'
    sizes and offsets), and the frame sizes the C side derives from them (its buffers) are
    the host's; the header's template writes no number of the layout itself."""
    import re
    import subprocess
    from importlib import resources

    from lwrl.export.c import find_compiler

    constants = layout.c_constants()
    assert constants["HEADER_STEP"] == 4 and constants["WEIGHTS_DIVERGED"] == 8
    assert constants["IDENTITY_BUILD"] == 5 and constants["IDENTITY_SIZE"] == 13
    layout.write_c(tmp_path)
    lines = "\n".join(f'    printf("{name} %d\\n", (int)LWRL_LINK_{name});' for name in constants)
    (tmp_path / "constants.c").write_text(C_CONSTANTS % lines)
    subprocess.run([find_compiler(), "-std=c99", "-Wall", "-Werror", "-o", "constants",
                    "constants.c"], cwd=tmp_path, check=True)
    printed = subprocess.run([str(tmp_path / "constants")], capture_output=True, text=True,
                             check=True).stdout
    got = {name: int(value) for name, value in (line.split() for line in printed.splitlines())}
    assert {name: got[name] for name in constants} == constants
    size = layout.frame_size
    assert got["ACTION_FRAME"] == size(layout.action_payload(True)) == 19
    assert got["WEIGHTS_FRAME"] == len(Weights(0, 30, 0, False, (0.0,) * 30).frame().encode())
    assert got["OBSERVATION_FRAME"] == len(Observation(0, (0.0,) * 8).frame().encode())
    assert got["HELLO_FRAME"] == size(layout.IDENTITY_PART.size + layout.MAX_TASK)
    template = resources.files("lwrl.export").joinpath("templates", "link", "lwrl_link.h.in")
    assert re.findall(r"#define LWRL_LINK_(\w+) \d", template.read_text()) == ["MAX_DIM"]


# Property-based tests of the reader over arbitrary byte streams.

STEPS = st.integers(0, 2 ** 32 - 1)
FRAMES = st.one_of(
    st.builds(lambda step, values, reward: Observation(step, tuple(values), reward).frame(),
              STEPS, st.lists(DOUBLES, max_size=8), DOUBLES),
    st.builds(lambda step, value: Action(step, value).frame(), STEPS,
              st.one_of(st.integers(-2 ** 31, 2 ** 31 - 1), DOUBLES)),
    st.builds(lambda step, offset: Request(step, offset).frame(), STEPS, STEPS),
    st.builds(lambda step, values: Weights(step, 100, 0, False, tuple(values)).frame(), STEPS,
              st.lists(DOUBLES, min_size=1, max_size=30)),
    st.builds(lambda step, task: Hello(step, Identity(task, 2, DISCRETE, 3, "float", 7)).frame(),
              STEPS, st.text("abc._", max_size=64)))


def corrupted(frame: Frame, position: int, flip: int) -> bytes:
    data = bytearray(frame.encode())
    data[position % len(data)] ^= flip
    return bytes(data)


NOISE = st.one_of(
    st.binary(max_size=32),
    st.builds(lambda frame, cut: frame.encode()[:cut % len(frame.encode())], FRAMES,
              st.integers(0, 300)),  # a frame cut short: its header promises bytes
    st.builds(corrupted, FRAMES, st.integers(0, 300), st.integers(1, 255)))
"""Bytes that hold no valid frame (but by a CRC's chance): arbitrary bytes, frames cut
short, frames with a byte changed."""
STREAMS = st.lists(st.one_of(NOISE, FRAMES.map(Frame.encode)), max_size=8).map(b"".join)
TAIL = bytes(layout.frame_size(layout.MAX_PAYLOAD))
"""The link going on after the stream: as many zero bytes as the longest frame, so that a
frame start in the noise whose length reaches past the stream's end has its bytes, fails
its CRC, and gives back the frames it had taken in."""


def read_in_pieces(data: bytes, cuts) -> tuple:
    """The frames a reader gives for `data` fed in the pieces between `cuts`, and the reader."""
    reader = FrameReader()
    bounds = [0, *sorted(cut % (len(data) + 1) for cut in cuts), len(data)]
    found = [frame for start, stop in zip(bounds, bounds[1:])
             for frame in reader.feed(data[start:stop])]
    return found, reader


def is_subsequence(wanted, found) -> bool:
    remaining = iter(found)
    return all(any(frame == other for other in remaining) for frame in wanted)


@settings(deadline=None)  # a loaded machine must not fail an example for its time
@given(st.one_of(st.binary(max_size=600), STREAMS), st.lists(st.integers(0, 4000), max_size=8))
def test_the_reader_never_fails_and_takes_only_frames_whose_crc_holds(data, cuts):
    """Any bytes (arbitrary, or frames whole, cut short and corrupted among noise), in any
    pieces: no exception, and every frame given is in the stream, its
    bytes, CRC included, as they came (a frame whose CRC failed is never taken), in order
    and without overlap; every byte is taken, skipped or still waiting."""
    found, reader = read_in_pieces(data, cuts)
    position = 0
    for frame in found:
        at = data.find(frame.encode(), position)
        assert at >= 0, frame
        position = at + len(frame.encode())
    assert sum(len(f.encode()) for f in found) + reader.skipped + len(reader.buffer) == len(data)
    assert all("\n" not in line for line in reader.errors)


@settings(deadline=None)
@given(st.lists(st.tuples(NOISE, FRAMES), max_size=6), NOISE,
       st.lists(st.integers(0, 4000), max_size=6))
def test_every_valid_frame_in_noise_is_found(pieces, last_noise, cuts):
    """Valid frames with noise before and between them, fed in any pieces, the link then
    going on (`TAIL`): the reader gives every one of them, in order (and perhaps a frame the
    noise itself spells, CRC and all)."""
    data = b"".join(noise + frame.encode() for noise, frame in pieces) + last_noise + TAIL
    found, _ = read_in_pieces(data, cuts)
    assert is_subsequence([frame for _, frame in pieces], found)
