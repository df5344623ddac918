"""The episodes per task, with their options, that the first benchmark (docs/benchmark, an
archive) gave every learner, the paper's figures' episodes cut to what a DQN or PPO agent
affords: 20 on Mountain-Car (Fig. 2's protocol) and the acrobot, 30 of the pendulum's
(Fig. 5 runs 200) and 30 of the cart-pole's, each of 60 s instead of 240 s (3000 steps
instead of 12 000; up-times are capped at 60 s).

`lwrl robustness` and `lwrl implementations` train the learners of the stepped loop (DQN, PPO
and their JAX ports) with them: their committed runs' keys name these episodes.
"""

EPISODE_BUDGETS = {
    "mountain_car.cost_to_go": (20, {}),
    "pendulum.swingup": (30, {}),
    "cartpole.balance": (30, {"time_limit": 60.0}),
    "acrobot.swingup": (20, {}),
}
"""`{task: (episodes, task options)}`."""


def episode_budgets() -> dict:
    """`{task: (episodes, task options)}` (`EPISODE_BUDGETS`), the options a fresh dict each."""
    return {task: (episodes, dict(options)) for task, (episodes, options) in EPISODE_BUDGETS.items()}
