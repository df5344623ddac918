"""The comparison of lwrl's stream-Q(lambda) with the authors' PyTorch code
(`studies.implementations.stream_q_report`): its reading of the runs on tiny hand-made ones,
and the committed report's numbers recomputed from the committed runs. No PyTorch training."""

import gzip
import json
import os

import numpy as np
import pandas as pd
import pytest

from lwrl.studies.implementations import stream_q_report as report
from lwrl.studies.implementations import stream_q_torch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KEPT = os.path.join(ROOT, "docs", "implementations", "stream_q")
REPORT = os.path.join(ROOT, "docs", "implementations", "stream_q.md")


def fake_runs(directory, budget=60, lwrl_lengths=None, authors_lengths=None, **changes):
    """A tiny pair of runs in `directory` as `stream_q_report` keeps them: lwrl's episodes
    (each agent's last one cut by the budget) and the authors' document."""
    lwrl_lengths = lwrl_lengths or {0: [10, 20, 30], 1: [30, 20]}
    authors_lengths = authors_lengths or {0: [5, 5, 50], 1: [40, 10]}
    rows = []
    for seed, lengths in lwrl_lengths.items():
        cut = budget - sum(lengths)
        for episode, steps in enumerate(lengths + ([cut] if cut else []), start=1):
            rows.append({"seed": seed, "episode": episode, "steps": steps,
                         "truncated": int(episode > len(lengths)), "return": -1.0})
    pd.DataFrame(rows).to_csv(os.path.join(directory, "lwrl.csv.gz"), index=False)
    configuration = {"task": "cartpole.balance", "plant": "analytic", "budget": budget,
                     "learner": "the learner",
                     "seed": 0, "agents": len(lwrl_lengths),
                     "settings": {**stream_q_torch.SETTINGS, "timesteps": budget}}
    configuration.update(changes)
    with open(os.path.join(directory, "lwrl.json"), "w") as file:
        json.dump(configuration, file)
    agents = [{"seed": seed, "lengths": lengths, "ends": list(np.cumsum(lengths).tolist()),
               "returns": [-1.0] * len(lengths), "seconds": 1.0}
              for seed, lengths in authors_lengths.items()]
    with gzip.open(os.path.join(directory, "torch.json.gz"), "wt") as file:
        json.dump({"env_id": "lwrl/cartpole-balance-analytic-v0", "timesteps": budget,
                   "settings": stream_q_torch.SETTINGS, "authors": "x", "torch": "x",
                   "python": "x", "agents": agents}, file)


def test_the_final_window_reads_each_agents_last_finished_episode(tmp_path):
    fake_runs(tmp_path)
    configuration, episodes, document = report.read(tmp_path)
    lwrl = report.final_window(report.lwrl_table(episodes, "cartpole.balance"), 60)
    authors = report.final_window(report.authors_table(document), 60)
    # 11 points from 48 to 60: lwrl's agent 0 finished its 20-step episode by step 30 and
    # its 30-step one at 60 (the last point); agent 1 finished 30 by 30 and 20 by 50, and
    # the budget cut its third episode (left out). The authors' agent 0: 50 by 60, 5
    # before; agent 1: 10 by 50, 40 before.
    np.testing.assert_allclose(lwrl, [(10 * 20 + 30) / 11, (2 * 30 + 9 * 20) / 11])
    np.testing.assert_allclose(authors, [(10 * 5 + 50) / 11, (2 * 40 + 9 * 10) / 11])


def test_the_report_states_the_numbers_it_computed(tmp_path):
    fake_runs(tmp_path)
    out = tmp_path / "stream_q.md"
    result = report.write(str(tmp_path), str(out), "the command")
    text = out.read_text()
    assert (f"| {report.MEASURES[0][0]} | {result['lwrl'].text(1)} | "
            f"{result['authors'].text(1)} | {result['difference'].text(1)} |") in text
    assert f"| 1 | {(2 * 30 + 9 * 20) / 11:.1f} | {(2 * 40 + 9 * 10) / 11:.1f} | 2 | 2 |" in text
    assert result["lwrl"].value == pytest.approx(((10 * 20 + 30) / 11 + (2 * 30 + 9 * 20) / 11) / 2)
    assert result["difference"].value == pytest.approx(
        result["lwrl"].value - result["authors"].value)
    assert result["detectable"] > 0
    assert (tmp_path / "figures" / "stream_q.png").is_file()  # named after the report


@pytest.mark.parametrize("changes, words", [
    ({"settings": {**stream_q_torch.SETTINGS, "timesteps": 50}}, "the runs differ"),
    ({"settings": {**stream_q_torch.SETTINGS, "timesteps": 60, "lam": 0.9}}, "lam"),
    ({"seed": 1}, "seeds differ"),
])
def test_runs_that_differ_are_refused(tmp_path, changes, words):
    fake_runs(tmp_path, **changes)
    with pytest.raises(ValueError, match=words):
        report.write(str(tmp_path), str(tmp_path / "r.md"), "c")


def test_an_lwrl_agent_short_of_the_budget_is_refused(tmp_path):
    fake_runs(tmp_path)
    episodes = pd.read_csv(tmp_path / "lwrl.csv.gz")
    episodes[episodes["truncated"] == 0].to_csv(tmp_path / "lwrl.csv.gz", index=False)
    with pytest.raises(ValueError, match="ran out of episodes"):
        report.write(str(tmp_path), str(tmp_path / "r.md"), "c")


@pytest.mark.skipif(not all(os.path.isfile(path) for path in (
    REPORT, *(os.path.join(KEPT, name) for name in ("torch.json.gz", "lwrl.json", "lwrl.csv.gz")))),
    reason="the comparison's runs are not committed")
def test_the_committed_report_recomputes_from_the_committed_runs(tmp_path):
    out = tmp_path / "stream_q.md"
    report.write(KEPT, str(out), report.command_line("docs/implementations/stream_q",
                                                     "docs/implementations/stream_q.md"))
    with open(REPORT) as file:
        assert out.read_text() == file.read()
