"""The third benchmark's committed report (docs/benchmark3/README.md) recomputed on
Mountain-Car (`mountain_car.cost_to_go`) from the committed tables alone: the reference rows
(docs/benchmark3/references), the rows' greedy evaluations (docs/benchmark3/runs) and their
trainings' records (docs/benchmark3/runs/records). Per row, its agents and seeds at every
point of the clock (past the budget, its own runs where continued, else carried), its
normalised score at 1/4, 1 and 4 times the budget, its search's final score, and at each of
those points its agents at the level 0.5, its Kaplan-Meier median steps and CPU seconds to
it and its share of agents reaching the goal in every greedy episode (with the
Clopper-Pearson interval); per rival at each point, d = mean(light) - mean(rival) of the
normalised scores, the rival's score the gate quotes, the p-values of Welch's one-sided
tests before the family's adjustment, TOST's p and the area's d.

The code here is independent of the code that wrote the report: plain pandas, numpy and
scipy on the tables, the definitions taken from docs/FINDINGS.md ("The light-weight claim
judged a third time: the third benchmark's rule"). Of lwrl it reads only constants of the
task and the protocol (the budget, the rows' seeds, the evaluation's seed offset and step
cap, the agents per row, the light-weight row's label), none of its scoring, normalisation,
statistics or report code. A printed number agrees where it lies within half a unit of its
last printed digit of the recomputed one.
"""

import glob
import math
import pathlib
import re

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from lwrl.studies.paper.benchmark import compute_plan, evaluation, protocol
from lwrl.studies.paper.benchmark.third import rule

ROOT = pathlib.Path(__file__).resolve().parents[1] / "docs" / "benchmark3"
RUNS = ROOT / "runs"
TASK = "mountain_car.cost_to_go"
BUDGET = protocol.BUDGETS[TASK]
STEP_CAP = evaluation.STEP_CAP
"""An evaluation episode that does not reach the goal counts this many steps; a diverged
agent's episodes (no measure) count it too."""
ROW_SEED = rule.SEED + evaluation.EVALUATION_SEED
"""The first evaluation seed of the rows' agents (13 000: agent b trains on 3000 + b)."""
SEARCH_SEED = rule.SEARCH_SEED + evaluation.EVALUATION_SEED
"""The first evaluation seed of the search's agents (12 000)."""
LEVEL = 0.5
"""The greedy normalised score whose first reaching is timed (the rule's "faster")."""
POINTS = tuple(range(-1, 19))
"""The fine clock's points j: an evaluation after 2^(j/3 - 6) of the budget."""
LONGER = tuple(range(19, 25))
"""The points past the budget, to 4 times it, of a row continued there."""
QUARTER, WHOLE, FOUR = 12, 18, 24
"""The points at 1/4, 1 and 4 times the budget, where each agent runs 10 greedy episodes."""
STEPS_AT = {j: round(2.0 ** (j / 3 - 6) * BUDGET) for j in POINTS + LONGER}
"""The steps trained at each point of the clock."""
LIGHT = protocol.LIGHT["discrete"]
ROWS = {"paper": ("sarsa", "nrbf", "replacing"),
        "sarsa-accumulating": ("sarsa", "nrbf", "accumulating"),
        "true_online_sarsa": ("true_online_sarsa", "nrbf", "dutch"),
        "cmac": ("sarsa", "cmac", "replacing_reset"),
        "dqn": ("dqn_jax", None, None), "ppo": ("ppo_jax", None, None),
        "ars": ("ars", None, None), "stream_q": ("stream_q", None, None),
        "stream_ac": ("stream_ac_discrete", None, None)}
"""`{label: (learner, features, trace)}` of the task's rows, as their run tables name them."""
LINEAR = ("paper", "sarsa-accumulating", "true_online_sarsa", "cmac")
"""The linear rows, of `compute_plan.LIGHT_AGENTS` agents; the others have `RIVAL_AGENTS`."""
RIVALS = ("dqn", "ppo", "ars", "stream_q", "stream_ac")
VARIANT_COLUMNS = ("thrust", "gravity")
"""The physics each episode draws on the variant `mountain_car.cost_to_go+physics`, whose
runs share the task's file names: a table with these columns is the variant's."""
NOT_SETTINGS = {"run", "trained", "agents", "episodes", "learn", "greedy", "agent", "seed",
                "episode", "steps", "return", "uptime_s", "truncated", "diverged",
                *VARIANT_COLUMNS}
"""A run table's columns that are not its learner's or environment's settings."""
AT = {"1/4": QUARTER, "1": WHOLE, "4": FOUR}
"""The report's budget points recomputed, by the name its sections give them."""


def readme_tables(lines: list) -> list:
    """The markdown tables among `lines`, each `[{header: cell}]`."""
    tables, current = [], None
    for line in lines + [""]:
        if line.startswith("|"):
            cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
            if current is None:
                current = {"header": cells, "rows": []}
            elif not set("".join(cells)) <= set("-"):
                current["rows"].append(dict(zip(current["header"], cells)))
        elif current is not None:
            tables.append(current["rows"])
            current = None
    return tables


@pytest.fixture(scope="module")
def readme() -> dict:
    """`{"rows": {label: cells}, "1/4" | "1" | "4": ({rival: cells}, {label: cells}, carried)}`:
    the task's table of rows, and at each point its comparisons' and its rows' tables (a
    row's label without the " (carried)" the table marks, the rows so marked in `carried`)."""
    lines = (ROOT / "README.md").read_text().splitlines()
    start = lines.index(f"## {TASK}")
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith("## "))
    section = lines[start:end]
    heads = {name: section.index(f"### At {name} times the budget") for name in AT}
    found = {"rows": {row["row"]: row for row in readme_tables(section[:min(heads.values())])[0]}}
    for name, head in heads.items():
        after = next((i for i in range(head + 1, len(section)) if section[i].startswith("### ")),
                     len(section))
        comparisons, rows = readme_tables(section[head:after])
        found[name] = ({row["rival"]: row for row in comparisons},
                       {row["row"].removesuffix(CARRIED): row for row in rows},
                       {row["row"].removesuffix(CARRIED) for row in rows
                        if row["row"].endswith(CARRIED)})
    return found


CARRIED = " (carried)"
"""How the report marks a row that stopped rising at the budget, its score at 1 standing at
4 times it."""


def interval_of(cell: str) -> tuple:
    """The two ends of the interval a cell prints."""
    low, high = cell.split(" [")[1].rstrip("]").split(", ")
    return float(low), float(high)


def agrees(text: str, value: float) -> bool:
    """Whether the number `text` prints is `value` to within half a unit of its last digit
    (a dash: `value` NaN)."""
    if text.split(" [")[0] == "—":
        return math.isnan(value)
    mantissa, _, exponent = text.split(" [")[0].lower().partition("e")
    digits = len(mantissa.partition(".")[2])
    return abs(float(mantissa) * 10.0 ** int(exponent or 0) - value) <= (
        0.5 * 10.0 ** (int(exponent or 0) - digits) + 1e-9)


def label_of(table: pd.DataFrame) -> str:
    """The row a run table is of, by its learner, features and trace (`ROWS`)."""
    first = table.iloc[0]
    named = tuple(None if column not in table or pd.isna(first[column]) else first[column]
                  for column in ("learner", "features", "trace"))
    found = [label for label, row in ROWS.items()
             if row[0] == named[0] and all(a is None or a == b for a, b in zip(row[1:], named[1:]))]
    assert len(found) == 1, (table.run.iloc[0], named)
    return found[0]


def record_of(table: pd.DataFrame) -> pd.DataFrame:
    """The records of the training an evaluation table evaluates, one row per agent."""
    (trained,) = table.trained.unique()
    return pd.read_csv(RUNS / "records" / f"{trained}.csv.gz")


def point_of(record: pd.DataFrame) -> int:
    """The clock's point a training ended at, from the steps its agents trained."""
    (steps,) = record.steps.unique()
    (point,) = [j for j, at in STEPS_AT.items() if at == steps]
    return point


@pytest.fixture(scope="module")
def references() -> tuple:
    """`(random, classical)`: the reference rows' mean steps per episode, each the mean over
    its agents of each agent's mean over its episodes (normalised score 0 and 1)."""
    table = pd.read_csv(ROOT / "references" / f"{TASK}-analytic.csv.gz")
    assert sorted(table.row.unique()) == ["classical", "random"]
    agents = compute_plan.LIGHT_AGENTS
    assert sorted(table.seed.unique()) == list(range(ROW_SEED, ROW_SEED + agents))
    means = table.groupby(["row", "seed"]).steps.mean().groupby("row").mean()
    return float(means["random"]), float(means["classical"])


def normalised(table: pd.DataFrame, references: tuple,
               diverged_as_worst: bool = True) -> pd.Series:
    """Each agent's (by evaluation seed) normalised score: its mean steps per greedy episode,
    a diverged agent's the cap (or NaN), the random row 0 and the classical row 1."""
    random, classical = references
    steps = table.groupby("seed", sort=True).steps.mean()
    if diverged_as_worst:
        steps = steps.fillna(STEP_CAP)
    return (steps - random) / (classical - random)


@pytest.fixture(scope="module")
def rows(references) -> dict:
    """`{label: {j: (evaluation table, training records, normalised scores)}}` of the task's
    rows: their greedy evaluations (seeds from `ROW_SEED`) of the nominal task at every point
    of the clock, and past it to 4 times the budget: a continued row's own, a carried row's
    (no run past the budget) its point at 1 again."""
    found = {label: {} for label in ROWS}
    for path in sorted(glob.glob(str(RUNS / f"{TASK}-analytic-*-s{ROW_SEED}-*.csv.gz"))):
        table = pd.read_csv(path)
        if set(VARIANT_COLUMNS) & set(table.columns):
            continue
        record = record_of(table)
        label, point = label_of(table), point_of(record)
        assert point not in found[label], (label, point)
        found[label][point] = (table, record, normalised(table, references))
    return {label: {**row, **{j: row.get(j, row[WHOLE]) for j in LONGER}}
            for label, row in found.items()}


def carried(rows: dict) -> set:
    """The rows with no run past the budget, their point at 1 standing for the later ones."""
    return {label for label, row in rows.items() if row[FOUR] is row[WHOLE]}


def scores_to(row: dict, point: int) -> np.ndarray:
    """Agents x points: a row's normalised scores at the clock's points to `point`."""
    return np.stack([row[j][2].to_numpy() for j in POINTS + LONGER if j <= point], axis=1)


def first_at_level(row: dict, point: int) -> tuple:
    """`(steps, cpu, reached)` per agent: at its first evaluation at or above the level, or
    at `point` (censored) where never; the CPU seconds its training run records there."""
    scores = scores_to(row, point)
    at = scores >= LEVEL
    reached = at.any(axis=1)
    first = np.where(reached, at.argmax(axis=1), scores.shape[1] - 1)
    points = [j for j in POINTS + LONGER if j <= point]
    cpu = np.stack([row[j][1].sort_values("seed").cpu_s.to_numpy() for j in points], axis=1)
    steps = np.array([STEPS_AT[points[k]] for k in first], dtype=float)
    return steps, cpu[np.arange(len(first)), first], reached


def kaplan_meier_median(times, reached) -> float:
    """The first time at which the Kaplan-Meier survival of `times` (right-censored where
    not `reached`) is at or below 1/2; NaN where it never is."""
    times, reached = np.asarray(times, dtype=float), np.asarray(reached, dtype=bool)
    survival = 1.0
    for time in np.unique(times[reached]):
        survival *= 1 - np.sum((times == time) & reached) / np.sum(times >= time)
        if survival <= 0.5 + 1e-12:
            return float(time)
    return math.nan


def test_each_row_runs_its_agents_at_every_point_of_the_clock(rows, readme):
    """Every row of the README's table has its greedy evaluations at all 20 points of the
    clock and the 6 past it to 4 times the budget (its own where continued, its point at 1
    again where the README says it is carried), one configuration (its
    episodes apart, which a continued run has more of), 10 episodes at 1/4, 1 and 4 and one
    elsewhere, and its agents (100 a linear row, 20 a rival, as the table says) on seeds
    13 000 up."""
    assert list(readme["rows"]) == list(ROWS)
    kept_at_one = carried(rows)
    assert readme["4"][2] == kept_at_one and {
        label for label, row in readme["rows"].items()
        if row["at 4 times the budget"].endswith(CARRIED)} == kept_at_one
    for label, row in rows.items():
        agents = compute_plan.LIGHT_AGENTS if label in LINEAR else compute_plan.RIVAL_AGENTS
        assert sorted(row) == list(POINTS + LONGER), label
        assert int(readme["rows"][label]["agents"]) == agents, label
        settings = {tuple(table[sorted(set(table.columns) - NOT_SETTINGS)].iloc[0].astype(str))
                    for table, _, _ in row.values()}
        assert len(settings) == 1, label
        for j, (table, record, scores) in row.items():
            if j in LONGER and label in kept_at_one:
                continue  # its point at 1 again
            assert not table.learn.any() and table.greedy.all(), (label, j)
            assert set(table.episode) == set(range(1, 11 if j in (*AT.values(), LONGER[-1])
                                                    else 2)), (label, j)
            assert list(scores.index) == list(range(ROW_SEED, ROW_SEED + agents)), (label, j)
            assert sorted(record.seed) == list(range(rule.SEED, rule.SEED + agents)), (label, j)


def test_the_final_scores_recompute_from_the_run_tables(rows, readme):
    """Each row's mean normalised score at 1/4 of the budget and at its end (the number
    before the interval)."""
    columns = {QUARTER: "normalised score at 1/4", WHOLE: "final normalised score",
               FOUR: "at 4 times the budget"}
    for label, row in rows.items():
        for point, column in columns.items():
            cell = readme["rows"][label][column]
            assert agrees(cell, row[point][2].mean()), (label, column, cell, row[point][2].mean())


def test_the_differences_to_each_rival_recompute_from_the_final_scores(rows, readme):
    """At 1/4, 1 and 4 times the budget, each rival's d = mean(light) - mean(rival) of the
    normalised scores there, and the rival's score a gate quotes where it does not pass."""
    for name, point in AT.items():
        comparisons = readme[name][0]
        assert tuple(comparisons) == RIVALS
        light = rows[LIGHT][point][2].mean()
        for rival in RIVALS:
            d = light - rows[rival][point][2].mean()
            assert agrees(comparisons[rival]["d"], d), (name, rival, comparisons[rival]["d"], d)
            gate = comparisons[rival]["gate"]
            quoted = re.fullmatch(rf"not judged: {rival}'s interval (\S+) \[.*", gate)
            assert gate == "passes" or quoted, (name, rival, gate)
            if quoted:
                assert agrees(quoted.group(1), rows[rival][point][2].mean()), (name, rival, gate)


def test_the_agents_at_the_level_recompute_from_the_clock(rows, readme):
    """At 1/4, 1 and 4 times the budget, each row's agents whose greedy normalised score is at
    or above 0.5 at some point of the clock to there ("k of n")."""
    for name, point in AT.items():
        for label, row in rows.items():
            _, _, reached = first_at_level(row, point)
            expected = f"{int(reached.sum())} of {len(reached)}"
            assert readme[name][1][label]["agents at 0.5"] == expected, (name, label, expected)


def test_the_median_steps_and_cpu_to_the_level_recompute_from_the_clock_and_records(rows, readme):
    """At 1/4, 1 and 4 times the budget, each row's Kaplan-Meier median steps to the level and
    median CPU seconds of training to it, read from the records of the training at each
    agent's first evaluation at the level (censored at the point where never)."""
    for name, point in AT.items():
        for label, row in rows.items():
            steps, cpu, reached = first_at_level(row, point)
            cells = readme[name][1][label]
            median_steps, median_cpu = (kaplan_meier_median(v, reached) for v in (steps, cpu))
            assert agrees(cells["median steps to 0.5"], median_steps), (name, label, median_steps)
            assert agrees(cells["median CPU s to 0.5"], median_cpu), (name, label, median_cpu)


def test_the_success_shares_recompute_from_the_greedy_episodes(rows, readme):
    """At 1/4, 1 and 4 times the budget, each row's share of agents reaching the goal (fewer
    steps than the cap) in every one of their 10 greedy episodes there, with its exact
    Clopper-Pearson 95 % interval."""
    for name, point in AT.items():
        for label, row in rows.items():
            table = row[point][0]
            every = (table.steps < STEP_CAP).groupby(table.seed).all()
            k, n = int(every.sum()), len(every)
            low = stats.beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
            high = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
            cell = readme[name][1][label]["reach the task in every greedy episode"]
            assert agrees(cell, k / n), (name, label, cell, k, n)
            assert all(agrees(f"{end:.2f}", value)
                       for end, value in zip(interval_of(cell), (low, high))), (name, label, cell)


def test_the_searchs_final_scores_recompute_from_its_last_rung(rows, readme, references):
    """Each row's search's final score: the mean final normalised score of the search's 10
    agents (seeds 12 000 up, a diverged one left out) trained with the settings the row runs
    to the whole budget."""
    for label, row in rows.items():
        table = row[WHOLE][0]
        settings = table[sorted(set(table.columns) - NOT_SETTINGS)].iloc[0]
        stem = re.sub(rf"-s{ROW_SEED}-[0-9a-f]+$", f"-s{SEARCH_SEED}-", table.run.iloc[0])
        finals = []
        for path in glob.glob(str(RUNS / f"{stem}*.csv.gz")):
            head = pd.read_csv(path, nrows=1)
            if (set(head.columns) - NOT_SETTINGS != set(settings.index)
                    or not head[settings.index].iloc[0].astype(str).equals(settings.astype(str))
                    or head.agents.iloc[0] != 10 or head.episodes.iloc[0] != 10):
                continue
            search = pd.read_csv(path)
            if point_of(record_of(search)) == WHOLE:
                finals.append(search)
        assert len(finals) == 1, (label, len(finals))
        (search,) = finals
        assert sorted(search.seed.unique()) == list(range(SEARCH_SEED, SEARCH_SEED + 10))
        score = normalised(search, references, diverged_as_worst=False).dropna().mean()
        cell = readme["rows"][label]["search's final score"]
        assert agrees(cell, score), (label, cell, score)


def welch_p(x, y, shift: float, alternative: str) -> float:
    """Welch's one-sided p-value of mean(x) + shift against mean(y) (`alternative` as
    scipy's `ttest_ind` takes it)."""
    return float(stats.ttest_ind(np.asarray(x) + shift, y, equal_var=False,
                                 alternative=alternative).pvalue)


def test_the_unadjusted_p_values_and_tost_recompute_from_the_final_scores(rows, readme):
    """At 1/4, 1 and 4 times the budget, each rival's p-values before the family's adjustment,
    by Welch's one-sided t tests of d = mean(light) - mean(rival) with the rule's margin
    0.1: "not worse" (H0: d <= -0.1), "worse" (H0: d >= 0), "better" (H0: d <= 0); and
    TOST's p, the larger of the two one-sided p-values of |d| < 0.1."""
    margin = 0.1
    for name, point in AT.items():
        light = rows[LIGHT][point][2].to_numpy()
        for rival in RIVALS:
            other = rows[rival][point][2].to_numpy()
            cells = readme[name][0][rival]
            printed = [part.split(" (")[0] for part in
                       cells["p not worse, worse, better (adjusted)"].split(", ")]
            expected = (welch_p(light, other, margin, "greater"), welch_p(light, other, 0, "less"),
                        welch_p(light, other, 0, "greater"))
            assert all(agrees(text, p) for text, p in zip(printed, expected)), (
                name, rival, printed, expected)
            tost = max(expected[0], welch_p(light, other, -margin, "less"))
            assert agrees(cells["TOST p"], tost), (name, rival, cells["TOST p"], tost)


def test_the_areas_differences_recompute_from_the_clock(rows, readme):
    """At 1/4, 1 and 4 times the budget, each rival's area's d: the difference of the rows'
    mean areas under their agents' normalised-score curves, the trapezoid over the clock's
    points to there in steps divided by the steps there (the span before the first point
    adds nothing)."""
    def areas(row, point):
        points = [j for j in POINTS + LONGER if j <= point]
        steps = np.array([STEPS_AT[j] for j in points], dtype=float)
        return np.trapezoid(scores_to(row, point), steps, axis=1) / STEPS_AT[point]

    for name, point in AT.items():
        light = areas(rows[LIGHT], point).mean()
        for rival in RIVALS:
            d = light - areas(rows[rival], point).mean()
            cell = readme[name][0][rival]["area's d"]
            assert agrees(cell, d), (name, rival, cell, d)
