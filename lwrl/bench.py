"""The second benchmark for a learner of any library: its protocol's numbers and its greedy
evaluation (`evaluate`), whose results (`results`) `lwrl bench score` places in the
benchmark, beside its rows, in its report's leaderboard.

Train 20 agents (seeds 0 to 19) on a task of the suite (`lwrl.gym`, `lwrl.jax`) for the
task's budget of environment steps (`BUDGETS`), keeping each agent as it was after each
fraction of it (`FRACTIONS`); evaluate each; write the file; score it:

    import numpy as np
    from lwrl import bench

    task = "mountain_car.cost_to_go"

    def policy(observations):  # a batch (n, 2): position, velocity
        return np.where(observations[:, 1] >= 0, 2, 0)  # push along the velocity

    evaluations = [bench.evaluate(policy, task, seed, fraction)
                   for seed in range(bench.AGENTS) for fraction in bench.FRACTIONS]
    bench.results(evaluations, "pump").to_csv("pump.csv.gz", index=False)
    # lwrl bench score pump.csv.gz

`evaluate` takes a function of observations (a batch or one), a JAX function, or an object
with Stable-Baselines3's `predict` (`studies.paper.benchmark.harness`).
"""

from lwrl.studies.paper.benchmark.evaluation import EPISODES, EVALUATION_SEED, STEP_CAP
from lwrl.studies.paper.benchmark.harness import Evaluation, evaluate, results
from lwrl.studies.paper.benchmark.protocol import AGENTS, BUDGETS, FRACTIONS, VERSION

__all__ = ["AGENTS", "BUDGETS", "EPISODES", "EVALUATION_SEED", "Evaluation", "FRACTIONS",
           "STEP_CAP", "VERSION", "evaluate", "results"]
