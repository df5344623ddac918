"""`lwrl bench score`'s reading of an outside learner's results (studies/paper/benchmark/
outside.py): a file on the protocol's seeds, fractions, episodes and budget is scored
between the reference rows; a malformed one is refused in one line naming what is wrong."""

import numpy as np
import pandas as pd
import pytest
from conftest import one_line_error

from lwrl.studies.paper.benchmark import evaluation, outside, protocol

TASK = "mountain_car.cost_to_go"


def results(task=TASK, steps=None) -> pd.DataFrame:
    index = pd.MultiIndex.from_product([protocol.FRACTIONS, range(protocol.AGENTS),
                                        range(1, evaluation.EPISODES + 1)],
                                       names=["fraction", "seed", "episode"]).to_frame(index=False)
    rng = np.random.default_rng(0)
    values = rng.integers(60, 200, len(index)) if steps is None else steps
    return index.assign(learner="toy", task=task, budget=protocol.BUDGETS[task], steps=values,
                        uptime_s=np.nan)


def test_a_file_on_the_protocol_is_scored_between_the_reference_rows(tmp_path):
    path = tmp_path / "toy.csv.gz"
    results(steps=100).to_csv(path, index=False, compression="gzip")
    table = outside.read(str(path))
    reference = {"random": np.full(20, 900.0), "classical": np.full(20, 50.0)}
    scores = outside.scores(table, reference)
    assert set(scores) == {("toy", f) for f in protocol.FRACTIONS}
    np.testing.assert_allclose(scores["toy", 1.0], np.full(20, (100 - 900) / (50 - 900)))


@pytest.mark.parametrize("change, fragment", [
    (lambda t: t.drop(columns="budget"), "missing column 'budget'"),
    (lambda t: t.assign(budget=5000), "the budget of mountain_car.cost_to_go is 100000 steps"),
    (lambda t: t[t["seed"] != 19], "seed must take each of 0..19"),
    (lambda t: t.assign(fraction=t["fraction"].replace(0.1, 0.2)), "fraction must take each of"),
    (lambda t: pd.concat([t, t.iloc[:1]]), "an episode is there twice"),
    (lambda t: t.assign(learner=["a", "b"] * (len(t) // 2)), "one learner per file"),
    (lambda t: t.assign(task="pendulum.swingup", budget=90_000).drop(columns="uptime_s"),
     "measured in uptime_s"),
    (lambda t: t.assign(steps=np.nan), "every steps must be a finite number"),
    (lambda t: t.assign(task="pendulum.balance"), "unknown task 'pendulum.balance'"),
])
def test_a_malformed_file_is_one_line(tmp_path, change, fragment):
    path = tmp_path / "bad.csv"
    change(results()).to_csv(path, index=False)
    one_line_error(lambda: outside.read(str(path)), str(path), fragment)


def test_a_file_that_is_not_a_table_is_one_line(tmp_path):
    path = tmp_path / "bad.csv.gz"
    path.write_bytes(b"\x1f\x8b not gzip")
    one_line_error(lambda: outside.read(str(path)), "not a readable CSV file")


def test_a_missing_episode_is_one_line(tmp_path):
    path = tmp_path / "bad.csv"
    table = results()
    table.drop(index=5).to_csv(path, index=False)
    one_line_error(lambda: outside.read(str(path)), "every seed needs every episode at every fraction")


def test_lwrl_bench_score_prints_the_scores_keeps_the_file_and_refuses_a_bad_one(tmp_path, capsys):
    from conftest import run_cli
    good, bad = tmp_path / "toy.csv", tmp_path / "bad.csv"
    results(steps=100).to_csv(good, index=False)
    results().drop(columns="seed").to_csv(bad, index=False)
    out = tmp_path / "bench"
    status, printed, _ = run_cli(["bench", "score", str(good), "--out", str(out)], capsys)
    lines = printed.splitlines()
    assert status == 0 and len(lines) == len(protocol.FRACTIONS)
    assert lines[-1].startswith("toy on mountain_car.cost_to_go after 1 of the budget: "
                                "normalised score ")
    assert (out / "outside" / "toy-mountain_car.cost_to_go.csv.gz").exists()
    assert (out / "references" / "mountain_car.cost_to_go-analytic.csv.gz").exists()
    status, _, err = run_cli(["bench", "score", str(bad), "--out", str(out)], capsys)
    assert status == 2 and len(err) == 1 and "missing column 'seed'" in err[0]
