"""The device link's frames (`export.frames`): the layout byte by byte, exact doubles, and a
reader that loses no more than a bad frame."""

import math
import struct

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from lwrl.export.frames import (ACTION, MAGIC, OBSERVATION, Action, Frame, FrameReader,
                                Observation, crc16)

DOUBLES = st.floats(allow_nan=True, allow_infinity=True, width=64)


def same_double(a: float, b: float) -> bool:
    return struct.pack("<d", a) == struct.pack("<d", b)


def test_the_crc_is_ccitt_false():
    assert crc16(b"123456789") == 0x29B1  # the catalogue's check value


def test_an_action_frame_byte_by_byte():
    data = Action(7, 1).frame().encode()
    assert data[:8] == bytes([MAGIC, 1, ACTION, 5, 7, 0, 0, 0])
    assert data[8:13] == bytes([0, 1, 0, 0, 0])  # discrete, index 1 (int32)
    assert data[13:] == struct.pack("<H", crc16(data[1:13])) and len(data) == 15
    continuous = Action(2 ** 32 - 1, -0.25).frame().encode()
    assert continuous[:8] == bytes([MAGIC, 1, ACTION, 9, 255, 255, 255, 255])
    assert continuous[8:17] == bytes([1]) + struct.pack("<d", -0.25)


def test_an_observation_frame_byte_by_byte():
    data = Observation(3, (0.5, -2.0), reward=-1.0, start=False, terminal=True).frame().encode()
    assert data[:8] == bytes([MAGIC, 1, OBSERVATION, 25, 3, 0, 0, 0])
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
 * variable its flags as an index; then prints nothing else. */
int main(void)
{
    static lwrl_link_reader reader;
    lwrl_link_observation observation;
    uint8_t frame[LWRL_LINK_ACTION_FRAME];
    int c, length;
    lwrl_link_reader_init(&reader);
    while ((c = getchar()) != EOF) {
        if (!lwrl_link_feed(&reader, (uint8_t)c, &observation))
            continue;
        length = observation.dim ? lwrl_link_action_value(observation.step, observation.observation[0], frame)
                                 : lwrl_link_action_index(observation.step, observation.flags, frame);
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
