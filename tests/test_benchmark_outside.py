"""`lwrl bench score`'s reading of an outside learner's results (studies/paper/benchmark/
outside.py, benchmark.py `score`): a file on the protocol's seeds, fractions, episodes,
budget, version and starts is scored between the reference rows and kept in the benchmark
directory under a name of its own; a file that breaks the protocol, a name already taken or
a folder that is no benchmark is refused in one line, and nothing of the benchmark changes."""

import pathlib
import shutil

import numpy as np
import pandas as pd
import pytest
from conftest import one_line_error, run_cli

from lwrl.cli import bench
from lwrl.studies.paper.benchmark import evaluation, harness, outside, protocol

TASK = "mountain_car.cost_to_go"
COMMITTED = pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark2"


def results(task=TASK, steps=None, learner="toy") -> pd.DataFrame:
    index = pd.MultiIndex.from_product([protocol.FRACTIONS, range(protocol.AGENTS),
                                        range(1, evaluation.EPISODES + 1)],
                                       names=["fraction", "seed", "episode"]).to_frame(index=False)
    rng = np.random.default_rng(0)
    values = rng.integers(60, 200, len(index)) if steps is None else steps
    return index.assign(learner=learner, task=task, budget=protocol.BUDGETS[task], steps=values,
                        uptime_s=np.nan, protocol=protocol.VERSION,
                        starts=evaluation.protocol_digest(task))


def uptime_results(uptime) -> pd.DataFrame:
    """A pendulum's file (measured in up-time) with `uptime` seconds up in every episode."""
    task = "pendulum.swingup"
    return results(task, steps=600).assign(uptime_s=uptime)


@pytest.fixture
def benchmark_dir(tmp_path) -> pathlib.Path:
    """A benchmark directory: the committed benchmark's configs.jsonl and Mountain-Car's
    reference rows (all that scoring reads)."""
    directory = tmp_path / "benchmark"
    (directory / "references").mkdir(parents=True)
    shutil.copy(COMMITTED / "configs.jsonl", directory)
    name = f"{TASK}-analytic.csv.gz"
    shutil.copy(COMMITTED / "references" / name, directory / "references" / name)
    return directory


def contents(directory: pathlib.Path) -> dict:
    """`{relative path: bytes}` of every file below `directory`."""
    return {str(path.relative_to(directory)): path.read_bytes()
            for path in sorted(directory.rglob("*")) if path.is_file()}


def test_a_file_on_the_protocol_is_scored_between_the_reference_rows(tmp_path):
    path = tmp_path / "toy.csv.gz"
    results(steps=100).to_csv(path, index=False, compression="gzip")
    table = outside.read(str(path))
    reference = {"random": np.full(20, 900.0), "classical": np.full(20, 50.0)}
    scores = outside.scores(table, reference)
    assert set(scores) == {("toy", f) for f in protocol.FRACTIONS}
    np.testing.assert_allclose(scores["toy", 1.0], np.full(20, (100 - 900) / (50 - 900)))


def test_the_protocols_starts_are_those_the_evaluation_runs_from():
    """The digest is of the first observations of the episodes the rows' evaluation runs
    (`evaluation_env`), and another seed's starts give another."""
    env = evaluation.evaluation_env(TASK, protocol.AGENTS, "analytic")
    first = env.reset().observation
    assert np.array_equal(evaluation.starts(TASK)[:, 0], first)
    moved = evaluation.starts(TASK).copy()
    moved[3, 4, 0] += 1e-6
    assert evaluation.starts_digest(moved) != evaluation.protocol_digest(TASK)
    assert evaluation.protocol_digest(TASK) != evaluation.protocol_digest("acrobot.swingup")


@pytest.mark.parametrize("change, fragment", [
    (lambda t: t.drop(columns="budget"), "missing column 'budget'"),
    (lambda t: t.assign(budget=5000), "the budget of mountain_car.cost_to_go is 100000 steps"),
    (lambda t: t[t["seed"] != 19], "seed must take each of 0..19"),
    (lambda t: t.assign(fraction=t["fraction"].replace(0.1, 0.2)), "fraction must take each of"),
    (lambda t: pd.concat([t, t.iloc[:1]]), "an episode is there twice"),
    (lambda t: t.assign(learner=["a", "b"] * (len(t) // 2)), "one learner per file"),
    (lambda t: t.assign(task="pendulum.swingup", budget=90_000).drop(columns="uptime_s"),
     "measured in uptime_s"),
    (lambda t: t.assign(steps=np.nan), "every steps must be a whole number"),
    (lambda t: t.assign(task="pendulum.balance"), "unknown task 'pendulum.balance'"),
    (lambda t: t.assign(steps=1001), "every steps of mountain_car.cost_to_go must be in [1, 1000]; got 1001"),
    (lambda t: t.assign(steps=0), "must be in [1, 1000]; got 0"),
    (lambda t: t.assign(steps=-5), "must be in [1, 1000]; got -5"),
    (lambda t: t.assign(steps=60.5), "every steps must be a whole number"),
    (lambda t: t.assign(seed=t["seed"] + 0.5), "every seed must be a whole number"),
    (lambda t: t.assign(episode=t["episode"] + 0.25), "every episode must be a whole number"),
    (lambda t: t.drop(columns="protocol"), "missing column 'protocol'"),
    (lambda t: t.drop(columns="starts"), "missing column 'starts'"),
    (lambda t: t.assign(protocol="benchmark2-0"), "protocol must be the protocol's version"),
    (lambda t: t.assign(starts="0123456789abcdef"),
     "starts must be the digest of the evaluation starts of mountain_car.cost_to_go"),
    (lambda t: t.assign(learner="paper"), "learner 'paper' is the name of a row of the benchmark"),
    (lambda t: t.assign(learner="classical"), "learner 'classical' is the name of a row"),
    (lambda t: t.assign(learner="../x"), "learner '../x' is no name"),
    (lambda t: uptime_results(60.5), "every uptime_s of pendulum.swingup must be in [0, 60]; got 60.5"),
    (lambda t: uptime_results(-1.0), "must be in [0, 60]; got -1"),
])
def test_a_file_that_breaks_the_protocol_is_one_line(tmp_path, change, fragment):
    path = tmp_path / "bad.csv"
    change(results()).to_csv(path, index=False)
    one_line_error(lambda: outside.read(str(path)), str(path), fragment)


def test_a_pendulum_file_within_its_episodes_is_read(tmp_path):
    path = tmp_path / "pendulum.csv"
    uptime_results(60.0).to_csv(path, index=False)
    assert len(outside.read(str(path))) == len(protocol.FRACTIONS) * protocol.AGENTS * evaluation.EPISODES


def test_a_digest_of_digits_alone_is_read_as_text(tmp_path, monkeypatch):
    monkeypatch.setattr(evaluation, "protocol_digest", lambda task, plant="analytic": "0012345678901234")
    path = tmp_path / "toy.csv"
    results().assign(starts="0012345678901234").to_csv(path, index=False)
    assert outside.read(str(path))["starts"].iloc[0] == "0012345678901234"


def test_an_evaluation_from_other_starts_is_refused(tmp_path, monkeypatch):
    """The harness records the starts it ran from: evaluated from other seeds' starts, its
    file does not pass."""
    policy = lambda o: np.where(o[:, 1] >= 0, 2, 0)  # noqa: E731
    monkeypatch.setattr(evaluation, "EVALUATION_SEED", 20_000)
    evaluations = [harness.evaluate(policy, TASK, None, f) for f in protocol.FRACTIONS]
    monkeypatch.undo()
    one_line_error(lambda: harness.results(evaluations, "pump"), "starts must be the digest")


def test_a_file_that_is_not_a_table_is_one_line(tmp_path):
    path = tmp_path / "bad.csv.gz"
    path.write_bytes(b"\x1f\x8b not gzip")
    one_line_error(lambda: outside.read(str(path)), "not a readable CSV file")


def test_a_missing_episode_is_one_line(tmp_path):
    path = tmp_path / "bad.csv"
    table = results()
    table.drop(index=5).to_csv(path, index=False)
    one_line_error(lambda: outside.read(str(path)), "every seed needs every episode at every fraction")


def test_lwrl_bench_score_prints_the_scores_keeps_the_file_and_refuses_a_bad_one(
        tmp_path, capsys, benchmark_dir):
    good, bad = tmp_path / "toy.csv", tmp_path / "bad.csv"
    results(steps=100).to_csv(good, index=False)
    results().drop(columns="seed").to_csv(bad, index=False)
    status, printed, err = run_cli(["bench", "score", str(good), "--out", str(benchmark_dir)], capsys)
    lines = printed.splitlines()
    assert status == 0 and len(lines) == len(protocol.FRACTIONS), err
    assert lines[-1].startswith("toy on mountain_car.cost_to_go after 1 of the budget: "
                                "normalised score ")
    assert (benchmark_dir / "outside" / "toy-mountain_car.cost_to_go.csv.gz").exists()
    before = contents(benchmark_dir)
    status, _, err = run_cli(["bench", "score", str(bad), "--out", str(benchmark_dir)], capsys)
    assert status == 2 and len(err) == 1 and "missing column 'seed'" in err[0]
    assert contents(benchmark_dir) == before


def test_a_name_already_scored_is_refused_unless_replaced(tmp_path, capsys, benchmark_dir):
    first, second, third = (tmp_path / f"{n}.csv" for n in ("first", "second", "third"))
    results(steps=100).to_csv(first, index=False)
    results(steps=300).to_csv(second, index=False)
    results(steps=300, learner="other").to_csv(third, index=False)
    assert run_cli(["bench", "score", str(first), "--out", str(benchmark_dir)], capsys)[0] == 0
    before = contents(benchmark_dir)
    status, _, err = run_cli(["bench", "score", str(third), str(second), "--out",
                              str(benchmark_dir)], capsys)
    assert status == 2 and len(err) == 1
    assert "toy is already scored on mountain_car.cost_to_go" in err[0] and "--replace" in err[0]
    assert contents(benchmark_dir) == before  # the good file before it is not kept either
    status, _, err = run_cli(["bench", "score", str(second), str(second), "--replace", "--out",
                              str(benchmark_dir)], capsys)
    assert status == 2 and "toy on mountain_car.cost_to_go is in another of the files" in err[0]
    status, printed, _ = run_cli(["bench", "score", str(second), "--replace", "--out",
                                  str(benchmark_dir)], capsys)
    assert status == 0
    kept = pd.read_csv(benchmark_dir / "outside" / "toy-mountain_car.cost_to_go.csv.gz")
    assert (kept["steps"] == 300).all()


def test_a_folder_that_is_no_benchmark_is_refused_and_left_alone(tmp_path, capsys, benchmark_dir):
    good = tmp_path / "toy.csv"
    results().to_csv(good, index=False)
    for folder in (tmp_path / "empty", tmp_path / "missing"):
        (tmp_path / "empty").mkdir(exist_ok=True)
        status, _, err = run_cli(["bench", "score", str(good), "--out", str(folder)], capsys)
        assert status == 2 and len(err) == 1
        assert "is no benchmark directory on the analytic plant: one holds configs.jsonl" in err[0]
    assert not (tmp_path / "missing").exists() and not list((tmp_path / "empty").iterdir())
    acrobot = results("acrobot.swingup")
    acrobot.to_csv(tmp_path / "acrobot.csv", index=False)
    status, _, err = run_cli(["bench", "score", str(tmp_path / "acrobot.csv"), "--out",
                              str(benchmark_dir)], capsys)
    assert status == 2 and "holds no runs of acrobot.swingup on the analytic plant" in err[0]
    assert not (benchmark_dir / "outside").exists()


def test_the_scores_default_directory_is_the_committed_benchmark_in_the_checkout():
    assert bench.committed_benchmark("analytic") == str(COMMITTED)
    assert bench.committed_benchmark("mujoco") == str(COMMITTED / "mujoco")


def test_outside_a_checkout_the_benchmark_directory_must_be_given(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(bench, "committed_benchmark", lambda plant: None)
    results().to_csv(tmp_path / "toy.csv", index=False)
    status, _, err = run_cli(["bench", "score", str(tmp_path / "toy.csv")], capsys)
    assert status == 2 and len(err) == 1 and "--out: give the benchmark directory" in err[0]
