"""The device link's frames (`export.frames`): the layout byte by byte, exact doubles, and a
reader that loses no more than a bad frame."""

import math
import struct

import numpy as np
from hypothesis import given, settings
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


@settings(max_examples=200)
@given(st.integers(0, 3), st.data())
def test_a_corrupted_frame_costs_that_frame_only(which, data):
    """Any byte of one frame changed (any bit pattern): the reader names what it skipped and
    gives back every other frame, in order; at worst the corrupted frame itself is lost."""
    frames = stream()
    encoded = [bytearray(frame.encode()) for frame in frames]
    position = data.draw(st.integers(0, len(encoded[which]) - 1))
    flip = data.draw(st.integers(1, 255))
    encoded[which][position] ^= flip
    reader = FrameReader()
    got = reader.feed(b"".join(encoded))
    assert got == [f for i, f in enumerate(frames) if i != which]
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
    for make, words in ((lambda: Frame(3, 0, b"").encode(), "kind"),
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
