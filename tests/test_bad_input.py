"""Every subcommand, fed generated bad arguments and agent files: exit status 2, one line on
standard error naming the problem, no traceback, and no file left behind."""

import contextlib
import io
import json
import math
import os
import shutil
import string
import tempfile
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lwrl.agent import io as agent_io
from lwrl.cli import main as cli

WORK = tempfile.mkdtemp(prefix="lwrl-bad-input-")
"""Where the commands may write: nothing of theirs may appear here."""


@pytest.fixture(scope="module", autouse=True)
def remove_work():
    yield
    shutil.rmtree(WORK, ignore_errors=True)


def parses_as(kind, text: str) -> bool:
    """Whether `kind(text)` (float or int) reads `text`."""
    try:
        kind(text)
        return True
    except ValueError:
        return False


words = st.text(alphabet=string.ascii_letters + string.digits + "._-:/", min_size=1, max_size=12)
not_numbers = words.filter(lambda text: not parses_as(float, text) and not text.startswith("-"))
non_finite = st.sampled_from(["inf", "-inf", "nan", "Infinity", "NaN"])


def floats_outside(low, high=None):
    """Numbers that are not finite, or finite and outside [low, high] (as text)."""
    outside = [st.floats(max_value=low, exclude_max=True, allow_nan=False, allow_infinity=False)]
    if high is not None:
        outside.append(st.floats(min_value=high, exclude_min=True, allow_nan=False,
                                 allow_infinity=False))
    return st.one_of(non_finite, not_numbers, st.one_of(*outside).map(repr))


def integers_below(minimum):
    return st.one_of(st.integers(max_value=minimum - 1).map(str),
                     not_numbers.filter(lambda text: not parses_as(int, text)),
                     st.floats(allow_nan=True).map(repr).filter(lambda text: not parses_as(int, text)))


TRAIN = ["train", "mountain_car.cost_to_go", "--agents=1", "--episodes=1"]
BAD_FLAGS = {
    # flag: (command, values that must be refused)
    "--alpha": (TRAIN, floats_outside(math.ulp(0.0))),
    "--lambda": (TRAIN, floats_outside(0.0, 1.0)),
    "--epsilon": (TRAIN, floats_outside(0.0, 1.0)),
    "--gamma": (TRAIN, floats_outside(0.0, 1.0)),
    "--r2": (TRAIN, floats_outside(math.ulp(0.0))),
    "--agents": (TRAIN[:2] + ["--episodes=1"], integers_below(1)),
    "--episodes": (TRAIN[:3], integers_below(1)),
    "--seed": (TRAIN, integers_below(0)),
    "--n": (TRAIN, integers_below(2)),
    "--tilings": (TRAIN + ["--features=cmac"], integers_below(1)),
    "--trace": (TRAIN, words.filter(lambda w: w not in ("replacing", "accumulating", "replacing_reset"))),
    "--features": (TRAIN, words.filter(lambda w: w not in ("nrbf", "cmac"))),
    "--integrator": (TRAIN[:1] + ["pendulum.swingup", "--plant=analytic"] + TRAIN[2:],
                     words.filter(lambda w: w not in ("semi_implicit", "explicit"))),
    "--plant": (TRAIN, words.filter(lambda w: w != "analytic")),
    "--learning-rate": (TRAIN + ["--learner=stream_q"], floats_outside(math.ulp(0.0))),
    "--sparsity": (TRAIN + ["--learner=stream_q"], st.one_of(floats_outside(0.0, 1.0), st.just("1"))),
    "--top": (TRAIN + ["--learner=ars", "--directions=2"],
              st.one_of(st.integers(min_value=3).map(str), integers_below(1))),
    "--low": (TRAIN, st.one_of(non_finite, not_numbers, st.just("0"), st.just("1,2,3"),
                                st.just("0.5,0.07"))),
    "--log-agents": (TRAIN + ["--rrd", os.path.join(WORK, "never.rrd")],
                     st.one_of(not_numbers, st.just("5"), st.just("-1"))),
    "--log-episodes": (TRAIN + ["--rrd", os.path.join(WORK, "never.rrd")],
                       st.one_of(words.filter(lambda w: w not in ("best", "last", "all")
                                                            and not w.startswith("every:")),
                                 st.just("every:0"), st.just("0"), st.just("2"))),
    "--out": (TRAIN, st.sampled_from(["/proc/lwrl", "/dev/null", "/proc/self/status/x"])),
    "--save": (TRAIN, st.sampled_from(["/proc/lwrl.npz", WORK, "/dev/null/x.npz"])),
    "--steps": (["rollout", "pendulum.swingup"], integers_below(1)),
    "--seeds": (["compare", "pendulum.swingup", "--quick", "--out", os.path.join(WORK, "compare")],
                integers_below(1)),
    "--workers": (["reproduce", "fig3", "--quick", "--out", os.path.join(WORK, "reproduction")],
                  integers_below(1)),
    "--alphas": (["reproduce", "fig3", "--quick", "--out", os.path.join(WORK, "reproduction")],
                 st.one_of(non_finite, not_numbers)),
    "--agents-per-cell": (["reproduce", "fig5", "--quick", "--out", os.path.join(WORK, "reproduction")],
                          integers_below(2)),
}
BAD_SETS = st.one_of(
    st.tuples(st.sampled_from(["r2", "epsilon"]),  # (epsilon=none is its default)
              st.one_of(non_finite, not_numbers.filter(lambda w: w.lower() != "none"))),
    st.tuples(st.just("centroids"), words.filter(lambda w: w not in ("midpoints", "edges", "none"))),
    st.tuples(st.just("low"), st.sampled_from(["1", "1,2,3", "a,b"])),
    st.tuples(words.filter(lambda w: "=" not in w and w not in ("r2", "epsilon", "centroids", "low",
                                                                 "high", "equations", "track_limit",
                                                                 "time_limit")),
              st.just("1")),
    st.tuples(st.just("equations"), st.just("kfnnet")),  # the items' MuJoCo runs have none
)
BAD_NAMES = st.one_of(words, st.sampled_from(["cartpole", "cartpole.", ".balance", "dmc:", "gym:"]))


def run(argv) -> tuple[int, list]:
    """`(exit status, standard error lines)` of the command, in this process."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            status = cli.main(argv)
        except SystemExit as exit_:
            status = exit_.code
    return status, err.getvalue().strip().splitlines()


def assert_refused(argv):
    before = set(os.listdir(WORK))
    status, lines = run(argv)
    assert status == 2, (argv, status, lines)
    assert len(lines) == 1 and "Traceback" not in lines[0], (argv, lines)
    assert lines[0].startswith(("lwrl", "usage")) and "error" in lines[0], (argv, lines)
    assert set(os.listdir(WORK)) == before, (argv, set(os.listdir(WORK)) - before)


QUICK = settings(max_examples=400, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


@QUICK
@given(flag=st.sampled_from(sorted(BAD_FLAGS)), data=st.data())
def test_a_bad_value_of_any_flag_is_one_line_and_status_2(flag, data):
    command, values = BAD_FLAGS[flag]
    value = data.draw(values, label=flag)
    assert_refused(command + [f"{flag}={value}"])


@QUICK
@given(reading=BAD_SETS, item=st.sampled_from(["fig3", "fig5"]), plant=st.sampled_from(["mujoco"]))
def test_a_bad_reading_is_one_line_and_status_2(reading, item, plant):
    name, value = reading
    out = os.path.join(WORK, "reproduction")
    assert_refused(["reproduce", item, "--quick", "--plant", plant, "--out", out,
                    "--set", f"{name}={value}"])
    if os.path.isdir(out):  # a refused reproduction may leave its empty directory tree only
        for root, _, files in os.walk(out):
            assert not files, (root, files)


@QUICK
@given(command=st.sampled_from(["train", "rollout", "compare", "export"]), name=BAD_NAMES)
def test_a_bad_task_or_path_is_one_line_and_status_2(command, name):
    argv = {"train": ["train", name], "rollout": ["rollout", name],
            "compare": ["compare", name, "--quick", "--out", os.path.join(WORK, "compare")],
            "export": ["export", os.path.join(WORK, name), "--c", os.path.join(WORK, "c")]}[command]
    assert_refused(argv)


@pytest.fixture(scope="module")
def agent_file(tmp_path_factory):
    path = str(tmp_path_factory.mktemp("agent") / "agents.npz")
    status, _ = run(["train", "mountain_car.cost_to_go", "--agents=2", "--episodes=1", "--save", path])
    assert status == 0
    return path


def damaged(source: str, how: str, blob: bytes) -> bytes:
    """The bytes of the agent file `source`, damaged in one way."""
    with np.load(source) as archive:
        arrays = {name: archive[name] for name in archive.files}
    document = json.loads(str(arrays["document"]))
    if how == "garbage":
        return blob
    if how == "truncated":
        data = open(source, "rb").read()
        return data[:max(0, len(data) * len(blob) // 300)]
    if how == "missing":
        arrays.pop(sorted(arrays)[len(blob) % len(arrays)])
    elif how == "shape":
        arrays["weights"] = arrays["weights"][:, :-1]
    elif how == "document":
        arrays["document"] = np.array(blob.decode("latin-1"))
    elif how == "format":
        document["format"] = "something/else"
    elif how == "features":
        document["features"]["n"] = -1
    elif how == "task":
        document["metadata"]["config"]["task"] = "pendulum.swingup"
    elif how == "config":
        document["metadata"] = {"config": {"alpha": 1}}
    if how in ("format", "features", "task", "config"):
        arrays["document"] = np.array(json.dumps(document))
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


@settings(max_examples=200, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(how=st.sampled_from(["garbage", "truncated", "missing", "shape", "document", "format",
                            "features", "task", "config"]),
       blob=st.binary(min_size=1, max_size=300), command=st.sampled_from(["eval", "export"]))
def test_a_damaged_agent_file_is_one_line_and_status_2(agent_file, how, blob, command):
    if command == "export" and how == "config":  # export needs no run configuration
        return
    with tempfile.TemporaryDirectory(prefix="lwrl-damaged-") as directory:
        path = os.path.join(directory, "agents.npz")
        with open(path, "wb") as file:
            file.write(damaged(agent_file, how, blob))
        argv = (["eval", path, "--episodes=1"] if command == "eval"
                else ["export", path, "--c", os.path.join(WORK, "c")])
        assert_refused(argv)


def test_every_check_looks_at_a_real_file():
    """The damaged files above are damaged: the undamaged one loads."""
    assert zipfile.is_zipfile(__file__) is False
    assert agent_io.FORMAT == "lwrl-agent/2"


# Values that enter a task from Python: the options of `tasks.load` (and so of
# `gymnasium.make` and `lwrl reproduce --set`), the batched stepper's seeds and states.

from lwrl import tasks  # noqa: E402
from lwrl.tasks.batched import BatchedEnv  # noqa: E402

TIMESTEPS = {(domain, task): tasks.definition(domain, task).control_timestep
             for domain, task in tasks.ALL_TASKS}
not_positive_numbers = st.one_of(
    st.floats(max_value=0.0), st.just(math.nan), st.booleans(), st.text(max_size=4),
    st.integers(max_value=0), st.lists(st.floats(min_value=1, max_value=9), max_size=2), st.none())


@QUICK
@given(task=st.sampled_from(sorted(TIMESTEPS)), steps=st.floats(min_value=1e-3, max_value=1e5),
       data=st.data())
def test_a_time_limit_that_is_not_a_whole_number_of_steps_names_the_step(task, steps, data):
    """`tasks.load("mountain_car", "cost_to_go", time_limit=2.5)` and the like: refused,
    naming the control step; a whole number of steps is taken, in seconds or steps."""
    timestep = TIMESTEPS[task]
    if abs(steps - round(steps)) > 1e-6:
        with pytest.raises(ValueError, match=rf"^time_limit must be a whole number of control "
                                             rf"steps of {timestep:g}; got "):
            tasks.load(*task, time_limit=steps * timestep)
    whole = data.draw(st.integers(min_value=1, max_value=10 ** 5), label="whole")
    assert tasks.definition(*task, time_limit=whole * timestep).step_limit == whole


@QUICK
@given(task=st.sampled_from(sorted(TIMESTEPS)), value=not_positive_numbers)
def test_a_time_limit_that_is_not_a_positive_number_is_refused(task, value):
    with pytest.raises(ValueError, match=r"^time_limit must be a positive number; got "):
        tasks.load(*task, time_limit=value)


@QUICK
@given(value=not_positive_numbers.filter(lambda value: value is not None))
def test_a_track_limit_that_is_not_a_positive_number_is_refused(value):
    with pytest.raises(ValueError, match=r"^track_limit must be a positive number of metres or "
                                         r"None; got "):
        tasks.load("cartpole", "balance", track_limit=value)


@QUICK
@given(seeds=st.one_of(
    st.lists(st.one_of(st.integers(max_value=-1), st.floats(), st.text(max_size=3)), min_size=1,
             max_size=3).map(lambda bad: [0] + bad),
    st.integers(), st.floats(), st.text(max_size=3), st.just([])))
def test_batched_seeds_that_are_not_non_negative_integers_are_refused(seeds):
    with pytest.raises(ValueError, match=r"^seeds? must "):
        BatchedEnv("pendulum", "swingup", "analytic", seeds=seeds)


@QUICK
@given(shape=st.lists(st.integers(min_value=0, max_value=4), min_size=0, max_size=3),
       fill=st.one_of(st.just(0.0), st.just(math.nan), st.just(math.inf)))
def test_a_batched_state_of_another_shape_or_not_finite_is_refused(shape, fill):
    env = BatchedEnv("cartpole", "balance", "analytic", seeds=[0, 1])
    env.reset()
    state = np.full(shape, fill)
    if tuple(shape) == (2, 4) and fill == 0.0:
        env.set_state(state)
        return
    with pytest.raises(ValueError, match=r"^state must (have|be finite)"):
        env.set_state(state)


def test_the_time_limit_of_the_issue_names_what_is_allowed():
    with pytest.raises(ValueError) as refused:
        tasks.load("mountain_car", "cost_to_go", time_limit=2.5)
    assert str(refused.value) == ("time_limit must be a whole number of control steps of 1; "
                                  "got 2.5 (2.5 steps)")
    gymnasium = pytest.importorskip("gymnasium")
    import lwrl.gym  # noqa: F401

    with pytest.raises(ValueError, match="time_limit must be a whole number of control steps of 0.02"):
        gymnasium.make("lwrl/pendulum-swingup-analytic-v0", time_limit=0.03)
    status, lines = run(["reproduce", "fig3", "--quick", "--out", os.path.join(WORK, "repro"),
                         "--set", "time_limit=2.5"])
    assert status == 2 and lines == ["lwrl reproduce: error: time_limit must be a whole number of "
                                     "control steps of 1; got 2.5 (2.5 steps)"]
