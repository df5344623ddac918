"""The third benchmark's rule (docs/FINDINGS.md, "The light-weight claim judged a third time:
the third benchmark's rule"): its edition, recorded in its directory; its tasks, the
variants among them; its rows, with the rivals of today (ARS, stream-Q(lambda),
stream-AC(lambda)) and the agents of each; and its seeds, disjoint from every seed any
tuning used.

What stays the second benchmark's (`benchmark.protocol`): the budgets, the rows of each
task and their settings, the runs that train them (`protocol.training`).

A variant is a task of its own, named `TASK+VARIANT` (`mountain_car.cost_to_go+physics`):
the task's environment with the variant's options (`benchmark.variants.environment`) in
training and evaluation, its own reference rows, and every row's configuration chosen on the
task, without a search of its own.
"""

import dataclasses
import json
import os

from lwrl.runners.config import RunConfig, tuned_settings
from lwrl.studies.paper.benchmark import compute_plan, protocol, variants

EDITION = "benchmark3-1"
"""The rule's edition, which a directory of the third benchmark records (`EDITION_FILE`)."""
EDITION_FILE = "rule.json"
"""The file of a benchmark directory that names its rule's edition: there, the directory is
the third benchmark's and resumes by it; absent, the second's."""
SEED = 3000
"""The rows' first seed: agent b of a row trains on seed `SEED` + b and is evaluated from
the starts of that seed + `evaluation.EVALUATION_SEED` (13 000 up)."""
SEARCH_SEED = 2000
"""The search's first seed (2000 to 2009; its evaluations' starts 12 000 to 12 009)."""
TUNING_SEEDS = {"the second benchmark's rows and the acrobot's defaults": (0, 20),
                "the second benchmark's search": (1000, 3),
                "the variants' measurement": (variants.SEED, variants.AGENTS),
                "the third benchmark's search": (SEARCH_SEED, 10)}
"""`{what: (first seed, seeds)}` of every tuning the rows' seeds must stay clear of (their
evaluation starts too: each seed + `evaluation.EVALUATION_SEED`)."""
STAGE_1 = ("mountain_car.cost_to_go", "pendulum.swingup", "cartpole.balance", "acrobot.swingup")
"""The four discrete tasks, searches and rows: the rule's first stage."""
VARIANTS = {"mountain_car.cost_to_go": "physics", "cartpole.balance": "noise",
            "acrobot.swingup": "physics"}
"""The variant each task gets (FINDINGS, "The variants": `variants.choose` on the measurement
committed in docs/benchmark3/variants): the second stage."""
JOIN = "+"
"""Between a task and its variant in a variant's name."""
TASKS = (*STAGE_1, *(f"{task}{JOIN}{variant}" for task, variant in VARIANTS.items()),
         "pendulum.swingup-continuous")
"""Every task of the third benchmark in the order `all` runs them: the rule's stages 1, 2
and 4 (stage 3, the rows continued to 4 times the budget, follows the verdicts at 1)."""


def stages(tasks) -> list:
    """`[(task, continued)]`: the `tasks` in the order the rule's stages run them, the first
    stage's tasks and the variants first, then (`continued` True) the first stage's tasks'
    rows still rising at the budget (stage 3), then the continuous pendulum (stage 4)."""
    ordered = [task for task in TASKS if task in tasks]
    before = [(task, False) for task in ordered if task != TASKS[-1]]
    return (before + [(task, True) for task in ordered if task in STAGE_1]
            + [(task, False) for task in ordered if task == TASKS[-1]])


RIVALS = {"discrete": {"ars": "ars", "stream_q": "stream_q", "stream_ac": "stream_ac_discrete"},
          "continuous": {"ars": "ars_continuous", "stream_ac": "stream_ac"}}
"""`{label: learner}` of the rows the third benchmark adds, by the task's kind of action."""


def check_task(task: str) -> str:
    """`task`, or a one-line ValueError naming the third benchmark's tasks."""
    if task not in TASKS:
        raise ValueError(f"unknown task {task!r} of the third benchmark; allowed: "
                         f"{', '.join(TASKS)}")
    return task


def split(task: str) -> tuple:
    """`(the benchmark task, its variant or None)` of a third benchmark's task."""
    base, _, variant = check_task(task).partition(JOIN)
    return base, variant or None


def environment(task: str) -> dict:
    """The environment options of `task`: its variant's, none for a task of the second."""
    base, variant = split(task)
    return variants.environment(base, variant) if variant else {}


def rows(task: str) -> list:
    """The rows of `task` (`protocol.Row`), the light-weight one first: the second
    benchmark's, then the rivals (`RIVALS`), each at its centre (the zoo's set where the
    learner has one for the task, else its authors' defaults) with its horizon the budget."""
    base = split(task)[0]
    name, actions = protocol.variant(base)
    kind = {"actions": actions} if actions == "continuous" else {}
    rivals = [protocol.Row(label, learner, dict(tuned_settings(name, learner),
                                                timesteps=protocol.BUDGETS[base], **kind))
              for label, learner in RIVALS[actions].items()]
    return [centre(row) for row in protocol.rows(base)] + rivals


def centre(row: protocol.Row) -> protocol.Row:
    """`row` at the centre its search draws around: the second benchmark's, but the
    actor-critic's, whose defaults that benchmark's search chose (the second benchmark's row
    kept the defaults before it, `protocol.ACTOR_CRITIC_START`)."""
    if row.settings == dict(row.settings, **protocol.ACTOR_CRITIC_START):
        return protocol.Row(row.label, row.learner,
                            {k: v for k, v in row.settings.items()
                             if k not in protocol.ACTOR_CRITIC_START})
    return row


def linear(task: str, row: protocol.Row) -> bool:
    """Whether `row` is one of the linear learners' (neither a deep row nor a rival)."""
    actions = protocol.variant(split(task)[0])[1]
    return row.label not in protocol.deep(split(task)[0]) and row.label not in RIVALS[actions]


def agents(task: str, row: protocol.Row) -> int:
    """The agents of `row` on `task`: `compute_plan.LIGHT_AGENTS` for a linear row, else
    `compute_plan.RIVAL_AGENTS`."""
    return compute_plan.LIGHT_AGENTS if linear(task, row) else compute_plan.RIVAL_AGENTS


def training(task: str, row: protocol.Row, settings: dict, seed: int, count: int,
             fraction: float = 1.0, plant: str = "analytic") -> RunConfig:
    """`protocol.training` of `task`'s benchmark task, in `task`'s environment (`environment`)."""
    config = protocol.training(split(task)[0], row, settings, seed, count, fraction, plant)
    options = environment(task)
    return dataclasses.replace(config, **options) if options else config


def write_edition(out_dir: str) -> None:
    """Record the rule's edition in `out_dir` (`EDITION_FILE`) where it is not yet; a one-line
    ValueError where the directory holds another benchmark."""
    path = os.path.join(out_dir, EDITION_FILE)
    if os.path.exists(path):
        check_edition(out_dir)
        return
    if os.path.isdir(os.path.join(out_dir, "runs")):
        raise ValueError(f"{out_dir} holds runs of the second benchmark (no {EDITION_FILE}); "
                         "give the third benchmark a directory of its own")
    os.makedirs(out_dir, exist_ok=True)
    with open(path, "w") as file:
        file.write(json.dumps({"rule": EDITION}) + "\n")


def edition(out_dir: str):
    """The rule's edition `out_dir` records, or None (a second benchmark's directory, or none)."""
    path = os.path.join(out_dir, EDITION_FILE)
    if not os.path.isfile(path):
        return None
    with open(path) as file:
        return json.load(file).get("rule")


def check_edition(out_dir: str) -> None:
    """A one-line ValueError where `out_dir` records an edition other than `EDITION`."""
    found = edition(out_dir)
    if found != EDITION:
        raise ValueError(f"{out_dir} records the rule {found!r} in {EDITION_FILE}; this lwrl "
                         f"runs {EDITION}")
